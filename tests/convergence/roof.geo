// A roof (body 2: its ridge down, its two sides rising at beta degrees from the horizontal)
// pressed onto a block (body 1), plane strain (tests/convergence.rs): the contact zone grows
// from the ridge, a sharp corner, over the first segments of both sides.
If (!Exists(beta))
  beta = 45;
EndIf
h = 0.05;
b = beta * Pi / 180;
W = 1; H = 1; w = 0.5;
Point(1) = {-W, -H, 0, 0.2}; Point(2) = {W, -H, 0, 0.2}; Point(3) = {W, 0, 0, h}; Point(4) = {-W, 0, 0, h};
Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 1};
Curve Loop(1) = {1, 2, 3, 4}; Plane Surface(1) = {1};
// roof: apex (0,0), corners (+-w, w tan b), top at y = w tan b + 0.3
t = w * Tan(b);
Point(11) = {0, 0, 0, h/4}; Point(12) = {w, t, 0, h}; Point(13) = {w, t + 0.3, 0, h}; Point(14) = {-w, t + 0.3, 0, h}; Point(15) = {-w, t, 0, h};
Line(11) = {15, 11}; Line(12) = {11, 12}; Line(13) = {12, 13}; Line(14) = {13, 14}; Line(15) = {14, 15};
Curve Loop(2) = {11, 12, 13, 14, 15}; Plane Surface(2) = {2};
Physical Surface("body1") = {1}; Physical Surface("body2") = {2};
Physical Curve("base") = {1}; Physical Curve("top") = {3};
Physical Curve("roof") = {11, 12}; Physical Curve("lid") = {14};
