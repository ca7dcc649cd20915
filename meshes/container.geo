// A thin-walled steel container (an open-topped box) and an inclined rigid wall, half modelled:
// the container is W long (x), 2 Y0 wide (y; the half y in [0, Y0] is meshed, y = 0 is the
// symmetry plane), HT high (z), with walls and bottom T thick, NT hexahedra through the
// thickness and elements of about H along the walls. The wall is a slab of thickness WT, tilted
// by ANG degrees about y (its lower part leaning away), GAP beyond the container's top edge at
// its end x = W.
// Volumes "container", "wall"; surfaces "symmetry" (y = 0 of the container), "wall_all" (every
// face of the wall), "container_skin" (every other boundary face of the container).
If(!Exists(W)) W = 0.6; EndIf
If(!Exists(Y0)) Y0 = 0.15; EndIf
If(!Exists(HT)) HT = 0.3; EndIf
If(!Exists(T)) T = 0.006; EndIf
If(!Exists(NT)) NT = 3; EndIf
If(!Exists(H)) H = 0.014; EndIf
If(!Exists(WT)) WT = 0.02; EndIf
If(!Exists(ANG)) ANG = 30; EndIf
If(!Exists(GAP)) GAP = 0.005; EndIf
SetFactory("OpenCASCADE");
// The wall first (volume 1: its elements and its body come first; the two-pass contact search
// does not depend on that order).
// The wall: a slab wider than the container's half and taller than the container, its front
// face GAP beyond the container's end at the height of the container's top edge, tilted about
// that edge so that its lower part leans away: the top edge of the end wall strikes first.
wv = newv;
Box(wv) = {W + GAP, -0.02, -0.25 * HT, WT, Y0 + 0.04, 1.35 * HT};
Rotate {{0, 1, 0}, {W + GAP, 0, HT}, -ANG * Pi / 180} { Volume{wv}; }
// The container as the cells of a grid (x: end wall, middle, end wall; y: inside, side wall;
// z: bottom, wall height), less the cells of the open inside.
xs[] = {0, T, W - T, W};
ys[] = {0, Y0 - T, Y0};
zs[] = {0, T, HT};
cells[] = {};
For i In {0 : 2}
  For j In {0 : 1}
    For k In {0 : 1}
      If (!(i == 1 && j == 0 && k == 1))
        c = newv;
        Box(c) = {xs[i], ys[j], zs[k], xs[i + 1] - xs[i], ys[j + 1] - ys[j], zs[k + 1] - zs[k]};
        cells[] += {c};
      EndIf
    EndFor
  EndFor
EndFor
frag[] = BooleanFragments{ Volume{cells[]}; Delete; }{};
// Element counts: edges about T long get NT, the others about H long (at least 1).
cs[] = Curve{:};
For n In {0 : #cs[] - 1}
  bb() = BoundingBox Curve{cs[n]};
  len = Sqrt((bb(3) - bb(0))^2 + (bb(4) - bb(1))^2 + (bb(5) - bb(2))^2);
  If (len < 1.5 * T)
    Transfinite Curve{cs[n]} = NT + 1;
  Else
    Transfinite Curve{cs[n]} = Max(1, Round(len / H)) + 1;
  EndIf
EndFor
ws[] = Boundary{ Volume{wv}; };
Transfinite Surface{:};
Recombine Surface{:};
Transfinite Volume{:};
Physical Volume("container") = {frag[]};
Physical Volume("wall") = {wv};
sym[] = Surface In BoundingBox{-1e-6, -1e-6, -1e-6, W + 1e-6, 1e-6, HT + 1e-6};
Physical Surface("symmetry") = {sym[]};
Physical Surface("wall_all") = {ws[]};
