//! Restart points: what `-nndd_checkpoint_every` and a signal write, and what
//! `-nndd_restart` reads. A checkpoint holds the NNDD loop's state ([`LoopState`]: λ_{p+1},
//! the iteration count, the history, the secant update and the last contact set), the
//! balanced stopping rule's state, and the identity of the discrete problem it belongs to,
//! which a restart compares with its own before anything else.
//!
//! The file is JSON (`PREFIX.checkpoint.json`), replaced atomically (a temporary, synced,
//! renamed), so a run killed while writing leaves the previous checkpoint whole. It carries a
//! checksum of its contents: a file edited or damaged after it was written (one λ changed, a
//! line lost) is refused instead of continued from. Floating
//! point numbers are written with the shortest representation that reads back to the same
//! bits, so a restart continues from exactly the checkpointed λ: the iterates it computes are
//! the uninterrupted run's, up to the round-off differences between rank counts.

use std::path::{Path, PathBuf};
use std::rc::Rc;

use crate::dd::nndd::LoopState;
use crate::fem::mesh::mix;
use crate::io::output::{write_atomic, OutputError};
use crate::problem::mortar::Coupling;
use crate::problem::{BodyProblem, GcTrace};

/// The format tag of the files this version writes and reads.
pub const FORMAT: &str = "nndd-checkpoint-2";

/// What cannot be restarted from, naming `-nndd_restart` and the file.
#[derive(Debug, thiserror::Error)]
pub enum CheckpointError {
    #[error("-nndd_restart {}: cannot read the checkpoint: {source}", .path.display())]
    Read {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("-nndd_restart {}: not an nndd checkpoint ({reason})", .path.display())]
    Format { path: PathBuf, reason: String },
    #[error("-nndd_restart {}: the checkpoint's contents do not match its checksum (edited or damaged after it was written); restart from an intact checkpoint, or run without -nndd_restart", .path.display())]
    Checksum { path: PathBuf },
    #[error("-nndd_restart {}: the checkpoint does not match this run: {what}", .path.display())]
    Differs { path: PathBuf, what: String },
    #[error("-nndd_restart {}: the checkpoint is at iteration {iteration}, not below -nndd_max_it {max_it}", .path.display())]
    Done {
        path: PathBuf,
        iteration: usize,
        max_it: usize,
    },
}

/// A restart point.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct Checkpoint {
    pub format: String,
    pub identity: Identity,
    pub state: LoopState,
    /// Balanced stopping: the η^FE of the last full estimate (None before the first).
    pub balanced_fe: Option<f64>,
    /// Balanced stopping: the cheap η^NNDD checks made (iteration, η^NNDD).
    pub checks: Vec<(usize, f64)>,
}

/// What a checkpoint belongs to: the discrete problem and the update rule.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Identity {
    /// `paper`, `uniform` or `mesh`.
    pub problem: String,
    pub bodies: [BodyIdentity; 2],
    /// `-nndd_theta`: `auto` or the fixed value.
    pub theta: String,
    /// The body of the Dirichlet step, whose normal Γc displacement λ is
    /// (`-nndd_dirichlet_body`; body 1 in checkpoints that do not say).
    #[serde(default = "body_one")]
    pub dirichlet_body: usize,
    /// The bodies of the Neumann step (`-nndd_neumann_bodies` resolved: `both`, `dirichlet`,
    /// `contact`; absent in checkpoints that do not say, and then not compared).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub neumann_bodies: Option<String>,
    /// The friction law and its parameter (`-nndd_friction`; absent without friction, and in
    /// checkpoints from before it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub friction: Option<String>,
    /// The length of λ, the number m of Γc pairs, 2m with friction (not stored: a checkpoint's is that of its λ,
    /// and its contact fingerprints cover it).
    #[serde(skip)]
    pub pairs: usize,
}

fn body_one() -> usize {
    1
}

