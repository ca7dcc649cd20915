// Underwater explosion, quarter model (symmetry planes x = 0 and y = 0), all lengths in units of
// the charge half-width A:
//   water  [0, 10A] x [0, 10A] x [-16A, 8A] with a cavity [0, A] x [0, A] x [-A, A] for the
//          charge (SPH particles fill it; the charge centre is the origin);
//   plate  steel [0, 10A] x [0, 10A] x [8A, 9A] with a square hole [0, 2A] x [0, 2A];
//   plug   steel [0, 2A] x [0, 2A] x [8A, 9A] in the hole (a separate body);
//   wall   two rigid slabs one element thick, [-h, 0] x [0, 6A] x [-6A, 6A] and
//          [0, 6A] x [-h, 0] x [-6A, 6A], whose faces on the symmetry planes hold the charge's
//          particles (the SPH stage has no symmetry planes; the water, plate and plug have theirs
//          as boundary conditions). They reach beyond the cavity, which grows.
// N hexahedra per A everywhere (h = A/N; N through the plate's thickness). The parts are
// meshed separately (no shared nodes): they meet through contact.
// Physical volumes: water, plate, plug, wall. Surfaces: sym_x, sym_y (water, plate, plug on the
// symmetry planes), water_far_x, water_far_y, water_bottom (the water's outer faces), cavity,
// water_top, plate_bottom, plate_edge (x = 10A and y = 10A), hole, plug_bottom, plug_side,
// wall_face (the two faces holding the charge), wall_skin (every face of the wall).
If(!Exists(A)) A = 0.02; EndIf
If(!Exists(N)) N = 2; EndIf
SetFactory("OpenCASCADE");
X = 10 * A;    // lateral extent (x and y)
ZB = -16 * A;  // water bottom
ZT = 8 * A;    // water top = plate bottom
T = A;         // plate thickness
B = 2 * A;     // plug half-width
h = A / N;
e = 1e-3 * A;  // selection tolerance (OpenCASCADE bounding boxes carry its 1e-7 m tolerance)

// Water: a 2 x 2 x 3 grid of boxes less the cavity cell, fragmented into one conformal body.
xs[] = {0, A, X};
zs[] = {ZB, -A, A, ZT};
k = 0;
For i In {0 : 1}
  For j In {0 : 1}
    For l In {0 : 2}
      If (!(i == 0 && j == 0 && l == 1))
        k += 1;
        Box(k) = {xs[i], xs[j], zs[l], xs[i + 1] - xs[i], xs[j + 1] - xs[j], zs[l + 1] - zs[l]};
      EndIf
    EndFor
  EndFor
EndFor
water() = BooleanFragments{ Volume{1 : k}; Delete; }{};
wsurf() = Surface{:};

// Plate: three boxes around the hole, fragmented together.
ps[] = {0, B, X};
n0 = k;
For i In {0 : 1}
  For j In {0 : 1}
    If (!(i == 0 && j == 0))
      k += 1;
      Box(k) = {ps[i], ps[j], ZT, ps[i + 1] - ps[i], ps[j + 1] - ps[j], T};
    EndIf
  EndFor
EndFor
plate() = BooleanFragments{ Volume{n0 + 1 : k}; Delete; }{};
psurf() = Surface{:};
psurf() -= wsurf();

k += 1;
Box(k) = {0, 0, ZT, B, B, T};
plug() = {k};
gsurf() = Surface{:};
gsurf() -= wsurf();
gsurf() -= psurf();

k += 1;
Box(k) = {-h, 0, -6 * A, h, 6 * A, 12 * A};
k += 1;
Box(k) = {0, -h, -6 * A, 6 * A, h, 12 * A};
wall() = {k - 1, k};
lsurf() = Surface{:};
lsurf() -= wsurf();
lsurf() -= psurf();
lsurf() -= gsurf();

// Every curve is axis-aligned with a length that is a multiple of h.
cs() = Curve{:};
For ci In {0 : #cs() - 1}
  c = cs(ci);
  bb() = BoundingBox Curve{c};
  len = Max(bb(3) - bb(0), Max(bb(4) - bb(1), bb(5) - bb(2)));
  Transfinite Curve{c} = Round(len / h) + 1;
EndFor
Transfinite Surface{:};
Recombine Surface{:};
Transfinite Volume{:};

// picked() = the members of cand() that are in part().
Macro Pick
  picked() = {};
  For ii In {0 : #cand() - 1}
    For jj In {0 : #part() - 1}
      If (cand(ii) == part(jj))
        picked() += cand(ii);
      EndIf
    EndFor
  EndFor
Return

Physical Volume("water") = {water()};
Physical Volume("plate") = {plate()};
Physical Volume("plug") = {plug()};
Physical Volume("wall") = {wall()};

solid() = {wsurf(), psurf(), gsurf()};
part() = solid();
cand() = Surface In BoundingBox{-e, -e, ZB - e, e, X + e, ZT + T + e};
Call Pick;
Physical Surface("sym_x") = {picked()};
cand() = Surface In BoundingBox{-e, -e, ZB - e, X + e, e, ZT + T + e};
Call Pick;
Physical Surface("sym_y") = {picked()};

part() = wsurf();
cand() = Surface In BoundingBox{X - e, -e, ZB - e, X + e, X + e, ZT + e};
Call Pick;
Physical Surface("water_far_x") = {picked()};
cand() = Surface In BoundingBox{-e, X - e, ZB - e, X + e, X + e, ZT + e};
Call Pick;
Physical Surface("water_far_y") = {picked()};
cand() = Surface In BoundingBox{-e, -e, ZB - e, X + e, X + e, ZB + e};
Call Pick;
Physical Surface("water_bottom") = {picked()};
cand() = Surface In BoundingBox{-e, -e, -A - e, A + e, A + e, A + e};
Call Pick;
Physical Surface("cavity") = {picked()};
cand() = Surface In BoundingBox{-e, -e, ZT - e, X + e, X + e, ZT + e};
Call Pick;
Physical Surface("water_top") = {picked()};

part() = psurf();
Call Pick;
Physical Surface("plate_bottom") = {picked()};
cand() = Surface In BoundingBox{X - e, -e, ZT - e, X + e, X + e, ZT + T + e};
cand() += Surface In BoundingBox{-e, X - e, ZT - e, X + e, X + e, ZT + T + e};
Call Pick;
Physical Surface("plate_edge") = {picked()};
cand() = Surface In BoundingBox{B - e, -e, ZT - e, B + e, B + e, ZT + T + e};
cand() += Surface In BoundingBox{-e, B - e, ZT - e, B + e, B + e, ZT + T + e};
Call Pick;
Physical Surface("hole") = {picked()};

part() = gsurf();
Call Pick;
Physical Surface("plug_side") = {picked()};
cand() = Surface In BoundingBox{-e, -e, ZT - e, X + e, X + e, ZT + e};
Call Pick;
Physical Surface("plug_bottom") = {picked()};

part() = lsurf();
cand() = Surface In BoundingBox{-e, -e, -6 * A - e, e, 6 * A + e, 6 * A + e};
cand() += Surface In BoundingBox{-e, -e, -6 * A - e, 6 * A + e, e, 6 * A + e};
Call Pick;
Physical Surface("wall_face") = {picked()};
Physical Surface("wall_skin") = {lsurf()};
