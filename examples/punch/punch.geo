// A flat punch with rounded corners (body 2, steel) pressed onto an elastic foundation
// (body 1, aluminium), plane strain. The punch is 2a wide and h high; its bottom is flat on
// [-(a - r), a - r] and turns up into its vertical sides by quarter circles of radius r.
// Body 1's interface nodes x_i on y = 0 span [-c, c], c = a - r + s (the flat part and
// the lower part of each rounded corner, where it is at most 30 degrees steep); the punch's
// contact curve is the polyline through the points straight above them, (x_i, g0(x_i)) with
// g0 = 0 under the flat part and g0 = r - sqrt(r^2 - (|x| - a + r)^2) on the corners, so every
// interface node has a partner. Above x = +-c the corners and the sides are free boundary.
// Mesh level `level` (1 .. 4, default 2) halves the mesh size each time:
//   gmsh -2 -format msh41 -setnumber level 2 punch.geo -o punch-2.msh
If (!Exists(level))
  level = 2;
EndIf
a = 0.5;        // punch half-width (m)
h = 0.5;        // punch height
r = 0.2;        // corner radius
s = 0.1;        // horizontal extent of the paired part of each corner (s < r)
W = 1.5;        // foundation half-width
H = 1;          // foundation depth
b = a - r;      // half-width of the flat bottom
c = b + s;      // half-width of the paired interface
hc = 0.025 / 2^level; // interface spacing (b and c are multiples of it)
M = Round(c / hc);  // interface segments on [0, c]
N = 2 * M;          // interface segments on [-c, c]
hf = 0.3 / 2^(level - 1);  // far-field size
hp = 0.1 / 2^(level - 1);  // punch size away from the interface

// Body 1, the foundation [-W, W] x [-H, 0]; its interface nodes x_i on y = 0.
Point(1) = {-W, -H, 0, hf};
Point(2) = {W, -H, 0, hf};
Point(3) = {W, 0, 0, hf};
Point(4) = {-W, 0, 0, hf};
For i In {0 : N}
  Point(1000 + i) = {-c + i * hc, 0, 0, hc};
EndFor
Line(1) = {1, 2};                   // base, clamped
Line(2) = {2, 3};
Line(3) = {3, 1000 + N};            // free top, right
Line(4) = {1000, 4};                // free top, left
Line(5) = {4, 1};
For i In {0 : N - 1}
  Line(1000 + i) = {1000 + i, 1001 + i};  // foundation interface, left to right
EndFor
Curve Loop(1) = {1, 2, 3, -(1000 + N - 1) : -1000 : 1, 4, 5};
Plane Surface(1) = {1};

// Body 2, the punch: interface points straight above the foundation's, then the rest of the
// corner arcs, the sides and the lid.
For i In {0 : N}
  x = -c + i * hc;
  d = Fabs(x) - b;
  g = 0;
  If (d > 1e-12)
    g = r - Sqrt(r * r - d * d);
  EndIf
  Point(5000 + i) = {x, g, 0, hc};
EndFor
For i In {0 : N - 1}
  Line(5000 + i) = {5000 + i, 5001 + i};  // punch interface, left to right
EndFor
Point(10) = {b, r, 0, hp};          // centre of the right corner
Point(11) = {a, r, 0, hp};
Point(12) = {a, h, 0, hp};
Point(13) = {-a, h, 0, hp};
Point(14) = {-a, r, 0, hp};
Point(15) = {-b, r, 0, hp};         // centre of the left corner
Circle(11) = {5000 + N, 10, 11};    // right corner, free
Line(12) = {11, 12};                // right side, horizontal traction
Line(13) = {12, 13};                // lid, pressed
Line(14) = {13, 14};                // left side, free
Circle(15) = {14, 15, 5000};        // left corner, free
Curve Loop(2) = {5000 : 5000 + N - 1, 11, 12, 13, 14, 15};
Plane Surface(2) = {2};

// One segment per interface line: the interface nodes are exactly the points above.
// (unless nndd remeshes it from a size field: an adaptive run sets nndd_cycle)
If (!Exists(nndd_cycle))
  Transfinite Curve{1000 : 1000 + N - 1, 5000 : 5000 + N - 1} = 2;
EndIf
Mesh.CharacteristicLengthExtendFromBoundary = 1;

Physical Surface("body1") = {1};
Physical Surface("body2") = {2};
Physical Curve("base") = {1};
Physical Curve("foundation_top") = {1000 : 1000 + N - 1};
Physical Curve("punch_bottom") = {5000 : 5000 + N - 1};
Physical Curve("punch_right") = {12};
Physical Curve("lid") = {13};
