// A flat punch with rounded corners on an elastic foundation, the two bodies meshed on their
// own, as a user would draw them: the punch (body 2, steel) is 2a wide and h high, its bottom
// flat on [-(a - r), a - r] and turning up into its vertical sides by quarter circles of radius
// r; the foundation (body 1, aluminium) is 2W x H. The contact curves are the foundation's top
// over [-c, c] and the punch's whole rounded bottom (flat part and both corners); the punch's
// mesh is 3 times coarser than the foundation's there, so the curves do not match. nndd makes
// them match and takes Γc where they overlap (the punch's bottom, |x| <= a).
// Mesh level `level` (0 .. 3) halves the sizes each time:
//   gmsh -2 -format msh41 -setnumber level 1 punch-nonmatching.geo -o punch-nonmatching-1.msh
If (!Exists(level))
  level = 1;
EndIf
If (!Exists(ratio))
  ratio = 3;    // punch size / foundation size at the contact
EndIf
a = 0.5;        // punch half-width (m)
h = 0.5;        // punch height
r = 0.2;        // corner radius
b = a - r;      // half-width of the flat bottom
W = 1.5;        // foundation half-width
H = 1;          // foundation depth
c = 0.7;        // half-width of the foundation's contact curve
hc = 0.02 / 2^level;          // foundation size at the contact
hf = 0.3 / 2^level;           // far-field size

// Body 1, the foundation [-W, W] x [-H, 0].
Point(1) = {-W, -H, 0, hf};
Point(2) = {W, -H, 0, hf};
Point(3) = {W, 0, 0, hf};
Point(4) = {c, 0, 0, hc};
Point(5) = {-c, 0, 0, hc};
Point(6) = {-W, 0, 0, hf};
Line(1) = {1, 2};   // base, clamped
Line(2) = {2, 3};
Line(3) = {3, 4};
Line(4) = {4, 5};   // the foundation's contact curve
Line(5) = {5, 6};
Line(6) = {6, 1};
Curve Loop(1) = {1 : 6};
Plane Surface(1) = {1};

// Body 2, the punch.
hp = ratio * hc;
Point(10) = {b, 0, 0, hp};
Point(11) = {b, r, 0, hp};      // centre of the right corner
Point(12) = {a, r, 0, hp};
Point(13) = {a, h, 0, 4 * hp};
Point(14) = {-a, h, 0, 4 * hp};
Point(15) = {-a, r, 0, hp};
Point(16) = {-b, r, 0, hp};     // centre of the left corner
Point(17) = {-b, 0, 0, hp};
Line(11) = {17, 10};            // flat bottom
Circle(12) = {10, 11, 12};      // right corner
Line(13) = {12, 13};            // right side, horizontal traction
Line(14) = {13, 14};            // lid, pressed
Line(15) = {14, 15};            // left side
Circle(16) = {15, 16, 17};      // left corner
Curve Loop(2) = {11 : 16};
Plane Surface(2) = {2};

Physical Surface("body1") = {1};
Physical Surface("body2") = {2};
Physical Curve("base") = {1};
Physical Curve("foundation_top") = {4};
Physical Curve("punch_bottom") = {16, 11, 12};
Physical Curve("punch_right") = {13};
Physical Curve("lid") = {14};
