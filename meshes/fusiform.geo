// -----------------------------------------------------------------------------
//  fusiform.geo -- structured (O-grid) mesh of an idealised fusiform muscle
// -----------------------------------------------------------------------------
//
//  Geometry (lengths in mm)
//    Body of revolution about the z (e3) axis, from z = 0 ("origin" end face)
//    to z = L = 100 ("insertion" end face).  The profile r(z) is given by
//    a Catmull-Rom spline through the paper's points (r, z) = (10, 0),
//    (15, 25), (20, 50), (15, 75), (10, 100): radius 10 at both ends and 20 at
//    mid-length, smooth there.  (The paper prints the second point as
//    ((r_max - r_min)/2, l/4) = (5, 25), a misprint for the mean radius 15: its
//    own figure shows a monotone spindle.)  With the reflected end point of
//    the Catmull-Rom construction the segment 0 <= z <= 25 is straight and
//    25 <= z <= 50 is r = 15 + 5t + 5t^2 - 5t^3, t = (z - 25)/25.  Each half is
//    sampled at 11 stations and meshed as its own spline so that z = 50 is a
//    mesh layer.  The lateral surface ("mantle") is the surface of revolution
//    of this profile (four quarter turns about the z axis; seams at 45, 135,
//    225 and 315 degrees).

//  Mesh: structured hexahedral O-grid, 10 transfinite volumes
//    cross-section: central block of 6n x 6n elements whose corners lie at
//      radius a*r(z) on the 45-degree lines, plus 4 outer blocks of 6n
//      (circumferential) x R(n) (radial) elements, R(n) = ceil(2.5 n);
//    along z: 10n elements in each half (20n in total).
//    => 20n (36 n^2 + 24 n R) hexahedra, (20n + 1) ((6n+1)^2 + 24 n R) nodes.
//
//  Parameters (override with e.g. "gmsh -3 -setnumber refinement 2 ...")
//    refinement  n = 1, 2 or 4 (default 1)
//    tet         0: hexahedra only (default); 1: tetrahedra only (each hex of
//                the same structured grid split into 6 tetrahedra)
//    core        radius fraction of the central block's corners (default 0.5;
//                values near 1 make nearly degenerate outer elements)
//    grade       along z, cell lengths in geometric progression, those at
//                mid-length grade^(1 - 1/NZ) times those at the end faces
//                (default 1: uniform)
//    grade_radial  in the outer blocks, the radial cells at the central block
//                grade_radial^(1 - 1/NR) times as thick as those at the mantle
//                (default 1)
//                Either keeps the meshes of one value similar under refinement
//                (one family for Richardson extrapolation).
//
//  Physical groups (the only ones, so only these elements are saved)
//    Physical Surface("origin", 1)     end face z = 0   (5 block faces)
//    Physical Surface("insertion", 2)  end face z = 100 (5 block faces)
//    Physical Surface("mantle", 3)     lateral surface of revolution
//    Physical Surface("midsection", 4) interior cross-section z = 50
//    Physical Volume("muscle", 10)     all 10 volumes
//
//  Example:
//    gmsh -3 -setnumber refinement 2 -setnumber tet 0 fusiform.geo \
//         -format msh41 -o fusiform.msh
// -----------------------------------------------------------------------------

SetFactory("Built-in");

DefineConstant[
  refinement = {1, Choices{1, 2, 4}, Name "Parameters/refinement"},
  tet = {0, Choices{0, 1}, Name "Parameters/tet"},
  core = {0.5, Min 0.05, Max 0.98, Name "Parameters/core"},
  grade = {1, Min 1, Max 100, Name "Parameters/grade"},
  grade_radial = {1, Min 1, Max 100, Name "Parameters/grade_radial"}
];

n  = refinement;
NC = 6 * n;             // elements along each side of the central block and
                        // along each outer arc (=> 24 n around)
NR = Ceil(2.5 * n);     // radial elements in the 4 outer blocks (3, 5, 10)
NZ = 10 * n;            // elements along z in each half

