// A steel pin in an aluminium seat, plane strain: body 1 is a block with a cylindrical groove
// of radius R1 (its contact side is the concave arc, so the contact normal turns along it),
// body 2 the lower half of a pin of radius R2 < R1 resting at the groove's bottom and pressed
// down through its flat top. Conforming contact: the contact arc grows with the load.
// The groove's paired arc is a polyline through the points at angles theta_i (from the
// downward vertical, about the groove's centre C1); the contact direction at a node is the
// mean of its two segments' normals, which is the radius through it (at the two end nodes,
// the end segment's normal). The pin's paired points lie on those lines, so every interface
// node has a partner and g0 is the distance to the pin along the line.
//   gmsh -2 -format msh41 -setnumber level 2 pin.geo -o pin-2.msh
If (!Exists(level))
  level = 1;
EndIf
R1 = 1;          // groove radius (m), centre C1 = (0, R1)
R2 = 0.99;       // pin radius, centre C2 = (0, R2): pin and groove touch at (0, 0)
W = 2;           // block half-width
H = 1.5;         // block depth below the groove's bottom
T = 0.6;         // height of the block's top (the groove's edge)
Th = 1.0;        // half-angle of the paired arc (the groove reaches acos(1 - T/R1) = 1.16)
N = 16 * 2^level;          // interface segments on [-Th, Th]
dt = 2 * Th / N;
hc = R1 * dt;              // interface spacing
hf = 0.4 / 2^(level - 1);  // far-field size

// Body 1: the block [-W, W] x [-H, T] minus the groove.
xe = Sqrt(R1 * R1 - (R1 - T) * (R1 - T));   // the groove's edge on y = T
Point(1) = {-W, -H, 0, hf};
Point(2) = {W, -H, 0, hf};
Point(3) = {W, T, 0, hf};
Point(4) = {-W, T, 0, hf};
Point(5) = {xe, T, 0, hc};
Point(6) = {-xe, T, 0, hc};
Point(7) = {0, R1, 0, hf};   // C1
For i In {0 : N}
  t = -Th + i * dt;
  Point(1000 + i) = {R1 * Sin(t), R1 - R1 * Cos(t), 0, hc};
EndFor
Line(1) = {1, 2};                   // base, clamped
Line(2) = {2, 3};
Line(3) = {3, 5};                   // top, right
Circle(4) = {5, 7, 1000 + N};       // groove above the paired arc, right
For i In {0 : N - 1}
  Line(1000 + i) = {1000 + i, 1001 + i};   // paired arc, left to right
EndFor
Circle(5) = {1000, 7, 6};           // groove above the paired arc, left
Line(6) = {6, 4};                   // top, left
Line(7) = {4, 1};
Curve Loop(1) = {1, 2, 3, 4, -(1000 + N - 1) : -1000 : 1, 5, 6, 7};
Plane Surface(1) = {1};

// Body 2: the lower half of the pin, flat top y = R2 (the lid). Paired point i: from groove
// point P_i along the contact direction u_i = (-sin phi_i, cos phi_i) (phi_i = theta_i
// inside, the end segment's mid-angle at the two ends) to the pin's circle.
Point(10) = {0, R2, 0, hf};  // C2
Point(11) = {R2, R2, 0, hf};
Point(12) = {-R2, R2, 0, hf};
For i In {0 : N}
  t = -Th + i * dt;
  phi = t;
  If (i == 0)
    phi = t + dt / 2;
  EndIf
  If (i == N)
    phi = t - dt / 2;
  EndIf
  px = R1 * Sin(t);
  py = R1 - R1 * Cos(t);
  ux = -Sin(phi);
  uy = Cos(phi);
  wx = px;
  wy = py - R2;
  wu = wx * ux + wy * uy;
  s = -wu - Sqrt(wu * wu - (wx * wx + wy * wy) + R2 * R2);
  Point(5000 + i) = {px + s * ux, py + s * uy, 0, hc};
EndFor
For i In {0 : N - 1}
  Line(5000 + i) = {5000 + i, 5001 + i};   // pin's paired arc, left to right
EndFor
Circle(11) = {5000 + N, 10, 11};    // pin side, right
Line(12) = {11, 12};                // lid
Circle(13) = {12, 10, 5000};        // pin side, left
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
Physical Curve("groove") = {1000 : 1000 + N - 1};
Physical Curve("pin_arc") = {5000 : 5000 + N - 1};
Physical Curve("lid") = {12};
