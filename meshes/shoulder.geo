// -----------------------------------------------------------------------------
//  shoulder.geo -- an idealised glenohumeral joint with the rotator cuff and
//  the deltoid (the paper's "Dynamic stabilization of the shoulder through
//  rotator cuff contraction", on a parametric geometry)
// -----------------------------------------------------------------------------
//  Axes: the centre of the humeral head at the origin, x lateral (the glenoid
//  lies at -x and faces +x), y anterior, z superior; the arm hangs along -z.
//  Dimensions: ../shared/ANATOMY.md.  The neck-shaft angle and the
//  retroversion are left out (the shaft axis passes through the head centre).
//
//  Humerus: a sphere (radius head) on a cylindrical shaft along -z.
//  Scapula: an elliptic glenoid neck along -x (glenoid_height along z,
//    glenoid_width along y) on a plate in the plane y = 0 (the blade, ending
//    medially at x = -blade_end); the glenoid fossa is the neck's end cut by a
//    sphere of radius head + glenoid_offset, placed so that the fossa's deepest
//    point lies gap from the head.  Its rim is a saddle: deeper superior-
//    inferior than anterior-posterior.
//  Labrum: an elliptic ring, labrum_width wide, around the neck's end, from
//    labrum_base below the fossa's deepest point up to labrum_rise above the
//    bony rim's highest points (superior, inferior; there it has a flat lip,
//    which keeps its inferior tip clear of the shaft), cut by the same
//    sphere: it continues the fossa outwards and deepens it.  Scapula and
//    labrum are fragments of one model (shared nodes on their interface).
//  Rotator cuff: four bands of thickness cuff_thickness, revolved about the
//    glenoid axis (x) over azimuth sectors (degrees from +z towards +y,
//    anterior): each a tube around the glenoid neck from its origin (the
//    cross-section x = -cuff_length, clamped in the scene) to x = 0, then a
//    spherical shell cuff_gap over the head that meets the head at the polar
//    angle insertion_start (from -x) and lies on it up to insertion_end: the
//    insertion on the tuberosity.  Supraspinatus superior, infraspinatus
//    posterior, teres minor posterior-inferior (greater tuberosity),
//    subscapularis anterior and anterior-inferior (lesser tuberosity).  No
//    cuff inferiorly (150..210 degrees), where the shaft leaves the head.  The
//    widths follow the muscles' cross-sections roughly (subscapularis >
//    infraspinatus > supraspinatus > teres minor); their pulls on the head
//    nearly balance about the head centre (the superior one is left over).
//  Deltoid: one continuum, a shell deltoid_gap over the cuff, revolved about
//    the shaft axis over the lateral side (sector deltoid_sector around +x),
//    from its origin arc (acromion and clavicle, polar angle origin_angle from
//    +z) over the head to polar angle deltoid_low, then tapering onto the shaft,
//    where its inner face lies on it (insertion_top .. insertion_bottom).
//  Humerus, scapula + labrum and the five muscles are separate bodies (meshes
//  not matching); ties and contact join them in the scene.  No two bodies
//  overlap for the default parameters (checked with BooleanIntersection).
//
//  Physical groups
//    Volumes: "humerus", "scapula", "labrum", "supraspinatus",
//      "infraspinatus", "teres_minor", "subscapularis", "deltoid".
//    Surfaces: "head" (the humeral head's sphere), "shaft", "shaft_end";
//      "fossa" (the articular surface of the glenoid: bone and labrum),
//      "scapula_fixed" (the blade's medial end);
//      for each cuff muscle M: "M_origin", "M_insertion" (on the head),
//      "M_inner" (its inner face, tube and shell, facing the head);
//      "cuff_outer" (the outer faces of the four cuff muscles);
//      "deltoid_origin", "deltoid_insertion" (on the shaft), "deltoid_inner"
//      (its inner face over the cuff and the shaft).
//  Parameters (mm, degrees): head (24), gap (1: joint gap at the fossa's
//    deepest point), glenoid_offset (2.3: fossa radius - head), glenoid_height
//    (39), glenoid_width (29), labrum_width (3), labrum_base (2), labrum_rise
//    (2), neck_end (44), blade_end (110), blade_top (15), blade_bottom (90),
//    blade_thickness (8), shaft_radius (11), shaft_length (150), cuff_gap
//    (0.5), cuff_thickness (8), cuff_length (40), insertion_start (115),
//    insertion_end (135), the sectors supraspinatus_from/to (-22/22),
//    subscapularis_from/to (40/150), teres_minor_from/to (210/245),
//    infraspinatus_from/to (250/315); deltoid_gap (1), deltoid_thickness
//    (10), origin_angle (25), deltoid_low (115), deltoid_sector (150),
//    insertion_top (-60), insertion_bottom (-80); size (element size around
//    the joint, 5), coarse (factor on size far from it: blade, lower shaft;
//    2), fine (element size within zone of the fossa's deepest point, 2), zone
//    (8), refinement (divides size and fine, 1).  Defaults: 14,017 tetrahedra,
//    4,274 nodes.  glenoid_height / 2 + labrum_width must stay below head +
//    cuff_gap (the cuff passes around the glenoid).
// -----------------------------------------------------------------------------
SetFactory("OpenCASCADE");

