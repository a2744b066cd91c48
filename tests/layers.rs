//! Capability: the code's layout shows the method. `src/` is one folder per layer, and a
//! layer uses only the layers below it (imports flow from the run down to the FFI). Reads the
//! sources as text: every `crate::X` path in a file of layer L must name a layer below L (or
//! L itself), and every layer's `mod.rs` says in its doc comment what it may use, which must
//! be exactly the layers below it.

use std::collections::BTreeSet;
use std::fs;
use std::path::{Path, PathBuf};

/// The layers, from the top (the run) to the bottom (the FFI and the operating system).
const LAYERS: [&str; 10] = [
    "app", "io", "estimate", "dd", "problem", "parallel", "qp", "fem", "petsc", "os",
];

fn rank(layer: &str) -> Option<usize> {
    LAYERS.iter().position(|&l| l == layer)
}

fn sources(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in fs::read_dir(dir).expect("src/ readable") {
        let p = e.expect("entry").path();
        if p.is_dir() {
            sources(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// The crate-level names a source refers to through `crate::`, outside comments.
fn crate_refs(text: &str) -> BTreeSet<String> {
    let mut refs = BTreeSet::new();
    for line in text.lines() {
        let code = line.split("//").next().unwrap_or("");
        let mut rest = code;
        while let Some(i) = rest.find("crate::") {
            rest = &rest[i + "crate::".len()..];
            if let Some(group) = rest.strip_prefix('{') {
                // `use crate::{a::b, c};`: the first segment of each item.
                let inner = group.split('}').next().unwrap_or("");
                for item in inner.split(',') {
                    let name: String = item
                        .trim()
                        .chars()
                        .take_while(|c| c.is_alphanumeric() || *c == '_')
                        .collect();
                    if !name.is_empty() {
                        refs.insert(name);
                    }
                }
            } else {
                let name: String = rest
                    .chars()
                    .take_while(|c| c.is_alphanumeric() || *c == '_')
                    .collect();
                refs.insert(name);
            }
        }
    }
    refs
}

#[test]
fn every_layer_uses_only_the_layers_below_it() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    sources(&src, &mut files);
    let mut violations = Vec::new();
    let mut seen = BTreeSet::new();
    for f in &files {
        let rel = f.strip_prefix(&src).unwrap();
        let first = rel
            .components()
            .next()
            .unwrap()
            .as_os_str()
            .to_string_lossy();
        let layer = first.trim_end_matches(".rs").to_string();
        let text = fs::read_to_string(f).unwrap();
        let Some(r) = rank(&layer) else {
            // The crate root, the binary and test helpers sit above or beside the layers.
            assert!(
                ["lib", "main", "testutil"].contains(&layer.as_str()),
                "{}: a file outside the layer folders",
                rel.display()
            );
            continue;
        };
        assert!(
            f.parent().unwrap() != src,
            "{}: a layer is a folder with a mod.rs",
            rel.display()
        );
        seen.insert(layer.clone());
        for name in crate_refs(&text) {
            match rank(&name) {
                Some(t) if t < r => violations.push(format!(
                    "{} (layer {layer}) uses crate::{name}, a layer above it",
                    rel.display()
                )),
                Some(_) => {}
                None if name == "testutil" => {}
                None => violations.push(format!("{}: crate::{name} is not a layer", rel.display())),
            }
        }
    }
    assert!(violations.is_empty(), "{}", violations.join("\n"));
    assert_eq!(
        seen.len(),
        LAYERS.len(),
        "every layer has sources: {seen:?}"
    );
}

#[test]
fn every_layer_says_what_it_may_use() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    for (r, layer) in LAYERS.iter().enumerate() {
        let text = fs::read_to_string(src.join(layer).join("mod.rs"))
            .unwrap_or_else(|_| panic!("src/{layer}/mod.rs"));
        let doc: Vec<&str> = text.lines().take_while(|l| l.starts_with("//!")).collect();
        assert!(!doc.is_empty(), "src/{layer}/mod.rs has no doc comment");
        let doc = doc.join(" ");
        let may = doc
            .split("May use:")
            .nth(1)
            .unwrap_or_else(|| panic!("src/{layer}/mod.rs: no 'May use:' line"));
        let named: BTreeSet<&str> = LAYERS
            .iter()
            .copied()
            .filter(|l| may.contains(&format!("`{l}`")))
            .collect();
        let below: BTreeSet<&str> = LAYERS[r + 1..].iter().copied().collect();
        assert_eq!(
            named, below,
            "src/{layer}/mod.rs: 'May use:' must name the layers below it"
        );
    }
}

#[test]
fn the_reference_parser_finds_grouped_and_inline_paths() {
    let refs = crate_refs(
        "use crate::{fem::Mesh, qp};\nlet x = crate::dd::nndd::solve(); // crate::app here is a comment\n",
    );
    let want: BTreeSet<String> = ["fem", "qp", "dd"].iter().map(|s| s.to_string()).collect();
    assert_eq!(refs, want);
}
