//! A body's mesh over the ranks of its group.
//!
//! METIS (`METIS_PartMeshDual`) splits the elements into one part per rank of the group, and
//! gives every node an owner. PETSc distributes a matrix by contiguous row ranges, so the nodes
//! are renumbered: the nodes of rank 0 first, then those of rank 1, …, each rank's in mesh
//! order. The rest of the code keeps the mesh numbering; this type translates (a dof `2 i + k`
//! of mesh node i is PETSc row `2 petsc_node[i] + k`). The group's first rank runs METIS and
//! broadcasts its element and node parts ([`Partition::on_group`]): one METIS run per body
//! whatever the rank count. With `-nndd_partition blocks` a body is dealt in the output's index
//! blocks instead ([`Partitioner::IndexBlocks`]): one distribution of its elements for the
//! assembly and the output, so that a rank reads its block alone (compact parts where the
//! numbering is: a built-in grid's rows, a Gmsh body in `-nndd_mesh_order bands`).

use std::ops::Range;

use crate::fem::mesh::Mesh;
use crate::fem::order::ElementOrder;
use crate::fem::wire::{Reader, Writer};
use crate::parallel::layout::{block_of, Layout};
use crate::petsc::Int;

#[derive(Debug, thiserror::Error)]
pub enum PartitionError {
    #[error("METIS could not partition body {alpha} ({elements} elements) into {parts} parts: {message}")]
    Metis {
        alpha: usize,
        elements: usize,
        parts: usize,
        message: String,
    },
}

/// How a body's elements and nodes are dealt over its group.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Partitioner {
    /// METIS's parts of the mesh's dual graph: compact in any numbering.
    #[default]
    Metis,
    /// The index blocks of the elements and of the nodes that the output writes
    /// ([`Layout::block`]), the nodes already in rank order: compact parts where the body's
    /// numbering is (a built-in grid's rows, a Gmsh body in `-nndd_mesh_order bands`).
    IndexBlocks,
}

/// What the user asked for (`-nndd_partition`): a partitioner, or `auto`, the default: index
/// blocks where a body's numbering is compact (a built-in grid's rows, a Gmsh body in
/// `-nndd_mesh_order bands`), so that a rank holds one share of its body and the output's block
/// is its part; METIS's parts in a Gmsh file's own order, where a block of the file's triangles
/// lies all over the body.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PartitionChoice {
    Auto,
    Given(Partitioner),
}

impl PartitionChoice {
    /// The partitioner for bodies numbered in `order` (`None`: the built-in grids').
    pub fn resolve(self, order: Option<ElementOrder>) -> Partitioner {
        match (self, order) {
            (PartitionChoice::Given(how), _) => how,
            (PartitionChoice::Auto, Some(ElementOrder::File)) => Partitioner::Metis,
            (PartitionChoice::Auto, None | Some(ElementOrder::Bands)) => Partitioner::IndexBlocks,
        }
    }
}

/// The distribution of one body over its group of `size` ranks.
#[derive(Clone, Debug)]
pub struct Partition {
    /// This rank's position in the group.
    pub rank: usize,
    pub size: usize,
    /// The elements this rank owns (assembles), by increasing index: its part of METIS's
    /// element parts, not the owner of every element (4 bytes per element on every rank).
    pub elements: Vec<u32>,
    /// PETSc node index of each mesh node.
    pub petsc_node: Vec<u32>,
    /// First PETSc node of each rank, and the node count at the end (`size + 1` entries).
    pub node_start: Vec<usize>,
    /// The mesh node of each of this rank's PETSc nodes, in PETSc order.
    mesh_nodes: Vec<u32>,
}