/// One body's discrete problem, by fingerprints (see [`crate::fem::mesh::Mesh::fingerprint`]).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct BodyIdentity {
    pub nodes: usize,
    pub elements: usize,
    pub mesh: u64,
    pub young: f64,
    pub poisson: f64,
    /// The Dirichlet dofs and values and the Neumann tractions.
    pub loads: u64,
    /// The Γc nodes, normals and initial gaps.
    pub contact: u64,
}

/// The fingerprint `h` mixed with a mortar coupling's pairs (gap, normal) and rows.
fn mortar_identity(mut h: u64, c: &Coupling) -> u64 {
    for ((g, n), row) in c.gap.iter().zip(&c.normals).zip(&c.rows) {
        h = mix(mix(mix(h, g.to_bits()), n[0].to_bits()), n[1].to_bits());
        h = mix(h, row.len() as u64);
        for &(node, p) in row {
            h = mix(mix(h, node as u64), p.to_bits());
        }
    }
    h
}

impl BodyIdentity {
    fn of(b: &BodyProblem) -> BodyIdentity {
        let mut loads = mix(b.dirichlet.len() as u64, b.neumann.len() as u64);
        for &(dof, v) in &b.dirichlet {
            loads = mix(mix(loads, dof as u64), v.to_bits());
        }
        for e in &b.neumann {
            loads = mix(mix(loads, e.nodes[0] as u64), e.nodes[1] as u64);
            for t in e.traction.iter().flatten() {
                loads = mix(loads, t.to_bits());
            }
        }
        let mut contact = mix(b.contact_nodes.len() as u64, 0);
        match &b.trace {
            GcTrace::Nodes => {
                for (k, &node) in b.contact_nodes.iter().enumerate() {
                    contact = mix(mix(contact, node as u64), b.gap[k].to_bits());
                    for c in b.contact_normals[k] {
                        contact = mix(contact, c.to_bits());
                    }
                }
            }
            // Body 2 under the mortar discretisation: where it meets each pair.
            GcTrace::Mortar(c) => contact = mortar_identity(contact, c),
        }

        BodyIdentity {
            nodes: b.num_nodes(),
            elements: b.num_elements(),
            mesh: b.mesh_fingerprint(),
            young: b.material.young,
            poisson: b.material.poisson,
            loads,
            contact,
        }
    }
}

impl Identity {
    pub fn of(
        problem: &str,
        bodies: &[Rc<BodyProblem>; 2],
        theta: String,
        dirichlet_body: usize,
        neumann_bodies: &str,
    ) -> Identity {
        Identity {
            problem: problem.to_string(),
            bodies: [BodyIdentity::of(&bodies[0]), BodyIdentity::of(&bodies[1])],
            theta,
            dirichlet_body,
            neumann_bodies: Some(neumann_bodies.to_string()),
            friction: None,
            pairs: bodies[0].pairs(),
        }
    }

    /// The identity of a run with friction: the law `law` (with its parameter) on an
    /// interface of `rows` values per λ.
    pub fn with_friction(mut self, law: Option<String>, rows: usize) -> Identity {
        self.friction = law;
        self.pairs = rows;
        self
    }

