// Two equal bars along x, end to end with a gap G: bar "bar_a" on [0, L], "bar_b" on [L + G, 2L + G];
// square cross-section A x A, N hexahedra along each bar and M across. Surfaces: "a_left", "a_right",
// "b_left", "b_right" (the ends), "sides" (the lateral faces of both). Override with -setnumber.
If(!Exists(L)) L = 0.1; EndIf
If(!Exists(A)) A = 0.01; EndIf
If(!Exists(G)) G = 0.0001; EndIf
If(!Exists(N)) N = 20; EndIf
If(!Exists(M)) M = 1; EndIf
SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, L, A, A};
Box(2) = {L + G, 0, 0, L, A, A};
For c In {1 : 24}
  bb() = BoundingBox Curve{c};
  If (bb(3) - bb(0) > 0.5 * L)
    Transfinite Curve{c} = N + 1;
  Else
    Transfinite Curve{c} = M + 1;
  EndIf
EndFor
Transfinite Surface{:};
Recombine Surface{:};
Transfinite Volume{:};
Physical Volume("bar_a") = {1};
Physical Volume("bar_b") = {2};
Physical Surface("a_left") = {1};
Physical Surface("a_right") = {2};
Physical Surface("b_left") = {7};
Physical Surface("b_right") = {8};
Physical Surface("sides") = {3, 4, 5, 6, 9, 10, 11, 12};