impl Partition {
    /// The partition of body `alpha`'s `mesh` over this rank's body group by `how`. METIS's
    /// is collective over the group: its first rank partitions, the others receive the parts.
    pub fn on_group(
        mesh: &Mesh,
        alpha: usize,
        layout: &Layout,
        how: Partitioner,
    ) -> Result<Partition, PartitionError> {
        let (rank, size) = (layout.group_rank(), layout.group_size());
        let (ne, nn) = (mesh.triangles.len(), mesh.num_nodes());
        if size == 1 {
            return Partition::new(mesh, alpha, rank, size);
        }
        if how == Partitioner::IndexBlocks {
            return Ok(Partition::index_blocks(ne, nn, rank, size));
        }
        // [ok, element parts …, node parts …], so that a METIS failure ends every rank.
        let mut parts = vec![0u32; 1 + ne + nn];
        let mut failure = None;
        if rank == 0 {
            match metis_parts(mesh, alpha, size) {
                Ok((epart, npart)) => {
                    parts[0] = 1;
                    parts[1..=ne].copy_from_slice(&epart);
                    parts[1 + ne..].copy_from_slice(&npart);
                }
                Err(e) => failure = Some(e),
            }
        }
        layout.group_broadcast(&mut parts);
        if let Some(e) = failure {
            return Err(e);
        }
        if parts[0] == 0 {
            return Err(PartitionError::Metis {
                alpha,
                elements: ne,
                parts: size,
                message: "reported by the group's first rank".into(),
            });
        }
        Ok(Partition::from_parts(
            rank,
            size,
            &parts[1..=ne],
            &parts[1 + ne..],
        ))
    }

    /// METIS partition of `mesh` over `size` ranks, seen from group rank `rank` (every rank
    /// that calls it runs METIS; [`Partition::on_group`] runs it once per group).
    pub fn new(
        mesh: &Mesh,
        alpha: usize,
        rank: usize,
        size: usize,
    ) -> Result<Partition, PartitionError> {
        let (ne, nn) = (mesh.triangles.len(), mesh.num_nodes());
        if size == 1 {
            return Ok(Partition {
                rank,
                size,
                elements: (0..ne as u32).collect(),
                petsc_node: (0..nn as u32).collect(),
                node_start: vec![0, nn],
                mesh_nodes: (0..nn as u32).collect(),
            });
        }
        let (epart, npart) = metis_parts(mesh, alpha, size)?;
        Ok(Partition::from_parts(rank, size, &epart, &npart))
    }

    /// The partition of `ne` elements and `nn` nodes in index blocks over `size` ranks
    /// ([`block_of`], the output's), seen from rank `rank`.
    pub fn index_blocks(ne: usize, nn: usize, rank: usize, size: usize) -> Partition {
        Partition::from_parts(rank, size, &block_parts(ne, size), &block_parts(nn, size))
    }

    /// Every rank's partition of body `alpha`'s `mesh` over a group of `size` ranks by `how`,
    /// made on the one rank that holds the mesh (one METIS run; `app::input` sends each
    /// rank its own): the partitions [`Partition::on_group`] gives the group's ranks.
    pub fn dealt(
        mesh: &Mesh,
        alpha: usize,
        size: usize,
        how: Partitioner,
    ) -> Result<Vec<Partition>, PartitionError> {
        let (ne, nn) = (mesh.triangles.len(), mesh.num_nodes());
        if size == 1 {
            return Ok(vec![Partition::new(mesh, alpha, 0, 1)?]);
        }
        let (epart, npart) = match how {
            Partitioner::IndexBlocks => (block_parts(ne, size), block_parts(nn, size)),
            Partitioner::Metis => metis_parts(mesh, alpha, size)?,
        };
        let (node_start, petsc_node) = numbering(size, &npart);
        let mut elements = vec![Vec::new(); size];
        for (e, &p) in epart.iter().enumerate() {
            elements[p as usize].push(e as u32);
        }
        let mut mesh_nodes = vec![Vec::new(); size];
        for (i, &p) in npart.iter().enumerate() {
            mesh_nodes[p as usize].push(i as u32);
        }
        Ok((elements.into_iter().zip(mesh_nodes).enumerate())
            .map(|(rank, (elements, mesh_nodes))| Partition {
                rank,
                size,
                elements,
                petsc_node: petsc_node.clone(),
                node_start: node_start.clone(),
                mesh_nodes,
            })
            .collect())
    }

