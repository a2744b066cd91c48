//! The checks made before anything is created: PREFIX, names, and one
//! rank's results and shares.

use std::path::Path;

use super::{grid_index, Center, Field, Grid, OutputError, Results, Share};

/// The file-name part of PREFIX, checked usable in XDMF references.
pub(super) fn prefix_name(prefix: &Path) -> Result<String, OutputError> {
    let bad = |reason: &str| OutputError::BadPrefix {
        path: prefix.to_path_buf(),
        reason: reason.to_string(),
    };
    let raw = prefix.as_os_str().to_string_lossy();
    if raw.ends_with('/') {
        return Err(bad(
            "it names a directory; give a directory and a file-name prefix, e.g. results/run1",
        ));
    }
    // `DIR/.` and `DIR/..` end in no file name, but `Path::file_name` reads `DIR/.` as `DIR`:
    // the files would be `DIR/..h5` and the like.
    let last = raw.rsplit('/').next().unwrap_or_default();
    if matches!(last, "." | "..") {
        return Err(bad(&format!(
            "its file name is '{last}'; give a directory and a file-name prefix, e.g. results/run1"
        )));
    }
    let name = prefix
        .file_name()
        .ok_or_else(|| bad("no file name; give e.g. results/run1"))?;
    let name = name
        .to_str()
        .ok_or_else(|| bad("the file name is not valid UTF-8"))?;
    if name.contains(':') {
        return Err(bad(
            "the file name contains ':', which XDMF cannot reference",
        ));
    }
    Ok(name.to_string())
}

const NAME_RULE: &str = "non-empty, ASCII letters, digits, '_', '-', '.', not starting with '.'";

fn valid_name(name: &str) -> bool {
    !name.is_empty()
        && !name.starts_with('.')
        && name
            .bytes()
            .all(|b| b.is_ascii_alphanumeric() || matches!(b, b'_' | b'-' | b'.'))
}

