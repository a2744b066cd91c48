// The `paper` benchmark (docs/benchmarks.md) as a Gmsh file: two unit squares, body 1 below
// body 2, each an n x n grid of squares split into two triangles along the diagonal from lower
// left to upper right, as the built-in mesh. Mesh it with
//   gmsh -2 -format msh41 -setnumber n 16 paper.geo -o paper-16.msh
If (!Exists(n))
  n = 8;
EndIf
// Body 2's cells along the interface and the top (default n; another value makes the
// interface nodes unpaired).
If (!Exists(n2))
  n2 = n;
EndIf
// Initial gap: body 2 lifted by g0 (-setnumber g0 2e-5).
If (!Exists(g0))
  g0 = 0;
EndIf

// Body 1: [0, 1] x [0, 1]
Point(1) = {0, 0, 0};
Point(2) = {1, 0, 0};
Point(3) = {1, 1, 0};
Point(4) = {0, 1, 0};
Line(1) = {1, 2};  // bottom, clamped
Line(2) = {2, 3};
Line(3) = {4, 3};  // contact side of body 1, left to right
Line(4) = {1, 4};
Curve Loop(1) = {1, 2, -3, -4};
Plane Surface(1) = {1};

// Body 2: [0, 1] x [1, 2] lifted by g0 (its own nodes on y = 1 + g0)
Point(5) = {0, 1 + g0, 0};
Point(6) = {1, 1 + g0, 0};
Point(7) = {1, 2 + g0, 0};
Point(8) = {0, 2 + g0, 0};
Line(5) = {5, 6};  // contact side of body 2
Line(6) = {6, 7};  // right edge, from y = 1 up to y = 2 (the linear load)
Line(7) = {8, 7};  // top, prescribed displacement
Line(8) = {5, 8};
Curve Loop(2) = {5, 6, -7, -8};
Plane Surface(2) = {2};

// The structured grid, unless nndd remeshes it from a size field (an adaptive run sets
// nndd_cycle, and the sizes come from its background view, which Transfinite would override).
If (!Exists(nndd_cycle))
  Transfinite Curve{1:4, 6, 8} = n + 1;
  Transfinite Curve{5, 7} = n2 + 1;
  Transfinite Surface{1} = {1, 2, 3, 4} Right;
  Transfinite Surface{2} = {5, 6, 7, 8} Right;
EndIf

Physical Surface("body1") = {1};
Physical Surface("body2") = {2};
Physical Curve("bottom") = {1};
Physical Curve("contact1") = {3};
Physical Curve("contact2") = {5};
Physical Curve("right2") = {6};
Physical Curve("top") = {7};
