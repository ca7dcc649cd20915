// Two quarters of a square Taylor bar for a symmetric impact: bar "bar_a" on x in [-L - G, -G]
// and "bar_b" on [0, L] (the gap G between their impact faces), y, z in [0, W] with symmetry
// planes at y = 0 and z = 0. Each bar N hexahedra along x and M across, the two impact faces'
// nodes opposite each other. Override with -setnumber.
If(!Exists(L)) L = 0.0254; EndIf
If(!Exists(W)) W = 0.0038; EndIf
If(!Exists(G)) G = 1.0e-5; EndIf
If(!Exists(N)) N = 30; EndIf
If(!Exists(M)) M = 4; EndIf
SetFactory("OpenCASCADE");
Box(1) = {-L - G, 0, 0, L, W, W};
Box(2) = {0, 0, 0, L, W, W};
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
Physical Surface("a_impact") = {2};
Physical Surface("b_impact") = {7};
Physical Surface("sym_y") = {3, 9};
Physical Surface("sym_z") = {5, 11};
