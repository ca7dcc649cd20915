// A thin square tube along z with a crush trigger: outer side S, wall T, length L, on
// [-S/2, S/2]^2 x [0, L]. Around z = ZW the walls are pressed in by D (a bead, as crash boxes
// have, so that the tube folds there rather than barrelling): the cross-section shrinks linearly
// from full size at ZW - BW to S - 2 D at ZW and back to full size at ZW + BW. Each of the four
// walls is a trapezoid of the cross-section (outer edge, inner edge, two corner diagonals)
// meshed NS along the side and NT through the wall; along z the tube has NL layers of hexahedra
// of about equal height. Volume "tube"; surfaces "bottom" (z = 0), "top" (z = L), "outer" and
// "inner" (the walls' faces). Override with -setnumber.
If(!Exists(S)) S = 0.03; EndIf
If(!Exists(T)) T = 0.001; EndIf
If(!Exists(L)) L = 0.09; EndIf
If(!Exists(NS)) NS = 6; EndIf
If(!Exists(NT)) NT = 1; EndIf
If(!Exists(NL)) NL = 30; EndIf
If(!Exists(ZW)) ZW = 0.06; EndIf
If(!Exists(BW)) BW = 0.006; EndIf
If(!Exists(D)) D = 0.001; EndIf
// Levels: z and inward offset of the cross-section.
zs[] = {0, ZW - BW, ZW, ZW + BW, L};
ds[] = {0, 0, D, 0, 0};
nk = 5;
For k In {0 : nk - 1}
  a = S / 2 - ds[k];
  b = a - T;
  // Points: outer corners 100k + 1..4, inner 100k + 5..8, counter-clockwise from (-, -).
  Point(100 * k + 1) = {-a, -a, zs[k]}; Point(100 * k + 2) = {a, -a, zs[k]};
  Point(100 * k + 3) = {a, a, zs[k]}; Point(100 * k + 4) = {-a, a, zs[k]};
  Point(100 * k + 5) = {-b, -b, zs[k]}; Point(100 * k + 6) = {b, -b, zs[k]};
  Point(100 * k + 7) = {b, b, zs[k]}; Point(100 * k + 8) = {-b, b, zs[k]};
  For i In {0 : 3}
    Line(100 * k + 1 + i) = {100 * k + 1 + i, 100 * k + 1 + (i + 1) % 4};  // outer edge
    Line(100 * k + 5 + i) = {100 * k + 5 + i, 100 * k + 5 + (i + 1) % 4};  // inner edge
    Line(100 * k + 9 + i) = {100 * k + 1 + i, 100 * k + 5 + i};            // diagonal
  EndFor
  For i In {0 : 3}
    Curve Loop(100 * k + 1 + i) = {100 * k + 1 + i, 100 * k + 9 + (i + 1) % 4,
                                   -(100 * k + 5 + i), -(100 * k + 9 + i)};
    Plane Surface(100 * k + 1 + i) = {100 * k + 1 + i};
  EndFor
  Transfinite Curve{100 * k + 1 : 100 * k + 8} = NS + 1;
  Transfinite Curve{100 * k + 9 : 100 * k + 12} = NT + 1;
EndFor
vols[] = {};
outer[] = {};
inner[] = {};
For k In {0 : nk - 2}
  m = 100 * k + 50;  // tags of the segment from level k to level k + 1
  For j In {1 : 8}
    Line(m + j) = {100 * k + j, 100 * (k + 1) + j};  // vertical edges
  EndFor
  Transfinite Curve{m + 1 : m + 8} = Max(1, Round(NL * (zs[k + 1] - zs[k]) / L)) + 1;
  For i In {0 : 3}
    i1 = (i + 1) % 4;
    // Outer face, inner face, diagonal face at corner i of wall i in the segment.
    Curve Loop(m + 10 + i) = {100 * k + 1 + i, m + 1 + i1, -(100 * (k + 1) + 1 + i), -(m + 1 + i)};
    Surface(m + 10 + i) = {m + 10 + i};
    Curve Loop(m + 20 + i) = {100 * k + 5 + i, m + 5 + i1, -(100 * (k + 1) + 5 + i), -(m + 5 + i)};
    Surface(m + 20 + i) = {m + 20 + i};
    Curve Loop(m + 30 + i) = {100 * k + 9 + i, m + 5 + i, -(100 * (k + 1) + 9 + i), -(m + 1 + i)};
    Surface(m + 30 + i) = {m + 30 + i};
    outer[] += {m + 10 + i};
    inner[] += {m + 20 + i};
  EndFor
  For i In {0 : 3}
    i1 = (i + 1) % 4;
    Surface Loop(m + 40 + i) = {100 * k + 1 + i, 100 * (k + 1) + 1 + i, m + 10 + i, m + 20 + i,
                                m + 30 + i, m + 30 + i1};
    Volume(m + 40 + i) = {m + 40 + i};
    vols[] += {m + 40 + i};
  EndFor
EndFor
Transfinite Surface{:};
Recombine Surface{:};
Transfinite Volume{:};
Physical Volume("tube") = {vols[]};
Physical Surface("bottom") = {1 : 4};
Physical Surface("top") = {100 * (nk - 1) + 1 : 100 * (nk - 1) + 4};
Physical Surface("outer") = {outer[]};
Physical Surface("inner") = {inner[]};