    /// The partition as bytes ([`Writer`]): what the rank that made it sends its rank.
    pub fn write(&self, w: &mut Writer) {
        w.int(self.rank);
        w.int(self.size);
        w.u32s(&self.elements);
        w.u32s(&self.petsc_node);
        w.ints(&self.node_start);
        w.u32s(&self.mesh_nodes);
    }

    /// What [`Partition::write`] wrote.
    pub fn read(r: &mut Reader) -> Option<Partition> {
        let p = Partition {
            rank: r.int()?,
            size: r.int()?,
            elements: r.u32s()?,
            petsc_node: r.u32s()?,
            node_start: r.ints()?,
            mesh_nodes: r.u32s()?,
        };
        let sound = p.rank < p.size
            && p.node_start.len() == p.size + 1
            && p.node_start.last() == Some(&p.petsc_node.len())
            && p.mesh_nodes.len() == p.owned_nodes().len();
        sound.then_some(p)
    }

    /// The partition with element parts `epart` and node parts `npart` (METIS's).
    fn from_parts(rank: usize, size: usize, epart: &[u32], npart: &[u32]) -> Partition {
        let (node_start, petsc_node) = numbering(size, npart);
        Partition {
            rank,
            size,
            elements: (epart.iter().enumerate())
                .filter(|(_, &p)| p as usize == rank)
                .map(|(e, _)| e as u32)
                .collect(),
            petsc_node,
            // (each rank's nodes are numbered in mesh order)
            mesh_nodes: (npart.iter().enumerate())
                .filter(|(_, &p)| p as usize == rank)
                .map(|(i, _)| i as u32)
                .collect(),
            node_start,
        }
    }

    /// This rank's PETSc nodes.
    pub fn owned_nodes(&self) -> Range<usize> {
        self.node_start[self.rank]..self.node_start[self.rank + 1]
    }

    /// The mesh node of each of this rank's PETSc nodes, in PETSc order.
    pub fn owned_mesh_nodes(&self) -> impl Iterator<Item = usize> + '_ {
        self.mesh_nodes.iter().map(|&n| n as usize)
    }

    /// Rows (dofs) of the matrix on this rank.
    pub fn local_rows(&self) -> usize {
        2 * self.owned_nodes().len()
    }

    /// The group rank owning PETSc node `p`.
    pub fn owner_of_petsc_node(&self, p: usize) -> usize {
        self.node_start.partition_point(|&s| s <= p) - 1
    }

    /// PETSc row of mesh dof `dof`.
    pub fn row(&self, dof: usize) -> Int {
        (2 * self.petsc_node[dof / 2] as usize + dof % 2) as Int
    }

    /// Does this rank own mesh dof `dof`?
    pub fn owns_dof(&self, dof: usize) -> bool {
        self.owned_nodes()
            .contains(&(self.petsc_node[dof / 2] as usize))
    }

    /// Every PETSc row in mesh dof order (row of dof 0, dof 1, …): gathering these rows gives
    /// a vector in mesh numbering.
    pub fn rows_in_mesh_order(&self) -> Vec<Int> {
        (0..2 * self.petsc_node.len())
            .map(|d| self.row(d))
            .collect()
    }

    /// This rank's entries (PETSc order) of a vector given in mesh numbering.
    pub fn local_part(&self, full: &[f64]) -> Vec<f64> {
        self.owned_mesh_nodes()
            .flat_map(|n| [full[2 * n], full[2 * n + 1]])
            .collect()
    }

    /// Number of elements owned by this rank.
    pub fn owned_elements(&self) -> usize {
        self.elements.len()
    }
}

