//! Capability (in progress): meshes adapted to the estimates. What exists: the sizes the
//! element estimates ask for (src/estimate/size_field.rs, the optimal-mesh criterion) and a
//! body meshed again by Gmsh from its `.geo` with those sizes (src/fem/geo.rs, `gmsh -bgm`).
//! - The sizes shrink where the error sits and grow elsewhere, and Gmsh's new mesh follows
//!   them: on Hertz (examples/hertz-nonmatching) with an error at the contact and a target that
//!   keeps the element count, the elements there shrink, the far field coarsens, and the
//!   element count is near the prediction.
//! - The new mesh keeps the physical names (so the options' conditions still apply) and its
//!   curves on the geometry: every node of the cylinder's arc on the circle to 1e−9 of R.

mod common;
use common::HERTZ_NM_GEO as HERTZ_GEO;

use std::path::Path;

use nndd::estimate::size_field::{nodal_sizes, size_field, triangle_size, Limits, Strategy};
use nndd::fem::geo;

/// The mean size of the triangles whose centroids lie within `radius` of `at` (or beyond it,
/// `inside` false).
fn mean_size(m: &nndd::fem::gmsh::GmshMesh, at: [f64; 2], radius: f64, inside: bool) -> f64 {
    let sizes: Vec<f64> = m
        .triangles
        .iter()
        .map(|t| t.0.map(|v| m.points[v]))
        .filter(|p| {
            let c = [
                (p[0][0] + p[1][0] + p[2][0]) / 3.0,
                (p[0][1] + p[1][1] + p[2][1]) / 3.0,
            ];
            ((c[0] - at[0]).hypot(c[1] - at[1]) < radius) == inside
        })
        .map(triangle_size)
        .collect();
    sizes.iter().sum::<f64>() / sizes.len() as f64
}

#[test]
fn a_body_meshed_again_from_the_sizes_of_its_errors() {
    let dir = std::env::temp_dir().join(format!("nndd-test-adapt-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let params = vec![("level".to_string(), 1.0), ("ratio".to_string(), 1.5)];
    let first = geo::mesh(Path::new(HERTZ_GEO), &params).expect("gmsh meshes the example");
    let triangles: Vec<[usize; 3]> = first.triangles.iter().map(|t| t.0).collect();
    let sizes: Vec<f64> = triangles
        .iter()
        .map(|t| triangle_size(t.map(|v| first.points[v])))
        .collect();
    // An error that sits at the contact (the origin): e_E² = h_E⁴ / (r_E + 0.02)⁶, steeper
    // than the example's grading (h ∝ r) equidistributes; the target Σ e_E / √N keeps the
    // element count (the sizes only move).
    let squares: Vec<f64> = triangles
        .iter()
        .zip(&sizes)
        .map(|(t, h)| {
            let c = t.map(|v| first.points[v]);
            let r =
                ((c[0][0] + c[1][0] + c[2][0]) / 3.0).hypot((c[0][1] + c[1][1] + c[2][1]) / 3.0);
            h.powi(4) / (r + 0.02).powi(6)
        })
        .collect();
    let target = squares.iter().map(|e| e.sqrt()).sum::<f64>() / (squares.len() as f64).sqrt();
    let field = size_field(
        &squares,
        &sizes,
        target,
        Strategy::Optimal { order: 1.0 },
        Limits::default(),
    );
    let view = dir.join("size.pos");
    let nodal = nodal_sizes(first.points.len(), &triangles, &field.sizes);
    geo::write_background(&view, &first.points, &triangles, &nodal).unwrap();
    let second = geo::remesh(Path::new(HERTZ_GEO), &params, &view).expect("gmsh meshes it again");
    let (near, far) = (
        [
            mean_size(&first, [0.0, 0.0], 0.1, true),
            mean_size(&second, [0.0, 0.0], 0.1, true),
        ],
        [
            mean_size(&first, [0.0, 0.0], 1.5, false),
            mean_size(&second, [0.0, 0.0], 1.5, false),
        ],
    );
    println!(
        "{} -> {} triangles (predicted {:.0}); mean size within 0.1 of the contact {:.4} -> {:.4}, beyond 1.5 {:.4} -> {:.4}",
        first.triangles.len(),
        second.triangles.len(),
        field.elements,
        near[0],
        near[1],
        far[0],
        far[1]
    );
    assert!(near[1] < 0.8 * near[0], "near the contact {near:?}");
    assert!(far[1] > 1.25 * far[0], "far from it {far:?}");
    let count = second.triangles.len() as f64;
    assert!(
        (0.5 * field.elements..2.0 * field.elements).contains(&count),
        "{count} triangles against {} predicted",
        field.elements
    );
    // The names carry over; the cylinder's arc stays on its circle (centre (0, 1), R = 1).
    assert_eq!(first.names, second.names);
    let arc = second.curve_edges("cylinder_arc").expect("the arc");
    let worst = arc
        .iter()
        .flatten()
        .map(|&v| (second.points[v][0].hypot(second.points[v][1] - 1.0) - 1.0).abs())
        .fold(0.0_f64, f64::max);
    println!(
        "{} arc edges, the largest distance of a node to the circle {worst:.1e} R",
        arc.len()
    );
    assert!(arc.len() > 20 && worst < 1e-9, "{worst:e}");
    std::fs::remove_dir_all(&dir).ok();
}