    /// The first difference of `self` (the checkpoint's) from `run` (this run's), as a phrase.
    pub fn difference(&self, run: &Identity) -> Option<String> {
        if self.problem != run.problem {
            return Some(format!(
                "problem '{}', this run '{}' (-nndd_problem, -nndd_mesh)",
                self.problem, run.problem
            ));
        }
        for (k, (c, r)) in self.bodies.iter().zip(&run.bodies).enumerate() {
            let body = k + 1;
            if (c.nodes, c.elements) != (r.nodes, r.elements) {
                return Some(format!(
                    "body {body}'s mesh has {} nodes and {} elements, this run's {} and {} (-nndd_n, -nndd_body{body}_nx, -nndd_body{body}_ny, -nndd_mesh)",
                    c.nodes, c.elements, r.nodes, r.elements
                ));
            }
            if c.mesh != r.mesh {
                return Some(format!(
                    "body {body}'s mesh has other coordinates or connectivity (-nndd_mesh)"
                ));
            }
            if (c.young, c.poisson) != (r.young, r.poisson) {
                return Some(format!(
                    "body {body}'s material is E = {:e}, nu = {}, this run's E = {:e}, nu = {} (-nndd_E, -nndd_nu, -nndd_body{body}_E, -nndd_body{body}_nu)",
                    c.young, c.poisson, r.young, r.poisson
                ));
            }
            if c.loads != r.loads {
                return Some(format!(
                    "body {body}'s boundary conditions or loads differ (-nndd_u_D, -nndd_F_max, -nndd_bc_*)"
                ));
            }
            if c.contact != r.contact {
                return Some(format!(
                    "body {body}'s contact interface (its nodes, normals or gaps) differs (-nndd_contact, -nndd_mesh)"
                ));
            }
        }
        if self.friction != run.friction {
            let name = |f: &Option<String>| f.clone().unwrap_or_else(|| "none".into());
            return Some(format!(
                "its friction is {}, this run's {} (-nndd_friction, -nndd_friction_coefficient, -nndd_friction_threshold)",
                name(&self.friction),
                name(&run.friction)
            ));
        }
        if self.dirichlet_body != run.dirichlet_body {
            return Some(format!(
                "its Dirichlet step is on body {}, this run's on body {} (-nndd_dirichlet_body {} continues it)",
                self.dirichlet_body, run.dirichlet_body, self.dirichlet_body
            ));
        }
        if self.theta != run.theta {
            return Some(format!(
                "-nndd_theta {}, this run {}",
                self.theta, run.theta
            ));
        }
        if let (Some(c), Some(r)) = (&self.neumann_bodies, &run.neumann_bodies) {
            if c != r {
                return Some(format!(
                    "its Neumann step is taken by '{c}', this run's by '{r}' (-nndd_neumann_bodies)"
                ));
            }
        }
        None
    }
}

/// The key of the checksum in the file.
const CHECKSUM: &str = "checksum";

/// The checksum of a checkpoint's JSON value (without its `checksum` key): a 64-bit hash
/// ([`mix`]) of its canonical text (keys sorted, numbers in their shortest exact form, which
/// reading and writing again leaves as they are), in hexadecimal.
fn checksum(value: &serde_json::Value) -> String {
    let text = serde_json::to_vec(value).unwrap_or_default();
    let mut h = mix(text.len() as u64, 0x6e6e_6464);
    for chunk in text.chunks(8) {
        let mut word = [0u8; 8];
        word[..chunk.len()].copy_from_slice(chunk);
        h = mix(h, u64::from_le_bytes(word));
    }
    format!("{h:016x}")
}

/// Write `cp` to `path` atomically, with its checksum (the caller is one rank).
pub fn write(path: &Path, cp: &Checkpoint) -> Result<(), OutputError> {
    let fail = |e: serde_json::Error| OutputError::Io {
        path: path.to_path_buf(),
        action: "serialise the checkpoint",
        source: std::io::Error::other(e.to_string()),
    };
    let mut value = serde_json::to_value(cp).map_err(fail)?;
    let sum = checksum(&value);
    if let Some(map) = value.as_object_mut() {
        map.insert(CHECKSUM.into(), sum.into());
    }
    write_atomic(path, &serde_json::to_vec(&value).map_err(fail)?)
}

