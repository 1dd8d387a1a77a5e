// -----------------------------------------------------------------------------
//  beam.geo -- a straight beam of rectangular section along x
// -----------------------------------------------------------------------------
//  length x width x height (mm) from the origin: x along the beam, y across,
//  z the height (the direction it bends under gravity along -z).  Structured
//  hexahedra of about `size` mm (at least one across the section), times the
//  refinement.  For the cantilevers of demos/scenes/beam_vibration.yaml and
//  demos/scenes/cantilever_pressure.yaml.
//
//  Physical groups
//    Surface "root" (x = 0), "tip" (x = length), "bottom" (z = 0), "top"
//    (z = height), "sides" (y = 0 and y = width); Volume "beam".
//  Parameters: length (100), width (5), height (5), size (2.5), refinement (1).
// -----------------------------------------------------------------------------
SetFactory("Built-in");

DefineConstant[
  length = {100, Name "Parameters/length"},
  width = {5, Name "Parameters/width"},
  height = {5, Name "Parameters/height"},
  size = {2.5, Name "Parameters/size"},
  refinement = {1, Name "Parameters/refinement"}
];
nx = Ceil(length / size) * refinement;
ny = Max(1, Ceil(width / size)) * refinement;
nz = Max(1, Ceil(height / size)) * refinement;

Point(1) = {0, 0, 0};
Point(2) = {0, width, 0};
Point(3) = {0, width, height};
Point(4) = {0, 0, height};
Line(1) = {1, 2};
Line(2) = {2, 3};
Line(3) = {3, 4};
Line(4) = {4, 1};
Curve Loop(1) = {1, 2, 3, 4};
Plane Surface(1) = {1};
Transfinite Curve{1, 3} = ny + 1;
Transfinite Curve{2, 4} = nz + 1;
Transfinite Surface{1};
Recombine Surface{1};

// out[0]: the tip (x = length), out[1]: the beam, out[2..5]: the faces swept by
// lines 1..4 (z = 0, y = width, z = height, y = 0)
out[] = Extrude {length, 0, 0} { Surface{1}; Layers{nx}; Recombine; };

Physical Surface("root", 1) = {1};
Physical Surface("tip", 2) = {out[0]};
Physical Surface("sides", 3) = {out[3], out[5]};
Physical Surface("bottom", 4) = {out[2]};
Physical Surface("top", 5) = {out[4]};
Physical Volume("beam", 10) = {out[1]};
