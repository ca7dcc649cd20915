// A round tube along z: outer radius R, wall thickness T, length L; NC hexahedra along each
// quarter of the circumference, NT through the wall, NL along the length. Physical groups:
// volume "tube", surfaces "bottom" (z = 0), "top" (z = L), "outer" and "inner".
If(!Exists(R)) R = 0.015; EndIf
If(!Exists(T)) T = 0.001; EndIf
If(!Exists(L)) L = 0.06; EndIf
If(!Exists(NC)) NC = 6; EndIf
If(!Exists(NT)) NT = 2; EndIf
If(!Exists(NL)) NL = 30; EndIf
Point(1) = {0, 0, 0};
For k In {0:3}
  Point(10+k) = {(R-T)*Cos(k*Pi/2), (R-T)*Sin(k*Pi/2), 0};
  Point(20+k) = {R*Cos(k*Pi/2), R*Sin(k*Pi/2), 0};
EndFor
For k In {0:3}
  k1 = (k+1)%4;
  Line(100+k) = {10+k, 20+k};
  Circle(200+k) = {20+k, 1, 20+k1};
  Circle(300+k) = {10+k, 1, 10+k1};
EndFor
bot[] = {};
For k In {0:3}
  k1 = (k+1)%4;
  Curve Loop(400+k) = {100+k, 200+k, -(100+k1), -(300+k)};
  Plane Surface(400+k) = {400+k};
  Transfinite Curve{100+k} = NT+1;
  Transfinite Curve{200+k, 300+k} = NC+1;
  Transfinite Surface{400+k};
  Recombine Surface{400+k};
  bot[] += {400+k};
EndFor
top[] = {}; vol[] = {}; outer[] = {}; inner[] = {};
For k In {0:3}
  out[] = Extrude {0, 0, L} { Surface{400+k}; Layers{NL}; Recombine; };
  top[] += {out[0]}; vol[] += {out[1]}; outer[] += {out[3]}; inner[] += {out[5]};
EndFor
Coherence;
Physical Volume("tube") = {vol[]};
Physical Surface("bottom") = {bot[]};
Physical Surface("top") = {top[]};
Physical Surface("outer") = {outer[]};
Physical Surface("inner") = {inner[]};