/// The PETSc numbering of node parts `npart` over `size` ranks: the first PETSc node of each
/// rank (and the count at the end), and each mesh node's, each rank's nodes in mesh order.
fn numbering(size: usize, npart: &[u32]) -> (Vec<usize>, Vec<u32>) {
    let mut node_start = vec![0usize; size + 1];
    for &p in npart {
        node_start[p as usize + 1] += 1;
    }
    for r in 0..size {
        node_start[r + 1] += node_start[r];
    }
    let mut next = node_start.clone();
    let petsc_node = npart
        .iter()
        .map(|&p| {
            let i = next[p as usize];
            next[p as usize] += 1;
            i as u32
        })
        .collect();
    (node_start, petsc_node)
}

/// The part of each of `len` items in the index blocks over `size` ranks ([`block_of`]).
fn block_parts(len: usize, size: usize) -> Vec<u32> {
    (0..size)
        .flat_map(|r| block_of(len, r, size).map(move |_| r as u32))
        .collect()
}

/// METIS's element and node parts of `mesh` in `size` parts (`METIS_PartMeshDual`), every
/// part with at least one node.
fn metis_parts(
    mesh: &Mesh,
    alpha: usize,
    size: usize,
) -> Result<(Vec<u32>, Vec<u32>), PartitionError> {
    let (ne, nn) = (mesh.triangles.len(), mesh.num_nodes());
    let eptr: Vec<metis::Idx> = (0..=ne).map(|e| (3 * e) as metis::Idx).collect();
    let eind: Vec<metis::Idx> = mesh
        .triangles
        .iter()
        .flat_map(|t| t.map(|v| v as metis::Idx))
        .collect();
    let mut epart = vec![0 as metis::Idx; ne];
    let mut npart = vec![0 as metis::Idx; nn];
    let metis_err = |message: String| PartitionError::Metis {
        alpha,
        elements: ne,
        parts: size,
        message,
    };
    metis::Mesh::new(size as metis::Idx, &eptr, &eind)
        .map_err(|e| metis_err(e.to_string()))?
        .part_dual(&mut epart, &mut npart)
        .map_err(|e| metis_err(e.to_string()))?;
    let mut count = vec![0usize; size];
    for &p in &npart {
        count[p as usize] += 1;
    }
    if let Some(r) = count.iter().position(|&c| c == 0) {
        return Err(metis_err(format!("part {r} received no node")));
    }
    Ok((
        epart.iter().map(|&p| p as u32).collect(),
        npart.iter().map(|&p| p as u32).collect(),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn metis_parts_cover_the_mesh_and_rows_are_contiguous() {
        let mesh = Mesh::structured([0.0, 0.0], [1.0, 1.0], 12, 9);
        for size in [1, 2, 3, 5] {
            let parts: Vec<Partition> = (0..size)
                .map(|r| Partition::new(&mesh, 1, r, size).unwrap())
                .collect();
            // Every rank computed the same partition: the ranks' elements are disjoint.
            let mut owner = vec![usize::MAX; mesh.triangles.len()];
            for p in &parts {
                assert_eq!(p.petsc_node, parts[0].petsc_node);
                assert!(p.elements.windows(2).all(|w| w[0] < w[1]));
                for &e in &p.elements {
                    assert_eq!(owner[e as usize], usize::MAX, "element {e} owned twice");
                    owner[e as usize] = p.rank;
                }
            }
            // PETSc numbering is a permutation; each rank's nodes are its range.
            let mut seen = vec![false; mesh.num_nodes()];
            for &p in &parts[0].petsc_node {
                assert!(!seen[p as usize]);
                seen[p as usize] = true;
            }
            let owned: usize = parts.iter().map(|p| p.owned_elements()).sum();
            assert_eq!(owned, mesh.triangles.len());
            let rows: usize = parts.iter().map(|p| p.local_rows()).sum();
            assert_eq!(rows, mesh.num_dofs());
            // Balanced within METIS's default 3 % imbalance (+1 element of rounding).
            let ideal = mesh.triangles.len() as f64 / size as f64;
            for p in &parts {
                assert!(p.owned_elements() as f64 <= 1.03 * ideal + 1.0);
            }
            // Local parts of a vector, concatenated by rank, are the vector in PETSc order.
            let full: Vec<f64> = (0..mesh.num_dofs()).map(|d| d as f64).collect();
            let concat: Vec<f64> = parts.iter().flat_map(|p| p.local_part(&full)).collect();
            let rows = parts[0].rows_in_mesh_order();
            for d in 0..mesh.num_dofs() {
                assert_eq!(concat[rows[d] as usize], full[d]);
                let owner = parts[0].owner_of_petsc_node(rows[d] as usize / 2);
                assert!(parts[owner].owns_dof(d));
            }
        }
    }

    /// `auto` deals a body in index blocks where its numbering is compact (a built-in grid,
    /// a Gmsh body in bands) and by METIS in a Gmsh file's order; a given one is kept.
    #[test]
    fn auto_partitions_in_blocks_where_the_numbering_is_compact() {
        use ElementOrder::{Bands, File};
        let (auto, blocks, metis) = (
            PartitionChoice::Auto,
            PartitionChoice::Given(Partitioner::IndexBlocks),
            PartitionChoice::Given(Partitioner::Metis),
        );
        assert_eq!(auto.resolve(None), Partitioner::IndexBlocks);
        assert_eq!(auto.resolve(Some(Bands)), Partitioner::IndexBlocks);
        assert_eq!(auto.resolve(Some(File)), Partitioner::Metis);
        for order in [None, Some(Bands), Some(File)] {
            assert_eq!(blocks.resolve(order), Partitioner::IndexBlocks);
            assert_eq!(metis.resolve(order), Partitioner::Metis);
        }
    }

    /// The partitions made on one rank are those each rank of the group makes, METIS's and
    /// the blocks', and read back as written.
    #[test]
    fn partitions_dealt_from_one_rank_are_the_groups_own() {
        let mesh = Mesh::structured([0.0, 0.0], [1.0, 1.0], 9, 7);
        for (how, size) in [
            (Partitioner::Metis, 3),
            (Partitioner::IndexBlocks, 4),
            (Partitioner::Metis, 1),
        ] {
            let dealt = Partition::dealt(&mesh, 2, size, how).unwrap();
            assert_eq!(dealt.len(), size);
            for (rank, d) in dealt.iter().enumerate() {
                let own = match how {
                    Partitioner::Metis => Partition::new(&mesh, 2, rank, size).unwrap(),
                    Partitioner::IndexBlocks => Partition::index_blocks(126, 80, rank, size),
                };
                let mut w = Writer::default();
                d.write(&mut w);
                let back = Partition::read(&mut Reader::new(&w.0)).unwrap();
                for p in [d, &back] {
                    assert_eq!((p.rank, p.size), (rank, size));
                    assert_eq!(p.elements, own.elements);
                    assert_eq!(p.petsc_node, own.petsc_node);
                    assert_eq!(p.node_start, own.node_start);
                    assert_eq!(p.mesh_nodes, own.mesh_nodes);
                }
                assert!(Partition::read(&mut Reader::new(&w.0[..w.0.len() - 4])).is_none());
            }
        }
    }

    /// Index blocks: each rank's elements and nodes are its blocks of the output's, and the
    /// PETSc numbering is the mesh's (the nodes already in rank order).
    #[test]
    fn index_blocks_are_the_output_blocks_in_mesh_order() {
        let (ne, nn) = (17, 11);
        for size in [2, 3, 5] {
            for rank in 0..size {
                let p = Partition::index_blocks(ne, nn, rank, size);
                let elements: Vec<u32> = block_of(ne, rank, size).map(|e| e as u32).collect();
                assert_eq!(p.elements, elements);
                assert_eq!(p.owned_nodes(), block_of(nn, rank, size));
                assert_eq!(p.petsc_node, (0..nn as u32).collect::<Vec<_>>());
                let nodes: Vec<usize> = p.owned_mesh_nodes().collect();
                assert_eq!(nodes, block_of(nn, rank, size).collect::<Vec<_>>());
            }
        }
    }
}
