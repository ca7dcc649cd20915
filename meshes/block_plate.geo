// A cube tilted about x then y, hovering a gap G above a square plate: the block-drop contact
// scene. Plate "plate": [-W/2, W/2]^2 x [-H, 0], NP x NP x NH hexahedra; block "block": side A,
// NB hexahedra per edge, turned TX degrees about x then TY degrees about y, its lowest point
// (a corner for generic angles) G above the plate's top face z = 0. The plate is volume 1, so
// its elements come first and it is body 0; the block is body 1 (the two-pass contact search
// does not depend on that order). Surfaces: "plate_top", "plate_bottom",
// "plate_sides", "block_skin". Override with -setnumber.
If(!Exists(A)) A = 0.02; EndIf
If(!Exists(NB)) NB = 4; EndIf
If(!Exists(W)) W = 0.08; EndIf
If(!Exists(H)) H = 0.01; EndIf
If(!Exists(NP)) NP = 16; EndIf
If(!Exists(NH)) NH = 2; EndIf
If(!Exists(G)) G = 0.001; EndIf
If(!Exists(TX)) TX = 30; EndIf
If(!Exists(TY)) TY = 20; EndIf
SetFactory("OpenCASCADE");
Box(1) = {-W/2, -W/2, -H, W, W, H};
Box(2) = {-A/2, -A/2, -A/2, A, A, A};
Rotate {{1, 0, 0}, {0, 0, 0}, TX * Pi / 180} { Volume{2}; }
Rotate {{0, 1, 0}, {0, 0, 0}, TY * Pi / 180} { Volume{2}; }
// gmsh's bounding boxes are padded by about 1e-7 m: the gap is G to that.
bb() = BoundingBox Volume{2};
Translate {0, 0, G - bb(2)} { Volume{2}; }
// Plate edges: NH across the thickness, NP along x and y; every block edge NB.
For c In {1 : 12}
  bb() = BoundingBox Curve{c};
  If (bb(5) - bb(2) > 0.5 * H)
    Transfinite Curve{c} = NH + 1;
  Else
    Transfinite Curve{c} = NP + 1;
  EndIf
EndFor
Transfinite Curve{13 : 24} = NB + 1;
Transfinite Surface{:};
Recombine Surface{:};
Transfinite Volume{:};
Physical Volume("plate") = {1};
Physical Volume("block") = {2};
Physical Surface("plate_top") = {6};
Physical Surface("plate_bottom") = {5};
Physical Surface("plate_sides") = {1, 2, 3, 4};
Physical Surface("block_skin") = {7 : 12};
