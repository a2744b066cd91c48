//! The XDMF texts, in the layout of DOLFINx's `XDMFFile` (and meshio's time series): one
//! mesh per file, a `Uniform` grid with its `Topology` and `Geometry`, then a temporal
//! collection whose grids include that mesh (`xi:include`) and carry the fields of one step.
//! Datasets are referred to as `NAME.h5:/path`, the bare file name, i.e. relative to the
//! `.xdmf`'s own folder.

use std::fmt::Write as _;

use super::{entries, function_path, Field, Grid, Results, Step};

fn xml_escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            c => out.push(c),
        }
    }
    out
}

/// One `DataItem` referring to `h5_name:path`.
fn data_item(
    out: &mut String,
    indent: &str,
    dims: &[usize],
    float: bool,
    h5_name: &str,
    path: &str,
) {
    let dims: Vec<String> = dims.iter().map(|d| d.to_string()).collect();
    let number_type = if float { "Float" } else { "Int" };
    let _ = writeln!(
        out,
        "{indent}<DataItem Dimensions=\"{}\" NumberType=\"{number_type}\" Precision=\"8\" Format=\"HDF\">{}:{}</DataItem>",
        dims.join(" "),
        xml_escape(h5_name),
        xml_escape(path)
    );
}

/// Topology + geometry of one grid.
fn grid_mesh(out: &mut String, indent: &str, g: &Grid, h5_name: &str) {
    let m = g.extent.cells;
    let npc = g.topology.nodes_per_cell();
    let _ = writeln!(
        out,
        "{indent}<Topology TopologyType=\"{}\" NumberOfElements=\"{m}\" NodesPerElement=\"{npc}\">",
        g.topology.xdmf_type()
    );
    let inner = format!("{indent}  ");
    let path = format!("/Mesh/{}/topology", g.name);
    data_item(out, &inner, &[m, npc], false, h5_name, &path);
    let _ = writeln!(out, "{indent}</Topology>");
    let _ = writeln!(out, "{indent}<Geometry GeometryType=\"XY\">");
    let path = format!("/Mesh/{}/geometry", g.name);
    data_item(out, &inner, &[g.extent.points, 2], true, h5_name, &path);
    let _ = writeln!(out, "{indent}</Geometry>");
}

/// One `Attribute` of grid `g`, its data at `path`.
fn attribute(out: &mut String, indent: &str, g: &Grid, field: &Field, h5_name: &str, path: &str) {
    let _ = writeln!(
        out,
        "{indent}<Attribute Name=\"{}\" AttributeType=\"{}\" Center=\"{}\">",
        xml_escape(&field.name),
        field.kind.xdmf_type(),
        field.center.xdmf_name()
    );
    let shape = field.stored_shape(entries(Some(g), field.center));
    data_item(out, &format!("{indent}  "), &shape, true, h5_name, path);
    let _ = writeln!(out, "{indent}</Attribute>");
}

/// The attributes of grid `g` at `step` (the grid's constant fields first).
fn step_attributes(out: &mut String, indent: &str, g: &Grid, step: &Step, h5_name: &str) {
    for field in &g.fields {
        let path = format!("/Mesh/{}/{}", g.name, field.name);
        attribute(out, indent, g, field, h5_name, &path);
    }
    for field in step.fields_of(&g.name) {
        let path = function_path(&g.name, &field.name, step.time);
        attribute(out, indent, g, field, h5_name, &path);
    }
}

const HEAD: &str = "<?xml version=\"1.0\"?>\n<!DOCTYPE Xdmf SYSTEM \"Xdmf.dtd\" []>\n\
<Xdmf Version=\"3.0\" xmlns:xi=\"http://www.w3.org/2001/XInclude\">\n  <Domain>\n";
const TAIL: &str = "  </Domain>\n</Xdmf>\n";

