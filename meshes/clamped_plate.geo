// A quarter of a clamped square plate: side A (the whole plate's), thickness T, the quarter
// [0, A/2] x [0, A/2] in x and y, mid-plane at z = 0 (-T/2 <= z <= T/2); N x N hexahedra in
// the quarter, M through the thickness.
// Physical groups: volume "plate"; surfaces "top" (z = T/2), "clamp" (the edges x = A/2 and
// y = A/2), "sym_x" (x = 0), "sym_y" (y = 0). Override with -setnumber.
If(!Exists(A)) A = 1.0; EndIf
If(!Exists(T)) T = 0.025; EndIf
If(!Exists(N)) N = 10; EndIf
If(!Exists(M)) M = 3; EndIf
SetFactory("OpenCASCADE");
Box(1) = {0, 0, -T / 2, A / 2, A / 2, T};
For c In {1 : 12}
  bb() = BoundingBox Curve{c};
  If (bb(5) - bb(2) > 0.5 * T)
    Transfinite Curve{c} = M + 1;
  Else
    Transfinite Curve{c} = N + 1;
  EndIf
EndFor
Transfinite Surface{:};
Recombine Surface{:};
Transfinite Volume{:};
Physical Volume("plate") = {1};
// OpenCASCADE's box faces: 1 x-, 2 x+, 3 y-, 4 y+, 5 z-, 6 z+.
Physical Surface("top") = {6};
Physical Surface("clamp") = {2, 4};
Physical Surface("sym_x") = {1};
Physical Surface("sym_y") = {3};
