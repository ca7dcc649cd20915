// A plate with a central circular hole in tension, a quarter of it (two symmetry planes):
// the textbook stress concentration (Kirsch; Howland for a finite width), meshed by gmsh's
// default tetrahedra from OpenCASCADE solids. The whole plate is W wide (along x), L long (along
// y, the pull), T thick, the hole of radius A through it at the origin; the quarter is x, y >= 0,
// z in [0, T]. Element size: HH at the hole's edge, HF at the far corners (gmsh grades between).
// Volume "plate"; surfaces "sym_x" (x = 0), "sym_y" (y = 0), "pulled" (y = L/2), "hole".
SetFactory("OpenCASCADE");
If(!Exists(A)) A = 0.005; EndIf
If(!Exists(W)) W = 0.04; EndIf
If(!Exists(L)) L = 0.08; EndIf
If(!Exists(T)) T = 0.002; EndIf
If(!Exists(HH)) HH = 0.0008; EndIf
If(!Exists(HF)) HF = 0.004; EndIf

Box(1) = {0, 0, 0, W / 2, L / 2, T};
Cylinder(2) = {0, 0, -T, 0, 0, 3 * T, A};
BooleanDifference(3) = { Volume{1}; Delete; }{ Volume{2}; Delete; };

// Faces by position (boxes 2e wide around each plane: OpenCASCADE pads its bounding boxes).
e = 1e-3 * A;
symx() = Surface In BoundingBox{-e, -e, -e, e, L, T + e};
symy() = Surface In BoundingBox{-e, -e, -e, W, e, T + e};
pulled() = Surface In BoundingBox{-e, L / 2 - e, -e, W, L / 2 + e, T + e};
hole() = Surface In BoundingBox{-e, -e, -e, A + e, A + e, T + e};
hole() -= symx();
hole() -= symy();

Physical Volume("plate") = {3};
Physical Surface("sym_x") = symx();
Physical Surface("sym_y") = symy();
Physical Surface("pulled") = pulled();
Physical Surface("hole") = hole();

MeshSize{ PointsOf{ Volume{3}; } } = HF;
MeshSize{ Point In BoundingBox{-e, -e, -e, A + e, A + e, T + e} } = HH;