/// Grid `g` at every step: its mesh, then (with steps) the temporal collection of its fields,
/// the time of each step its NNDD iteration number.
pub(super) fn series_text(results: &Results, g: &Grid, h5_name: &str) -> String {
    let mut out = String::from(HEAD);
    let name = xml_escape(&g.name);
    let _ = writeln!(out, "    <Grid Name=\"{name}\" GridType=\"Uniform\">");
    grid_mesh(&mut out, "      ", g, h5_name);
    out.push_str("    </Grid>\n");
    if !results.steps.is_empty() {
        let _ = writeln!(
            out,
            "    <Grid Name=\"{name}\" GridType=\"Collection\" CollectionType=\"Temporal\">"
        );
        for step in &results.steps {
            let _ = writeln!(out, "      <Grid Name=\"{name}\" GridType=\"Uniform\">");
            out.push_str(
                "        <xi:include xpointer=\"xpointer(/Xdmf/Domain/Grid[@GridType='Uniform'][1]/*[self::Topology or self::Geometry])\"/>\n",
            );
            let _ = writeln!(out, "        <Time Value=\"{}\"/>", step.time);
            step_attributes(&mut out, "        ", g, step, h5_name);
            out.push_str("      </Grid>\n");
        }
        out.push_str("    </Grid>\n");
    }
    out.push_str(TAIL);
    out
}

/// Grid `g` at one step alone: a single `Uniform` grid with its mesh and fields (what
/// meshio's `read` and every XDMF reader open without a time series).
pub(super) fn single_text(g: &Grid, step: &Step, h5_name: &str) -> String {
    let mut out = String::from(HEAD);
    let _ = writeln!(
        out,
        "    <Grid Name=\"{}\" GridType=\"Uniform\">",
        xml_escape(&g.name)
    );
    grid_mesh(&mut out, "      ", g, h5_name);
    step_attributes(&mut out, "      ", g, step, h5_name);
    out.push_str("    </Grid>\n");
    out.push_str(TAIL);
    out
}

/// Single grids ([`single_text`], each its own mesh and data file) as one temporal collection,
/// the time of the i-th `singles[i].0`: an adaptive run's cycles, one mesh each, through
/// which a reader's time slider steps. `None` if a text is not a single grid of this writer.
pub fn collection_of_singles(singles: &[(f64, String)]) -> Option<String> {
    let mut out = String::from(HEAD);
    out.push_str(
        "    <Grid Name=\"cycles\" GridType=\"Collection\" CollectionType=\"Temporal\">\n",
    );
    for (time, text) in singles {
        let body = text.strip_prefix(HEAD)?.strip_suffix(TAIL)?;
        let (open, rest) = body.split_once('\n')?;
        if !open.trim_start().starts_with("<Grid ") {
            return None;
        }
        let _ = writeln!(out, "  {open}");
        let _ = writeln!(out, "        <Time Value=\"{time}\"/>");
        for line in rest.lines() {
            let _ = writeln!(out, "  {line}");
        }
    }
    out.push_str("    </Grid>\n");
    out.push_str(TAIL);
    Some(out)
}

#[cfg(test)]
mod tests {
    use std::fs;

    use super::super::testutil::{data_items, sample, TestDir};
    use super::super::write_results;

    #[test]
    fn meshes_only_without_steps() {
        let dir = TestDir::new("nosteps");
        let prefix = dir.0.join("mesh");
        let mut results = sample();
        results.steps.clear();
        write_results(&prefix, &results).expect("write");
        assert_eq!(
            dir.entries(),
            vec!["mesh-contact.xdmf", "mesh.h5", "mesh.xdmf"]
        );
        let file = hdf5::File::open(dir.0.join("mesh.h5")).unwrap();
        for name in ["mesh.xdmf", "mesh-contact.xdmf"] {
            let xdmf = fs::read_to_string(dir.0.join(name)).unwrap();
            assert!(!xdmf.contains("Temporal"));
            let items = data_items(&xdmf);
            assert_eq!(items.len(), 2, "{name}: topology and geometry");
            for (_, path, dims) in &items {
                assert_eq!(&file.dataset(path).unwrap().shape(), dims);
            }
        }
    }
}
