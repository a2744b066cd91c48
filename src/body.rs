//! One body (subdomain) Ω^α on its communicator: the stiffness, its factorised systems and the
//! solves the NNDD steps are made of (method.md §2).
//!
//! Two systems exist, both SPD with Dirichlet rows and columns eliminated symmetrically:
//! - the *Neumann* system: Γ_D^α prescribed; used for the contact step and the Neumann step;
//! - the *Dirichlet* system (body 1, when step 1 is not condensed): Γ_D¹ and the Γc normal dofs
//!   prescribed.
//!
//! Each is a PETSc KSP with prefix `body<α>_`, factored once at setup. With MUMPS, the
//! factorisation of the Neumann system also yields the interface Schur complement S^α on the
//! Γc normal dofs (everything else condensed), used by the contact step and the condensed
//! Dirichlet step.

use crate::dense::{DenseError, SymMatrix};
use crate::fem::assemble_stiffness;
use crate::petsc::{self, Comm, Ksp, Matrix, Vector};
use crate::problem::BodyProblem;

#[derive(Debug, thiserror::Error)]
pub enum BodyError {
    #[error(transparent)]
    Petsc(#[from] petsc::PetscError),
    #[error("body {alpha}: the {system} solve did not converge (KSP reason {reason}); check -body{alpha}_ksp_* options")]
    NotConverged {
        alpha: usize,
        system: &'static str,
        reason: i32,
    },
    #[error("body {alpha}: interface Schur complement: {source}")]
    Schur { alpha: usize, source: DenseError },
}

/// Whether a body needs its interface Schur complement S^α.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SchurMode {
    None,
    /// Only when the factorisation computes it at no extra cost (MUMPS).
    IfFactored,
    /// Always: from MUMPS, else from m back-solves.
    Always,
}

/// Which factorised system to solve with.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum System {
    Neumann,
    Dirichlet,
}

pub struct Body {
    pub problem: BodyProblem,
    /// Assembled stiffness K^α without boundary conditions.
    k: Matrix,
    /// Neumann load f^α.
    pub load: Vec<f64>,
    /// Value on the diagonal of eliminated rows (mean diagonal of K, for conditioning).
    diag: f64,
    comm: Comm,
    neumann: Ksp,
    dirichlet: Option<Ksp>,
    /// Γc normal dofs in pair order.
    pub gc: Vec<usize>,
    /// Interface Schur complement S^α of the Neumann system on the Γc normal dofs.
    pub schur: Option<SymMatrix>,
    /// How the Schur complement was obtained ("mumps" or "solves").
    pub schur_source: &'static str,
    /// Counters of back-solves per system (for the summary).
    pub solves: std::cell::Cell<usize>,
    /// Wall time of assembly and of factorisation (s).
    pub setup_seconds: (f64, f64),
    x: std::cell::RefCell<Vector>,
    b: std::cell::RefCell<Vector>,
    kx: std::cell::RefCell<Vector>,
}

impl Body {
    /// Assemble K^α and factor its Neumann system; `schur` says whether S^α is wanted.
    pub fn setup(
        problem: BodyProblem,
        comm: Comm,
        schur: SchurMode,
        stages: &crate::log::Stages,
    ) -> Result<Body, BodyError> {
        let alpha = problem.alpha;
        let ndof = problem.mesh.num_dofs();
        let t0 = std::time::Instant::now();
        let (k, diag, k_neu) = {
            let _s = stages.assembly.enter();
            let csr = assemble_stiffness(&problem.mesh, &problem.material);
            let diag = csr.diag_mean();
            let k = Matrix::from_csr(comm, ndof, &csr.row_ptr, &csr.cols, &csr.vals)?;
            drop(csr);
            let rows: Vec<petsc::Int> = problem
                .dirichlet
                .iter()
                .map(|d| d.0 as petsc::Int)
                .collect();
            let mut k_neu = k.duplicate()?;
            k_neu.zero_rows_columns(&rows, diag)?;
            (k, diag, k_neu)
        };
        let gc = problem.contact_normal_dofs();
        let gc_rows: Vec<petsc::Int> = gc.iter().map(|&d| d as petsc::Int).collect();
        let t_assembly = t0.elapsed().as_secs_f64();
        let t1 = std::time::Instant::now();
        let _s = stages.factorisation.enter();
        let want = if schur == SchurMode::None {
            None
        } else {
            Some(&gc_rows[..])
        };
        let neumann = Ksp::new(comm, k_neu, &format!("body{alpha}_"), want)?;
        let x = Vector::new(comm, ndof)?;
        let b = x.duplicate()?;
        let kx = x.duplicate()?;
        let load = problem.load();
        let mut body = Body {
            problem,
            comm,
            k,
            load,
            diag,
            neumann,
            dirichlet: None,
            gc,
            schur: None,
            schur_source: "none",
            solves: std::cell::Cell::new(0),
            setup_seconds: (t_assembly, 0.0),
            x: std::cell::RefCell::new(x),
            b: std::cell::RefCell::new(b),
            kx: std::cell::RefCell::new(kx),
        };
        if schur == SchurMode::Always
            || (schur == SchurMode::IfFactored && body.neumann.schur_complement().is_some())
        {
            body.schur = Some(body.compute_schur()?);
        }
        body.setup_seconds.1 = t1.elapsed().as_secs_f64();
        Ok(body)
    }