DefineConstant[
  head = {24, Name "Parameters/head"},
  gap = {1, Name "Parameters/gap"},
  glenoid_offset = {2.3, Name "Parameters/glenoid_offset"},
  glenoid_height = {39, Name "Parameters/glenoid_height"},
  glenoid_width = {29, Name "Parameters/glenoid_width"},
  labrum_width = {3, Name "Parameters/labrum_width"},
  labrum_base = {2, Name "Parameters/labrum_base"},
  labrum_rise = {2, Name "Parameters/labrum_rise"},
  neck_end = {44, Name "Parameters/neck_end"},
  blade_end = {110, Name "Parameters/blade_end"},
  blade_top = {15, Name "Parameters/blade_top"},
  blade_bottom = {90, Name "Parameters/blade_bottom"},
  blade_thickness = {8, Name "Parameters/blade_thickness"},
  shaft_radius = {11, Name "Parameters/shaft_radius"},
  shaft_length = {150, Name "Parameters/shaft_length"},
  cuff_gap = {0.5, Name "Parameters/cuff_gap"},
  cuff_thickness = {8, Name "Parameters/cuff_thickness"},
  cuff_length = {40, Name "Parameters/cuff_length"},
  insertion_start = {115, Name "Parameters/insertion_start"},
  insertion_end = {135, Name "Parameters/insertion_end"},
  supraspinatus_from = {-22, Name "Parameters/supraspinatus_from"},
  supraspinatus_to = {22, Name "Parameters/supraspinatus_to"},
  subscapularis_from = {40, Name "Parameters/subscapularis_from"},
  subscapularis_to = {150, Name "Parameters/subscapularis_to"},
  teres_minor_from = {210, Name "Parameters/teres_minor_from"},
  teres_minor_to = {245, Name "Parameters/teres_minor_to"},
  infraspinatus_from = {250, Name "Parameters/infraspinatus_from"},
  infraspinatus_to = {315, Name "Parameters/infraspinatus_to"},
  deltoid_gap = {1, Name "Parameters/deltoid_gap"},
  deltoid_thickness = {10, Name "Parameters/deltoid_thickness"},
  origin_angle = {25, Name "Parameters/origin_angle"},
  deltoid_low = {115, Name "Parameters/deltoid_low"},
  deltoid_sector = {150, Name "Parameters/deltoid_sector"},
  insertion_top = {-60, Name "Parameters/insertion_top"},
  insertion_bottom = {-80, Name "Parameters/insertion_bottom"},
  size = {5, Name "Parameters/size"},
  fine = {2, Name "Parameters/fine"},
  zone = {8, Name "Parameters/zone"},
  coarse = {2, Name "Parameters/coarse"},
  refinement = {1, Name "Parameters/refinement"}
];

deg = Pi / 180;
e = 1e-3;

// ---------------------------------------------------------------- humerus
Sphere(1) = {0, 0, 0, head};
Cylinder(2) = {0, 0, 0, 0, 0, -shaft_length, shaft_radius};
humerus[] = BooleanUnion{ Volume{1}; Delete; }{ Volume{2}; Delete; };

