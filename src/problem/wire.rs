//! A body's problem as bytes: what the rank that built both bodies sends each other rank
//! (`app::input`), with the mesh as that rank holds it (whole, its part, or released to the
//! outline), and its trace on Γc (a mortar body's coupling with it).

use std::cell::OnceCell;

use super::mortar::Coupling;
use super::{BodyMesh, BodyProblem, GcTrace, NeumannEdge, Outline, Support};
use crate::fem::mesh::Mesh;
use crate::fem::wire::{Reader, Writer};
use crate::fem::Material;

const WHOLE: u8 = 0;
const PART: u8 = 1;
const RELEASED: u8 = 2;

impl BodyProblem {
    /// The problem as bytes, its mesh as held here and its whole mesh's fingerprint (made
    /// here from the whole mesh where not yet).
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut w = Writer::default();
        w.int(self.alpha);
        match &self.mesh {
            BodyMesh::Whole(m) | BodyMesh::Part(m) => {
                w.u8(if matches!(self.mesh, BodyMesh::Whole(_)) {
                    WHOLE
                } else {
                    PART
                });
                m.write(&mut w);
            }
            &BodyMesh::Released { nodes, elements } => {
                w.u8(RELEASED);
                w.int(nodes);
                w.int(elements);
            }
        }
        self.outline().write(&mut w);
        w.u64(self.mesh_fingerprint());
        w.f64(self.material.young);
        w.f64(self.material.poisson);
        w.list(&self.dirichlet, |w, &(dof, v)| {
            w.int(dof);
            w.f64(v);
        });
        w.list(&self.neumann, |w, e| {
            e.nodes.iter().for_each(|&n| w.int(n));
            e.traction.iter().flatten().for_each(|&t| w.f64(t));
        });
        w.ints(&self.contact_nodes);
        w.f64s(&self.gap);
        w.points(&self.contact_normals);
        w.f64s(&self.contact_lengths);
        w.ints(&self.contact_candidates);
        w.points(&self.candidate_normals);
        w.u8(match self.support {
            Support::Conditions => 0,
            Support::Contact => 1,
        });
        write_trace(&mut w, &self.trace);
        w.0
    }

    /// What [`BodyProblem::to_bytes`] wrote (`None` for bytes it did not write).
    pub fn from_bytes(bytes: &[u8]) -> Option<BodyProblem> {
        let mut r = Reader::new(bytes);
        let alpha = r.int()?;
        let mesh = match r.u8()? {
            WHOLE => BodyMesh::Whole(Mesh::read(&mut r)?),
            PART => BodyMesh::Part(Mesh::read(&mut r)?),
            RELEASED => BodyMesh::Released {
                nodes: r.int()?,
                elements: r.int()?,
            },
            _ => return None,
        };
        let outline = OnceCell::from(Outline::read(&mut r)?);
        let fingerprint = OnceCell::from(r.u64()?);
        let material = Material {
            young: r.f64()?,
            poisson: r.f64()?,
        };
        let dirichlet = r.list(16, |r| Some((r.int()?, r.f64()?)))?;
        let neumann = r.list(48, |r| {
            Some(NeumannEdge {
                nodes: [r.int()?, r.int()?],
                traction: [[r.f64()?, r.f64()?], [r.f64()?, r.f64()?]],
            })
        })?;
        let problem = BodyProblem {
            alpha,
            mesh,
            outline,
            fingerprint,
            material,
            dirichlet,
            neumann,
            contact_nodes: r.ints()?,
            gap: r.f64s()?,
            contact_normals: r.points()?,
            contact_lengths: r.f64s()?,
            contact_candidates: r.ints()?,
            candidate_normals: r.points()?,
            support: match r.u8()? {
                0 => Support::Conditions,
                1 => Support::Contact,
                _ => return None,
            },
            // (the fields are read in the order written)
            trace: read_trace(&mut r)?,
        };
        r.is_done().then_some(problem)
    }
}

const NODES: u8 = 0;
const MORTAR: u8 = 1;

/// A body's trace on Γc: node to node, or a mortar body's coupling ([`Coupling`]: its rows of
/// P by the other body's node, the weighted gaps and normals, and where Γc closes).
fn write_trace(w: &mut Writer, trace: &GcTrace) {
    let GcTrace::Mortar(c) = trace else {
        w.u8(NODES);
        return;
    };
    w.u8(MORTAR);
    w.ints(&c.nodes);
    w.points(&c.normals);
    w.f64s(&c.gap);
    w.list(&c.rows, |w, row| {
        w.list(row, |w, &(node, p)| {
            w.int(node);
            w.f64(p);
        })
    });
    w.f64(c.seconds);
    match c.closing {
        None => w.u8(0),
        Some(length) => {
            w.u8(1);
            w.f64(length);
        }
    }
}

