//! What a run writes and prints (`-nndd_output`, `-nndd_monitor`, `-nndd_schur_view`), read
//! and validated into [`OutputSettings`].

use crate::io::output::OutputPaths;
use crate::petsc::readers::SettingsError;
use crate::petsc::OptionsBlock;
use crate::problem::ProblemKind;

/// The run's output (plain data).
#[derive(Clone, Debug)]
pub struct OutputSettings {
    /// Every file name, from the prefix PREFIX (`PREFIX.h5`, `PREFIX.xdmf`, `PREFIX.json`, …).
    pub paths: OutputPaths,
    /// Print one line per NNDD iteration.
    pub monitor: bool,
    /// Write each body's S^α and D^α to `PREFIX.body<α>_schur.json`.
    pub schur_view: bool,
}

impl OutputSettings {
    /// Read, register (for `-help`) and validate the output's options; the prefix defaults to
    /// `results/<problem>`.
    pub fn from_options(
        o: &mut OptionsBlock,
        problem: ProblemKind,
    ) -> Result<OutputSettings, SettingsError> {
        let monitor = o.flag("-nndd_monitor", "Print one line per NNDD iteration", false)?;
        let (prefix, _) = o.string(
            "-nndd_output",
            "Output prefix: PREFIX.h5, PREFIX.xdmf, PREFIX.json",
            &format!("results/{}", problem.name()),
        )?;
        if prefix.is_empty() {
            return Err(SettingsError::out_of_range(
                "-nndd_output",
                "a non-empty path prefix",
                "''",
            ));
        }
        let schur_view = o.flag(
            "-nndd_schur_view",
            "Write each body's interface operators S and D to PREFIX.body<alpha>_schur.json",
            false,
        )?;
        Ok(OutputSettings {
            paths: OutputPaths::new(prefix),
            monitor,
            schur_view,
        })
    }
}
