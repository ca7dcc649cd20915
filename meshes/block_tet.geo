// A block L x A x A meshed by gmsh's default tetrahedra of size H (the tetrahedral counterpart
// of bar.geo, for the FE benchmark on tetrahedra). Volume "bar"; surfaces "left" (x = 0),
// "right" (x = L), "sides" (the other four).
SetFactory("OpenCASCADE");
If(!Exists(L)) L = 1.0; EndIf
If(!Exists(A)) A = 1.0; EndIf
If(!Exists(H)) H = 0.05; EndIf
Box(1) = {0, 0, 0, L, A, A};
e = 1e-3 * A;
left() = Surface In BoundingBox{-e, -e, -e, e, A + e, A + e};
right() = Surface In BoundingBox{L - e, -e, -e, L + e, A + e, A + e};
sides() = Boundary{ Volume{1}; };
sides() -= left();
sides() -= right();
Physical Volume("bar") = {1};
Physical Surface("left") = left();
Physical Surface("right") = right();
Physical Surface("sides") = sides();
MeshSize{ PointsOf{ Volume{1}; } } = H;
