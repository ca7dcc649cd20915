// A bar along x: length L, square cross-section A x A, N hexahedra along x and M across.
// Physical groups: volume "bar"; surfaces "left" (x = 0), "right" (x = L), "sides_y" (the two
// faces normal to y), "sides_z" (the two faces normal to z). Override with -setnumber.
If(!Exists(L)) L = 1.0; EndIf
If(!Exists(A)) A = 0.05; EndIf
If(!Exists(N)) N = 40; EndIf
If(!Exists(M)) M = 2; EndIf
SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, L, A, A};
// The box's 12 edges: those along x get N elements, the others M (by bounding box, so it also
// works for a cube, L = A).
For c In {1 : 12}
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
Physical Volume("bar") = {1};
Physical Surface("left") = {1};
Physical Surface("right") = {2};
Physical Surface("sides_y") = {3, 4};
Physical Surface("sides_z") = {5, 6};
