// A steel rod and a wall of separate bricks (the paper's rod-and-wall scene, coarse). The rod,
// of square section RS x RS and length RL, lies along x with its tip at x = -GAP0; the wall
// stands at x in [0, BX]: NY x NZ bricks of BY (along y) x BZ (along z), separated by gaps G so
// that each brick is a body of its own, centred on the rod's axis. Hexahedra of about H
// (at least 2 across any edge). Volumes "rod" and "bricks"; surface "rod_tip" (x = -GAP0).
If(!Exists(RS)) RS = 0.03; EndIf
If(!Exists(RL)) RL = 0.3; EndIf
If(!Exists(GAP0)) GAP0 = 0.002; EndIf
If(!Exists(BX)) BX = 0.05; EndIf
If(!Exists(BY)) BY = 0.1; EndIf
If(!Exists(BZ)) BZ = 0.05; EndIf
If(!Exists(NY)) NY = 4; EndIf
If(!Exists(NZ)) NZ = 6; EndIf
If(!Exists(G)) G = 0.0005; EndIf
If(!Exists(H)) H = 0.025; EndIf
SetFactory("OpenCASCADE");
Box(1) = {-GAP0 - RL, -RS / 2, -RS / 2, RL, RS, RS};
bricks[] = {};
For j In {0 : NY - 1}
  For k In {0 : NZ - 1}
    y0 = -NY * (BY + G) / 2 + j * (BY + G) + G / 2;
    z0 = -NZ * (BZ + G) / 2 + k * (BZ + G) + G / 2;
    b = newv;
    Box(b) = {0, y0, z0, BX, BY, BZ};
    bricks[] += {b};
  EndFor
EndFor
// Every edge of every box: about H long elements, at least 2.
cs[] = Curve{:};
For i In {0 : #cs[] - 1}
  bb() = BoundingBox Curve{cs[i]};
  len = Sqrt((bb(3) - bb(0))^2 + (bb(4) - bb(1))^2 + (bb(5) - bb(2))^2);
  Transfinite Curve{cs[i]} = Max(2, Round(len / H)) + 1;
EndFor
Transfinite Surface{:};
Recombine Surface{:};
Transfinite Volume{:};
Physical Volume("rod") = {1};
Physical Volume("bricks") = {bricks[]};
tip[] = Surface In BoundingBox{-GAP0 - 1e-6, -RS, -RS, -GAP0 + 1e-6, RS, RS};
Physical Surface("rod_tip") = {tip[]};
