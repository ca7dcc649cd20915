// A bar along x meshed with gmsh's default tetrahedra (no Transfinite, no Recombine): length L,
// square cross-section A x A, element size H. The same physical groups as bar.geo: volume
// "bar"; surfaces "left" (x = 0), "right" (x = L), "sides_y" (the two faces normal to y),
// "sides_z" (the two faces normal to z). tdyn runs each tetrahedron as 4 hexahedra.
If(!Exists(L)) L = 1.0; EndIf
If(!Exists(A)) A = 0.1; EndIf
If(!Exists(H)) H = 0.025; EndIf
SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, L, A, A};
Mesh.MeshSizeMin = H;
Mesh.MeshSizeMax = H;
Physical Volume("bar") = {1};
Physical Surface("left") = {1};
Physical Surface("right") = {2};
Physical Surface("sides_y") = {3, 4};
Physical Surface("sides_z") = {5, 6};
