//! Layer `estimate`: guaranteed a posteriori error estimates of an NNDD iterate (paper §4,
//! `docs/method.md` §3). [`traction`]: the admissible contact traction on Γc; [`polygon`]:
//! η^glo's traction and displacement correction on a curved Γc (§5); [`cre`]: one
//! body's constitutive relation error element by element; [`view`]: where a rank's recoveries
//! of a body run; [`iteration`]: what an estimate of one
//! iteration reads; [`equilibrate`]: strictly
//! equilibrated stresses (EET + Johnson–Mercier, patch relaxation); [`overlap`]: a rank's
//! elements plus the rings its recovery needs; [`share`]: which rank estimates which
//! elements; [`reference`]: the reference solution of (26); [`settings`]: the estimates'
//! options; [`balanced`]: the balanced stopping rule, η^NNDD ≤ κ η^FE; [`estimator`]: the
//! estimator itself, [`error`] its errors and [`parts`] where its time goes; [`size_field`]:
//! the mesh sizes the element estimates ask for.
//!
//! May use: `dd`, `problem`, `parallel`, `qp`, `fem`, `petsc`, `os`.
//!
//! The estimates:
//! the global estimator η^glo (22) and the indicators η^FE (23) and η^NNDD (24), each a sum of
//! element contributions, computed by the ranks that estimate the elements (all ranks in
//! equal shares, [`share`]; the re-solves on each body's group).
//!
//! At iteration p, with û^α = u^α_p (step 1's fields: û¹_n = λ_p, û²_n ≥ λ_p on Γc):
//! - η^glo² = Σ_α ‖σ̂^α − Kε(u^α_p)‖²_{K⁻¹} + 2∫_Γc t̂^c (λ_p − u²_{p,n}), with t̂^c the
//!   admissible contact traction closest to ½(t¹_h − t²_h) and σ̂^α the strictly equilibrated
//!   stresses recovered from the Neumann re-solves ũ^α_h (data t̂¹ = t̂^c, t̂² = −t̂^c);
//! - η^FE² the same for the step-p problem at fixed λ_p: body 1 equilibrates σ(u¹_p) itself
//!   with its Γc reaction density M_Γ⁻¹T¹_p, body 2 uses t̂^c_p ≤ 0 closest to −t²_h;
//! - η^NNDD, the CRE of the discrete global problem (whose contact constraint and forces are
//!   nodal): with the nodal contact forces μ̂ = max(½(T²_p − T¹_p), 0) ≥ 0 on the contact set
//!   (0 off it) and the Neumann
//!   re-solves ũ^α_d (Γc forces ∓μ̂), η^NNDD² = Σ_α ‖Kε(ũ^α_d − u^α_p)‖²_{K⁻¹} +
//!   2 μ̂ᵀ(u²_{p,n} − λ_p). It vanishes exactly at the discrete solution (T¹ = −T², and
//!   complementarity). docs/method.md §3.3 builds it from the P1 density t̂^c of η^glo instead;
//!   that variant (`NnddVariant::Density`) does not vanish as the NNDD converges, because the
//!   density M_Γ⁻¹T of the converged nodal forces changes sign near the end of the contact
//!   zone and its projection on t̂ ≤ 0 alters the loads (see tests/estimates.rs).
//!
//! Norms follow the paper: ‖σ‖²_{K⁻¹} = ∫ σ:K⁻¹:σ, ‖u‖²_E = ∫ Kε(u):ε(u) (no ½).

pub mod balanced;
pub mod cre;
pub mod equilibrate;
pub mod error;
pub mod estimator;
pub mod friction;
pub mod iteration;
pub mod mortar;
pub mod overlap;
pub mod parts;
pub mod polygon;
pub mod reference;
pub mod settings;
pub mod share;
pub mod size_field;
pub mod traction;
pub mod view;

pub use balanced::BalancedRule;
pub use error::EstimateError;
pub use estimator::{EstimateRecord, Estimator};
pub use parts::{Part, Parts};
pub use reference::{Reference, ReferencePart};
pub use settings::{EstimateSettings, NnddVariant};
pub use traction::Interface;