L = 100;                // length
// profile of the lower half (z increasing, last = L/2); the upper half is its
// mirror image about z = L/2
zProf[] = {};
rProf[] = {};
For i In {0 : 10}
  zi = 5 * i;
  If (zi <= 25)
    ri = 10 + zi / 5;
  Else
    ti = (zi - 25) / 25;
    ri = 15 + 5 * ti + 5 * ti^2 - 5 * ti^3;
  EndIf
  zProf[] += zi;
  rProf[] += ri;
EndFor
a = core;               // central-block corners at radius a * r(z) (0.5; near 1
                        // the outer blocks degenerate into slivers)
bulge = 15;             // the central-block edges are circular arcs leaving
                        // the corners at this angle (deg) to the chord
                        // (0 = straight lines)

Geometry.AutoCoherence = 1;                 // (defaults, relied upon by the
Geometry.ExtrudeReturnLateralEntities = 1;  // Extrude loop below)

c45 = Cos(Pi / 4);
np = #zProf[];

// all profile stations along z: lower half, then the mirrored upper half
zSt[] = zProf[];
rSt[] = rProf[];
For i In {np - 2 : 0 : -1}
  zSt[] += L - zProf[i];
  rSt[] += rProf[i];
EndFor
// the three cross-section levels j = 0, 1, 2 (z = 0, 50, 100)
lev[] = {0, np - 1, 2 * np - 2};     // station index of each level

// ---------------------------------------------------------------------------
// Mantle: profile splines at 45 degrees, rotated 4 x 90 degrees about z
// ---------------------------------------------------------------------------
pm[] = {};
For i In {0 : 2 * np - 2}
  pm[] += newp;
  Point(pm[i]) = {rSt[i] * c45, rSt[i] * c45, zSt[i]};
EndFor
mer[] = {};   // mer[2*k + h]: meridian of half h (0: lower, 1: upper) at angle
              // 45 + 90 k degrees, oriented towards +z
For h In {0 : 1}
  pts[] = {};
  For i In {h * (np - 1) : (h + 1) * (np - 1)}
    pts[] += pm[i];
  EndFor
  mer[] += newc;
  Spline(mer[h]) = pts[];
EndFor

mant[] = {};    // mant[2*k + h]: mantle patch of half h, sector k
arc0[] = {};    // rim arcs at z = 0, L/2, L, sector k (counter-clockwise)
arc1[] = {};
arc2[] = {};
For k In {0 : 3}
  // for each curve Extrude returns {top curve, surface, end-point arc,
  // -start-point arc}; at k = 3 the top curves coincide with (and are merged
  // into) the original profile splines
  ex[] = Extrude {{0, 0, 1}, {0, 0, 0}, Pi / 2} { Curve{mer[2*k], mer[2*k+1]}; };
  If (k < 3)
    mer[] += {ex[0], ex[4]};
  EndIf
  mant[] += {ex[1], ex[5]};
  arc0[] += Abs(ex[3]);   // z = 0
  arc1[] += Abs(ex[2]);   // z = L/2 (shared by both halves)
  arc2[] += Abs(ex[6]);   // z = L
EndFor
arc[] = {arc0[], arc1[], arc2[]};  // arc[4*j + k]: level j, sector k

// outer block corners oc[4*j + k] (start points of the rim arcs)
oc[] = {};
For j In {0 : 2}
  For k In {0 : 3}
    bnd[] = Boundary{ Curve{arc[4*j + k]}; };
    oc[] += bnd[0];
  EndFor
EndFor

// ---------------------------------------------------------------------------
// Central block: corners at radius a r(z) on the 45-degree lines
// ---------------------------------------------------------------------------
pin[] = {};   // pin[(2*np - 1)*k + i]: station i, angle 45 + 90 k
For k In {0 : 3}
  th = Pi / 4 + k * Pi / 2;
  For i In {0 : 2 * np - 2}
    pin[] += newp;
    Point(pin[(2*np - 1)*k + i]) = {a * rSt[i] * Cos(th), a * rSt[i] * Sin(th), zSt[i]};
  EndFor
EndFor

// inner longitudinal splines s[4*h + k]
s[] = {};
For h In {0 : 1}
  For k In {0 : 3}
    pts[] = {};
    For i In {h * (np - 1) : (h + 1) * (np - 1)}
      pts[] += pin[(2*np - 1)*k + i];
    EndFor
    s[] += newc;
    Spline(s[4*h + k]) = pts[];
  EndFor
