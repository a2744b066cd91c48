//! The XDMF text ParaView reads: one temporal collection of spatial
//! collections of all grids, datasets referred to as `NAME.h5:/path`.

use std::fmt::Write as _;

use super::{entries, Grid, Results};

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
    let (number_type, precision) = if float { ("Float", 8) } else { ("Int", 8) };
    let _ = writeln!(
        out,
        "{indent}<DataItem Dimensions=\"{}\" NumberType=\"{number_type}\" Precision=\"{precision}\" Format=\"HDF\">{}:{}</DataItem>",
        dims.join(" "),
        xml_escape(h5_name),
        xml_escape(path)
    );
}

/// Topology + geometry of one grid.
fn grid_mesh(out: &mut String, indent: &str, g: &Grid, h5_name: &str) {
    let m = g.topology.cell_count();
    let npc = g.topology.nodes_per_cell();
    let _ = writeln!(
        out,
        "{indent}<Topology TopologyType=\"{}\" NumberOfElements=\"{m}\" NodesPerElement=\"{npc}\">",
        g.topology.xdmf_type()
    );
    let inner = format!("{indent}  ");
    data_item(
        out,
        &inner,
        &[m, npc],
        false,
        h5_name,
        &format!("/grids/{}/cells", g.name),
    );
    let _ = writeln!(out, "{indent}</Topology>");
    let _ = writeln!(out, "{indent}<Geometry GeometryType=\"XY\">");
    let n = g.points.len();
    data_item(
        out,
        &inner,
        &[n, 2],
        true,
        h5_name,
        &format!("/grids/{}/points", g.name),
    );
    let _ = writeln!(out, "{indent}</Geometry>");
}

/// The XDMF text; `h5_name` is the bare file name of the HDF5 file.
pub(super) fn xdmf_text(results: &Results, h5_name: &str) -> String {
    let mut out = String::new();
    out.push_str("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
    out.push_str("<Xdmf Version=\"3.0\">\n  <Domain>\n");
    if results.steps.is_empty() {
        out.push_str(
            "    <Grid Name=\"meshes\" GridType=\"Collection\" CollectionType=\"Spatial\">\n",
        );
        for g in &results.grids {
            let _ = writeln!(
                out,
                "      <Grid Name=\"{}\" GridType=\"Uniform\">",
                xml_escape(&g.name)
            );
            grid_mesh(&mut out, "        ", g, h5_name);
            out.push_str("      </Grid>\n");
        }
        out.push_str("    </Grid>\n");
    } else {
        out.push_str(
            "    <Grid Name=\"nndd\" GridType=\"Collection\" CollectionType=\"Temporal\">\n",
        );
        for (k, step) in results.steps.iter().enumerate() {
            let _ = writeln!(
                out,
                "      <Grid Name=\"step_{k}\" GridType=\"Collection\" CollectionType=\"Spatial\">"
            );
            let _ = writeln!(out, "        <Time Value=\"{}\"/>", step.time);
            for g in &results.grids {
                let _ = writeln!(
                    out,
                    "        <Grid Name=\"{}\" GridType=\"Uniform\">",
                    xml_escape(&g.name)
                );
                grid_mesh(&mut out, "          ", g, h5_name);
                let fields = step
                    .grids
                    .iter()
                    .filter(|gf| gf.grid == g.name)
                    .flat_map(|gf| &gf.fields);
                for field in fields {
                    let _ = writeln!(
                        out,
                        "          <Attribute Name=\"{}\" AttributeType=\"{}\" Center=\"{}\">",
                        xml_escape(&field.name),
                        field.kind.xdmf_type(),
                        field.center.xdmf_name()
                    );
                    let shape = field.stored_shape(entries(Some(g), field.center));
                    let path = format!("/steps/{k}/{}/{}", g.name, field.name);
                    data_item(&mut out, "            ", &shape, true, h5_name, &path);
                    out.push_str("          </Attribute>\n");
                }
                out.push_str("        </Grid>\n");
            }
            out.push_str("      </Grid>\n");
        }
        out.push_str("    </Grid>\n");
    }
    out.push_str("  </Domain>\n</Xdmf>\n");
    out
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
        let xdmf = fs::read_to_string(dir.0.join("mesh.xdmf")).unwrap();
        assert!(!xdmf.contains("Temporal"));
        let file = hdf5::File::open(dir.0.join("mesh.h5")).unwrap();
        let items = data_items(&xdmf);
        assert_eq!(items.len(), 6);
        for (_, path, dims) in &items {
            assert_eq!(&file.dataset(path).unwrap().shape(), dims);
        }
    }
}