    /// Assemble and factor the Dirichlet system (Γ_D and the Γc normal dofs prescribed).
    pub fn add_dirichlet_system(&mut self, stages: &crate::log::Stages) -> Result<(), BodyError> {
        let t0 = std::time::Instant::now();
        let m = {
            let _s = stages.assembly.enter();
            let mut rows: Vec<petsc::Int> = self
                .problem
                .dirichlet
                .iter()
                .map(|d| d.0 as petsc::Int)
                .collect();
            rows.extend(self.gc.iter().map(|&d| d as petsc::Int));
            rows.sort_unstable();
            rows.dedup();
            let mut m = self.k.duplicate()?;
            m.zero_rows_columns(&rows, self.diag)?;
            m
        };
        self.setup_seconds.0 += t0.elapsed().as_secs_f64();
        let t1 = std::time::Instant::now();
        let _s = stages.factorisation.enter();
        self.dirichlet = Some(Ksp::new(
            self.comm,
            m,
            &format!("body{}_", self.alpha()),
            None,
        )?);
        self.setup_seconds.1 += t1.elapsed().as_secs_f64();
        Ok(())
    }

    pub fn has_dirichlet_system(&self) -> bool {
        self.dirichlet.is_some()
    }

    pub fn alpha(&self) -> usize {
        self.problem.alpha
    }

    /// S^α from MUMPS's Schur complement when available, else from m back-solves
    /// (the Delassus operator D = B K⁻¹ Bᵀ, S = D⁻¹).
    fn compute_schur(&mut self) -> Result<SymMatrix, BodyError> {
        let m = self.gc.len();
        let alpha = self.alpha();
        if let Some(s) = self.neumann.schur_complement() {
            // Column-major; a symmetric factorisation may fill only one triangle.
            let mut out = SymMatrix::new(m);
            for j in 0..m {
                for i in 0..m {
                    let (a, b) = (s[j * m + i], s[i * m + j]);
                    let v = if a == 0.0 {
                        b
                    } else if b == 0.0 {
                        a
                    } else {
                        0.5 * (a + b)
                    };
                    out.set(i, j, v);
                }
            }
            self.schur_source = "mumps";
            return Ok(out);
        }
        let mut d = SymMatrix::new(m);
        for j in 0..m {
            let mut e = vec![0.0; m];
            e[j] = 1.0;
            let w = self.neumann_solve(&e, false)?;
            for i in 0..m {
                d.set(i, j, w[self.gc[i]]);
            }
        }
        d.symmetrize();
        self.schur_source = "solves";
        d.inverse_spd()
            .map_err(|source| BodyError::Schur { alpha, source })
    }

