// A steel pin (R2 = 10 mm, 210 GPa) in the hole (R1 = 10.02 mm) of an aluminium plate
// (70 GPa, 80 mm square, clamped on its outside), plane strain, concentric (a 20 um clearance
// all round), the pin pushed 50 um down through its bore (radius 3 mm): the contact arc grows
// to about +-55 deg. Body 1 is the plate, its contact side the hole's lower arc (+-80 deg, a
// concave polyline, N segments); body 2's is the pin's lower arc at the same angles
// (ratio = 1: the curves match but for the end nodes, which are radial, not on the end
// segments' normals) or meshed on its own with Round(ratio N) segments; `arc` sets the arcs'
// half-angle (up to 180: the contact curves may span more than a half circle); `clearance`
// the radial clearance (m; 20e-6 by default).
//   gmsh -2 -format msh41 -setnumber level 1 [-setnumber ratio 1.5] [-setnumber arc 120] [-setnumber clearance 1e-3] pin-hole.geo -o pin-hole-1.msh
If (!Exists(level))
  level = 1;
EndIf
If (!Exists(ratio))
  ratio = 1;
EndIf
If (!Exists(arc))
  arc = 80;                  // half-angle of the contact arcs (deg)
EndIf
If (!Exists(clearance))
  clearance = 20e-6;
EndIf
R2 = 10e-3; R1 = R2 + clearance; Rb = 3e-3; L = 40e-3;
Th = arc * Pi / 180;
N = 16 * 2^level;            // hole's arc segments
N2 = Round(ratio * N);       // pin's arc segments
hc = R2 * 2 * Th / N;
hf = 8e-3 / 2^(level - 1);
Point(1) = {-L, -L, 0, hf}; Point(2) = {L, -L, 0, hf}; Point(3) = {L, L, 0, hf}; Point(4) = {-L, L, 0, hf};
Point(9) = {0, 0, 0, hf};    // the common centre
For i In {0 : N}
  t = -Th + i * 2 * Th / N;
  Point(1000 + i) = {R1 * Sin(t), -R1 * Cos(t), 0, hc};
EndFor
For i In {0 : N2}
  t = -Th + i * 2 * Th / N2;
  Point(5000 + i) = {R2 * Sin(t), -R2 * Cos(t), 0, hc};
EndFor
Point(20) = {0, R1, 0, 2 * hc}; Point(21) = {0, R2, 0, 2 * hc};
Point(30) = {Rb, 0, 0, 2 * hc}; Point(31) = {-Rb, 0, 0, 2 * hc};
Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 1};
For i In {0 : N - 1}
  Line(1000 + i) = {1000 + i, 1001 + i};   // the hole's contact arc, left to right
EndFor
For i In {0 : N2 - 1}
  Line(5000 + i) = {5000 + i, 5001 + i};   // the pin's contact arc, left to right
EndFor
Circle(5) = {1000 + N, 9, 20}; Circle(6) = {20, 9, 1000};     // the hole's upper part
Circle(7) = {5000 + N2, 9, 21}; Circle(8) = {21, 9, 5000};    // the pin's upper part
Circle(9) = {30, 9, 31}; Circle(10) = {31, 9, 30};            // the bore
Curve Loop(1) = {1, 2, 3, 4};
Curve Loop(2) = {1000 : 1000 + N - 1, 5, 6};
Plane Surface(1) = {1, 2};
Curve Loop(3) = {5000 : 5000 + N2 - 1, 7, 8};
Curve Loop(4) = {9, 10};
Plane Surface(2) = {3, 4};
// One segment per contact line: the arcs' nodes are exactly the points above.
Transfinite Curve{1000 : 1000 + N - 1, 5000 : 5000 + N2 - 1} = 2;
Physical Surface("body1") = {1};
Physical Surface("body2") = {2};
Physical Curve("outer") = {1, 2, 3, 4};
Physical Curve("hole") = {1000 : 1000 + N - 1};
Physical Curve("pin") = {5000 : 5000 + N2 - 1};
Physical Curve("bore") = {9, 10};
