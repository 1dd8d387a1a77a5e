// -----------------------------------------------------------------------------
//  block.geo -- a small structured block of muscle, two stacked halves
// -----------------------------------------------------------------------------
//  width x width x length (mm), fibres usually along z.  Hexahedra: 3n x 3n
//  across, 6n along.  Cheap enough for quick scenes and tests.
//
//  Physical groups
//    Surface "bottom" (z = 0), "middle" (z = length/2, interior), "top"
//    (z = length), "sides"; Volume "lower", "upper".
//  Parameters: refinement n (default 1), width (10), length (30).
// -----------------------------------------------------------------------------
SetFactory("Built-in");

DefineConstant[
  refinement = {1, Name "Parameters/refinement"},
  width = {10, Name "Parameters/width"},
  length = {30, Name "Parameters/length"}
];
n = refinement;

Point(1) = {0, 0, 0};
Point(2) = {width, 0, 0};
Point(3) = {width, width, 0};
Point(4) = {0, width, 0};
Line(1) = {1, 2};
Line(2) = {2, 3};
Line(3) = {3, 4};
Line(4) = {4, 1};
Curve Loop(1) = {1, 2, 3, 4};
Plane Surface(1) = {1};
Transfinite Curve{1 : 4} = 3 * n + 1;
Transfinite Surface{1};
Recombine Surface{1};

lower[] = Extrude {0, 0, length / 2} { Surface{1}; Layers{3 * n}; Recombine; };
upper[] = Extrude {0, 0, length / 2} { Surface{lower[0]}; Layers{3 * n}; Recombine; };

Physical Surface("bottom", 1) = {1};
Physical Surface("middle", 2) = {lower[0]};
Physical Surface("top", 3) = {upper[0]};
Physical Surface("sides", 4) = {lower[{2 : 5}], upper[{2 : 5}]};
Physical Volume("lower", 10) = {lower[1]};
Physical Volume("upper", 11) = {upper[1]};
