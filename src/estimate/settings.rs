//! The estimates' options (`-nndd_estimate…`, `-nndd_reference_factor`, `-nndd_recovery…`,
//! `-nndd_eta_nndd`), read and validated into [`EstimateSettings`].

use super::equilibrate::Recovery;
use crate::petsc::readers::{Bounds, SettingsError};
use crate::petsc::OptionsBlock;

/// What the run estimates, and how (plain data).
#[derive(Clone, Debug)]
pub struct EstimateSettings {
    /// Estimate the errors of the reported iterate (and of the iterations of `every`).
    pub enabled: bool,
    /// Also estimate every k-th iteration (0: never).
    pub every: usize,
    /// Reference mesh factor r of (26) (0: no reference solution).
    pub reference_factor: usize,
    /// How the equilibrated stresses are recovered (see `estimate::equilibrate`).
    pub recovery: Recovery,
    /// Largest relative change of a body's displacement (energy norm) between two recoveries
    /// for which the second starts warm (`estimate::view::View::prepare`).
    pub warm_change: f64,
    /// The reference problem of η^NNDD (see `estimate`).
    pub nndd_variant: NnddVariant,
}

/// `-nndd_estimate_every`.
const EVERY: Bounds<i64> = Bounds {
    accepted: "an integer >= 0 (0: never)",
    holds: |k| (0..=1 << 16).contains(&k),
};

/// `-nndd_reference_factor`.
const REFERENCE_FACTOR: Bounds<i64> = Bounds {
    accepted: "0 (off) or an integer in [2, 64]",
    holds: |r| r == 0 || (2..=64).contains(&r),
};

/// `-nndd_recovery_sweeps`.
const SWEEPS: Bounds<i64> = Bounds {
    accepted: "an integer in [1, 1000]",
    holds: |s| (1..=1000).contains(&s),
};

/// `-nndd_recovery_warm_sweeps`.
const WARM_SWEEPS: Bounds<i64> = Bounds {
    accepted: "an integer in [0, 1000]",
    holds: |s| (0..=1000).contains(&s),
};

/// The values of `-nndd_recovery`.
const RECOVERIES: [&str; 4] = ["patch", "patch-classic", "star", "eet"];

impl EstimateSettings {
    /// Read, register (for `-help`) and validate the estimates' options. `balanced`: the NNDD
    /// stops by the balanced rule (`-nndd_stop balanced`), which estimates every iteration
    /// unless told otherwise.
    pub fn from_options(
        o: &mut OptionsBlock,
        balanced: bool,
    ) -> Result<EstimateSettings, SettingsError> {
        let asked = o.flag(
            "-nndd_estimate",
            "Estimate eta_glo, eta_FE, eta_NNDD of the final iterate (paper (22)-(24))",
            false,
        )?;
        let (every, _) = o.int_in(
            "-nndd_estimate_every",
            "Also estimate every k-th NNDD iteration (0: never)",
            0,
            EVERY,
        )?;
        let (reference_factor, _) = o.int_in(
            "-nndd_reference_factor",
            "Solve the reference problem on the nested mesh r*n (a Gmsh mesh: each triangle split into r^2) and report e_ref and the effectivity (0: off; paper: 8)",
            0,
            REFERENCE_FACTOR,
        )?;
        let recovery = o.choice(
            "-nndd_recovery",
            "Equilibrated stress recovery: patch (EET then patch-wise complementary energy minimisation, planned on the edge tractions, the eta_FE recovery warm-started), patch-classic (the same minimisation on the Johnson-Mercier fields, every recovery from EET), star (EET, star parameters minimising it), eet (EET, averaged tractions)",
            &RECOVERIES.map(|r| (r, r)),
        )?;
        // patch-classic keeps the sweeps it had as the default recovery.
        let (sweeps, _) = o.int_in(
            "-nndd_recovery_sweeps",
            "Patch relaxation sweeps of -nndd_recovery patch (default 6) and patch-classic (default 10)",
            if recovery == "patch-classic" { 10 } else { 6 },
            SWEEPS,
        )?;
        let (warm_sweeps, _) = o.int_in(
            "-nndd_recovery_warm_sweeps",
            "Sweeps of a -nndd_recovery patch recovery started from the change the previous recovery's sweeps made (the eta_FE one after the eta_glo one, and each estimate's after the previous estimate's, when the displacement changed by at most -nndd_recovery_warm_change); 0: every recovery cold, with -nndd_recovery_sweeps",
            1,
            WARM_SWEEPS,
        )?;
        let (warm_change, _) = o.real_in(
            "-nndd_recovery_warm_change",
            "Largest relative change of a body's displacement in the energy norm since the previous recovery for which a -nndd_recovery patch recovery starts warm (-nndd_recovery_warm_sweeps); further apart it starts cold, as the final iterate's eta_glo recovery always does",
            WARM_CHANGE,
            Bounds::NON_NEGATIVE,
        )?;
        let nndd_variant = o.choice(
            "-nndd_eta_nndd",
            "eta_NNDD against: discrete (the discrete problem, nodal contact forces) or density (docs/method.md 3.3 as written)",
            &[
                ("discrete", NnddVariant::Discrete),
                ("density", NnddVariant::Density),
            ],
        )?;
        let recovery = match recovery {
            "patch" => Recovery::Patch {
                sweeps,
                warm_sweeps,
            },
            "patch-classic" => Recovery::PatchClassic { sweeps },
            "star" => Recovery::star(),
            _ => Recovery::Eet, // eet
        };
        Ok(EstimateSettings {
            // A reference solution is only of use with an estimate to compare; balanced
            // stopping estimates every iteration unless told otherwise.
            enabled: asked || every > 0 || reference_factor > 0 || balanced,
            every: if balanced && every == 0 { 1 } else { every },
            reference_factor,
            recovery,
            warm_change,
            nndd_variant,
        })
    }
}

/// Which reference problem η^NNDD is measured against (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NnddVariant {
    /// The discrete global problem, nodal contact forces (vanishes at convergence).
    Discrete,
    /// docs/method.md §3.3 as written: the P1 density t̂^c of η^glo.
    Density,
}

/// The default of `-nndd_recovery_warm_change`: the largest relative change of the data (the
/// displacement, in the energy norm) from one recovery to the next for which the next starts
/// warm, from the change the previous one's
/// sweeps made (`Recovery::Patch`); further apart, it starts cold. The warm
/// start's distance to the relaxed field is about this fraction of a cold start's. Measured
/// on `paper` with one warm sweep against six cold ones: n = 256, θ auto, estimates every
/// iteration, between iteration 1's η^FE recovery and iteration 2's η^glo one (change 1.0
/// and 0.73 on the two bodies) η^glo came out 5.8 % higher warm; from iteration 2 on
/// (changes ≤ 8·10⁻⁵) 1 % lower, the sweeps accumulating over the estimates. At n = 64,
/// θ = 0.25, changes of 0.07–0.7 cost at most 0.03 %. The bound holds either way.
pub const WARM_CHANGE: f64 = 1.0 / 32.0;
