// Quarter of a square bar for a Taylor impact: x in [0, L] (impact face at x = 0),
// y, z in [0, W] with symmetry planes at y = 0 and z = 0. All hexahedra.
// Parameters (override with -setnumber): L length, W half-width, N elements along x, M across.
If(!Exists(L)) L = 0.0254; EndIf
If(!Exists(W)) W = 0.0038; EndIf
If(!Exists(N)) N = 30; EndIf
If(!Exists(M)) M = 4; EndIf
SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, L, W, W};
// The box's 12 edges: those along x get N elements, the others M.
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
Physical Surface("impact") = {1};
Physical Surface("free_end") = {2};
Physical Surface("sym_y") = {3};
Physical Surface("sym_z") = {5};
