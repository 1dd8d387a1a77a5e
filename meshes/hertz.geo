// -----------------------------------------------------------------------------
//  hertz.geo -- an elastic hemisphere resting on an elastic block (Hertz contact)
// -----------------------------------------------------------------------------
//  The hemisphere (radius, flat face up at z = radius) touches the block's top
//  face (z = 0) at the origin; the two are meshed separately (no shared nodes),
//  with tetrahedra refined around the contact point.
//
//  Physical groups
//    Surface "sphere_top" (the flat face), "sphere_surface" (the curved face),
//    "block_top" (z = 0), "block_bottom" (z = -depth); Volume "sphere", "block".
//  Parameters: radius (10), width (40) and depth (20) of the block, size (far
//  element size, 3), fine (element size at the contact, 0.25), zone (radius of
//  the fine zone, 2.5), refinement (divides both sizes, 1).
// -----------------------------------------------------------------------------
SetFactory("OpenCASCADE");

DefineConstant[
  radius = {10, Name "Parameters/radius"},
  width = {40, Name "Parameters/width"},
  depth = {20, Name "Parameters/depth"},
  size = {3, Name "Parameters/size"},
  fine = {0.25, Name "Parameters/fine"},
  zone = {2.5, Name "Parameters/zone"},
  refinement = {1, Name "Parameters/refinement"}
];

Sphere(1) = {0, 0, radius, radius};
Box(2) = {-radius, -radius, radius, 2 * radius, 2 * radius, radius};
BooleanDifference(3) = { Volume{1}; Delete; }{ Volume{2}; Delete; };
Box(4) = {-width / 2, -width / 2, -depth, width, width, depth};

e = 1e-6 * radius;
sphere_top[] = Surface In BoundingBox{-radius - e, -radius - e, radius - e,
                                      radius + e, radius + e, radius + e};
sphere_all[] = Boundary{ Volume{3}; };
sphere_surface[] = {};
For i In {0 : #sphere_all[] - 1}
  If (Fabs(sphere_all[i]) != sphere_top[0])
    sphere_surface[] += Fabs(sphere_all[i]);
  EndIf
EndFor
block_top[] = Surface In BoundingBox{-width / 2 - e, -width / 2 - e, -e,
                                     width / 2 + e, width / 2 + e, e};
block_bottom[] = Surface In BoundingBox{-width / 2 - e, -width / 2 - e, -depth - e,
                                        width / 2 + e, width / 2 + e, -depth + e};

Physical Surface("sphere_top", 1) = {sphere_top[]};
Physical Surface("sphere_surface", 2) = {sphere_surface[]};
Physical Surface("block_top", 3) = {block_top[]};
Physical Surface("block_bottom", 4) = {block_bottom[]};
Physical Volume("sphere", 10) = {3};
Physical Volume("block", 11) = {4};

// fine around the contact point, coarse far away
Point(1000) = {0, 0, 0};
Field[1] = Distance;
Field[1].PointsList = {1000};
Field[2] = Threshold;
Field[2].InField = 1;
Field[2].SizeMin = fine / refinement;
Field[2].SizeMax = size / refinement;
Field[2].DistMin = zone;
Field[2].DistMax = 4 * zone + radius / 2;
Background Field = 2;
Mesh.MeshSizeExtendFromBoundary = 0;
Mesh.MeshSizeFromPoints = 0;
Mesh.MeshSizeFromCurvature = 0;
