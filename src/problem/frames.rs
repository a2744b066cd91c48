//! A body's Γc in its nodal frames: the rotated frames of the Γc nodes whose normal is not
//! (0, 1) ([`Frames`]), and the normal and tangential traces read and set through them.

use super::{BodyProblem, GcTrace, UP};
use crate::fem::{Dofs, DofsMut};

impl BodyProblem {
    /// The rotated nodal frames of the Γc nodes whose normal is not (0, 1) (none under the
    /// mortar discretisation: its trace reads both components).
    pub fn frames(&self) -> Frames {
        if let GcTrace::Mortar(_) = self.trace {
            return Frames::default();
        }
        Frames {
            normal: self
                .contact_nodes
                .iter()
                .zip(&self.contact_normals)
                .filter(|(_, n)| **n != UP)
                .map(|(&node, &n)| (node, n))
                .collect(),
        }
    }

    /// Normal Γc displacements u_n = n_k · u (global components) in pair order.
    pub fn normal_trace<U: Dofs + ?Sized>(&self, u: &U) -> Vec<f64> {
        if let GcTrace::Mortar(c) = &self.trace {
            return c.mortar_trace(u);
        }
        self.contact_nodes
            .iter()
            .zip(&self.contact_normals)
            .map(|(&node, n)| {
                if *n == UP {
                    u[2 * node + 1]
                } else {
                    n[0] * u[2 * node] + n[1] * u[2 * node + 1]
                }
            })
            .collect()
    }

    /// Set the normal component of pair k's node to `value`, keeping its tangential one
    /// (node to node; a mortar trace is a mean over nodes, left as solved).
    pub fn set_normal_trace<U: DofsMut + ?Sized>(&self, u: &mut U, k: usize, value: f64) {
        if let GcTrace::Mortar(_) = self.trace {
            return;
        }
        let (node, n) = (self.contact_nodes[k], self.contact_normals[k]);
        if n == UP {
            u[2 * node + 1] = value;
        } else {
            let c = value - (n[0] * u[2 * node] + n[1] * u[2 * node + 1]);
            u[2 * node] += c * n[0];
            u[2 * node + 1] += c * n[1];
        }
    }

    /// Tangential Γc displacements u_t = τ_k · u, τ_k = (n_y, −n_x) (node to node; with n =
    /// (0, 1), u_x), in pair order: the frictional interface's second half.
    pub fn tangential_trace<U: Dofs + ?Sized>(&self, u: &U) -> Vec<f64> {
        self.contact_nodes
            .iter()
            .zip(&self.contact_normals)
            .map(|(&node, n)| n[1] * u[2 * node] - n[0] * u[2 * node + 1])
            .collect()
    }

    /// Set the tangential component of pair k's node to `value`, keeping its normal one.
    pub fn set_tangential_trace<U: DofsMut + ?Sized>(&self, u: &mut U, k: usize, value: f64) {
        let (node, n) = (self.contact_nodes[k], self.contact_normals[k]);
        let tau = [n[1], -n[0]];
        let c = value - (tau[0] * u[2 * node] + tau[1] * u[2 * node + 1]);
        u[2 * node] += c * tau[0];
        u[2 * node + 1] += c * tau[1];
    }

    /// The x coordinates of the Γc nodes.
    pub fn contact_x(&self) -> Vec<f64> {
        self.contact_nodes
            .iter()
            .map(|&n| self.boundary_point(n)[0])
            .collect()
    }
}

/// Rotated nodal frames: at a Γc node of normal n ≠ (0, 1) the node's two dofs are its
/// displacement along τ = (n_y, −n_x) and along n (so the Γc normal dof is still the node's
/// second dof, and the contact steps need no change); every other node keeps (x, y). The
/// bodies' systems are assembled in these frames (K_l = Rᵀ K R node by node, R = [τ n]);
/// vectors leave the body layer in global components.
#[derive(Clone, Debug, Default)]
pub struct Frames {
    normal: std::collections::HashMap<usize, [f64; 2]>,
}

impl Frames {
    pub fn is_empty(&self) -> bool {
        self.normal.is_empty()
    }

    /// The normal of `node`'s rotated frame, if it has one.
    pub fn normal(&self, node: usize) -> Option<[f64; 2]> {
        self.normal.get(&node).copied()
    }

    /// Global components to frame components (Rᵀ v), in place: displacements and forces alike.
    pub fn to_local(&self, v: &mut [f64]) {
        for (&node, n) in &self.normal {
            let (x, y) = (v[2 * node], v[2 * node + 1]);
            v[2 * node] = n[1] * x - n[0] * y;
            v[2 * node + 1] = n[0] * x + n[1] * y;
        }
    }

