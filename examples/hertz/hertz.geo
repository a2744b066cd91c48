// Hertz: a half-cylinder of radius R (body 2, steel) pressed onto a wide block (body 1,
// aluminium), plane strain. The contact arc of the cylinder is a polyline through the points
// straight above the block's interface nodes x_i, so every interface node has a partner and
// the initial gap is g0(x_i) = R - sqrt(R^2 - x_i^2). Mesh level `level` (1 .. 4) halves the
// interface spacing each time:
//   gmsh -2 -format msh41 -setnumber level 2 hertz.geo -o hertz-2.msh
If (!Exists(level))
  level = 1;
EndIf
R = 1;          // cylinder radius (m)
W = 2;          // block half-width
H = 2;          // block depth
If (!Exists(c))
  c = 0.16;     // half-width of the paired interface (the contact zone lies inside it)
EndIf
N = 16 * 2^level;   // interface segments on [-c, c]
hc = 2 * c / N;     // interface spacing
hf = 0.4 / 2^(level - 1) ; // far-field size

// Body 1, the block [-W, W] x [-H, 0]; its interface nodes x_i on y = 0.
Point(1) = {-W, -H, 0, hf};
Point(2) = {W, -H, 0, hf};
Point(3) = {W, 0, 0, hf};
Point(4) = {-W, 0, 0, hf};
For i In {0 : N}
  Point(1000 + i) = {-c + i * hc, 0, 0, hc};
EndFor
Line(1) = {1, 2};                  // base, clamped
Line(2) = {2, 3};
Line(3) = {3, 1000 + N};            // free top, right
Line(4) = {1000, 4};                // free top, left
Line(5) = {4, 1};
For i In {0 : N - 1}
  Line(1000 + i) = {1000 + i, 1001 + i};  // block interface, left to right
EndFor
Curve Loop(1) = {1, 2, 3, -(1000 + N - 1) : -1000 : 1, 4, 5};
Plane Surface(1) = {1};

// Body 2, the lower half-disc of centre (0, R): flat top y = R, interface points straight
// above the block's, then circular arcs up to the top.
Point(10) = {0, R, 0, hf};         // centre
Point(11) = {R, R, 0, hf};
Point(12) = {-R, R, 0, hf};
For i In {0 : N}
  x = -c + i * hc;
  Point(5000 + i) = {x, R - Sqrt(R * R - x * x), 0, hc};
EndFor
For i In {0 : N - 1}
  Line(5000 + i) = {5000 + i, 5001 + i};  // cylinder interface, left to right
EndFor
Circle(11) = {5000 + N, 10, 11};    // arc, right
Line(12) = {11, 12};               // flat top, pressed
Circle(13) = {12, 10, 5000};        // arc, left
Curve Loop(2) = {5000 : 5000 + N - 1, 11, 12, 13};
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
Physical Curve("block_top") = {1000 : 1000 + N - 1};
Physical Curve("cylinder_arc") = {5000 : 5000 + N - 1};
Physical Curve("lid") = {12};