// ---------------------------------------------------------------- scapula
Rg = head + glenoid_offset;       // radius of the fossa
xg = -(head + gap) + Rg;          // centre of the fossa's sphere on the x axis
deepest = -(head + gap);          // x of the fossa's deepest point
a = glenoid_height / 2;           // semi-axes of the glenoid rim
b = glenoid_width / 2;
x_top = xg - Sqrt(Rg * Rg - (a + labrum_width) ^ 2) + 2 * e;  // above every rim point
If (a + labrum_width >= Rg)
  Error("glenoid_height / 2 + labrum_width must stay below the fossa radius");
EndIf
x_labrum = deepest - labrum_base; // the labrum's base
// the labrum's lip: at most labrum_rise above the bony rim's highest
// (superior and inferior) points, so that its inferior tip clears the shaft
x_lip = Min(x_top, xg - Sqrt(Rg * Rg - a * a) + labrum_rise);

// the glenoid neck: an elliptic cylinder from x_top down to -neck_end
d0 = news; Disk(d0) = {0, 0, 0, a, b};
Rotate {{0, 1, 0}, {0, 0, 0}, Pi / 2} { Surface{d0}; }       // normal along x, a along z
Translate {x_top, 0, 0} { Surface{d0}; }
neck[] = Extrude {-neck_end - x_top, 0, 0} { Surface{d0}; };
v0 = newv; Box(v0) = {-blade_end, -blade_thickness / 2, -blade_bottom,
           blade_end - neck_end + 1, blade_thickness, blade_bottom + blade_top};
bone[] = BooleanUnion{ Volume{neck[1]}; Delete; }{ Volume{v0}; Delete; };
ball = newv; Sphere(ball) = {xg, 0, 0, Rg};
scapula0[] = BooleanDifference{ Volume{bone[]}; Delete; }{ Volume{ball}; };

// the labrum: an elliptic ring around the neck's end from x_labrum to x_lip
d1 = news; Disk(d1) = {0, 0, 0, a + labrum_width, b + labrum_width};
d2 = news; Disk(d2) = {0, 0, 0, a, b};
ring[] = BooleanDifference{ Surface{d1}; Delete; }{ Surface{d2}; Delete; };
Rotate {{0, 1, 0}, {0, 0, 0}, Pi / 2} { Surface{ring[]}; }
Translate {x_lip, 0, 0} { Surface{ring[]}; }
lab[] = Extrude {x_labrum - x_lip, 0, 0} { Surface{ring[]}; };
labrum0[] = BooleanDifference{ Volume{lab[1]}; Delete; }{ Volume{ball}; Delete; };

