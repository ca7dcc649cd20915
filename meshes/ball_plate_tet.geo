// A steel ball over a square plate, both meshed by gmsh's default tetrahedra (OpenCASCADE
// solids, no structured blocks): the tetrahedral counterpart of ball_plate.geo. Plate "plate":
// [-W/2, W/2]^2 x [-H, 0]; ball "ball": radius R, centre R + G above the plate's top face.
// Element size: HB in the ball, HP in the plate (gmsh's size at the solids' points; the default
// Delaunay/frontal algorithms fill the volumes). Surfaces: "ball_skin", "plate_top",
// "plate_bottom", "plate_sides". The two solids are separate (no shared nodes): a gap G.
SetFactory("OpenCASCADE");
If(!Exists(R)) R = 0.005; EndIf
If(!Exists(W)) W = 0.03; EndIf
If(!Exists(H)) H = 0.004; EndIf
If(!Exists(G)) G = 0.0005; EndIf
If(!Exists(HB)) HB = 0.0015; EndIf
If(!Exists(HP)) HP = 0.0025; EndIf

Box(1) = {-W / 2, -W / 2, -H, W, W, H};
Sphere(2) = {0, 0, R + G, R};

// Faces of the plate by position (boxes 2e wide around each plane: OpenCASCADE pads its bounding boxes).
e = 1e-3 * W;
top() = Surface In BoundingBox{-W, -W, -e, W, W, e};
bottom() = Surface In BoundingBox{-W, -W, -H - e, W, W, -H + e};
plate() = Boundary{ Volume{1}; };
sides() = plate();
sides() -= top();
sides() -= bottom();
skin() = Boundary{ Volume{2}; };

Physical Volume("plate") = {1};
Physical Volume("ball") = {2};
Physical Surface("plate_top") = top();
Physical Surface("plate_bottom") = bottom();
Physical Surface("plate_sides") = sides();
Physical Surface("ball_skin") = skin();

MeshSize{ PointsOf{ Volume{1}; } } = HP;
MeshSize{ PointsOf{ Volume{2}; } } = HB;
