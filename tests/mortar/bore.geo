// The pin in its hole with whole circles for contact curves (tests/mortar.rs): a steel pin
// (R2 = 10 mm, 210 GPa) in the hole (R1 = R2 + 20 um) of an aluminium plate (70 GPa, 80 mm
// square, clamped on its outside), pushed 50 um down through its bore (radius 3 mm), as
// examples/pin-hole. The hole's whole circle has N segments, the pin's Round(ratio N),
// starting at angle `phase` (deg, from the bottom; 0 by default); `clearance` the radial
// clearance (m, 20e-6 by default; negative: an interference fit). The same lines also form
// the circles' lower arcs of +-`arc` deg ("hole_low", "pin_low": N/2 and the pin's nearest
// whole segments), so that the problem can be posed on whole circles or on arcs, one mesh.
//   gmsh -2 -format msh41 -setnumber level 1 [-setnumber ratio 1.5] bore.geo -o bore-1.msh
If (!Exists(level))
  level = 1;
EndIf
If (!Exists(ratio))
  ratio = 1.5;
EndIf
If (!Exists(arc))
  arc = 120;
EndIf
If (!Exists(phase))
  phase = 0;
EndIf
If (!Exists(clearance))
  clearance = 20e-6;
EndIf
R2 = 10e-3; R1 = R2 + clearance; Rb = 3e-3; L = 40e-3;
N = 32 * 2^level;            // the hole's segments, all round
N2 = Round(ratio * N);       // the pin's
hc = 2 * Pi * R2 / N;
hf = 8e-3 / 2^(level - 1);
Point(1) = {-L, -L, 0, hf}; Point(2) = {L, -L, 0, hf}; Point(3) = {L, L, 0, hf}; Point(4) = {-L, L, 0, hf};
Point(9) = {0, 0, 0, hf};
P0 = phase * Pi / 180;
For i In {0 : N - 1}
  t = P0 + i * 2 * Pi / N;
  Point(1000 + i) = {R1 * Sin(t), -R1 * Cos(t), 0, hc};
EndFor
For i In {0 : N2 - 1}
  t = P0 + i * 2 * Pi / N2;
  Point(5000 + i) = {R2 * Sin(t), -R2 * Cos(t), 0, hc};
EndFor
Point(30) = {Rb, 0, 0, 2 * hc}; Point(31) = {-Rb, 0, 0, 2 * hc};
Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 1};
For i In {0 : N - 1}
  Line(1000 + i) = {1000 + i, 1000 + (i + 1) % N};
EndFor
For i In {0 : N2 - 1}
  Line(5000 + i) = {5000 + i, 5000 + (i + 1) % N2};
EndFor
Circle(9) = {30, 9, 31}; Circle(10) = {31, 9, 30};
Curve Loop(1) = {1, 2, 3, 4};
Curve Loop(2) = {1000 : 1000 + N - 1};
Plane Surface(1) = {1, 2};
Curve Loop(3) = {5000 : 5000 + N2 - 1};
Curve Loop(4) = {9, 10};
Plane Surface(2) = {3, 4};
Transfinite Curve{1000 : 1000 + N - 1, 5000 : 5000 + N2 - 1} = 2;
Physical Surface("body1") = {1};
Physical Surface("body2") = {2};
Physical Curve("outer") = {1, 2, 3, 4};
Physical Curve("bore") = {9, 10};
Physical Curve("hole") = {1000 : 1000 + N - 1};
Physical Curve("pin") = {5000 : 5000 + N2 - 1};
// The lower arcs (phase 0): the segments within +-arc of the bottom.
K1 = Round(arc / 360 * N); K2 = Round(arc / 360 * N2);
Physical Curve("hole_low") = {1000 : 1000 + K1 - 1, 1000 + N - K1 : 1000 + N - 1};
Physical Curve("pin_low") = {5000 : 5000 + K2 - 1, 5000 + N2 - K2 : 5000 + N2 - 1};