glenoid[] = BooleanFragments{ Volume{scapula0[]}; Delete; }{ Volume{labrum0[]}; Delete; };
scapula[] = {};
labrum[] = {};
For i In {0 : #glenoid[] - 1}
  bb[] = BoundingBox Volume{glenoid[i]};
  If (bb[0] < -neck_end)
    scapula[] += glenoid[i];
  Else
    labrum[] += glenoid[i];
  EndIf
EndFor

// ---------------------------------------------------------------- rotator cuff
// The profile in the half-plane y = 0, z > 0 (azimuth 0), revolved about the
// x axis; a point at polar angle t from -x: (-r cos t, 0, r sin t).
Ri = head + cuff_gap;
Ro = Ri + cuff_thickness;
If (a + labrum_width >= Ri - e)
  Error("glenoid_height / 2 + labrum_width must stay below head + cuff_gap (the cuff passes the glenoid)");
EndIf
t1 = insertion_start * deg;
t2 = insertion_end * deg;
t0 = t1 - 4 * deg;                // the inner face leaves Ri here for the head
Function CuffProfile
  // in: p (first tag); out: the surface p
  Point(p + 0) = {0, 0, 0};
  Point(p + 1) = {-cuff_length, 0, Ri};
  Point(p + 2) = {0, 0, Ri};
  Point(p + 3) = {-Ri * Cos(t0), 0, Ri * Sin(t0)};
  Point(p + 4) = {-head * Cos(t1), 0, head * Sin(t1)};
  Point(p + 5) = {-head * Cos(t2), 0, head * Sin(t2)};
  Point(p + 6) = {-Ro * Cos(t2), 0, Ro * Sin(t2)};
  Point(p + 7) = {0, 0, Ro};
  Point(p + 8) = {-cuff_length, 0, Ro};
  Line(p + 1) = {p + 1, p + 2};        // inner tube
  Circle(p + 2) = {p + 2, p + 0, p + 3}; // inner shell over the head
  Line(p + 3) = {p + 3, p + 4};        // onto the head
  Circle(p + 4) = {p + 4, p + 0, p + 5}; // insertion
  Line(p + 5) = {p + 5, p + 6};        // lateral end
  Circle(p + 6) = {p + 6, p + 0, p + 7}; // outer shell
  Line(p + 7) = {p + 7, p + 8};        // outer tube
  Line(p + 8) = {p + 8, p + 1};        // origin
  Curve Loop(p) = {p + 1 : p + 8};
  Plane Surface(p) = {p};
Return

// one muscle: azimuth sector [from, to] in degrees from +z towards +y; the
// rotation about -x turns +z towards +y
Function CuffMuscle
  // in: p, from, to; out: vol, inner[], outer[], origin, insertion
  Call CuffProfile;
  Rotate {{-1, 0, 0}, {0, 0, 0}, from * deg} { Surface{p}; }
  ex[] = Extrude {{-1, 0, 0}, {0, 0, 0}, (to - from) * deg} { Surface{p}; };
  // ex[]: end face, volume, then the faces swept by the curves p+1 .. p+8
  vol = ex[1];
  inner[] = {ex[2], ex[3]};
  insertion = ex[5];
  outer[] = {ex[7], ex[8]};
  origin = ex[9];
Return

p = 10000; from = supraspinatus_from; to = supraspinatus_to; Call CuffMuscle;
supraspinatus = vol; supraspinatus_inner[] = inner[]; supraspinatus_origin = origin;
supraspinatus_insertion = insertion; cuff_outer[] = outer[];
p = 20000; from = infraspinatus_from; to = infraspinatus_to; Call CuffMuscle;
infraspinatus = vol; infraspinatus_inner[] = inner[]; infraspinatus_origin = origin;
infraspinatus_insertion = insertion; cuff_outer[] += outer[];
p = 30000; from = teres_minor_from; to = teres_minor_to; Call CuffMuscle;
teres_minor = vol; teres_minor_inner[] = inner[]; teres_minor_origin = origin;
teres_minor_insertion = insertion; cuff_outer[] += outer[];
p = 40000; from = subscapularis_from; to = subscapularis_to; Call CuffMuscle;
subscapularis = vol; subscapularis_inner[] = inner[]; subscapularis_origin = origin;
subscapularis_insertion = insertion; cuff_outer[] += outer[];

// ---------------------------------------------------------------- deltoid
// the profile in the xz-plane (x: distance from the shaft axis), revolved
// about z over the lateral side
a0 = origin_angle * deg;
a1 = deltoid_low * deg;
Di = Ro + deltoid_gap;
Do = Di + deltoid_thickness;
ti = deltoid_thickness / 2;
Point(50001) = {0, 0, 0};
Point(50002) = {Di * Sin(a0), 0, Di * Cos(a0)};
Point(50003) = {Di * Sin(a1), 0, Di * Cos(a1)};
Point(50004) = {shaft_radius, 0, insertion_top};
Point(50005) = {shaft_radius, 0, insertion_bottom};
Point(50006) = {shaft_radius + ti, 0, insertion_bottom};
Point(50007) = {shaft_radius + ti, 0, insertion_top};
Point(50008) = {Do * Sin(a1), 0, Do * Cos(a1)};
Point(50009) = {Do * Sin(a0), 0, Do * Cos(a0)};
Circle(50001) = {50002, 50001, 50003};
Line(50002) = {50003, 50004};
Line(50003) = {50004, 50005};
Line(50004) = {50005, 50006};
Line(50005) = {50006, 50007};
Line(50006) = {50007, 50008};
Circle(50007) = {50008, 50001, 50009};
Line(50008) = {50009, 50002};
Curve Loop(50001) = {50001 : 50008};
Plane Surface(50001) = {50001};
Rotate {{0, 0, 1}, {0, 0, 0}, -deltoid_sector / 2 * deg} { Surface{50001}; }
dex[] = Extrude {{0, 0, 1}, {0, 0, 0}, deltoid_sector * deg} { Surface{50001}; };
deltoid = dex[1];
deltoid_inner[] = {dex[2], dex[3]};
deltoid_insertion = dex[4];
deltoid_origin = dex[9];

// ---------------------------------------------------------------- surfaces
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

// the fossa: the faces of scapula and labrum that lie above the labrum's base
// (the sphere's cut); the fixed end: the blade's medial face
all_glenoid[] = Boundary{ Volume{scapula[], labrum[]}; };
fossa[] = {};
scapula_fixed[] = {};
For i In {0 : #all_glenoid[] - 1}
  s = Fabs(all_glenoid[i]);
  bb[] = BoundingBox Surface{s};
  If (bb[0] > x_labrum + e)
    fossa[] += s;
  ElseIf (bb[3] < -blade_end + e)
    scapula_fixed[] += s;
  EndIf
EndFor

Physical Surface("head", 1) = {head_side[]};
Physical Surface("shaft", 2) = {shaft_side[]};
Physical Surface("shaft_end", 3) = {shaft_end[]};
Physical Surface("fossa", 4) = {fossa[]};
Physical Surface("scapula_fixed", 5) = {scapula_fixed[]};
Physical Surface("supraspinatus_origin", 11) = {supraspinatus_origin};
Physical Surface("supraspinatus_insertion", 12) = {supraspinatus_insertion};
Physical Surface("supraspinatus_inner", 13) = {supraspinatus_inner[]};
Physical Surface("infraspinatus_origin", 21) = {infraspinatus_origin};
Physical Surface("infraspinatus_insertion", 22) = {infraspinatus_insertion};
Physical Surface("infraspinatus_inner", 23) = {infraspinatus_inner[]};
Physical Surface("teres_minor_origin", 31) = {teres_minor_origin};
Physical Surface("teres_minor_insertion", 32) = {teres_minor_insertion};
Physical Surface("teres_minor_inner", 33) = {teres_minor_inner[]};
Physical Surface("subscapularis_origin", 41) = {subscapularis_origin};
Physical Surface("subscapularis_insertion", 42) = {subscapularis_insertion};
Physical Surface("subscapularis_inner", 43) = {subscapularis_inner[]};
Physical Surface("cuff_outer", 50) = {cuff_outer[]};
Physical Surface("deltoid_origin", 61) = {deltoid_origin};
Physical Surface("deltoid_insertion", 62) = {deltoid_insertion};
Physical Surface("deltoid_inner", 63) = {deltoid_inner[]};
Physical Volume("humerus", 100) = {humerus[]};
Physical Volume("scapula", 101) = {scapula[]};
Physical Volume("labrum", 102) = {labrum[]};
Physical Volume("supraspinatus", 103) = {supraspinatus};
Physical Volume("infraspinatus", 104) = {infraspinatus};
Physical Volume("teres_minor", 105) = {teres_minor};
Physical Volume("subscapularis", 106) = {subscapularis};
Physical Volume("deltoid", 107) = {deltoid};

// ---------------------------------------------------------------- mesh size
// size around the joint (the head, the cuff, the glenoid, the deltoid over
// the head), coarse * size on the blade and the lower shaft, fine within zone
// of the fossa's deepest point (the glenohumeral contact)
h = size / refinement;
Field[1] = Box;
Field[1].VIn = h;
Field[1].VOut = coarse * h;
Field[1].XMin = -cuff_length - 5;
Field[1].XMax = Do + 5;
Field[1].YMin = -Do - 5;
Field[1].YMax = Do + 5;
Field[1].ZMin = -head - 10;
Field[1].ZMax = Do + 5;
Field[1].Thickness = 20;
Point(60001) = {-head - gap / 2, 0, 0};
Field[2] = Distance;
Field[2].PointsList = {60001};
Field[3] = Threshold;
Field[3].InField = 2;
Field[3].SizeMin = fine / refinement;
Field[3].SizeMax = coarse * h;
Field[3].DistMin = zone;
Field[3].DistMax = zone + 2 * h;
Field[4] = Min;
Field[4].FieldsList = {1, 3};
Background Field = 4;
Mesh.MeshSizeExtendFromBoundary = 0;
Mesh.MeshSizeFromPoints = 0;
Mesh.MeshSizeFromCurvature = 12;
Mesh.MeshSizeMax = coarse * h;
Mesh.MeshSizeMin = Min(fine, h) / refinement / 3;