EndFor

// cross-section curves of level j: central-block edges e[4*j + k] (corner k
// -> corner k+1) and radial lines rl[4*j + k] (inner corner -> outer corner)
e[] = {};
rl[] = {};
For j In {0 : 2}
  ist = lev[j];                     // station index of level j
  rc = a * rSt[ist];                // corner radius
  For k In {0 : 3}
    p1 = pin[(2*np - 1)*k + ist];
    p2 = pin[(2*np - 1)*((k + 1) % 4) + ist];
    If (bulge > 0)
      beta = bulge * Pi / 180;
      rho = rc * Sin(Pi / 4) / Sin(beta);          // arc radius
      dc = rc * Cos(Pi / 4) - rho * Cos(beta);     // centre, from the axis
      phi = (k + 1) * Pi / 2;                      // towards mid-edge
      pc = newp;
      Point(pc) = {dc * Cos(phi), dc * Sin(phi), zSt[ist]};
      e[] += newc;
      Circle(e[4*j + k]) = {p1, pc, p2};
    Else
      e[] += newc;
      Line(e[4*j + k]) = {p1, p2};
    EndIf
    rl[] += newc;
    Line(rl[4*j + k]) = {p1, oc[4*j + k]};
  EndFor
EndFor

// ---------------------------------------------------------------------------
// Surfaces
// ---------------------------------------------------------------------------
// cross-sections: cs[5*j] central block, cs[5*j + 1 + k] outer block k
cs[] = {};
For j In {0 : 2}
  cs[] += news;
  Curve Loop(cs[5*j]) = {e[4*j], e[4*j+1], e[4*j+2], e[4*j+3]};
  Plane Surface(cs[5*j]) = {cs[5*j]};
  For k In {0 : 3}
    cs[] += news;
    Curve Loop(cs[5*j + 1 + k]) = {e[4*j + k], rl[4*j + (k+1)%4],
                                   -arc[4*j + k], -rl[4*j + k]};
    Plane Surface(cs[5*j + 1 + k]) = {cs[5*j + 1 + k]};
  EndFor
EndFor

// longitudinal interior surfaces of half h: fin[4*h + k] central-block side
// k, frad[4*h + k] radial (meridian-plane) face at angle 45 + 90 k
fin[] = {};
frad[] = {};
For h In {0 : 1}
  For k In {0 : 3}
    fin[] += news;
    Curve Loop(fin[4*h + k]) = {e[4*h + k], s[4*h + (k+1)%4],
                                -e[4*(h+1) + k], -s[4*h + k]};
    Surface(fin[4*h + k]) = {fin[4*h + k]};
    frad[] += news;
    Curve Loop(frad[4*h + k]) = {rl[4*h + k], mer[2*k + h],
                                 -rl[4*(h+1) + k], -s[4*h + k]};
    Plane Surface(frad[4*h + k]) = {frad[4*h + k]};
  EndFor
EndFor

// ---------------------------------------------------------------------------
// Volumes: vol[5*h] central block, vol[5*h + 1 + k] outer block k
// ---------------------------------------------------------------------------
vol[] = {};
For h In {0 : 1}
  sl = newsl;
  Surface Loop(sl) = {cs[5*h], cs[5*(h+1)], fin[4*h], fin[4*h+1], fin[4*h+2],
                      fin[4*h+3]};
  vol[] += newv;
  Volume(vol[5*h]) = {sl};
  For k In {0 : 3}
    sl = newsl;
    Surface Loop(sl) = {cs[5*h + 1 + k], cs[5*(h+1) + 1 + k], fin[4*h + k],
                        frad[4*h + k], frad[4*h + (k+1)%4], mant[2*k + h]};
    vol[] += newv;
    Volume(vol[5*h + 1 + k]) = {sl};
  EndFor
EndFor

