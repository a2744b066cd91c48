//! A Gmsh problem's parsed file, and when it is let go.
//!
//! World rank 0 reads the file and checks the options against it; the other ranks learn its
//! facts (its physical names, each body's dofs, its extent, how its contact curves were made
//! to match) and hold no mesh ([`ParsedFile::on_root`]). A run that builds its bodies on every
//! rank has rank 0 send them the parsed file first ([`ParsedFile::share`]); one that builds
//! them on world rank 0 alone (`-nndd_mesh_input root`, `app::input`) never sends it. Only a
//! reference solution's refinement (there on world rank 0 alone, which tells the other ranks
//! the refined file's facts, [`ParsedFile::share_facts`]), a mortar run's matched meshes and
//! an adaptive run's size view and remeshing (under `root` on world rank 0 alone, which keeps
//! each cycle's new file, [`crate::problem::meshed::MeshSpec::remeshed`]) read it again; a run that does none of these releases it before its bodies are
//! set up ([`ParsedFile::release`]), keeping what it reports of the file to its end: the path,
//! the physical names and each body's dofs.

use std::collections::BTreeMap;
use std::rc::Rc;

use super::curves::MeshedError;
use crate::fem::gmsh::{self, GmshMesh};
use crate::fem::wire::{Reader, Writer};

/// Where a Gmsh problem's bodies are built on several ranks (`-nndd_mesh_input`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum MeshInput {
    /// World rank 0 builds both bodies, partitions them and sends every other rank its part
    /// (`app::input`), where no later phase reads the whole meshes; else as [`EveryRank`].
    ///
    /// [`EveryRank`]: MeshInput::EveryRank
    #[default]
    Root,
    /// Every rank builds both bodies, then keeps its part (`app::parts::keep_read_parts`).
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
    /// The mesh's bounding box, lower left and upper right corners.
    pub bbox: [[f64; 2]; 2],
    /// The points of the mesh this rank held: all of them on the rank that read it or was
    /// sent it, none on a rank that held its facts alone.
    pub held_points: usize,
    mesh: Held,
}

/// Whether the mesh itself is held.
#[derive(Clone, Debug)]
enum Held {
    Whole(Rc<GmshMesh>),
    /// Held on world rank 0 alone, which read it (on the others; [`ParsedFile::share`] sends it).
    OnRoot,
    /// Let go once the bodies were built (no later phase of the run reads it).
    Released,
}

impl ParsedFile {
    /// The file of `mesh`, held here (and on every rank that made it alike).
    pub fn new(mesh: GmshMesh) -> ParsedFile {
        ParsedFile {
            path: mesh.path.clone(),
            names: mesh.names.clone(),
            body_dofs: BODY_NAMES.map(|name| 2 * mesh.surface_node_count(name)),
            bbox: crate::fem::checks::bbox(&mesh.points),
            held_points: mesh.points.len(),
            mesh: Held::Whole(Rc::new(mesh)),
        }
    }

    /// The file world rank 0 holds, on another rank: its facts alone.
    pub fn on_root(
        path: String,
        names: BTreeMap<(i32, i32), String>,
        body_dofs: [usize; 2],
        bbox: [[f64; 2]; 2],
    ) -> ParsedFile {
        ParsedFile {
            path,
            names,
            body_dofs,
            bbox,
            held_points: 0,
            mesh: Held::OnRoot,
        }
    }

    /// Whether world rank 0 alone holds the mesh (this rank its facts).
    pub fn is_on_root(&self) -> bool {
        matches!(self.mesh, Held::OnRoot)
    }

    /// The file's facts as bytes ([`Writer`]): what world rank 0, which holds the mesh, tells
    /// the ranks that do not ([`ParsedFile::read_facts`]).
    pub fn write_facts(&self, w: &mut Writer) {
        w.text(&self.path);
        gmsh::write_names(w, &self.names);
        w.ints(&self.body_dofs);
        w.points(&self.bbox);
    }

    /// The file of the facts [`ParsedFile::write_facts`] wrote, its mesh on world rank 0.
    pub fn read_facts(r: &mut Reader) -> Option<ParsedFile> {
        let path = r.text()?;
        let names = gmsh::read_names(r)?;
        let body_dofs = <[usize; 2]>::try_from(r.ints()?).ok()?;
        let bbox = <[[f64; 2]; 2]>::try_from(r.points()?).ok()?;
        Some(ParsedFile::on_root(path, names, body_dofs, bbox))
    }

