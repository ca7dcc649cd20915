// Quarter of a round bar for a Taylor impact (O-grid of hexahedra): axis along z, impact face
// at z = 0, symmetry planes x = 0 and y = 0. Parameters (override with -setnumber):
// L length, R radius, N elements across the radius (the O-grid's inner square takes N/2 of them,
// rounded down, the ring the rest; the quarter arc 2 Floor(N/2)), NL elements along the axis
// (default: the nearest to L/R N, elements near cubes).
If(!Exists(L)) L = 0.0324; EndIf
If(!Exists(R)) R = 0.0032; EndIf
If(!Exists(N)) N = 6; EndIf
If(!Exists(NL)) NL = Round(N * L / R); EndIf
Ni = Floor(N / 2);          // elements along each side of the inner square
Nr = N - Ni;                // elements across the ring
s = 0.5 * R;                // half-side of the inner square on the axes
c = 0.6 * R / Sqrt(2);      // its diagonal corner, pushed out to round the ring's cells
Point(1) = {0, 0, 0};
Point(2) = {s, 0, 0};
Point(3) = {c, c, 0};
Point(4) = {0, s, 0};
Point(5) = {R, 0, 0};
Point(6) = {R / Sqrt(2), R / Sqrt(2), 0};
Point(7) = {0, R, 0};
Line(1) = {1, 2};
Line(2) = {2, 3};
Line(3) = {3, 4};
Line(4) = {4, 1};
Line(5) = {2, 5};
Circle(6) = {5, 1, 6};
Line(7) = {6, 3};
Circle(8) = {6, 1, 7};
Line(9) = {7, 4};
Curve Loop(1) = {1, 2, 3, 4};
Plane Surface(1) = {1};
Curve Loop(2) = {5, 6, 7, -2};
Plane Surface(2) = {2};
Curve Loop(3) = {-7, 8, 9, -3};
Plane Surface(3) = {3};
Transfinite Curve{1, 2, 3, 4, 6, 8} = Ni + 1;
Transfinite Curve{5, 7, 9} = Nr + 1;
Transfinite Surface{1, 2, 3};
Recombine Surface{1, 2, 3};
out[] = Extrude {0, 0, L} { Surface{1, 2, 3}; Layers{NL}; Recombine; };
// out[]: for each extruded surface: top, volume, then the side of each curve of its loop.
Physical Volume("bar") = {out[1], out[7], out[13]};
Physical Surface("impact") = {1, 2, 3};
Physical Surface("free_end") = {out[0], out[6], out[12]};
Physical Surface("sym_x") = {out[5], out[16]};
Physical Surface("sym_y") = {out[2], out[8]};
Physical Surface("mantle") = {out[9], out[15]};
