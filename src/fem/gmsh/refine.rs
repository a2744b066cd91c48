//! The uniform, nested refinement of a [`GmshMesh`]: the reference mesh of (26) for a Gmsh
//! problem.

use std::collections::HashMap;

use super::{Cells, GmshMesh, Nesting};

impl GmshMesh {
    /// The uniform refinement of the mesh by `r` (the reference mesh of (26) for a Gmsh
    /// problem): every triangle is split into r² similar triangles through the points
    /// p₀ + (i/r)(p₁ − p₀) + (j/r)(p₂ − p₀), every line into r segments, so the meshes are
    /// nested and every curve keeps its (polyline) shape.
    ///
    /// Numbering, which the reference solution's transfer relies on: the nodes keep
    /// their numbers (new nodes follow), and the r² triangles of triangle t are
    /// r² t … r² (t + 1) − 1, with t's orientation and physical groups (its [`Nesting`]).
    pub fn refined(&self, r: usize) -> GmshMesh {
        assert!(r >= 1, "refinement factor r >= 1");
        let mut points = self.points.clone();
        // The r − 1 points inside each edge, listed from its lower-numbered end.
        let mut edge_points: HashMap<(usize, usize), Vec<usize>> = HashMap::new();
        let mut on_edge = |points: &mut Vec<[f64; 2]>, a: usize, b: usize, k: usize| -> usize {
            if k == 0 {
                return a;
            }
            if k == r {
                return b;
            }
            let (lo, hi) = (a.min(b), a.max(b));
            let inner = edge_points.entry((lo, hi)).or_insert_with(|| {
                let (p, q) = (points[lo], points[hi]);
                (1..r)
                    .map(|m| {
                        let t = m as f64 / r as f64;
                        points.push([p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])]);
                        points.len() - 1
                    })
                    .collect()
            });
            if a == lo {
                inner[k - 1]
            } else {
                inner[r - k - 1]
            }
        };
        let mut triangles = Cells::with_capacity(r * r * self.triangles.len());
        for ([v0, v1, v2], phys) in &self.triangles {
            // Lattice point (i, j), i + j ≤ r, of the triangle.
            let mut lattice = vec![usize::MAX; (r + 1) * (r + 1)];
            for j in 0..=r {
                for i in 0..=r - j {
                    lattice[j * (r + 1) + i] = if j == 0 {
                        on_edge(&mut points, v0, v1, i)
                    } else if i == 0 {
                        on_edge(&mut points, v0, v2, j)
                    } else if i + j == r {
                        on_edge(&mut points, v1, v2, j)
                    } else {
                        let (p0, p1, p2) = (points[v0], points[v1], points[v2]);
                        let (s, u) = (i as f64 / r as f64, j as f64 / r as f64);
                        points.push([
                            p0[0] + s * (p1[0] - p0[0]) + u * (p2[0] - p0[0]),
                            p0[1] + s * (p1[1] - p0[1]) + u * (p2[1] - p0[1]),
                        ]);
                        points.len() - 1
                    };
                }
            }
            let at = |i: usize, j: usize| lattice[j * (r + 1) + i];
            for j in 0..r {
                for i in 0..r - j {
                    triangles.push([at(i, j), at(i + 1, j), at(i, j + 1)], phys);
                    if i + j + 1 < r {
                        triangles.push([at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)], phys);
                    }
                }
            }
        }
        let mut lines = Cells::with_capacity(r * self.lines.len());
        for ([a, b], phys) in &self.lines {
            for k in 0..r {
                let (p, q) = (
                    on_edge(&mut points, a, b, k),
                    on_edge(&mut points, a, b, k + 1),
                );
                lines.push([p, q], phys);
            }
        }
        // The r² triangles of triangle t keep its Gmsh tag.
        let triangle_tags = self
            .triangle_tags
            .iter()
            .flat_map(|t| std::iter::repeat_n(t, r * r))
            .collect();
        // (a refined mesh refined again nests in the file's all the same)
        let nesting = Nesting {
            children: r * r * self.nesting.map_or(1, |n| n.children),
        };
        GmshMesh {
            path: format!("{} refined {r}x", self.path),
            points,
            triangles,
            triangle_tags,
            lines,
            names: self.names.clone(),
            nesting: Some(nesting),
        }
    }
}
