// Hertz with the two bodies meshed on their own: a half-cylinder of radius R (body 2, steel)
// pressed onto a wide block (body 1, aluminium), plane strain, as examples/hertz but drawn as a
// user would: the block's top and the cylinder's arc are plain Gmsh curves with point sizes,
// the cylinder's 1.7 times the block's, so the two contact curves do not match. nndd makes
// them match (inserting each curve's nodes into the other) and takes Γc where they overlap.
// Mesh level `level` (0 .. 3) halves the sizes each time:
//   gmsh -2 -format msh41 -setnumber level 1 hertz-nonmatching.geo -o hertz-nonmatching-1.msh
If (!Exists(level))
  level = 1;
EndIf
If (!Exists(ratio))
  ratio = 1.7;  // cylinder size / block size at the contact
EndIf
R = 1;          // cylinder radius (m)
W = 2;          // block half-width
H = 2;          // block depth
If (!Exists(c))
  c = 0.2;      // half-width of the block's contact curve (Hertz's a is 0.08)
EndIf
If (!Exists(ca))
  ca = 0.25;    // half-width of the cylinder's contact arc
EndIf
hc = 0.02 / 2^level;            // block size at the contact
hf = 0.4 / 2^(level - 1);       // far-field size (as examples/hertz)

// Body 1, the block [-W, W] x [-H, 0].
Point(1) = {-W, -H, 0, hf};
Point(2) = {W, -H, 0, hf};
Point(3) = {W, 0, 0, hf};
Point(4) = {c, 0, 0, hc};
Point(5) = {-c, 0, 0, hc};
Point(6) = {-W, 0, 0, hf};
Line(1) = {1, 2};   // base, clamped
Line(2) = {2, 3};
Line(3) = {3, 4};
Line(4) = {4, 5};   // the block's contact curve
Line(5) = {5, 6};
Line(6) = {6, 1};
Curve Loop(1) = {1 : 6};
Plane Surface(1) = {1};

// Body 2, the lower half-disc of centre (0, R).
t = Asin(ca / R);
Point(10) = {0, R, 0, hf};                        // centre
Point(11) = {R, R, 0, hf};
Point(12) = {-R, R, 0, hf};
Point(13) = {ca, R - R * Cos(t), 0, ratio * hc};
Point(14) = {0, 0, 0, ratio * hc};                 // the lowest point, touching the block
Point(15) = {-ca, R - R * Cos(t), 0, ratio * hc};
Circle(11) = {11, 10, 13};
Circle(12) = {13, 10, 14};  // the cylinder's contact arc, in two pieces
Circle(13) = {14, 10, 15};
Circle(14) = {15, 10, 12};
Line(15) = {12, 11};        // flat top, pressed
Curve Loop(2) = {11 : 15};
Plane Surface(2) = {2};

Physical Surface("body1") = {1};
Physical Surface("body2") = {2};
Physical Curve("base") = {1};
Physical Curve("block_top") = {4};
Physical Curve("cylinder_arc") = {12, 13};
Physical Curve("lid") = {15};