    /// The file of this one's mesh refined `r` times ([`GmshMesh::refined`]): held where this
    /// one is; on a rank where world rank 0 alone holds the mesh, its facts are the coarse
    /// file's until [`ParsedFile::share_facts`] gives it the refined one's.
    pub fn refined(&self, r: usize) -> Result<ParsedFile, MeshedError> {
        match &self.mesh {
            Held::OnRoot => Ok(self.clone()),
            _ => Ok(ParsedFile::new(self.mesh()?.refined(r))),
        }
    }

    /// World rank 0's facts on every rank where it alone holds the mesh (collective over
    /// `world`; nothing where no rank holds the file's facts alone): after rank 0 made the
    /// file ([`ParsedFile::refined`]). An error where the bytes do not read back.
    pub fn share_facts(&mut self, world: &mpi::topology::SimpleCommunicator) -> Result<(), String> {
        if !needed_anywhere(matches!(self.mesh, Held::OnRoot), world) {
            return Ok(());
        }
        let facts = matches!(self.mesh, Held::Whole(_)).then(|| {
            let mut w = Writer::default();
            self.write_facts(&mut w);
            w.0
        });
        let path = self.path.clone();
        let bytes = crate::parallel::root::bytes_from_root(&path, || {
            facts.ok_or_else(|| format!("{path}: world rank 0 holds no mesh"))
        })?;
        if matches!(self.mesh, Held::OnRoot) {
            let mut r = Reader::new(&bytes);
            *self = ParsedFile::read_facts(&mut r)
                .filter(|_| r.is_done())
                .ok_or_else(|| format!("{path}: the facts sent by world rank 0 are damaged"))?;
        }
        Ok(())
    }

    /// The mesh; an error where it was released (a phase that reads it after the bodies were
    /// built must keep it: [`crate::app::options::Settings::reads_mesh_after_build`]) or is
    /// held on world rank 0 alone (a phase that reads it on every rank shares it first).
    pub fn mesh(&self) -> Result<&GmshMesh, MeshedError> {
        match &self.mesh {
            Held::Whole(mesh) => Ok(mesh),
            Held::Released | Held::OnRoot => Err(MeshedError::Released {
                path: self.path.clone(),
            }),
        }
    }

    /// Let the mesh go (this copy's share of it: the others held by clones of these settings
    /// keep it until they are dropped).
    pub fn release(&mut self) {
        self.mesh = Held::Released;
    }

    /// The mesh on every rank where world rank 0 alone holds it (collective over `world`;
    /// nothing where every rank holds it, or none): rank 0 sends it as bytes
    /// ([`GmshMesh::to_bytes`]). An error where the bytes do not read back.
    pub fn share(&mut self, world: &mpi::topology::SimpleCommunicator) -> Result<(), String> {
        use mpi::traits::Communicator;
        if !needed_anywhere(matches!(self.mesh, Held::OnRoot), world) {
            return Ok(());
        }
        let root = world.rank() == 0;
        let path = self.path.clone();
        let mesh = match &self.mesh {
            Held::Whole(m) if root => Some(m.clone()),
            _ => None,
        };
        let bytes = crate::parallel::root::bytes_from_root(&path, || {
            mesh.map(|m| m.to_bytes())
                .ok_or_else(|| format!("{path}: world rank 0 no longer holds the parsed mesh"))
        })?;
        if !root {
            let mesh = GmshMesh::from_bytes(&bytes)
                .ok_or_else(|| format!("{path}: the mesh sent by world rank 0 is damaged"))?;
            self.held_points = mesh.points.len();
            self.mesh = Held::Whole(Rc::new(mesh));
        }
        Ok(())
    }
}

/// Whether `here` holds on some rank of `world` (collective).
fn needed_anywhere(here: bool, world: &mpi::topology::SimpleCommunicator) -> bool {
    use mpi::collective::SystemOperation;
    use mpi::traits::CommunicatorCollectives;
    let mut needed = 0u8;
    world.all_reduce_into(&(here as u8), &mut needed, SystemOperation::max());
    needed > 0
}

impl super::ProblemSettings {
    /// A Gmsh problem's parsed file (`None` for a built-in problem): what
    /// [`ParsedFile::share`] and [`ParsedFile::share_facts`] complete on every rank.
    pub fn parsed_file_mut(&mut self) -> Option<&mut ParsedFile> {
        self.mesh.as_mut().map(|spec| &mut spec.gmsh)
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
