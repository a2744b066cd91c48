//! A body's displacement field as a rank holds it: whole (every mesh dof), or at the mesh
//! nodes the rank reads alone (its own rows, Γc, the outline and its block of the output),
//! gathered from their owners, so that no rank holds a whole vector of a field it writes and
//! checks in parts (docs/scaling.md, "Memory per rank").

use std::ops::{Index, IndexMut};
use std::sync::Arc;

use crate::fem::Dofs;

/// u^α on a rank, indexed by mesh dof (2 n + c for node n, component c: global x, y).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Displacement {
    /// The mesh nodes held, ascending; `None`: every node.
    nodes: Option<Arc<[u32]>>,
    /// Two values per held node, in the order of `nodes` (every dof where whole).
    values: Vec<f64>,
}

/// No field (a body this rank does not work on), borrowable for any lifetime.
pub static NONE: Displacement = Displacement {
    nodes: None,
    values: Vec::new(),
};

impl Displacement {
    /// The whole field (mesh dofs).
    pub fn whole(values: Vec<f64>) -> Displacement {
        Displacement {
            nodes: None,
            values,
        }
    }

    /// The field at the ascending mesh `nodes` alone, `values` two per node in that order.
    pub fn at_nodes(nodes: Arc<[u32]>, values: Vec<f64>) -> Displacement {
        assert_eq!(values.len(), 2 * nodes.len(), "two values per node");
        debug_assert!(nodes.windows(2).all(|w| w[0] < w[1]), "ascending nodes");
        Displacement {
            nodes: Some(nodes),
            values,
        }
    }

    /// Nothing held (not formed, or not this rank's body).
    pub fn is_empty(&self) -> bool {
        self.values.is_empty()
    }

    /// The values held (every dof where whole; two per held node otherwise).
    pub fn len(&self) -> usize {
        self.values.len()
    }

    /// The whole field's values, `None` where only some nodes are held.
    pub fn as_whole(&self) -> Option<&[f64]> {
        self.nodes.is_none().then_some(self.values.as_slice())
    }

    /// The whole field's values. Panics where only some nodes are held: the callers are a
    /// recovery on the whole body and a mortar run's estimates carrying a body's field on its
    /// only rank, both of which read a field the rank holds whole
    /// ([`crate::dd::body::Body::keep_fields_at`]; gathered whole first where it is not).
    pub fn whole_values(&self) -> &[f64] {
        self.as_whole()
            .expect("a field held at some nodes read whole (a body's only rank holds it whole)")
    }

    /// The mesh nodes held, ascending; `None` where whole.
    pub fn nodes(&self) -> Option<&[u32]> {
        self.nodes.as_deref()
    }

    /// `whole` − this field, at the nodes this field holds (`whole` in mesh dofs: a whole
    /// vector, or a field held at those nodes at least).
    pub fn subtracted_from(&self, whole: &(impl Dofs + ?Sized)) -> Displacement {
        let values = match &self.nodes {
            None => (self.values.iter().enumerate())
                .map(|(d, b)| whole[d] - b)
                .collect(),
            Some(nodes) => (nodes.iter().zip(self.values.chunks_exact(2)))
                .flat_map(|(&n, v)| {
                    [
                        whole[2 * n as usize] - v[0],
                        whole[2 * n as usize + 1] - v[1],
                    ]
                })
                .collect(),
        };
        Displacement {
            nodes: self.nodes.clone(),
            values,
        }
    }

    /// Whether mesh node `n` is held.
    pub fn holds(&self, n: usize) -> bool {
        self.slot(n).is_some()
    }

    /// The value at mesh dof `dof` where held.
    pub fn get(&self, dof: usize) -> Option<f64> {
        self.slot(dof / 2).map(|i| self.values[2 * i + dof % 2])
    }

    /// The index of mesh node `n` among those held.
    fn slot(&self, n: usize) -> Option<usize> {
        match &self.nodes {
            None => (2 * n + 1 < self.values.len()).then_some(n),
            Some(nodes) => u32::try_from(n)
                .ok()
                .and_then(|n| nodes.binary_search(&n).ok()),
        }
    }

    /// This field at the ascending mesh `nodes` alone (those of them it holds).
    pub fn keep(&self, nodes: &[usize]) -> Displacement {
        if self.is_empty() {
            return Displacement::default();
        }
        let nodes: Vec<u32> = (nodes.iter())
            .filter(|&&n| self.holds(n))
            .map(|&n| n as u32)
            .collect();
        let values = nodes
            .iter()
            .flat_map(|&n| [self[2 * n as usize], self[2 * n as usize + 1]])
            .collect();
        Displacement::at_nodes(nodes.into(), values)
    }
}

