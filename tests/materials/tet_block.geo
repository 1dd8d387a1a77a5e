// -----------------------------------------------------------------------------
//  tet_block.geo -- the block of meshes/block.geo (10 x 10 x 30 mm) in unstructured
//  tetrahedra, for tests/materials/test_materials.py: a homogeneous deformation is
//  exact on P1 and P2 as on Q1 and Q2, so the same closed forms hold.
//
//  Physical groups: Surface "bottom" (z = 0), "top" (z = 30), "sides"; Volume "block".
//  Parameter: size (mesh size, default 5 mm).
// -----------------------------------------------------------------------------
SetFactory("OpenCASCADE");

DefineConstant[ size = {5, Name "Parameters/size"} ];

Box(1) = {0, 0, 0, 10, 10, 30};
Mesh.MeshSizeMin = size;
Mesh.MeshSizeMax = size;

// OpenCASCADE's box faces: 1, 2 at x = 0, 10; 3, 4 at y = 0, 10; 5, 6 at z = 0, 30
Physical Surface("bottom", 1) = {5};
Physical Surface("top", 3) = {6};
Physical Surface("sides", 4) = {1, 2, 3, 4};
Physical Volume("block", 10) = {1};