    /// Node `node`'s two global components `v` to frame ones (Rᵀ v), in place.
    pub fn node_to_local(&self, node: usize, v: &mut [f64]) {
        if let Some(n) = self.normal.get(&node) {
            let (x, y) = (v[0], v[1]);
            v[0] = n[1] * x - n[0] * y;
            v[1] = n[0] * x + n[1] * y;
        }
    }

    /// Node `node`'s two frame components `v` to global ones (R v), in place.
    pub fn node_to_global(&self, node: usize, v: &mut [f64]) {
        if let Some(n) = self.normal.get(&node) {
            let (t, m) = (v[0], v[1]);
            v[0] = n[1] * t + n[0] * m;
            v[1] = -n[0] * t + n[1] * m;
        }
    }

    /// Frame components to global ones (R v), in place.
    pub fn to_global(&self, v: &mut [f64]) {
        for (&node, n) in &self.normal {
            let (t, m) = (v[2 * node], v[2 * node + 1]);
            v[2 * node] = n[1] * t + n[0] * m;
            v[2 * node + 1] = -n[0] * t + n[1] * m;
        }
    }

    /// An element stiffness (dofs x, y of the triangle's nodes) in the nodal frames: Tᵀ K T.
    pub fn rotate_element(&self, nodes: &[usize; 3], ke: &mut [[f64; 6]; 6]) {
        for (i, node) in nodes.iter().enumerate() {
            let Some(n) = self.normal(*node) else {
                continue;
            };
            // R = [[n_y, n_x], [−n_x, n_y]] on the block of node i.
            let r = [[n[1], n[0]], [-n[0], n[1]]];
            let (a, b) = (2 * i, 2 * i + 1);
            for row in ke.iter_mut() {
                let (x, y) = (row[a], row[b]);
                row[a] = x * r[0][0] + y * r[1][0];
                row[b] = x * r[0][1] + y * r[1][1];
            }
            let (ra, rb) = (ke[a], ke[b]);
            for (c, (x, y)) in ra.iter().zip(&rb).enumerate() {
                ke[a][c] = r[0][0] * x + r[1][0] * y;
                ke[b][c] = r[0][1] * x + r[1][1] * y;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fem::Material;

    #[test]
    fn frames_rotate_and_back() {
        let s = 0.6f64;
        let c = 0.8f64;
        let f = Frames {
            normal: [(1, [-s, c])].into_iter().collect(),
        };
        let mut v = vec![1.0, 2.0, 3.0, 4.0];
        f.to_local(&mut v);
        // Node 1: u_t = τ·u with τ = (c, s), u_n = n·u.
        assert_eq!(&v[..2], &[1.0, 2.0]);
        assert!((v[2] - (c * 3.0 + s * 4.0)).abs() < 1e-15);
        assert!((v[3] - (-s * 3.0 + c * 4.0)).abs() < 1e-15);
        f.to_global(&mut v);
        for (a, b) in v.iter().zip([1.0, 2.0, 3.0, 4.0]) {
            assert!((a - b).abs() < 1e-15);
        }
    }

    #[test]
    fn rotated_element_stiffness_is_the_same_energy() {
        use crate::fem::element_stiffness;
        let pts = [[0.0, 0.0], [1.0, 0.2], [0.3, 0.9]];
        let mat = Material {
            young: 2.0,
            poisson: 0.3,
        };
        let ke = element_stiffness(&pts, &mat);
        let f = Frames {
            normal: [(5, [0.6, 0.8]), (9, [-1.0, 0.0])].into_iter().collect(),
        };
        let mut kl = ke;
        f.rotate_element(&[5, 7, 9], &mut kl);
        // uᵀ K u = u_lᵀ K_l u_l for u_l the frame components of u.
        let u = [0.3, -0.1, 0.7, 0.2, -0.4, 0.5];
        let mut ul = vec![0.0; 20];
        for (i, node) in [5usize, 7, 9].iter().enumerate() {
            ul[2 * node] = u[2 * i];
            ul[2 * node + 1] = u[2 * i + 1];
        }
        f.to_local(&mut ul);
        let loc: Vec<f64> = [5usize, 7, 9]
            .iter()
            .flat_map(|&n| [ul[2 * n], ul[2 * n + 1]])
            .collect();
        let quad = |k: &[[f64; 6]; 6], v: &[f64]| -> f64 {
            (0..6)
                .map(|r| v[r] * (0..6).map(|c| k[r][c] * v[c]).sum::<f64>())
                .sum()
        };
        let (a, b) = (quad(&ke, &u), quad(&kl, &loc));
        assert!((a - b).abs() < 1e-14 * a.abs(), "{a} {b}");
        // Symmetry kept.
        for (r, row) in kl.iter().enumerate() {
            for (c, v) in row.iter().enumerate() {
                assert!((v - kl[c][r]).abs() < 1e-14);
            }
        }
    }
}