impl Index<usize> for Displacement {
    type Output = f64;

    /// The value at mesh dof `dof`. Panics where the node is not held: the node sets are made
    /// from what each reader reads ([`crate::dd::body::Body::keep_fields_at`]).
    fn index(&self, dof: usize) -> &f64 {
        match self.slot(dof / 2) {
            Some(i) => &self.values[2 * i + dof % 2],
            None => panic!("displacement at dof {dof}: its node is not held on this rank"),
        }
    }
}

impl IndexMut<usize> for Displacement {
    fn index_mut(&mut self, dof: usize) -> &mut f64 {
        match self.slot(dof / 2) {
            Some(i) => &mut self.values[2 * i + dof % 2],
            None => panic!("displacement at dof {dof}: its node is not held on this rank"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_field_at_some_nodes_reads_as_the_whole_one_there() {
        let whole: Vec<f64> = (0..20).map(|d| d as f64 * 0.5 - 3.0).collect();
        let nodes: Arc<[u32]> = vec![1, 4, 7, 9].into();
        let values = nodes
            .iter()
            .flat_map(|&n| [whole[2 * n as usize], whole[2 * n as usize + 1]])
            .collect();
        let part = Displacement::at_nodes(nodes.clone(), values);
        let all = Displacement::whole(whole.clone());
        for &n in nodes.iter() {
            for c in 0..2 {
                let d = 2 * n as usize + c;
                assert_eq!(part[d], whole[d]);
                assert_eq!(all[d], whole[d]);
            }
        }
        assert!(part.holds(7) && !part.holds(8) && !part.holds(10));
        assert_eq!(part.get(16), None);
        assert_eq!(all.get(19), Some(whole[19]));
        assert_eq!(all.get(20), None);
        assert!(part.as_whole().is_none());
        assert_eq!(all.as_whole(), Some(whole.as_slice()));
        let kept = all.keep(&[3, 4, 5, 6, 7]);
        assert_eq!(kept.len(), 10);
        assert_eq!(kept[14], whole[14]);
        assert!(!kept.holds(2) && !kept.holds(8));
        let kept = part.keep(&[3, 4, 5, 6, 7]);
        assert_eq!(kept.len(), 4);
        assert_eq!(kept[9], whole[9]);
        assert!(!kept.holds(1) && kept.holds(4) && kept.holds(7));
    }

    #[test]
    fn a_difference_is_held_where_the_field_is() {
        let whole: Vec<f64> = (0..12).map(|d| (d * d) as f64).collect();
        let part = Displacement::at_nodes(vec![1, 4].into(), vec![1.0, 2.0, 3.0, 4.0]);
        let d = part.subtracted_from(&whole);
        assert_eq!(d.nodes(), Some(&[1, 4][..]));
        assert_eq!(
            [d[2], d[3], d[8], d[9]],
            [4.0 - 1.0, 9.0 - 2.0, 64.0 - 3.0, 81.0 - 4.0]
        );
        let all = Displacement::whole(vec![1.0; 12]);
        assert_eq!(all.subtracted_from(&whole)[11], 120.0);
        // From a field held at the same nodes.
        let other = Displacement::at_nodes(vec![1, 4].into(), vec![5.0, 6.0, 7.0, 8.0]);
        let d = part.subtracted_from(&other);
        assert_eq!([d[2], d[3], d[8], d[9]], [4.0, 4.0, 4.0, 4.0]);
        assert!(NONE.is_empty() && NONE.as_whole() == Some(&[][..]));
    }

    #[test]
    fn writing_through_an_index_changes_the_held_value() {
        let mut part = Displacement::at_nodes(vec![2, 5].into(), vec![1.0, 2.0, 3.0, 4.0]);
        part[11] += 1.5;
        assert_eq!(part.get(11), Some(5.5));
        assert_eq!(part.get(10), Some(3.0));
    }

    #[test]
    #[should_panic(expected = "not held")]
    fn reading_a_node_not_held_panics() {
        let part = Displacement::at_nodes(vec![2, 5].into(), vec![1.0, 2.0, 3.0, 4.0]);
        let _ = part[6];
    }
}
