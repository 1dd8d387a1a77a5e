// -----------------------------------------------------------------------------
//  tied_blocks.geo -- two blocks stacked along z, meshed separately
// -----------------------------------------------------------------------------
//  width x width x height each; the lower block has n_lower cells per edge, the
//  upper n_upper, so their nodes do not match on the interface z = height.  For
//  the tie patch test (tests/ties).
//
//  Physical groups
//    Surface "bottom" (z = 0), "top" (z = 2 height), "xmin", "ymin" (both
//    blocks), "lower_top", "upper_bottom" (the two sides of the interface);
//    Volume "lower", "upper".
//  Parameters: width (10), height (10), n_lower (3), n_upper (2).
// -----------------------------------------------------------------------------
// OpenCASCADE keeps the two boxes apart (no fragments): separate nodes on the
// interface, each box meshed with its own number of cells
SetFactory("OpenCASCADE");

DefineConstant[
  width = {10, Name "Parameters/width"},
  height = {10, Name "Parameters/height"},
  n_lower = {3, Name "Parameters/n_lower"},
  n_upper = {2, Name "Parameters/n_upper"}
];

Box(1) = {0, 0, 0, width, width, height};
Box(2) = {0, 0, height, width, width, height};
For v In {1 : 2}
  faces[] = Boundary{ Volume{v}; };
  edges[] = Boundary{ Surface{faces[]}; };
  For i In {0 : #edges[] - 1}
    edges[i] = Fabs(edges[i]);
  EndFor
  Transfinite Curve{edges[]} = (v == 1 ? n_lower : n_upper) + 1;
  Transfinite Surface{faces[]};
  Recombine Surface{faces[]};
  Transfinite Volume{v};
  box~{v}[] = faces[];
EndFor
// OpenCASCADE box faces: x = 0, x = w, y = 0, y = w, z = 0, z = top
Physical Surface("bottom", 1) = {box~{1}[4]};
Physical Surface("top", 2) = {box~{2}[5]};
Physical Surface("ymin", 3) = {box~{1}[2], box~{2}[2]};
Physical Surface("xmin", 4) = {box~{1}[0], box~{2}[0]};
Physical Surface("lower_top", 5) = {box~{1}[5]};
Physical Surface("upper_bottom", 6) = {box~{2}[4]};
Physical Volume("lower", 10) = {1};
Physical Volume("upper", 11) = {2};
