//! K^α applied on each rank's rows of a body: the checks of an iterate (its equilibrium
//! residual, interface forces and energy) and a solve's K x_g, with no whole K u on any rank
//! (docs/scaling.md, "Memory per rank").

use std::collections::HashSet;

use super::{Body, BodyError, System};
use crate::dd::displacement::Displacement;
use crate::dd::stiffness::Stiffness;

impl Body {
    /// K v into `kx`, `v` this rank's entries of a vector (PETSc order, nodal frames): no
    /// whole vector (collective).
    pub(super) fn mult_k_local(&self, v: &[f64]) -> Result<(), BodyError> {
        let mut x = self.x.borrow_mut();
        let mut kx = self.kx.borrow_mut();
        match &self.stiffness {
            Stiffness::Whole(k) => {
                x.copy_from(v)?;
                k.mult(&x, &mut kx)?;
            }
            // K v = K_N (P v) + B v.
            Stiffness::Split { coupling } => {
                let mut free = v.to_vec();
                for (row, _) in self.owned(&self.problem.dirichlet) {
                    free[row] = 0.0;
                }
                x.copy_from(&free)?;
                self.ksp(System::Neumann)?.operator().mult(&x, &mut kx)?;
                x.copy_from(v)?;
                coupling.mult_add(&x, &mut kx)?;
            }
        }
        Ok(())
    }

    /// The (dof, value) pairs of `pairs` on this rank's rows, as (index among this rank's
    /// entries, value).
    pub(super) fn owned<'a>(
        &'a self,
        pairs: &'a [(usize, f64)],
    ) -> impl Iterator<Item = (usize, f64)> + 'a {
        let first = 2 * self.partition.owned_nodes().start;
        pairs
            .iter()
            .filter(|(dof, _)| self.partition.owns_dof(*dof))
            .map(move |&(dof, v)| (self.partition.row(dof) as usize - first, v))
    }

    /// `u` (global components) on this rank's rows, in PETSc order and the nodal frames
    /// ([`Body::rows_of`]), with K applied to it on those rows and each row's mesh dof
    /// ([`Body::owned_dofs`]): no whole vector (collective).
    fn apply_k_rows(&self, u: &Displacement) -> Result<Rows, BodyError> {
        let dofs = self.owned_dofs();
        let mut values = self.rows_of(u)?;
        for (node, v) in self
            .partition
            .owned_mesh_nodes()
            .zip(values.chunks_exact_mut(2))
        {
            self.frames.node_to_local(node, v);
        }
        self.mult_k_local(&values)?;
        let ku = self.kx.borrow().to_vec()?;
        Ok(Rows { dofs, values, ku })
    }

    /// The mesh dof of each of this rank's rows, in PETSc order.
    pub(super) fn owned_dofs(&self) -> Vec<usize> {
        (self.partition.owned_mesh_nodes())
            .flat_map(|n| [2 * n, 2 * n + 1])
            .collect()
    }

    /// uᵀK u (K without boundary conditions, `u` in global components), from each rank's
    /// rows summed over the group: no whole K u (collective).
    pub fn quadratic(&self, u: &Displacement) -> Result<f64, BodyError> {
        let rows = self.apply_k_rows(u)?;
        let mut sum = [rows
            .values
            .iter()
            .zip(&rows.ku)
            .map(|(u, k)| u * k)
            .sum::<f64>()];
        self.own_comm.sum(&mut sum);
        Ok(sum[0])
    }

    /// The discrete equilibrium of `u` (global components, read at this rank's rows) with the
    /// Γc nodal forces `gc_forces` as a normwise backward error: ‖K u − f − Bᵀt‖∞ over the dofs
    /// not on Γ_D, over ‖K‖∞ ‖u‖∞ + ‖f‖∞ + ‖t‖∞; round-off (1e−16) for a field solved with
    /// these forces. Each rank measures its own rows (no whole K u). Collective over the
    /// body's group.
    pub fn equilibrium_residual(
        &self,
        u: &Displacement,
        gc_forces: &[f64],
    ) -> Result<f64, BodyError> {
        let rows = self.apply_k_rows(u)?;
        // f + Bᵀt: the body's data and the Γc forces, as a Neumann solve's load.
        let load = self.neumann_load(gc_forces, true);
        let fixed: HashSet<usize> = self.problem.dirichlet.iter().map(|d| d.0).collect();
        let mut num = 0.0_f64;
        for (&d, &k) in rows
            .dofs
            .iter()
            .zip(&rows.ku)
            .filter(|(d, _)| !fixed.contains(d))
        {
            let r = k - load.at(d);
            // (a NaN row makes the residual NaN, as the whole vector's maximum did)
            num = if r.is_nan() {
                f64::NAN
            } else {
                num.max(r.abs())
            };
        }
        let inf = |v: &[f64]| v.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
        let [num, u_inf] = [num, inf(&rows.values)].map(|v| self.own_comm.max(v));
        let scale = self.k_norm * u_inf + self.load.norm_inf() + inf(gc_forces);
        Ok(if !(num.is_finite() && scale.is_finite()) {
            f64::NAN
        } else if scale > 0.0 {
            num / scale
        } else {
            0.0
        })
    }

    /// Interface nodal forces T^α = n · (K u − f) on the Γc normal dofs of the last solve's
    /// solution (in `x`) with its exact prescribed values `fixed`: the force the other body
    /// exerts on this one (docs/method.md §1). Node to node: the Dirichlet step's body, which
    /// under the mortar discretisation is the non-mortar one. K u is formed on each rank's rows
    /// and gathered on the Γc dofs alone (collective).
    pub(super) fn reaction(&self, fixed: &[(usize, f64)]) -> Result<Vec<f64>, BodyError> {
        let mut u = self.x.borrow().to_vec()?;
        for (row, v) in self.owned(fixed) {
            u[row] = v;
        }
        self.mult_k_local(&u)?;
        let ku = self.trace.borrow_mut().gather(&self.kx.borrow())?;
        Ok(self
            .gc
            .iter()
            .zip(ku)
            .map(|(&d, k)| k - self.load.at(d))
            .collect())
    }

    /// Potential energy ½ uᵀK u − fᵀu (both terms from each rank's rows, summed over the
    /// group: no whole K u). Collective over the body's group.
    pub fn potential_energy(&self, u: &Displacement) -> Result<f64, BodyError> {
        let rows = self.apply_k_rows(u)?;
        let mut sum = [(rows.dofs.iter().zip(&rows.values).zip(&rows.ku))
            .map(|((&d, &u), k)| 0.5 * u * k - self.load.at(d) * u)
            .sum::<f64>()];
        self.own_comm.sum(&mut sum);
        Ok(sum[0])
    }
}

/// A field on this rank's rows of a body ([`Body::apply_k_rows`]): each row's mesh dof, the
/// field's value there (nodal frames) and K times the field there.
struct Rows {
    dofs: Vec<usize>,
    values: Vec<f64>,
    ku: Vec<f64>,
}
