// -----------------------------------------------------------------------------
//  humerus_deltoid.geo -- an idealised humerus and the deltoid draped over it
// -----------------------------------------------------------------------------
//  Humerus: a spherical head (radius head, centre at the origin) on a straight
//  cylindrical shaft along -z.  Deltoid: a thick muscle revolved about the shaft
//  axis over the lateral side (azimuth -sector/2 .. sector/2 around +x), from an
//  origin arc above the head (polar angle origin_angle) over the head at a small
//  gap, tapering onto the shaft, where its inner face lies on the shaft over the
//  insertion patch.  The two bodies are meshed separately (tied at the
//  insertion, in contact over the head).  Dimensions: ../shared/ANATOMY.md.
//
//  Physical groups
//    Surfaces: "head" (humeral head), "shaft" (side of the shaft), "shaft_end",
//    "origin" (deltoid's origin arc: clavicle, acromion, scapular spine),
//    "deltoid_inner" (the deltoid's inner face over the head), "insertion" (its
//    inner face on the shaft); Volumes: "humerus", "spinal", "acromial",
//    "clavicular" (posterior -y, lateral, anterior +y thirds of the deltoid).
//  Parameters: head (24), shaft_radius (11), shaft_length (150), gap (1),
//    thickness (12), origin_angle (25 deg), insertion_top (-60), insertion_bottom
//    (-80), sector (150 deg), size (element size, 6), refinement (1).
// -----------------------------------------------------------------------------
SetFactory("OpenCASCADE");

DefineConstant[
  head = {24, Name "Parameters/head"},
  shaft_radius = {11, Name "Parameters/shaft_radius"},
  shaft_length = {150, Name "Parameters/shaft_length"},
  gap = {1, Name "Parameters/gap"},
  thickness = {12, Name "Parameters/thickness"},
  origin_angle = {25, Name "Parameters/origin_angle"},
  insertion_top = {-60, Name "Parameters/insertion_top"},
  insertion_bottom = {-80, Name "Parameters/insertion_bottom"},
  sector = {150, Name "Parameters/sector"},
  size = {6, Name "Parameters/size"},
  refinement = {1, Name "Parameters/refinement"}
];

// humerus
Sphere(1) = {0, 0, 0, head};
Cylinder(2) = {0, 0, 0, 0, 0, -shaft_length, shaft_radius};
humerus[] = BooleanUnion{ Volume{1}; Delete; }{ Volume{2}; Delete; };

// the deltoid's profile in the xz-plane (x: distance from the shaft axis)
a0 = origin_angle * Pi / 180;
Ri = head + gap;
Ro = head + gap + thickness;
ti = thickness / 2;
Point(101) = {0, 0, 0};
Point(102) = {Ri * Sin(a0), 0, Ri * Cos(a0)};
Point(103) = {Ri, 0, 0};
Point(104) = {shaft_radius, 0, insertion_top};
Point(105) = {shaft_radius, 0, insertion_bottom};
Point(106) = {shaft_radius + ti, 0, insertion_bottom};
Point(107) = {shaft_radius + ti, 0, insertion_top};
Point(108) = {Ro, 0, 0};
Point(109) = {Ro * Sin(a0), 0, Ro * Cos(a0)};
Circle(101) = {102, 101, 103};
Line(102) = {103, 104};
Line(103) = {104, 105};
Line(104) = {105, 106};
Line(105) = {106, 107};
Line(106) = {107, 108};
Circle(107) = {108, 101, 109};
Line(108) = {109, 102};
Curve Loop(101) = {101 : 108};
Plane Surface(101) = {101};
Rotate {{0, 0, 1}, {0, 0, 0}, -sector / 2 * Pi / 180} { Surface{101}; }

// three thirds of the sector: spinal (posterior), acromial, clavicular (anterior)
third = sector / 3 * Pi / 180;
s1[] = Extrude {{0, 0, 1}, {0, 0, 0}, third} { Surface{101}; };
s2[] = Extrude {{0, 0, 1}, {0, 0, 0}, third} { Surface{s1[0]}; };
s3[] = Extrude {{0, 0, 1}, {0, 0, 0}, third} { Surface{s2[0]}; };
// (each third extrudes the previous one's end face: the thirds share it, conforming)
// Extrude returns [end face, volume, faces swept by curves 101..108]
deltoid[] = {s1[1], s2[1], s3[1]};
inner[] = {s1[2], s1[3], s2[2], s2[3], s3[2], s3[3]};
insertion[] = {s1[4], s2[4], s3[4]};
origin[] = {s1[9], s2[9], s3[9]};

// humerus surfaces by where they lie
e = 1e-3;
shaft_bottom = -shaft_length;
all_humerus[] = Boundary{ Volume{humerus[]}; };
shaft_end[] = {};
shaft_side[] = {};
head_side[] = {};
For i In {0 : #all_humerus[] - 1}
  s = Fabs(all_humerus[i]);
  bb[] = BoundingBox Surface{s};
  If (Fabs(bb[2] - shaft_bottom) < e && Fabs(bb[5] - shaft_bottom) < e)
    shaft_end[] += s;
  ElseIf (bb[2] < -head)
    shaft_side[] += s;
  Else
    head_side[] += s;
  EndIf
EndFor

Physical Surface("head", 1) = {head_side[]};
Physical Surface("shaft", 2) = {shaft_side[]};
Physical Surface("shaft_end", 3) = {shaft_end[]};
Physical Surface("origin", 4) = {origin[]};
Physical Surface("deltoid_inner", 5) = {inner[]};
Physical Surface("insertion", 6) = {insertion[]};
Physical Volume("humerus", 10) = {humerus[]};
Physical Volume("spinal", 11) = {deltoid[0]};
Physical Volume("acromial", 12) = {deltoid[1]};
Physical Volume("clavicular", 13) = {deltoid[2]};

Mesh.MeshSizeMax = size / refinement;
Mesh.MeshSizeMin = size / refinement / 3;
Mesh.MeshSizeFromCurvature = 12;
