//! An iterate of the NNDD (or the monolithic solve's solution): the fields of a step 1 and
//! its Γc data, what the final check, the estimates and the output read.

use crate::dd::displacement::Displacement;
use crate::dd::friction::Tangential;

/// The state the loop ends in: the fields of the last step 1 (at λ_p) and their data.
#[derive(Clone, Debug)]
pub struct Iterate {
    /// u¹_{p,n}, body 1's normal Γc displacement (λ_p itself when body 1 takes the Dirichlet
    /// step).
    pub lambda: Vec<f64>,
    /// λ_p, the Dirichlet body's normal Γc displacement (the loop's variable).
    pub interface: Vec<f64>,
    /// u¹_p on body 1's ranks, u²_p on body 2's, each rank's at the nodes it reads
    /// ([`crate::dd::body::Body::keep_fields_at`]; empty elsewhere; formed after the loop, for
    /// the reported step, where the steps did not produce them).
    pub u: [Displacement; 2],
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
    /// With friction, the nodal bounds g_k of the tangential forces while the interface
    /// vectors above still hold both parts (empty once split, and without friction).
    pub friction_bounds: Vec<f64>,
    /// With friction, once split ([`Iterate::split_tangential`]): the tangential part, the
    /// vectors above then holding the normal part only.
    pub tangential: Option<Tangential>,
}

impl Iterate {
    /// Body k's (0 or 1) Γc forces on its whole interface: the normal ones, then with friction
    /// the tangential ones.
    pub fn interface_forces(&self, k: usize) -> Vec<f64> {
        let mut f = self.forces[k].clone();
        if let Some(t) = &self.tangential {
            f.extend(&t.forces[k]);
        }
        f
    }

    /// The tangential forces on body 2 with friction, from the contact step (T²_t, or −T¹_t);
    /// empty without friction.
    pub fn tangential_contact_forces(&self) -> Vec<f64> {
        match &self.tangential {
            None => Vec::new(),
            Some(t) if self.contact_body == 2 => t.forces[1].clone(),
            Some(t) => t.forces[0].iter().map(|f| -f).collect(),
        }
    }

    /// This iterate without its displacement fields (`u` empty): what an estimate carries from
    /// its re-solves to its recoveries, which read the fields from the caller's iterate again,
    /// so that no copy of them is held beside the bodies' factorisations.
    pub fn without_fields(&self) -> Iterate {
        Iterate {
            lambda: self.lambda.clone(),
            interface: self.interface.clone(),
            u: Default::default(),
            forces: self.forces.clone(),
            contact_body: self.contact_body,
            trace2: self.trace2.clone(),
            active: self.active.clone(),
            qp_kkt: self.qp_kkt,
            iteration: self.iteration,
            friction_bounds: self.friction_bounds.clone(),
            tangential: self.tangential.clone(),
        }
    }

    /// λ_p whole: the normal rows, then with friction the tangential ones (the loop's
    /// variable; an adaptive run carries it to its next cycle).
    pub fn whole_interface(&self) -> Vec<f64> {
        let mut v = self.interface.clone();
        if let Some(t) = &self.tangential {
            v.extend(&t.interface);
        }
        v
    }

    /// Split a frictional iterate's interface vectors (normal rows, then tangential) into
    /// their normal part, which the checks, the output and the summary read as without
    /// friction, and [`Iterate::tangential`]. Nothing to do without friction or once split.
    pub fn split_tangential(&mut self) {
        let m = self.friction_bounds.len();
        if m == 0 {
            return;
        }
        let tail = |v: &mut Vec<f64>| v.split_off(m);
        let [f1, f2] = &mut self.forces;
        self.tangential = Some(Tangential {
            trace1: tail(&mut self.lambda),
            trace2: tail(&mut self.trace2),
            forces: [tail(f1), tail(f2)],
            bounds: std::mem::take(&mut self.friction_bounds),
            stick: self.active.split_off(m),
            interface: self.interface.split_off(m),
        });
    }

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