/// All checks of one rank's results and shares, before anything is created.
pub(super) fn validate(
    results: &Results,
    shares: &[Share],
    path: &Path,
) -> Result<(), OutputError> {
    let invalid = |reason: String| OutputError::Invalid {
        path: path.to_path_buf(),
        reason,
    };
    let name_rule = NAME_RULE;
    if shares.len() != results.grids.len() {
        return Err(invalid(format!(
            "{} shares for {} grids",
            shares.len(),
            results.grids.len()
        )));
    }
    for (i, (g, share)) in results.grids.iter().zip(shares).enumerate() {
        if !valid_name(&g.name) {
            return Err(invalid(format!(
                "grid name {:?}: must be {name_rule}",
                g.name
            )));
        }
        if i > 0 && g.name == "final" {
            return Err(invalid(
                "grid name \"final\": PREFIX-final.xdmf is the first grid's last step".into(),
            ));
        }
        if results.grids[..i].iter().any(|o| o.name == g.name) {
            return Err(invalid(format!("grid name {:?} is used twice", g.name)));
        }
        if let Some(max) = g.topology.max_index() {
            if max as usize >= g.extent.points {
                return Err(invalid(format!(
                    "grid {:?}: cell refers to point {max}, but it has {} points",
                    g.name, g.extent.points
                )));
            }
        }
        let totals = [
            (&share.points, g.extent.points, g.points.len(), "points"),
            (
                &share.cells,
                g.extent.cells,
                g.topology.cell_count(),
                "cells",
            ),
        ];
        for (rows, total, held, what) in totals {
            if rows.start > rows.end || rows.end > total {
                return Err(invalid(format!(
                    "grid {:?}: share of {what} {rows:?} is not within 0..{total}",
                    g.name
                )));
            }
            if held != total && held != rows.len() {
                return Err(invalid(format!(
                    "grid {:?}: {held} {what} given, expected all {total} or this rank's {} of them",
                    g.name,
                    rows.len()
                )));
            }
        }
    }
    for (gi, g) in results.grids.iter().enumerate() {
        for (f, field) in g.fields.iter().enumerate() {
            let at = format!("grid {:?}, field {:?}", g.name, field.name);
            let taken = ["geometry", "topology"].contains(&field.name.as_str());
            if taken || g.fields[..f].iter().any(|o| o.name == field.name) {
                return Err(invalid(format!("{at}: name used twice")));
            }
            check_field(&at, field, g, &shares[gi]).map_err(invalid)?;
        }
    }
    let names: Vec<&str> = (results.attributes.iter().map(|(n, _)| n.as_str()))
        .chain(results.text.iter().map(|(n, _)| n.as_str()))
        .collect();
    for (i, name) in names.iter().enumerate() {
        if name.is_empty() || name.contains('\0') {
            return Err(invalid(format!(
                "attribute name {name:?}: empty or contains NUL"
            )));
        }
        if names[..i].contains(name) {
            return Err(invalid(format!("attribute name {name:?} is used twice")));
        }
    }
    let mut previous: Option<f64> = None;
    for (k, step) in results.steps.iter().enumerate() {
        if !step.time.is_finite() {
            return Err(invalid(format!(
                "step {k}: time {} is not finite",
                step.time
            )));
        }
        if let Some(p) = previous {
            if step.time <= p {
                return Err(invalid(format!(
                    "step {k}: time {} does not increase (previous step: {p})",
                    step.time
                )));
            }
        }
        previous = Some(step.time);
        for (j, gf) in step.grids.iter().enumerate() {
            let gi = grid_index(results, &gf.grid)
                .ok_or_else(|| invalid(format!("step {k}: unknown grid {:?}", gf.grid)))?;
            let grid = &results.grids[gi];
            if step.grids[..j].iter().any(|o| o.grid == gf.grid) {
                return Err(invalid(format!(
                    "step {k}: grid {:?} listed twice",
                    gf.grid
                )));
            }
            for (f, field) in gf.fields.iter().enumerate() {
                let at = format!("step {k}, grid {:?}, field {:?}", gf.grid, field.name);
                if gf.fields[..f].iter().any(|o| o.name == field.name)
                    || grid.fields.iter().any(|o| o.name == field.name)
                {
                    return Err(invalid(format!("{at}: name used twice")));
                }
                check_field(&at, field, grid, &shares[gi]).map_err(invalid)?;
            }
        }
    }
    Ok(())
}

