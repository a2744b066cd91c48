//! A Gmsh problem's parsed file, and when it is let go.
//!
//! Every rank holds the parsed file whole (world rank 0 reads it and sends it,
//! [`super::settings::shared_mesh`]) until both bodies' problems are built from it. Only a
//! reference solution's refinement, a mortar run's matched meshes and an adaptive run's
//! remeshing read it again; a run that does none of these releases it before its bodies are
//! set up ([`ParsedFile::release`]), keeping what it reports of the file to its end: the path,
//! the physical names and each body's dofs.

use std::collections::BTreeMap;
use std::rc::Rc;

use super::curves::MeshedError;
use crate::fem::gmsh::GmshMesh;

/// Where a Gmsh problem's bodies are built on several ranks (`-nndd_mesh_input`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum MeshInput {
    /// World rank 0 builds both bodies, partitions them and sends every other rank its part
    /// (`app::input`), where no later phase reads the whole meshes; else as [`EveryRank`].
    ///
    /// [`EveryRank`]: MeshInput::EveryRank
    #[default]
    Root,
    /// Every rank builds both bodies, then keeps its part (`app::keep_read_parts`).
    EveryRank,
}

/// The physical surface names of the two bodies.
pub const BODY_NAMES: [&str; 2] = ["body1", "body2"];

/// A parsed Gmsh file: the mesh while something reads it, and what the run reports of it.
#[derive(Clone, Debug)]
pub struct ParsedFile {
    /// The file, as given (for messages and the results' attributes).
    pub path: String,
    /// The file's physical names by (dimension, tag).
    pub names: BTreeMap<(i32, i32), String>,
    /// The dofs of each body (2 per node of its physical surface; they size the rank groups).
    pub body_dofs: [usize; 2],
    mesh: Held,
}

/// Whether the mesh itself is still held.
#[derive(Clone, Debug)]
enum Held {
    Whole(Rc<GmshMesh>),
    /// Let go once the bodies were built (no later phase of the run reads it).
    Released,
}

impl ParsedFile {
    pub fn new(mesh: GmshMesh) -> ParsedFile {
        ParsedFile {
            path: mesh.path.clone(),
            names: mesh.names.clone(),
            body_dofs: BODY_NAMES.map(|name| 2 * mesh.surface_node_count(name)),
            mesh: Held::Whole(Rc::new(mesh)),
        }
    }

    /// The mesh; an error where it was released (a phase that reads it after the bodies were
    /// built must keep it: [`crate::app::options::Settings::reads_mesh_after_build`]).
    pub fn mesh(&self) -> Result<&GmshMesh, MeshedError> {
        match &self.mesh {
            Held::Whole(mesh) => Ok(mesh),
            Held::Released => Err(MeshedError::Released {
                path: self.path.clone(),
            }),
        }
    }

    /// Let the mesh go (this copy's share of it: the others held by clones of these settings
    /// keep it until they are dropped).
    pub fn release(&mut self) {
        self.mesh = Held::Released;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fem::gmsh;

    const TWO_BODIES: &str = "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$PhysicalNames\n2\n2 1 \"body1\"\n2 2 \"body2\"\n$EndPhysicalNames\n$Entities\n0 0 2 0\n1 0 0 0 1 1 0 1 1 0\n2 0 1 0 1 2 0 1 2 0\n$EndEntities\n$Nodes\n2 6 1 6\n2 1 0 4\n1\n2\n3\n4\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n2 2 0 2\n5\n6\n1 2 0\n0 2 0\n$EndNodes\n$Elements\n2 4 1 4\n2 1 2 2\n1 1 2 3\n2 1 3 4\n2 2 2 2\n3 4 3 5\n4 4 5 6\n$EndElements\n";

    #[test]
    fn a_released_file_keeps_its_facts_and_refuses_its_mesh() {
        let mesh = gmsh::parse(TWO_BODIES.as_bytes(), "two.msh").unwrap();
        let mut file = ParsedFile::new(mesh);
        // body 1: the square's 4 nodes; body 2: the strip above it, nodes 3..6.
        assert_eq!(file.body_dofs, [8, 8]);
        assert_eq!(file.mesh().unwrap().points.len(), 6);
        let copy = file.clone();
        file.release();
        assert_eq!(copy.mesh().unwrap().points.len(), 6);
        assert_eq!((file.path.as_str(), file.body_dofs), ("two.msh", [8, 8]));
        assert_eq!(file.names.get(&(2, 2)).map(String::as_str), Some("body2"));
        let err = file.mesh().unwrap_err().to_string();
        assert!(err.contains("two.msh") && err.contains("released"), "{err}");
    }
}
