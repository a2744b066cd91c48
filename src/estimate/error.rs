//! What can go wrong in an estimate.

use crate::dd::body::BodyError;
use crate::estimate::equilibrate::EquilibrationError;
use crate::qp::QpError;

#[derive(Debug, thiserror::Error)]
pub enum EstimateError {
    #[error(transparent)]
    Body(#[from] BodyError),
    #[error("admissible contact traction: {0}")]
    Qp(#[from] QpError),
    #[error("body {alpha}: equilibrated stress: {source}")]
    Equilibration {
        alpha: usize,
        source: EquilibrationError,
    },
    #[error("reference mesh {fine} is not a refinement of mesh {coarse}")]
    NotNested { coarse: String, fine: String },
    #[error(transparent)]
    Fault(#[from] crate::parallel::fault::InjectedFault),
    /// A stop signal arrived on some rank: every rank left the estimate at the same point
    /// ([`Estimator::stop_point`]); the NNDD loop then stops at the end of its iteration.
    #[error("the estimate was left for a stop signal")]
    Stopped,
}
