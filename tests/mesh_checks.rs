//! Capability: the mesh checks refuse what Gmsh users produce by mistake, with one line that
//! names the cause: inverted, folded or flat triangles, NaN/inf coordinates, a node tag used
//! twice, a triangle or a surface in both bodies, bodies that overlap away from the contact
//! curves, a piece of a body with no Dirichlet condition, contact curves that do not face each
//! other. Each bad mesh is made here from examples/paper/paper.geo (the `paper` benchmark in
//! Gmsh), from an edited copy of it, or by editing the .msh Gmsh wrote. A thin triangle the
//! checks accept is estimated with a warning where its recovered stresses are not admissible
//! to round-off.

mod common;
use common::*;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

const GEO: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/paper/paper.geo");

/// The options of examples/paper/paper.opts for a mesh file (and the contact curves).
fn paper_args(msh: &Path, contact: &str, extra: &[&str]) -> Vec<String> {
    let mut a = paper_mesh_args(msh, contact, "-1e-4");
    a.extend(extra.iter().map(|s| s.to_string()));
    a
}

/// Run with bad input on `np` ranks and require exit code 1, exactly one line
/// `nndd: error: …` naming `option` and every word of `cause`, no panic or PETSc traceback,
/// and no file written under the output directory. The error line.
fn refused_with(np: usize, args: &[String], option: &str, cause: &[&str]) -> String {
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let needles: Vec<&str> = std::iter::once(option)
        .chain(cause.iter().copied())
        .collect();
    let line = fails_with(np, &args, Some(1), &needles);
    assert!(line.starts_with("nndd: error: "), "{line}");
    println!("{np} ranks: {line}");
    line
}

/// The paper mesh at level n, written by Gmsh from `geo` (paper.geo or an edited copy).
fn paper_mesh(dir: &Path, name: &str, geo_text: Option<&str>, n: usize) -> PathBuf {
    let geo = match geo_text {
        Some(t) => {
            let p = dir.join(format!("{name}.geo"));
            std::fs::write(&p, t).unwrap();
            p
        }
        None => PathBuf::from(GEO),
    };
    let out = dir.join(format!("{name}.msh"));
    gmsh(geo.to_str().unwrap(), &[("n", &n.to_string())], &[], &out);
    out
}

/// An ASCII MSH 4.1 file as lines, with where each node's tag and coordinates are and each
/// element's line and block.
struct Msh {
    lines: Vec<String>,
    /// Node tag → (line of its tag, line of its coordinates).
    nodes: BTreeMap<u64, (usize, usize)>,
    /// Element tag → (line, the line of its block's header).
    elements: BTreeMap<u64, (usize, usize)>,
}

impl Msh {
    fn read(path: &Path) -> Msh {
        let lines: Vec<String> = std::fs::read_to_string(path)
            .unwrap()
            .lines()
            .map(String::from)
            .collect();
        let at = |s: &str| lines.iter().position(|l| l == s).unwrap();
        let nums =
            |l: &str| -> Vec<u64> { l.split_whitespace().map(|w| w.parse().unwrap()).collect() };
        let mut nodes = BTreeMap::new();
        let mut i = at("$Nodes") + 1;
        let blocks = nums(&lines[i])[0];
        i += 1;
        for _ in 0..blocks {
            let n = nums(&lines[i])[3] as usize;
            for k in 0..n {
                nodes.insert(nums(&lines[i + 1 + k])[0], (i + 1 + k, i + 1 + n + k));
            }
            i += 1 + 2 * n;
        }
        let mut elements = BTreeMap::new();
        let mut i = at("$Elements") + 1;
        let blocks = nums(&lines[i])[0];
        i += 1;
        for _ in 0..blocks {
            let n = nums(&lines[i])[3] as usize;
            for k in 0..n {
                elements.insert(nums(&lines[i + 1 + k])[0], (i + 1 + k, i));
            }
            i += 1 + n;
        }
        Msh {
            lines,
            nodes,
            elements,
        }
    }

    fn xy(&self, tag: u64) -> [f64; 2] {
        let l = &self.lines[self.nodes[&tag].1];
        let v: Vec<f64> = l.split_whitespace().map(|w| w.parse().unwrap()).collect();
        [v[0], v[1]]
    }

    /// The tag of the node nearest to p.
    fn node_at(&self, p: [f64; 2]) -> u64 {
        *self
            .nodes
            .keys()
            .min_by(|a, b| {
                let d = |t: u64| {
                    let q = self.xy(t);
                    (q[0] - p[0]).hypot(q[1] - p[1])
                };
                d(**a).total_cmp(&d(**b))
            })
            .unwrap()
    }

