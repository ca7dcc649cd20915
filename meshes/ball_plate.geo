// A steel ball (hex O-grid) over a square plate: contact of a curved surface, its faces at
// angles to the plate's, onto a plate node or not. Plate "plate": [-W/2, W/2]^2 x [-H, 0],
// NP x NP x NH hexahedra (NP even: a plate node right under the ball's pole; odd: a face
// centre). Ball "ball": radius R, centre R + G above the plate's top face, an O-grid of seven
// blocks (an inner cube of half-diagonal R/2 and six shells), N hexahedra along each edge of the
// cube and of the six spherical patches (N even: a node at the pole, x = y = 0), M through the
// shells. BALL_FIRST = 1 meshes the ball first, so that its elements come first and it is body
// 0 (the contact answer must not depend on that order). Surfaces: "plate_top", "plate_bottom",
// "plate_sides", "ball_skin". Built-in kernel (the O-grid's spherical patches are transfinite
// surfaces "In Sphere"); the ball's entities are numbered from 1001 up, and its curve loops
// and orientations were generated once (they do not depend on the parameters).
If(!Exists(R)) R = 0.005; EndIf
If(!Exists(N)) N = 6; EndIf
If(!Exists(M)) M = 3; EndIf
If(!Exists(W)) W = 0.03; EndIf
If(!Exists(H)) H = 0.004; EndIf
If(!Exists(NP)) NP = 12; EndIf
If(!Exists(NH)) NH = 2; EndIf
If(!Exists(G)) G = 0.0005; EndIf
If(!Exists(BALL_FIRST)) BALL_FIRST = 0; EndIf

