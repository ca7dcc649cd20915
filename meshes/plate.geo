// A flat plate: L x L in x and y, thickness T in z (top face at z = 0), N x N x M hexahedra;
// LX and NX (default L and N) make it LX long in x with NX elements along x.
// Physical groups: volume "plate"; surfaces "top" (z = 0), "bottom" (z = -T), "edges" (the four
// sides). Override with -setnumber.
If(!Exists(L)) L = 0.1; EndIf
If(!Exists(LX)) LX = L; EndIf
If(!Exists(T)) T = 0.01; EndIf
If(!Exists(N)) N = 10; EndIf
If(!Exists(M)) M = 2; EndIf
If(!Exists(NX)) NX = N; EndIf
SetFactory("OpenCASCADE");
Box(1) = {-LX / 2, -L / 2, -T, LX, L, T};
For c In {1 : 12}
  bb() = BoundingBox Curve{c};
  If (bb(5) - bb(2) > 0.5 * T)
    Transfinite Curve{c} = M + 1;
  ElseIf (bb(3) - bb(0) > 0.5 * LX)
    Transfinite Curve{c} = NX + 1;
  Else
    Transfinite Curve{c} = N + 1;
  EndIf
EndFor
Transfinite Surface{:};
Recombine Surface{:};
Transfinite Volume{:};
Physical Volume("plate") = {1};
Physical Surface("top") = {6};
Physical Surface("bottom") = {5};
Physical Surface("edges") = {1, 2, 3, 4};
