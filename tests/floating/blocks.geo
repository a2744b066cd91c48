// Two blocks stacked (tests/floating.rs): body 1 [0, 1] x [-0.5, 0] on a roller base (uy = 0)
// and a roller on its left side (ux = 0); body 2 [0, 1] x [0, 0.5] with a roller on its left
// side (ux = 0) and a traction on its top: nothing but the contact holds body 2 vertically
// (force-controlled contact). The two contact sides are meshed on their own (sizes h1, h2).
// Physical curves: base, left1, top1 (body 1's contact side), bottom2 (body 2's), left2, lid.
If (!Exists(h1))
  h1 = 0.125;
EndIf
If (!Exists(h2))
  h2 = 0.1;
EndIf
Point(1) = {0, -0.5, 0, h1}; Point(2) = {1, -0.5, 0, h1}; Point(3) = {1, 0, 0, h1}; Point(4) = {0, 0, 0, h1};
Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 1};
Curve Loop(1) = {1, 2, 3, 4}; Plane Surface(1) = {1};
Point(11) = {0, 0, 0, h2}; Point(12) = {1, 0, 0, h2}; Point(13) = {1, 0.5, 0, h2}; Point(14) = {0, 0.5, 0, h2};
Line(11) = {11, 12}; Line(12) = {12, 13}; Line(13) = {13, 14}; Line(14) = {14, 11};
Curve Loop(2) = {11, 12, 13, 14}; Plane Surface(2) = {2};
Physical Surface("body1") = {1}; Physical Surface("body2") = {2};
Physical Curve("base") = {1}; Physical Curve("left1") = {4}; Physical Curve("top1") = {3};
Physical Curve("bottom2") = {11}; Physical Curve("left2") = {14}; Physical Curve("lid") = {13};