/// What [`write_trace`] wrote.
fn read_trace(r: &mut Reader) -> Option<GcTrace> {
    match r.u8()? {
        NODES => return Some(GcTrace::Nodes),
        MORTAR => {}
        _ => return None,
    }
    let nodes = r.ints()?;
    let normals = r.points()?;
    let gap = r.f64s()?;
    let rows = r.list(8, |r| r.list(16, |r| Some((r.int()?, r.f64()?))))?;
    let seconds = r.f64()?;
    let closing = match r.u8()? {
        0 => None,
        1 => Some(r.f64()?),
        _ => return None,
    };
    let coupling = Coupling {
        nodes,
        normals,
        gap,
        rows,
        seconds,
        closing,
    };
    Some(GcTrace::Mortar(std::rc::Rc::new(coupling)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::problem::{benchmarks, ProblemKind, ProblemSettings};

    /// `paper` n's settings, both bodies steel.
    fn paper(n: usize) -> ProblemSettings {
        let steel = Material {
            young: 210e9,
            poisson: 0.27,
        };
        ProblemSettings {
            kind: ProblemKind::Paper,
            n,
            grids: [(n, n), (n, n)],
            materials: [steel, steel],
            u_d: -1e-4,
            f_max: 1e7,
            mesh: None,
            partitioner: Default::default(),
            input: Default::default(),
        }
    }

    /// A built-in body, whole, as a part and released, read back with the same data: its
    /// counts, conditions, Γc, outline and fingerprint.
    #[test]
    fn a_body_problem_written_as_bytes_reads_back_the_same() {
        let settings = paper(4);
        let body = benchmarks::body(&settings, 2);
        // (made from the whole mesh, and kept by the part and the outline made from it)
        let fingerprint = body.mesh_fingerprint();
        let part = body.part(&[0, 5, 9], &[1]);
        let released = body.released();
        for p in [&body, &part, &released] {
            let back = BodyProblem::from_bytes(&p.to_bytes()).expect("read back");
            assert_eq!(
                (back.alpha, back.num_nodes(), back.num_elements()),
                (2, body.num_nodes(), body.num_elements())
            );
            assert_eq!(back.holds_mesh(), p.holds_mesh());
            assert_eq!(back.mesh_fingerprint(), fingerprint);
            assert_eq!(back.outline(), body.outline());
            assert_eq!(back.dirichlet, body.dirichlet);
            assert_eq!(back.neumann.len(), body.neumann.len());
            for (a, b) in back.neumann.iter().zip(&body.neumann) {
                assert_eq!((a.nodes, a.traction), (b.nodes, b.traction));
            }
            assert_eq!(
                (&back.contact_nodes, &back.gap),
                (&body.contact_nodes, &body.gap)
            );
            assert_eq!(back.contact_normals, body.contact_normals);
            assert_eq!(back.contact_lengths, body.contact_lengths);
            assert_eq!(back.contact_candidates, body.contact_candidates);
            assert_eq!(back.candidate_normals, body.candidate_normals);
            assert_eq!(
                (back.support, back.material.young),
                (body.support, body.material.young)
            );
            assert_eq!(back.trace, GcTrace::Nodes);
        }
        let back = BodyProblem::from_bytes(&part.to_bytes()).unwrap();
        assert_eq!(back.mesh().triangles.get(9), body.mesh().triangles.get(9));
        let bytes = body.to_bytes();
        assert!(BodyProblem::from_bytes(&bytes[..bytes.len() - 1]).is_none());
        // A part whose whole mesh's fingerprint was never made cannot make it.
        let fresh = benchmarks::body(&settings, 2).part(&[0], &[]);
        let made =
            std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| fresh.mesh_fingerprint()));
        assert!(made.is_err());
    }

    /// A mortar body's coupling read back entry for entry (its rows of P, gaps, normals and
    /// the closing segment), and a damaged trace refused.
    #[test]
    fn a_mortar_trace_reads_back_the_same() {
        let mut body = benchmarks::body(&paper(4), 1);
        let coupling = Coupling {
            nodes: vec![3, 7],
            normals: vec![[0.0, 1.0], [0.6, 0.8]],
            gap: vec![1e-3, -2e-4],
            rows: vec![vec![(10, 0.25), (11, 0.75)], vec![(11, 1.0)]],
            seconds: 0.5,
            closing: Some(0.125),
        };
        for closing in [Some(0.125), None] {
            body.trace = GcTrace::Mortar(std::rc::Rc::new(Coupling {
                closing,
                ..coupling.clone()
            }));
            let bytes = body.to_bytes();
            let back = BodyProblem::from_bytes(&bytes).expect("read back");
            assert_eq!(back.trace, body.trace);
            assert!(BodyProblem::from_bytes(&bytes[..bytes.len() - 1]).is_none());
        }
    }
}
