// An N x N x N grid of separate cubic bricks (the paper's bricks flying apart): side A, gap G
// between neighbours, NE hexahedra per brick edge, the grid centred on the origin. Brick
// (i, j, k) (each index in 0..N-1) is the physical volume "b<i + N j + N^2 k>", so that a scene
// can give each brick its own velocity; "brick_skin" is every brick face. With TABLE = 1 a table
// lies under the grid, G below the lowest bricks: W x W x TH (W = the grid's width + 2 A), NW x
// NW x NH hexahedra, volume "table", its top face "table_top". Override with -setnumber.
If(!Exists(N)) N = 4; EndIf
If(!Exists(A)) A = 0.01; EndIf
If(!Exists(G)) G = 0.0002; EndIf
If(!Exists(NE)) NE = 3; EndIf
If(!Exists(TABLE)) TABLE = 0; EndIf
If(!Exists(TH)) TH = 0.01; EndIf
If(!Exists(NW)) NW = 24; EndIf
If(!Exists(NH)) NH = 4; EndIf
SetFactory("OpenCASCADE");
c0 = -0.5 * (N * A + (N - 1) * G);
For k In {0 : N - 1}
  For j In {0 : N - 1}
    For i In {0 : N - 1}
      b = i + N * j + N * N * k;
      Box(b + 1) = {c0 + i * (A + G), c0 + j * (A + G), c0 + k * (A + G), A, A, A};
      Physical Volume(Sprintf("b%g", b)) = {b + 1};
    EndFor
  EndFor
EndFor
Physical Surface("brick_skin") = {1 : 6 * N^3};
Transfinite Curve{:} = NE + 1;
If (TABLE > 0)
  W = N * A + (N - 1) * G + 2 * A;
  Box(N^3 + 1) = {-W / 2, -W / 2, c0 - G - TH, W, W, TH};
  Physical Volume("table") = {N^3 + 1};
  Physical Surface("table_top") = {6 * N^3 + 6};
  For c In {12 * N^3 + 1 : 12 * N^3 + 12}
    bb() = BoundingBox Curve{c};
    If (bb(5) - bb(2) > 0.5 * TH)
      Transfinite Curve{c} = NH + 1;
    Else
      Transfinite Curve{c} = NW + 1;
    EndIf
  EndFor
EndIf
Transfinite Surface{:};
Recombine Surface{:};
Transfinite Volume{:};