Macro Ball
  zc = R + G;
  a = 0.5 * R / Sqrt(3);
  For k In {0 : 7}
    sx = 2 * (k % 2) - 1;
    sy = 2 * (Floor(k / 2) % 2) - 1;
    sz = 2 * (Floor(k / 4) % 2) - 1;
    Point(1001 + k) = {a * sx, a * sy, zc + a * sz};
    Point(1009 + k) = {sx * R / Sqrt(3), sy * R / Sqrt(3), zc + sz * R / Sqrt(3)};
  EndFor
  Point(1017) = {0, 0, zc};
  Line(1001) = {1001, 1002};
  Line(1002) = {1001, 1003};
  Line(1003) = {1001, 1005};
  Line(1004) = {1002, 1004};
  Line(1005) = {1002, 1006};
  Line(1006) = {1003, 1004};
  Line(1007) = {1003, 1007};
  Line(1008) = {1004, 1008};
  Line(1009) = {1005, 1006};
  Line(1010) = {1005, 1007};
  Line(1011) = {1006, 1008};
  Line(1012) = {1007, 1008};
  Circle(1013) = {1009, 1017, 1010};
  Circle(1014) = {1009, 1017, 1011};
  Circle(1015) = {1009, 1017, 1013};
  Circle(1016) = {1010, 1017, 1012};
  Circle(1017) = {1010, 1017, 1014};
  Circle(1018) = {1011, 1017, 1012};
  Circle(1019) = {1011, 1017, 1015};
  Circle(1020) = {1012, 1017, 1016};
  Circle(1021) = {1013, 1017, 1014};
  Circle(1022) = {1013, 1017, 1015};
  Circle(1023) = {1014, 1017, 1016};
  Circle(1024) = {1015, 1017, 1016};
  Line(1025) = {1001, 1009};
  Line(1026) = {1002, 1010};
  Line(1027) = {1003, 1011};
  Line(1028) = {1004, 1012};
  Line(1029) = {1005, 1013};
  Line(1030) = {1006, 1014};
  Line(1031) = {1007, 1015};
  Line(1032) = {1008, 1016};
  Curve Loop(1101) = {1002, 1007, -1010, -1003};
  Surface(1102) = {1101};
  Curve Loop(1103) = {1014, 1019, -1022, -1015};
  Surface(1104) = {1103} In Sphere {1017};
  Curve Loop(1105) = {1004, 1008, -1011, -1005};
  Surface(1106) = {1105};
  Curve Loop(1107) = {1016, 1020, -1023, -1017};
  Surface(1108) = {1107} In Sphere {1017};
  Curve Loop(1109) = {1001, 1005, -1009, -1003};
  Surface(1110) = {1109};
  Curve Loop(1111) = {1013, 1017, -1021, -1015};
  Surface(1112) = {1111} In Sphere {1017};
  Curve Loop(1113) = {1006, 1008, -1012, -1007};
  Surface(1114) = {1113};
  Curve Loop(1115) = {1018, 1020, -1024, -1019};
  Surface(1116) = {1115} In Sphere {1017};
  Curve Loop(1117) = {1001, 1004, -1006, -1002};
  Surface(1118) = {1117};
  Curve Loop(1119) = {1013, 1016, -1018, -1014};
  Surface(1120) = {1119} In Sphere {1017};
  Curve Loop(1121) = {1009, 1011, -1012, -1010};
  Surface(1122) = {1121};
  Curve Loop(1123) = {1021, 1023, -1024, -1022};
  Surface(1124) = {1123} In Sphere {1017};
  Curve Loop(1125) = {1001, 1026, -1013, -1025};
  Surface(1126) = {1125};
  Curve Loop(1127) = {1002, 1027, -1014, -1025};
  Surface(1128) = {1127};
  Curve Loop(1129) = {1003, 1029, -1015, -1025};
  Surface(1130) = {1129};
  Curve Loop(1131) = {1004, 1028, -1016, -1026};
  Surface(1132) = {1131};
  Curve Loop(1133) = {1005, 1030, -1017, -1026};
  Surface(1134) = {1133};
  Curve Loop(1135) = {1006, 1028, -1018, -1027};
  Surface(1136) = {1135};
  Curve Loop(1137) = {1007, 1031, -1019, -1027};
  Surface(1138) = {1137};
  Curve Loop(1139) = {1008, 1032, -1020, -1028};
  Surface(1140) = {1139};
  Curve Loop(1141) = {1009, 1030, -1021, -1029};
  Surface(1142) = {1141};
  Curve Loop(1143) = {1010, 1031, -1022, -1029};
  Surface(1144) = {1143};
  Curve Loop(1145) = {1011, 1032, -1023, -1030};
  Surface(1146) = {1145};
  Curve Loop(1147) = {1012, 1032, -1024, -1031};
  Surface(1148) = {1147};
  Surface Loop(1201) = {1102, 1106, 1110, 1114, 1118, 1122};
  Volume(1202) = {1201};
  Surface Loop(1203) = {1102, 1104, 1128, 1138, 1144, 1130};
  Volume(1204) = {1203};
  Surface Loop(1205) = {1106, 1108, 1132, 1140, 1146, 1134};
  Volume(1206) = {1205};
  Surface Loop(1207) = {1110, 1112, 1126, 1134, 1142, 1130};
  Volume(1208) = {1207};
  Surface Loop(1209) = {1114, 1116, 1136, 1140, 1148, 1138};
  Volume(1210) = {1209};
  Surface Loop(1211) = {1118, 1120, 1126, 1132, 1136, 1128};
  Volume(1212) = {1211};
  Surface Loop(1213) = {1122, 1124, 1142, 1146, 1148, 1144};
  Volume(1214) = {1213};
  BALL_VOLUMES() = {1202, 1204, 1206, 1208, 1210, 1212, 1214};
  BALL_OUTER() = {1104, 1108, 1112, 1116, 1120, 1124};
  Transfinite Curve{1001 : 1024} = N + 1;
  Transfinite Curve{1025 : 1032} = M + 1;
  Transfinite Surface{1102 : 1148 : 2};
  Recombine Surface{1102 : 1148 : 2};
  Transfinite Volume{BALL_VOLUMES()};
Return

Macro Plate
  p0 = newp;
  Point(p0) = {-W/2, -W/2, -H};
  Point(p0 + 1) = {W/2, -W/2, -H};
  Point(p0 + 2) = {W/2, W/2, -H};
  Point(p0 + 3) = {-W/2, W/2, -H};
  l0 = newl;
  For k In {0 : 3}
    Line(l0 + k) = {p0 + k, p0 + (k + 1) % 4};
  EndFor
  Transfinite Curve{l0 : l0 + 3} = NP + 1;
  cl = newll;
  Curve Loop(cl) = {l0, l0 + 1, l0 + 2, l0 + 3};
  s0 = news;
  Plane Surface(s0) = {cl};
  Transfinite Surface{s0};
  Recombine Surface{s0};
  ex[] = Extrude {0, 0, H} { Surface{s0}; Layers{NH}; Recombine; };
  PLATE_BOTTOM = s0;
  PLATE_TOP = ex[0];
  PLATE_VOLUME = ex[1];
  PLATE_SIDES[] = ex[{2 : 5}];
Return

If (BALL_FIRST)
  Call Ball;
  Call Plate;
Else
  Call Plate;
  Call Ball;
EndIf

Physical Volume("plate") = {PLATE_VOLUME};
Physical Volume("ball") = {BALL_VOLUMES()};
Physical Surface("plate_top") = {PLATE_TOP};
Physical Surface("plate_bottom") = {PLATE_BOTTOM};
Physical Surface("plate_sides") = {PLATE_SIDES[]};
Physical Surface("ball_skin") = {BALL_OUTER()};