/// Read the checkpoint `path` and check it against this run's `identity` and `max_it`.
pub fn read(
    path: &Path,
    identity: &Identity,
    max_it: usize,
) -> Result<Checkpoint, CheckpointError> {
    let bytes = std::fs::read(path).map_err(|source| CheckpointError::Read {
        path: path.to_path_buf(),
        source,
    })?;
    let format = |reason: String| CheckpointError::Format {
        path: path.to_path_buf(),
        reason,
    };
    let mut value: serde_json::Value =
        serde_json::from_slice(&bytes).map_err(|e| format(e.to_string()))?;
    match value.get("format").and_then(|f| f.as_str()) {
        Some(FORMAT) => {}
        Some(other) => {
            return Err(format(format!(
                "format '{other}', this version reads '{FORMAT}'"
            )))
        }
        None => return Err(format("no 'format' field".into())),
    }
    let stored = value
        .as_object_mut()
        .and_then(|m| m.remove(CHECKSUM))
        .and_then(|c| c.as_str().map(str::to_string));
    if stored.as_deref() != Some(checksum(&value).as_str()) {
        return Err(CheckpointError::Checksum {
            path: path.to_path_buf(),
        });
    }
    let secant = secant_mismatch(&value["state"], identity.pairs);
    let cp: Checkpoint = serde_json::from_value(value).map_err(|e| format(e.to_string()))?;
    let differs = cp.identity.difference(identity);
    if let Some(what) = differs.or_else(|| length_mismatch(&cp.state, identity)) {
        return Err(CheckpointError::Differs {
            path: path.to_path_buf(),
            what,
        });
    }
    if let Some(reason) = inconsistency(&cp.state).or(secant) {
        return Err(format(reason));
    }
    if cp.state.iteration >= max_it {
        return Err(CheckpointError::Done {
            path: path.to_path_buf(),
            iteration: cp.state.iteration,
            max_it,
        });
    }
    Ok(cp)
}

/// How λ of a checkpoint of this problem does not fit this run's `m` Γc pairs (a file edited
/// and its checksum made again), if it does not.
fn length_mismatch(state: &LoopState, identity: &Identity) -> Option<String> {
    let m = identity.pairs;
    (state.lambda.len() != m).then(|| match identity.friction {
        None => format!(
            "its λ has {} values, this run's contact interface {m} pairs",
            state.lambda.len()
        ),
        Some(_) => format!(
            "its λ has {} values, this run's contact interface {m} (its {} pairs' normal and tangential components: friction)",
            state.lambda.len(),
            m / 2
        ),
    })
}

/// Why a state's sizes do not match each other (a damaged or hand-edited file), if they do not:
/// a contact flag per λ value (none before the first contact step), a history line per
/// iteration, numbered from 1, and the stagnation guard's best iteration among them.
fn inconsistency(state: &LoopState) -> Option<String> {
    let m = state.lambda.len();
    let flags = state.active.len();
    let numbered = (1..).zip(&state.history).all(|(k, r)| r.iteration == k);
    if (flags != m && flags != 0) || state.history.len() != state.iteration || !numbered {
        return Some(format!(
            "inconsistent state: {m} λ values, {flags} contact flags, {} history lines at iteration {}",
            state.history.len(),
            state.iteration
        ));
    }
    if state.best_at > state.iteration {
        return Some(format!(
            "inconsistent state: best iteration {} after iteration {}",
            state.best_at, state.iteration
        ));
    }
    None
}

/// How the secant update's vectors (in the JSON `state`: its previous iterate's, its columns')
/// do not have the length `m` of λ, if they do not.
fn secant_mismatch(state: &serde_json::Value, m: usize) -> Option<String> {
    let secant = state.get("secant")?;
    let columns = secant.get("columns").and_then(|c| c.as_array());
    let parts = secant
        .get("previous")
        .into_iter()
        .chain(columns.into_iter().flatten());
    let (name, len) = parts
        .filter_map(|p| p.as_object())
        .flatten()
        .filter_map(|(k, v)| Some((k, v.as_array()?.len())))
        .find(|&(_, len)| len != m)?;
    Some(format!(
        "inconsistent state: the secant update's '{name}' has {len} values, λ {m}"
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The checksum survives writing and reading the text back (the numbers keep their
    /// shortest exact form), and changes with any edited number.
    #[test]
    fn checksum_reads_back_and_sees_an_edit() {
        let value = serde_json::json!({
            "format": FORMAT,
            "lambda": [1.2345678901234567e-5, -3.0e-300, 0.1, 1e300],
            "iteration": 17,
        });
        let text = serde_json::to_string(&value).unwrap();
        let back: serde_json::Value = serde_json::from_str(&text).unwrap();
        assert_eq!(checksum(&value), checksum(&back));
        let edited: serde_json::Value = serde_json::from_str(&text.replace("0.1", "0.11")).unwrap();
        assert_ne!(checksum(&value), checksum(&edited));
    }
}
