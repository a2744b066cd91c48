//! Helpers of the tests of `output`: a scratch directory and sample results.

use std::fs;
use std::path::PathBuf;

use super::{Center, Field, Grid, GridFields, Kind, Results, Step, Topology};

/// A fresh, empty directory unique to this process and test.
pub(super) struct TestDir(pub(super) PathBuf);

impl TestDir {
    pub(super) fn new(test: &str) -> TestDir {
        let dir = std::env::temp_dir().join(format!("nndd-output-{}-{test}", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        fs::create_dir_all(&dir).expect("create test dir");
        TestDir(dir)
    }

    pub(super) fn entries(&self) -> Vec<String> {
        let mut v: Vec<String> = fs::read_dir(&self.0)
            .expect("read test dir")
            .map(|e| {
                e.expect("dir entry")
                    .file_name()
                    .to_string_lossy()
                    .into_owned()
            })
            .collect();
        v.sort();
        v
    }
}

impl Drop for TestDir {
    fn drop(&mut self) {
        let _ = fs::remove_dir_all(&self.0);
    }
}

/// Distinct, non-round values: value `i` of a field tagged `tag`.
fn vals(tag: f64, n: usize) -> Vec<f64> {
    (0..n).map(|i| tag + 0.1 * i as f64 + 1.0 / 3.0).collect()
}

fn field(name: &str, center: Center, kind: Kind, tag: f64, entries: usize) -> Field {
    Field {
        name: name.into(),
        center,
        kind,
        values: vals(tag, entries * kind.given()),
    }
}

/// Two bodies in one grid (a square and a trapezoid above it, with a constant cell field)
/// and their contact line, at two steps.
pub(super) fn sample() -> Results {
    let bodies = Grid::whole(
        "bodies",
        vec![
            [0.0, 0.0],
            [1.0, 0.0],
            [1.0, 1.0],
            [0.0, 1.0],
            [0.0, 1.0],
            [1.0, 1.0],
            [2.0, 1.0],
            [0.5, 2.0],
            [1.5, 2.0],
        ],
        Topology::Triangle(vec![[0, 1, 2], [0, 2, 3], [4, 5, 7], [5, 8, 7], [5, 6, 8]]),
        vec![Field {
            name: "body".into(),
            center: Center::Cell,
            kind: Kind::Scalar,
            values: vec![1.0, 1.0, 2.0, 2.0, 2.0],
        }],
    );
    let contact = Grid::whole(
        "contact",
        vec![[0.0, 1.0], [0.5, 1.0], [1.0, 1.0]],
        Topology::Segment(vec![[0, 1], [1, 2]]),
        Vec::new(),
    );
    let steps = (0..2)
        .map(|k| {
            let t = 10.0 * (k as f64 + 1.0);
            Step {
                time: k as f64 + 1.0,
                grids: vec![
                    GridFields {
                        grid: "bodies".into(),
                        fields: vec![
                            field("u", Center::Node, Kind::Vector, t + 1.0, 9),
                            field("sigma", Center::Cell, Kind::Tensor, t + 2.0, 5),
                            field("eta", Center::Cell, Kind::Scalar, t + 3.0, 5),
                        ],
                    },
                    GridFields {
                        grid: "contact".into(),
                        fields: vec![
                            field("lambda", Center::Node, Kind::Scalar, t + 7.0, 3),
                            field("gap", Center::Cell, Kind::Scalar, t + 8.0, 2),
                        ],
                    },
                ],
            }
        })
        .collect();
    Results {
        grids: vec![bodies, contact],
        steps,
        attributes: vec![("nranks".into(), 2.0), ("error_bound".into(), 0.125)],
        text: vec![("program".into(), "nndd test".into())],
    }
}

pub(super) fn read(file: &hdf5::File, path: &str) -> (Vec<usize>, Vec<f64>) {
    let ds = file.dataset(path).unwrap_or_else(|e| panic!("{path}: {e}"));
    (ds.shape(), ds.read_raw::<f64>().expect("read f64"))
}

/// (file part, dataset path, dims) of every DataItem in the XDMF text.
pub(super) fn data_items(xdmf: &str) -> Vec<(String, String, Vec<usize>)> {
    let mut items = Vec::new();
    let mut rest = xdmf;
    while let Some(start) = rest.find("<DataItem ") {
        let after = &rest[start..];
        let tag_end = after.find('>').expect("DataItem tag end");
        let tag = &after[..tag_end];
        let dims_at = tag.find("Dimensions=\"").expect("Dimensions") + 12;
        let dims_len = tag[dims_at..].find('"').expect("Dimensions end");
        let dims = tag[dims_at..dims_at + dims_len]
            .split_whitespace()
            .map(|d| d.parse().expect("dimension"))
            .collect();
        let body_end = after.find("</DataItem>").expect("DataItem end");
        let body = after[tag_end + 1..body_end].trim();
        let (file, path) = body.split_once(':').expect("file:path");
        items.push((file.to_string(), path.to_string(), dims));
        rest = &after[body_end..];
    }
    items
}
