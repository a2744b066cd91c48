// The contact patch test: a block [dx, dx + 1] x [0, 0.5] (body 2) on a foundation
// [0, 1] x [-1, 0] (body 1), the foundation's top meshed with n1 segments and the block's
// bottom with n2, each body meshed by Gmsh from there. dx shifts the block sideways (dx >= 1:
// the contact curves do not face each other).
//   gmsh -2 -format msh41 -setnumber n1 10 -setnumber n2 17 patch.geo -o patch.msh
If (!Exists(n1))
  n1 = 10;
EndIf
If (!Exists(n2))
  n2 = 17;
EndIf
If (!Exists(dx))
  dx = 0;
EndIf
Point(1) = {0, -1, 0}; Point(2) = {1, -1, 0}; Point(3) = {1, 0, 0}; Point(4) = {0, 0, 0};
Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 1};
Curve Loop(1) = {1, 2, 3, 4}; Plane Surface(1) = {1};
Point(5) = {dx, 0, 0}; Point(6) = {dx + 1, 0, 0}; Point(7) = {dx + 1, 0.5, 0};
Point(8) = {dx, 0.5, 0};
Line(5) = {5, 6}; Line(6) = {6, 7}; Line(7) = {7, 8}; Line(8) = {8, 5};
Curve Loop(2) = {5, 6, 7, 8}; Plane Surface(2) = {2};
Transfinite Curve{3} = n1 + 1;
Transfinite Curve{5} = n2 + 1;
Mesh.CharacteristicLengthFromPoints = 0;
Mesh.CharacteristicLengthExtendFromBoundary = 1;
Physical Surface("body1") = {1};
Physical Surface("body2") = {2};
Physical Curve("base") = {1};
Physical Curve("left1") = {4};
Physical Curve("top1") = {3};
Physical Curve("bottom2") = {5};
Physical Curve("left2") = {8};
Physical Curve("lid") = {7};
