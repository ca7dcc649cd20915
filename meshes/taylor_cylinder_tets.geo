// Quarter of a round bar for a Taylor impact, meshed with gmsh's default tetrahedra (no
// Transfinite, no Recombine; tdyn runs each tetrahedron as 4 hexahedra): axis along z, impact
// face at z = 0, symmetry planes x = 0 and y = 0. The same physical groups as
// taylor_cylinder.geo. Parameters (override with -setnumber): L length, R radius, N elements
// across the radius (the element size is R / N, as the O-grid's at the same N).
If(!Exists(L)) L = 0.0324; EndIf
If(!Exists(R)) R = 0.0032; EndIf
If(!Exists(N)) N = 6; EndIf
SetFactory("OpenCASCADE");
Cylinder(1) = {0, 0, 0, 0, 0, L, R, Pi / 2};
Mesh.MeshSizeMin = R / N;
Mesh.MeshSizeMax = R / N;
e = 1e-3 * R;
Physical Volume("bar") = {1};
Physical Surface("impact") = Surface In BoundingBox{-e, -e, -e, R + e, R + e, e};
Physical Surface("free_end") = Surface In BoundingBox{-e, -e, L - e, R + e, R + e, L + e};
Physical Surface("sym_x") = Surface In BoundingBox{-e, -e, -e, e, R + e, L + e};
Physical Surface("sym_y") = Surface In BoundingBox{-e, -e, -e, R + e, e, L + e};
all() = Surface{:};
Physical Surface("mantle") = {};
For k In {0 : #all() - 1}
  bb() = BoundingBox Surface{all(k)};
  If (bb(3) - bb(0) > 0.5 * R && bb(4) - bb(1) > 0.5 * R && bb(5) - bb(2) > 0.5 * L)
    Physical Surface("mantle") += {all(k)};
  EndIf
EndFor
