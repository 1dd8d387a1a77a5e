// -----------------------------------------------------------------------------
//  box.geo -- a structured box with each face a group of its own
// -----------------------------------------------------------------------------
//  lx x ly x lz (mm) from the origin, hexahedra: nx x ny x nz cells times the
//  refinement.  For tests with closed forms: rollers on three faces, loads on
//  the others (uniaxial stress, hanging bar, pressure).
//
//  Physical groups
//    Surface "xmin", "xmax", "ymin", "ymax", "zmin", "zmax"; Volume "box".
//  Parameters: lx, ly, lz (10, 10, 10), nx, ny, nz (2, 2, 2), refinement (1).
// -----------------------------------------------------------------------------
SetFactory("Built-in");

DefineConstant[
  lx = {10, Name "Parameters/lx"},
  ly = {10, Name "Parameters/ly"},
  lz = {10, Name "Parameters/lz"},
  nx = {2, Name "Parameters/nx"},
  ny = {2, Name "Parameters/ny"},
  nz = {2, Name "Parameters/nz"},
  refinement = {1, Name "Parameters/refinement"}
];

Point(1) = {0, 0, 0};
Point(2) = {lx, 0, 0};
Point(3) = {lx, ly, 0};
Point(4) = {0, ly, 0};
Line(1) = {1, 2};
Line(2) = {2, 3};
Line(3) = {3, 4};
Line(4) = {4, 1};
Curve Loop(1) = {1, 2, 3, 4};
Plane Surface(1) = {1};
Transfinite Curve{1, 3} = nx * refinement + 1;
Transfinite Curve{2, 4} = ny * refinement + 1;
Transfinite Surface{1};
Recombine Surface{1};

// out[0]: top (z = lz), out[1]: the box, out[2..5]: sides along lines 1..4
out[] = Extrude {0, 0, lz} { Surface{1}; Layers{nz * refinement}; Recombine; };

Physical Surface("zmin", 1) = {1};
Physical Surface("zmax", 2) = {out[0]};
Physical Surface("ymin", 3) = {out[2]};
Physical Surface("xmax", 4) = {out[3]};
Physical Surface("ymax", 5) = {out[4]};
Physical Surface("xmin", 6) = {out[5]};
Physical Volume("box", 10) = {out[1]};