    /// Solve `system` with right-hand side `load` and prescribed values: Γ_D data (or zero when
    /// `homogeneous`) and, for the Dirichlet system, `gc_values` on the Γc normal dofs.
    fn solve(
        &self,
        system: System,
        load: &[f64],
        homogeneous: bool,
        gc_values: Option<&[f64]>,
    ) -> Result<Vec<f64>, BodyError> {
        let ndof = load.len();
        // x_g: the prescribed values, zero elsewhere; rhs = load − K x_g, prescribed rows = diag·g.
        let mut g = vec![0.0; ndof];
        let mut fixed: Vec<(usize, f64)> =
            Vec::with_capacity(self.problem.dirichlet.len() + self.gc.len());
        for &(dof, v) in &self.problem.dirichlet {
            let v = if homogeneous { 0.0 } else { v };
            fixed.push((dof, v));
        }
        if let Some(vals) = gc_values {
            for (&dof, &v) in self.gc.iter().zip(vals) {
                fixed.push((dof, v));
            }
        }
        for &(dof, v) in &fixed {
            g[dof] = v;
        }
        let mut rhs = load.to_vec();
        if fixed.iter().any(|f| f.1 != 0.0) {
            let kg = self.apply_k(&g)?;
            for i in 0..ndof {
                rhs[i] -= kg[i];
            }
        }
        for &(dof, v) in &fixed {
            rhs[dof] = self.diag * v;
        }
        let ksp = match system {
            System::Neumann => &self.neumann,
            System::Dirichlet => self
                .dirichlet
                .as_ref()
                .expect("body 1 has a Dirichlet system"),
        };
        let mut b = self.b.borrow_mut();
        let mut x = self.x.borrow_mut();
        b.copy_from(&rhs)?;
        let info = ksp.solve(&b, &mut x)?;
        self.solves.set(self.solves.get() + 1);
        if info.reason < 0 {
            return Err(BodyError::NotConverged {
                alpha: self.alpha(),
                system: if system == System::Neumann {
                    "Neumann"
                } else {
                    "Dirichlet"
                },
                reason: info.reason,
            });
        }
        let mut u = x.to_vec()?;
        for &(dof, v) in &fixed {
            u[dof] = v; // exact prescribed values (the solve returns them to round-off)
        }
        Ok(u)
    }

    /// K u (K without boundary conditions).
    pub fn apply_k(&self, u: &[f64]) -> Result<Vec<f64>, BodyError> {
        let mut x = self.x.borrow_mut();
        let mut kx = self.kx.borrow_mut();
        x.copy_from(u)?;
        self.k.mult(&x, &mut kx)?;
        Ok(kx.to_vec()?)
    }

    /// Interface nodal forces T^α = (K u − f) on the Γc normal dofs: the force the other body
    /// exerts on this one (method.md §1).
    pub fn interface_forces(&self, u: &[f64]) -> Result<Vec<f64>, BodyError> {
        let ku = self.apply_k(u)?;
        Ok(self.gc.iter().map(|&d| ku[d] - self.load[d]).collect())
    }

    /// Solve the Dirichlet system: u = u_D on Γ_D, u_n = λ on Γc, tangential Γc free.
    /// Returns the displacement and the reaction T = K u − f on the Γc normal dofs.
    pub fn dirichlet_solve(&self, lambda: &[f64]) -> Result<(Vec<f64>, Vec<f64>), BodyError> {
        let u = self.solve(System::Dirichlet, &self.load, false, Some(lambda))?;
        let t = self.interface_forces(&u)?;
        Ok((u, t))
    }

    /// Solve the Neumann system with nodal forces `gc_forces` on the Γc normal dofs, plus the
    /// body's own data (f^α and u_D) when `with_data`, else homogeneous (paper (15)–(16)).
    pub fn neumann_solve(&self, gc_forces: &[f64], with_data: bool) -> Result<Vec<f64>, BodyError> {
        let mut load = if with_data {
            self.load.clone()
        } else {
            vec![0.0; self.load.len()]
        };
        for (&d, &f) in self.gc.iter().zip(gc_forces) {
            load[d] += f;
        }
        self.solve(System::Neumann, &load, !with_data, None)
    }

    /// Normal Γc displacements B u.
    pub fn normal_trace(&self, u: &[f64]) -> Vec<f64> {
        self.gc.iter().map(|&d| u[d]).collect()
    }

    /// Potential energy ½ uᵀK u − fᵀu.
    pub fn potential_energy(&self, u: &[f64]) -> Result<f64, BodyError> {
        let ku = self.apply_k(u)?;
        Ok(u.iter()
            .zip(&ku)
            .zip(&self.load)
            .map(|((u, ku), f)| 0.5 * u * ku - f * u)
            .sum())
    }
}
