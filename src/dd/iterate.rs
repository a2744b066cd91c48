//! An iterate of the NNDD (or the monolithic solve's solution): the fields of a step 1 and
//! its Γc data, what the final check, the estimates and the output read.

/// The state the loop ends in: the fields of the last step 1 (at λ_p) and their data.
#[derive(Clone, Debug)]
pub struct Iterate {
    /// u¹_{p,n}, body 1's normal Γc displacement (λ_p itself when body 1 takes the Dirichlet
    /// step).
    pub lambda: Vec<f64>,
    /// λ_p, the Dirichlet body's normal Γc displacement (the loop's variable).
    pub interface: Vec<f64>,
    /// u¹_p on body 1's ranks, u²_p on body 2's (empty elsewhere; formed after the loop, for
    /// the reported step, where the steps did not produce them).
    pub u: [Vec<f64>; 2],
    /// T¹_p, T²_p on the Γc normal dofs (known on every rank).
    pub forces: [Vec<f64>; 2],
    /// The body whose contact step gave its forces (2, or 1 with the Dirichlet step on body 2;
    /// 2 for the monolithic solve, whose multiplier is T²).
    pub contact_body: usize,
    /// u²_{p,n}, body 2's normal Γc trace (known on every rank once the fields are formed).
    pub trace2: Vec<f64>,
    pub active: Vec<bool>,
    /// Relative KKT violation of the contact QP of this step.
    pub qp_kkt: f64,
    /// The iteration p.
    pub iteration: usize,
}

impl Iterate {
    /// The contact forces on body 2, ≥ 0 in compression and 0 off the contact set: the
    /// contact step's multipliers, T² or −T¹ (the Dirichlet step's reaction on the other body
    /// equals them only up to the defect R).
    pub fn contact_forces(&self) -> Vec<f64> {
        if self.contact_body == 2 {
            self.forces[1].clone()
        } else {
            self.forces[0].iter().map(|f| -f).collect()
        }
    }
}
