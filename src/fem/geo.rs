//! A problem given as its Gmsh geometry (`-nndd_mesh FILE.geo`): meshed by the `gmsh` program
//! when the run starts, with the parameters of `-nndd_geo_set NAME=VALUE,…` (Gmsh's
//! `-setnumber`), into an MSH 4.1 file that is read as a given one and removed; and meshed
//! again from a size field ([`remesh`], a background view written by [`write_background`]).
//! (`gmsh -2 -format msh41` is what a user runs by hand; Debian's `gmsh` package has it.)

use std::path::{Path, PathBuf};
use std::process::Command;

use super::gmsh::{self, GmshError, GmshMesh};

/// Whether `path` names a Gmsh geometry (`.geo`) rather than a mesh.
pub fn is_geo(path: &Path) -> bool {
    path.extension().is_some_and(|e| e == "geo")
}

/// The parameters of `-nndd_geo_set`: `NAME=VALUE` items separated by commas, NAME a Gmsh
/// identifier, VALUE a finite number; empty for an empty text.
pub fn parse_parameters(text: &str) -> Result<Vec<(String, f64)>, String> {
    let mut out: Vec<(String, f64)> = Vec::new();
    for item in text.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        let (name, value) = item
            .split_once('=')
            .ok_or_else(|| format!("'{item}' is not NAME=VALUE"))?;
        let name = name.trim();
        let identifier = name
            .chars()
            .next()
            .is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
            && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
        if !identifier {
            return Err(format!(
                "'{name}' is not a Gmsh parameter name (letters, digits, _)"
            ));
        }
        let v: f64 = value
            .trim()
            .parse()
            .ok()
            .filter(|v: &f64| v.is_finite())
            .ok_or_else(|| format!("'{}' (for {name}) is not a finite number", value.trim()))?;
        if out.iter().any(|(n, _)| n == name) {
            return Err(format!("{name} is set twice"));
        }
        out.push((name.to_string(), v));
    }
    Ok(out)
}

/// Mesh the geometry `path` with `gmsh -2 -format msh41 -setnumber NAME VALUE …` and read the
/// mesh (the temporary file removed whatever happens).
pub fn mesh(path: &Path, parameters: &[(String, f64)]) -> Result<GmshMesh, GmshError> {
    run_gmsh(path, parameters, None)
}

/// Mesh the geometry `path` again with the mesh sizes of the background view `background`
/// ([`write_background`]) alone: the sizes its points give (`Mesh.MeshSizeFromPoints`) and
/// their extension from the boundary are off, so the new mesh follows the view (`gmsh -bgm`).
/// The geometry's curves are meshed on the geometry itself (a circle's nodes on the circle) and
/// its physical names are kept.
pub fn remesh(
    path: &Path,
    parameters: &[(String, f64)],
    background: &Path,
) -> Result<GmshMesh, GmshError> {
    run_gmsh(path, parameters, Some(background))
}

/// A Gmsh post-processing view (ASCII `.pos`) of the sizes `nodal` at the `points` of the
/// `triangles`, for [`remesh`]: Gmsh interpolates it linearly over each triangle. The sizes
/// are written to 7 digits, so that sizes equal to round-off (the same run on other rank
/// counts) give the same view, hence the same mesh.
pub fn write_background(
    path: &Path,
    points: &[[f64; 2]],
    triangles: &[[usize; 3]],
    nodal: &[f64],
) -> std::io::Result<()> {
    use std::fmt::Write as _;
    let mut text = String::from("View \"size\" {\n");
    for t in triangles {
        let [a, b, c] = t.map(|v| points[v]);
        let _ = writeln!(
            text,
            "ST({:e},{:e},0,{:e},{:e},0,{:e},{:e},0){{{:.6e},{:.6e},{:.6e}}};",
            a[0], a[1], b[0], b[1], c[0], c[1], nodal[t[0]], nodal[t[1]], nodal[t[2]]
        );
    }
    text.push_str("};\n");
    std::fs::write(path, text)
}

fn run_gmsh(
    path: &Path,
    parameters: &[(String, f64)],
    background: Option<&Path>,
) -> Result<GmshMesh, GmshError> {
    let name = path.display().to_string();
    let fail = |reason: String| GmshError::Meshing {
        path: name.clone(),
        reason,
    };
    let meta = std::fs::metadata(path).map_err(|e| GmshError::Io {
        path: name.clone(),
        reason: e.to_string(),
    })?;
    if !meta.is_file() {
        return Err(fail("it is not a regular file".into()));
    }
    let out = Scratch::new(path);
    let mut cmd = Command::new("gmsh");
    cmd.args(["-2", "-format", "msh41", "-v", "1", "-nt", "1"]);
    for (k, v) in parameters {
        cmd.args(["-setnumber", k, &format!("{v:e}")]);
    }
    if let Some(view) = background {
        cmd.arg("-bgm").arg(view).args([
            "-string",
            "Mesh.MeshSizeFromPoints = 0; Mesh.MeshSizeExtendFromBoundary = 0; Mesh.MeshSizeFromCurvature = 0;",
        ]);
    }
    let run = cmd
        .arg(path)
        .arg("-o")
        .arg(&out.0)
        .output()
        .map_err(|e| {
            fail(format!(
                "it needs the gmsh program ({e}; Debian: apt install gmsh), or give the mesh: gmsh -2 -format msh41 {name}"
            ))
        })?;
    let said = |bytes: &[u8]| {
        String::from_utf8_lossy(bytes)
            .lines()
            .map(str::trim)
            .rfind(|l| !l.is_empty())
            .map(str::to_string)
    };
    if !run.status.success() || !out.0.exists() {
        let why = said(&run.stderr)
            .or_else(|| said(&run.stdout))
            .unwrap_or_else(|| format!("gmsh ended with {}", run.status));
        return Err(fail(format!("gmsh says: {why}")));
    }
    let bytes = std::fs::read(&out.0).map_err(|e| fail(format!("its mesh: {e}")))?;
    gmsh::parse(&bytes, &name)
}

/// The temporary mesh file, removed when dropped.
struct Scratch(PathBuf);

impl Scratch {
    fn new(geo: &Path) -> Scratch {
        let stem = geo
            .file_stem()
            .map_or("mesh".into(), |s| s.to_string_lossy().into_owned());
        Scratch(std::env::temp_dir().join(format!("nndd-{}-{stem}.msh", std::process::id())))
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        std::fs::remove_file(&self.0).ok();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parameters_are_names_and_numbers() {
        assert_eq!(
            parse_parameters(" level = 2, ratio=1.5 ,").unwrap(),
            vec![("level".to_string(), 2.0), ("ratio".to_string(), 1.5)]
        );
        assert!(parse_parameters("").unwrap().is_empty());
        for bad in ["level", "2x=1", "level=two", "level=inf", "a=1,a=2", "=3"] {
            assert!(parse_parameters(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn a_geometry_is_told_from_a_mesh_by_its_extension() {
        assert!(is_geo(Path::new("examples/paper/paper.geo")));
        assert!(!is_geo(Path::new("examples/paper/paper.msh")));
        assert!(!is_geo(Path::new("geo")));
    }
}