    fn set_xy(&mut self, tag: u64, text: &str) {
        let l = self.nodes[&tag].1;
        self.lines[l] = text.to_string();
    }

    /// The node tags of element `tag`.
    fn element_nodes(&self, tag: u64) -> Vec<u64> {
        self.lines[self.elements[&tag].0]
            .split_whitespace()
            .skip(1)
            .map(|w| w.parse().unwrap())
            .collect()
    }

    /// The triangles (element tags) with node `tag`.
    fn triangles_of(&self, node: u64) -> Vec<u64> {
        self.elements
            .keys()
            .copied()
            .filter(|&e| {
                let n = self.element_nodes(e);
                n.len() == 3 && n.contains(&node)
            })
            .collect()
    }

    fn write(&self, path: &Path) {
        std::fs::write(path, self.lines.join("\n") + "\n").unwrap();
    }
}

/// A node moved onto the opposite edge of one of its triangles: a nearly flat triangle
/// (reported with an area of −3.9e−34: energy 1.8e16 J/m on 1 rank, −2.3e15 on 3, exit 0).
#[test]
fn a_node_moved_onto_an_edge_is_refused() {
    let dir = scratch("mc-flat");
    let good = paper_mesh(&dir, "good", None, 4);
    let mut m = Msh::read(&good);
    // Body 1's interior node (0.25, 0.25) onto the middle of the opposite side of one of its
    // triangles: that triangle is flat, its neighbours stay valid.
    let p = m.node_at([0.25, 0.25]);
    let tri = m.triangles_of(p)[0];
    let others: Vec<u64> = m
        .element_nodes(tri)
        .into_iter()
        .filter(|&n| n != p)
        .collect();
    let (a, b) = (m.xy(others[0]), m.xy(others[1]));
    // (1e−12 off the side: a relative area of about 1e−12, not exactly zero.)
    let mid = [0.5 * (a[0] + b[0]) + 1e-12, 0.5 * (a[1] + b[1]) - 0.5e-12];
    m.set_xy(p, &format!("{:e} {:e} 0", mid[0], mid[1]));
    let bad = dir.join("flat.msh");
    m.write(&bad);
    for np in [1, 3] {
        let line = refused_with(
            np,
            &paper_args(&bad, "contact1,contact2", &[]),
            "-nndd_mesh",
            &["body1", "degenerate"],
        );
        assert!(line.contains(&format!("element {tri}")), "{line}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// A thin triangle the checks accept, near their limit: body 1's node (0, 0.5) moved along
/// its side to 3e−4 of it from (0, 0.375), which leaves two triangles of relative area about
/// 1.5e−4 on the boundary. Their recovered stresses equilibrate to about 1e−5 only, and the
/// run says so: one warning naming the residual (`Residuals::warning`, above 1e−6), in the
/// summary's warnings. The mesh as Gmsh wrote it has none, its residuals below 1e−9.
#[test]
fn a_thin_triangle_the_checks_accept_is_estimated_with_a_warning() {
    let dir = scratch("mc-thin");
    let good = paper_mesh(&dir, "good", None, 8);
    let mut m = Msh::read(&good);
    let (p, q) = (m.node_at([0.0, 0.5]), m.node_at([0.0, 0.375]));
    let (a, b) = (m.xy(p), m.xy(q));
    let t = 3e-4;
    let moved = [b[0] + t * (a[0] - b[0]), b[1] + t * (a[1] - b[1])];
    m.set_xy(p, &format!("{:e} {:e} 0", moved[0], moved[1]));
    let thin = dir.join("thin.msh");
    m.write(&thin);
    let extra = ["-nndd_estimate", "-nndd_estimate_every", "0"];
    for (name, msh) in [("good", &good), ("thin", &thin)] {
        let args = paper_args(msh, "contact1,contact2", &extra);
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let j = solve(2, &dir.join(format!("run-{name}")), &args);
        let r = &j["equilibrium_residuals"];
        let worst = ["divergence", "internal_jump", "element_jump", "boundary"]
            .map(|k| f(r, k))
            .into_iter()
            .fold(0.0, f64::max);
        let warned: Vec<&str> = (j["warnings"].as_array().unwrap().iter())
            .filter_map(|w| w.as_str())
            .filter(|w| w.contains("recovered stresses are equilibrated to"))
            .collect();
        println!("{name}: largest residual {worst:.2e}, warnings {warned:?}");
        match name {
            "good" => assert!(worst < 1e-9 && warned.is_empty(), "{r} {warned:?}"),
            _ => {
                assert!(worst > 1e-6, "{r}");
                assert_eq!(warned.len(), 1, "{}", j["warnings"]);
                assert!(warned[0].contains(&format!("{worst:.1e}")), "{}", warned[0]);
            }
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// Two neighbouring nodes swapped: the triangles between them fold over each other
/// (reported: energy 827.44 instead of 825.5, exit 0).
#[test]
fn folded_triangles_are_refused() {
    let dir = scratch("mc-fold");
    let good = paper_mesh(&dir, "good", None, 4);
    let mut m = Msh::read(&good);
    let (p, q) = (m.node_at([0.25, 0.25]), m.node_at([0.5, 0.25]));
    let (tp, tq) = (
        m.lines[m.nodes[&p].1].clone(),
        m.lines[m.nodes[&q].1].clone(),
    );
    m.set_xy(p, &tq);
    m.set_xy(q, &tp);
    let bad = dir.join("folded.msh");
    m.write(&bad);
    for np in [1, 3] {
        refused_with(
            np,
            &paper_args(&bad, "contact1,contact2", &[]),
            "-nndd_mesh",
            &["body1", "folded"],
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// NaN and inf coordinates are named as such, with the node's tag.
#[test]
fn nan_and_inf_coordinates_are_named() {
    let dir = scratch("mc-nan");
    let good = paper_mesh(&dir, "good", None, 4);
    for (k, bad_value) in ["nan", "inf"].iter().enumerate() {
        let mut m = Msh::read(&good);
        let p = m.node_at([0.5, 0.5]);
        m.set_xy(p, &format!("{bad_value} 0.5 0"));
        let bad = dir.join(format!("{bad_value}.msh"));
        m.write(&bad);
        let np = [1, 3][k];
        let line = refused_with(
            np,
            &paper_args(&bad, "contact1,contact2", &[]),
            "-nndd_mesh",
            &["not a finite number", &format!("node {p}")],
        );
        assert!(line.contains("bad.msh") || line.contains(&format!("{bad_value}.msh")));
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// A node tag given twice with other coordinates.
#[test]
fn a_node_tag_used_twice_is_refused() {
    let dir = scratch("mc-duptag");
    let good = paper_mesh(&dir, "good", None, 4);
    let mut m = Msh::read(&good);
    let (p, q) = (m.node_at([0.25, 0.25]), m.node_at([0.75, 0.75]));
    // Node q's line now carries p's tag.
    let l = m.nodes[&q].0;
    m.lines[l] = p.to_string();
    let bad = dir.join("duptag.msh");
    m.write(&bad);
    refused_with(
        2,
        &paper_args(&bad, "contact1,contact2", &[]),
        "-nndd_mesh",
        &[&format!("node tag {p}"), "twice"],
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// A triangle of body 1 listed in body 2's surface too.
#[test]
fn a_triangle_in_both_bodies_is_refused() {
    let dir = scratch("mc-both-tri");
    let good = paper_mesh(&dir, "good", None, 4);
    let mut m = Msh::read(&good);
    let p = m.node_at([0.5, 0.5]);
    let tri = m.triangles_of(p)[0];
    let nodes = m.element_nodes(tri);
    // Body 2's triangle block: the one with the highest element tags.
    let (&last, &(_, header)) = m.elements.iter().next_back().unwrap();
    let mut h: Vec<u64> = m.lines[header]
        .split_whitespace()
        .map(|w| w.parse().unwrap())
        .collect();
    h[3] += 1;
    m.lines[header] = h.iter().map(u64::to_string).collect::<Vec<_>>().join(" ");
    let new_tag = last + 1;
    let at = m.elements[&last].0 + 1;
    m.lines.insert(
        at,
        format!("{new_tag} {} {} {}", nodes[0], nodes[1], nodes[2]),
    );
    // The section header: count and largest tag.
    let s = m.lines.iter().position(|l| l == "$Elements").unwrap() + 1;
    let mut h: Vec<u64> = m.lines[s]
        .split_whitespace()
        .map(|w| w.parse().unwrap())
        .collect();
    h[1] += 1;
    h[3] = new_tag;
    m.lines[s] = h.iter().map(u64::to_string).collect::<Vec<_>>().join(" ");
    let bad = dir.join("both-tri.msh");
    m.write(&bad);
    for np in [1, 3] {
        refused_with(
            np,
            &paper_args(&bad, "contact1,contact2", &[]),
            "-nndd_mesh",
            &["body1", "body2", "both"],
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// A whole surface in both physical groups.
#[test]
fn a_surface_in_both_bodies_is_refused() {
    let dir = scratch("mc-both-surface");
    let geo = std::fs::read_to_string(GEO).unwrap().replace(
        "Physical Surface(\"body2\") = {2};",
        "Physical Surface(\"body2\") = {2, 1};",
    );
    let bad = paper_mesh(&dir, "both-surface", Some(&geo), 4);
    refused_with(
        2,
        &paper_args(&bad, "contact1,contact2", &[]),
        "-nndd_mesh",
        &["body1", "body2", "both"],
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// `paper.geo` with a square of side `side` from `corner` added to body 2, its side
/// `Line(curve)` (20: bottom, 21: right) the physical curve `name`.
fn with_square_in_body2(corner: [f64; 2], side: f64, name: &str, curve: usize) -> String {
    let [x, y] = corner;
    let (x1, y1) = (x + side, y + side);
    std::fs::read_to_string(GEO).unwrap().replace(
        "Physical Surface(\"body2\") = {2};",
        &format!(
            "Point(20) = {{{x}, {y}, 0}};\nPoint(21) = {{{x1}, {y}, 0}};\n\
             Point(22) = {{{x1}, {y1}, 0}};\nPoint(23) = {{{x}, {y1}, 0}};\n\
             Line(20) = {{20, 21}};\nLine(21) = {{21, 22}};\nLine(22) = {{22, 23}};\n\
             Line(23) = {{23, 20}};\nCurve Loop(20) = {{20, 21, 22, 23}};\n\
             Plane Surface(20) = {{20}};\nPhysical Curve(\"{name}\") = {{{curve}}};\n\
             Physical Surface(\"body2\") = {{2, 20}};"
        ),
    )
}

/// A small square of body 2 inside body 1, away from the contact curves.
#[test]
fn a_piece_of_body2_inside_body1_is_refused() {
    let dir = scratch("mc-inside");
    let geo = with_square_in_body2([0.4, 0.3], 0.2, "inner_base", 20);
    let bad = paper_mesh(&dir, "inside", Some(&geo), 4);
    // Even with the piece held (so that only the overlap is wrong).
    for np in [1, 3] {
        refused_with(
            np,
            &paper_args(
                &bad,
                "contact1,contact2",
                &["-nndd_bc_inner_base_ux", "0", "-nndd_bc_inner_base_uy", "0"],
            ),
            "-nndd_mesh",
            &["overlap", "body 2", "body 1"],
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// A piece of body 2 away from everything with no Dirichlet condition: loaded by a traction
/// (reported: energy −2.2e16 J/m, exit 0) or not (accepted with u = 0 there).
#[test]
fn a_floating_piece_is_refused_loaded_or_not() {
    let dir = scratch("mc-float");
    let geo = with_square_in_body2([2.0, 1.0], 0.5, "float_side", 21);
    let bad = paper_mesh(&dir, "float", Some(&geo), 4);
    let loaded = paper_args(
        &bad,
        "contact1,contact2",
        &["-nndd_bc_float_side_traction", "1e6,0"],
    );
    let free = paper_args(&bad, "contact1,contact2", &[]);
    for (np, args) in [(1, &loaded), (3, &loaded), (2, &free)] {
        refused_with(np, args, "-nndd_mesh", &["body 2", "piece", "rigid"]);
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// Contact curves that do not face each other: body 1's top paired with body 2's top
/// (reported: contact force 0, body 2 inside body 1 by 1.19e−4 m, exit 0); body 1's base
/// paired with body 2's top, back to back (their normals opposite, body 2's curve behind body
/// 1's): named as curves that face away, not as overlapping bodies.
#[test]
fn contact_curves_that_do_not_face_each_other_are_refused() {
    let dir = scratch("mc-facing");
    let good = paper_mesh(&dir, "good", None, 4);
    for np in [1, 3] {
        refused_with(
            np,
            &paper_args(&good, "contact1,top", &[]),
            "-nndd_contact",
            &["face"],
        );
    }
    refused_with(
        2,
        &paper_args(&good, "bottom,top", &[]),
        "-nndd_contact",
        &["face away", "behind"],
    );
    std::fs::remove_dir_all(&dir).ok();
}