/// A field of `grid`: its name, and as many values as the grid has entries of its center,
/// or as this rank's share has rows of them (none where that share is empty).
fn check_field(at: &str, field: &Field, grid: &Grid, share: &Share) -> Result<(), String> {
    if !valid_name(&field.name) {
        return Err(format!("{at}: name must be {NAME_RULE}"));
    }
    let (entries, what) = match field.center {
        Center::Node => (grid.extent.points, "points"),
        Center::Cell => (grid.extent.cells, "cells"),
    };
    let expected = entries.checked_mul(field.kind.given());
    let rows = share.rows(field.center).len();
    let local = rows.checked_mul(field.kind.given());
    let absent = field.values.is_empty() && rows == 0;
    if expected != Some(field.values.len()) && local != Some(field.values.len()) && !absent {
        return Err(format!(
            "{at}: {} values, expected {entries} {what} x {} ({:?}), or this rank's {rows} of them",
            field.values.len(),
            field.kind.given(),
            field.kind
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::super::testutil::{sample, TestDir};
    use super::super::{write_results, Topology};
    use super::*;

    fn assert_invalid(results: &Results, needle: &str) {
        let dir = TestDir::new(&format!("invalid-{}", needle.replace(' ', "_")));
        let prefix = dir.0.join("run");
        match write_results(&prefix, results) {
            Err(OutputError::Invalid { path, reason }) => {
                assert_eq!(path, dir.0.join("run.h5"));
                assert!(reason.contains(needle), "{reason:?} lacks {needle:?}");
            }
            other => panic!("expected Invalid({needle}), got {other:?}"),
        }
        assert!(dir.entries().is_empty(), "{:?}", dir.entries());
    }

    #[test]
    fn a_field_is_given_whole_or_for_the_share_alone() {
        let r = sample();
        let (g, f) = (&r.grids[0], &r.steps[0].grids[0].fields[1]);
        let whole = Share::whole(g);
        let part = Share {
            points: 1..3,
            cells: 2..4,
        };
        let given = f.kind.given();
        let mut local = f.clone();
        local.values = f.values[2 * given..4 * given].to_vec();
        assert!(check_field("f", f, g, &whole).is_ok());
        assert!(check_field("f", f, g, &part).is_ok());
        assert!(check_field("f", &local, g, &part).is_ok());
        // The share's rows, from either form, are the same entries.
        let n = g.topology.cell_count();
        assert_eq!(
            local.stored_rows(part.cells.clone(), n),
            f.stored_rows(part.cells.clone(), n)
        );
        // Neither whole nor the share's length: refused.
        local.values.pop();
        let err = check_field("f", &local, g, &part).unwrap_err();
        assert!(err.contains("or this rank's 2 of them"), "{err}");
    }

    #[test]
    fn a_grid_is_given_whole_or_for_the_share_alone() {
        let whole = sample();
        let g = &whole.grids[0];
        let part = Share {
            points: 2..7,
            cells: 1..4,
        };
        let mut local = whole.clone();
        let l = &mut local.grids[0];
        l.points = g.points[part.points.clone()].to_vec();
        let Topology::Triangle(cells) = &g.topology else {
            panic!("the sample's first grid is of triangles")
        };
        l.topology = Topology::Triangle(cells[part.cells.clone()].to_vec());
        let shares = |s: &Share| vec![s.clone(), Share::whole(&whole.grids[1])];
        let path = std::path::Path::new("run.h5");
        assert!(validate(&whole, &shares(&part), path).is_ok());
        assert!(validate(&local, &shares(&part), path).is_ok());
        // The share's rows, from either form, are the same entries.
        let l = &local.grids[0];
        assert_eq!(
            l.stored_points(part.points.clone()),
            g.stored_points(part.points.clone())
        );
        assert_eq!(
            l.stored_cells(part.cells.clone()),
            g.stored_cells(part.cells.clone())
        );
        assert_eq!(g.stored_cells(1..2), vec![0, 2, 3]);
        // A part that is not the share's rows: refused, naming the counts.
        let other = Share {
            points: 2..6,
            cells: 1..4,
        };
        let err = validate(&local, &shares(&other), path).unwrap_err();
        assert!(
            err.to_string()
                .contains("5 points given, expected all 9 or this rank's 4 of them"),
            "{err}"
        );
    }

    #[test]
    fn invalid_results_fail_and_leave_nothing() {
        let mut r = sample();
        r.steps[1].grids[0].fields[1].values.pop();
        assert_invalid(&r, "29 values, expected 5 cells x 6");

        let mut r = sample();
        r.steps[0].grids[1].fields[0].values.push(1.0);
        assert_invalid(&r, "4 values, expected 3 points x 1");

        let mut r = sample();
        r.steps[1].grids[1].grid = "body3".into();
        assert_invalid(&r, "unknown grid");

        let mut r = sample();
        r.grids[0].fields[0].values.pop();
        assert_invalid(&r, "4 values, expected 5 cells x 1");

        let mut r = sample();
        r.steps[0].grids[0].fields[2].name = "body".into();
        assert_invalid(&r, "name used twice");

        let mut r = sample();
        r.text.push(("nranks".into(), "two".into()));
        assert_invalid(&r, "is used twice");

        let mut r = sample();
        r.grids[1].name = "final".into();
        r.steps
            .iter_mut()
            .for_each(|s| s.grids[1].grid = "final".into());
        assert_invalid(&r, "PREFIX-final.xdmf");

        let mut r = sample();
        r.grids[0].topology = Topology::Triangle(vec![[0, 1, 9]]);
        assert_invalid(&r, "refers to point 9");

        let mut r = sample();
        r.steps[1].time = 1.0;
        assert_invalid(&r, "does not increase");

        let mut r = sample();
        r.steps[0].grids[0].fields[0].name = "u/x".into();
        assert_invalid(&r, "name must be");

        let mut r = sample();
        r.grids[1].name = "bodies".into();
        assert_invalid(&r, "used twice");
    }
}