// ---------------------------------------------------------------------------
// Structured mesh
// ---------------------------------------------------------------------------
Transfinite Curve{e[], arc[]} = NC + 1;
// grading: cell lengths in geometric progression, shortest at the end faces
// (grade) and at the mantle (grade_radial), the ratios of the header.  A
// per-cell ratio grade^(1/NZ) puts node i at phi(i / NZ) with phi independent
// of n: exactly on the straight radial lines (similar for even n, whose radial
// count 2.5 n is exact), to about 0.002 mm along the curved profiles (Gmsh
// integrates the graded size along them).
qz = grade^(1 / NZ);
qr = grade_radial^(1 / NR);
Transfinite Curve{rl[]} = NR + 1 Using Progression 1 / qr;   // inner -> rim
For k In {0 : 3}          // meridians and inner splines run towards +z
  Transfinite Curve{mer[2*k], s[k]} = NZ + 1 Using Progression qz;
  Transfinite Curve{mer[2*k + 1], s[4 + k]} = NZ + 1 Using Progression 1 / qz;
EndFor

// Explicit corners orient the grid of every block along +x / +y (central
// block), outwards / along +x or +y (outer blocks) and +z, with right-handed
// (i, j, k).  Hence all hexahedra are positively oriented and, for tet == 1,
// the diagonals of the surface triangulations ("Left": (i+1,j)-(i,j+1)) match
// the 6-tetrahedra split of the transfinite volumes (which Gmsh does not
// check).  Outer block k: grid runs circumferentially from corner cA[k] to
// cB[k]; corner k of a cross-section is at angle 45 + 90 k degrees.
cA[] = {1, 2, 2, 3};
cB[] = {0, 1, 3, 0};
For j In {0 : 2}
  For k In {0 : 3}
    I~{j}[k] = pin[(2*np - 1)*k + lev[j]];   // central-block corners
    O~{j}[k] = oc[4*j + k];                  // outer corners (on the rim)
  EndFor
  // corners of the 5 cross-section faces of level j, cross~{j}[4*b + 0..3]
  cross~{j}[] = {I~{j}[2], I~{j}[3], I~{j}[0], I~{j}[1]};
  For k In {0 : 3}
    If (k < 2)   // (i, j) = (circumferential, radial)
      cross~{j}[] += {I~{j}[cA[k]], I~{j}[cB[k]], O~{j}[cB[k]], O~{j}[cA[k]]};
    Else         // (i, j) = (radial, circumferential)
      cross~{j}[] += {I~{j}[cA[k]], O~{j}[cA[k]], O~{j}[cB[k]], I~{j}[cB[k]]};
    EndIf
  EndFor
EndFor
For j In {0 : 2}
  For b In {0 : 4}
    Transfinite Surface{cs[5*j + b]} = {cross~{j}[{4*b : 4*b + 3}]};
  EndFor
EndFor
For h In {0 : 1}
  For k In {0 : 3}
    Transfinite Surface{fin[4*h + k]} = {I~{h}[cA[k]], I~{h}[cB[k]],
                                         I~{h+1}[cB[k]], I~{h+1}[cA[k]]};
    Transfinite Surface{frad[4*h + k]} = {I~{h}[k], O~{h}[k], O~{h+1}[k],
                                          I~{h+1}[k]};
    Transfinite Surface{mant[2*k + h]} = {O~{h}[cA[k]], O~{h}[cB[k]],
                                          O~{h+1}[cB[k]], O~{h+1}[cA[k]]};
  EndFor
  For b In {0 : 4}
    Transfinite Volume{vol[5*h + b]} = {cross~{h}[{4*b : 4*b + 3}],
                                        cross~{h+1}[{4*b : 4*b + 3}]};
  EndFor
EndFor

allSurf[] = {cs[], fin[], frad[], mant[]};
Mesh.RecombineAll = 0;
If (tet == 0)
  Recombine Surface{allSurf[]};   // quadrilaterals => hexahedra
  Recombine Volume{vol[]};
EndIf

// ---------------------------------------------------------------------------
// Physical groups
// ---------------------------------------------------------------------------
Physical Surface("origin", 1) = {cs[{0 : 4}]};
Physical Surface("insertion", 2) = {cs[{10 : 14}]};
Physical Surface("mantle", 3) = {mant[]};
Physical Surface("midsection", 4) = {cs[{5 : 9}]};
Physical Volume("muscle", 10) = {vol[]};
