// A striker and a two-layer target along x, square section A x A with M hexahedra across (the
// eroding-contact test, tests/tests/erosion_contact.rs). The target's front layer "front" on
// [0, LF] (NF hexahedra along x) and its back "back" on [LF, LF + LB] (NB) share the face
// x = LF node for node (one body); the striker "striker" on [-GAP - LS, -GAP] (NS) is a body of
// its own. Extruded with the built-in kernel, so the two layers' common face is conforming.
// Surfaces: "striker_tip" (x = -GAP), "target_face" (x = 0). Override with -setnumber.
If(!Exists(A)) A = 0.01; EndIf
If(!Exists(M)) M = 1; EndIf
If(!Exists(LS)) LS = 0.02; EndIf
If(!Exists(NS)) NS = 4; EndIf
If(!Exists(GAP)) GAP = 0.0001; EndIf
If(!Exists(LF)) LF = 0.005; EndIf
If(!Exists(NF)) NF = 1; EndIf
If(!Exists(LB)) LB = 0.02; EndIf
If(!Exists(NB)) NB = 4; EndIf
// The target's front square at x = 0 and the striker's back square at x = -GAP - LS.
Point(1) = {0, 0, 0}; Point(2) = {0, A, 0}; Point(3) = {0, A, A}; Point(4) = {0, 0, A};
Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 1};
Curve Loop(1) = {1, 2, 3, 4};
Plane Surface(1) = {1};
x0 = -GAP - LS;
Point(11) = {x0, 0, 0}; Point(12) = {x0, A, 0}; Point(13) = {x0, A, A}; Point(14) = {x0, 0, A};
Line(11) = {11, 12}; Line(12) = {12, 13}; Line(13) = {13, 14}; Line(14) = {14, 11};
Curve Loop(11) = {11, 12, 13, 14};
Plane Surface(11) = {11};
Transfinite Curve{1, 2, 3, 4, 11, 12, 13, 14} = M + 1;
Transfinite Surface{1, 11};
Recombine Surface{1, 11};
front[] = Extrude {LF, 0, 0} { Surface{1}; Layers{NF}; Recombine; };
back[] = Extrude {LB, 0, 0} { Surface{front[0]}; Layers{NB}; Recombine; };
striker[] = Extrude {LS, 0, 0} { Surface{11}; Layers{NS}; Recombine; };
Physical Volume("striker") = {striker[1]};
Physical Volume("front") = {front[1]};
Physical Volume("back") = {back[1]};
Physical Surface("striker_tip") = {striker[0]};
Physical Surface("target_face") = {1};
