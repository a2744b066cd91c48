// A block with a bore under a lid (tests/gmsh_input.rs): body 1 is [-1, 1] x [-1, 0] with a
// circular bore of radius 0.25 about (0, -0.5), body 2 the lid [-1, 1] x [0, 0.5] on it.
// split = 0: the bore is one closed physical curve "bore"; split = 1: two open halves
// "bore_a", "bore_b" (the same mesh). inner = 1 adds a line inside body 1, "inner", embedded
// in its surface.
If (!Exists(split))
  split = 0;
EndIf
If (!Exists(inner))
  inner = 0;
EndIf
h = 0.1;
Point(1) = {-1, -1, 0, h};
Point(2) = {1, -1, 0, h};
Point(3) = {1, 0, 0, h};
Point(4) = {-1, 0, 0, h};
Point(5) = {0, -0.5, 0, h};
Point(6) = {0.25, -0.5, 0, h / 2};
Point(7) = {-0.25, -0.5, 0, h / 2};
Line(1) = {1, 2};
Line(2) = {2, 3};
Line(3) = {3, 4};
Line(4) = {4, 1};
Circle(5) = {6, 5, 7};
Circle(6) = {7, 5, 6};
Curve Loop(1) = {1, 2, 3, 4};
Curve Loop(2) = {5, 6};
Plane Surface(1) = {1, 2};
Point(11) = {1, 0.5, 0, h};
Point(12) = {-1, 0.5, 0, h};
Point(13) = {-1, 0, 0, h};
Point(14) = {1, 0, 0, h};
Line(11) = {13, 14};
Line(12) = {14, 11};
Line(13) = {11, 12};
Line(14) = {12, 13};
Curve Loop(3) = {11, 12, 13, 14};
Plane Surface(2) = {3};
If (inner == 1)
  Point(20) = {-0.8, -0.9, 0, h};
  Point(21) = {-0.5, -0.9, 0, h};
  Line(20) = {20, 21};
  Line{20} In Surface{1};
  Physical Curve("inner") = {20};
EndIf
Physical Surface("body1") = {1};
Physical Surface("body2") = {2};
Physical Curve("base") = {1};
Physical Curve("top1") = {3};
Physical Curve("bottom2") = {11};
Physical Curve("lid") = {13};
If (split == 0)
  Physical Curve("bore") = {5, 6};
Else
  Physical Curve("bore_a") = {5};
  Physical Curve("bore_b") = {6};
EndIf
