//! Capability: the code's layout shows the method. `src/` is one folder per layer, and a
//! layer uses only the layers below it (imports flow from the run down to the FFI). Reads the
//! sources as text: every `crate::X` path in a file of layer L must name a layer below L (or
//! L itself), and every layer's `mod.rs` says in its doc comment what it may use, which must
//! be exactly the layers below it. Inside a layer, no modules use each other in a circle
//! (through `super::` and `crate::<layer>::` paths outside test code), but for the circles
//! listed as existing today.

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

/// `text` without its comments and without the contents of its string and character
/// literals (kept as `""` and `' '`), so that neither a commented-out path nor a brace in a
/// format string counts.
fn code_only(text: &str) -> String {
    let c: Vec<char> = text.chars().collect();
    let mut out = String::with_capacity(text.len());
    let mut i = 0;
    while i < c.len() {
        let next = c.get(i + 1).copied();
        if c[i] == '/' && next == Some('/') {
            while i < c.len() && c[i] != '\n' {
                i += 1;
            }
        } else if c[i] == '/' && next == Some('*') {
            let mut depth = 0;
            while i < c.len() {
                if c[i] == '/' && c.get(i + 1) == Some(&'*') {
                    depth += 1;
                    i += 2;
                } else if c[i] == '*' && c.get(i + 1) == Some(&'/') {
                    depth -= 1;
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    i += 1;
                }
            }
            out.push(' ');
        } else if c[i] == 'r'
            && (next == Some('"') || next == Some('#'))
            && (i == 0 || !(c[i - 1].is_alphanumeric() || c[i - 1] == '_'))
        {
            // A raw string r"…" or r#"…"#.
            let mut j = i + 1;
            let mut hashes = 0;
            while c.get(j) == Some(&'#') {
                hashes += 1;
                j += 1;
            }
            if c.get(j) != Some(&'"') {
                out.push(c[i]);
                i += 1;
                continue;
            }
            j += 1;
            while j < c.len() && !(c[j] == '"' && (1..=hashes).all(|k| c.get(j + k) == Some(&'#')))
            {
                j += 1;
            }
            i = j + 1 + hashes;
            out.push_str("\"\"");
        } else if c[i] == '"' {
            i += 1;
            while i < c.len() && c[i] != '"' {
                i += if c[i] == '\\' { 2 } else { 1 };
            }
            i += 1;
            out.push_str("\"\"");
        } else if c[i] == '\'' && next == Some('\\') {
            // An escaped character literal: '\n', '\'', '\u{…}'.
            i += 3;
            while i < c.len() && c[i] != '\'' {
                i += 1;
            }
            i += 1;
            out.push_str("' '");
        } else if c[i] == '\'' && c.get(i + 2) == Some(&'\'') {
            i += 3;
            out.push_str("' '");
        } else {
            out.push(c[i]);
            i += 1;
        }
    }
    out
}

fn is_ident(c: char) -> bool {
    c.is_alphanumeric() || c == '_'
}

/// The paths of a `use` tree or an inline path starting at `c[*i]` (after its first `::`):
/// `a::b`, `a::{b, c::{d, e}}`, `a::*`, each as its segments after `prefix`.
fn path_tree(c: &[char], i: &mut usize, prefix: &[String], out: &mut Vec<Vec<String>>) {
    let skip_ws = |i: &mut usize| {
        while *i < c.len() && c[*i].is_whitespace() {
            *i += 1;
        }
    };
    let mut path = prefix.to_vec();
    loop {
        skip_ws(i);
        if c.get(*i) == Some(&'{') {
            *i += 1;
            loop {
                skip_ws(i);
                match c.get(*i) {
                    Some('}') => {
                        *i += 1;
                        return;
                    }
                    Some(',') => *i += 1,
                    Some(_) => {
                        let before = *i;
                        path_tree(c, i, &path, out);
                        // Skip `as name` and anything else up to the next item.
                        while *i < c.len() && c[*i] != ',' && c[*i] != '}' {
                            *i += 1;
                        }
                        if *i == before {
                            *i += 1;
                        }
                    }
                    None => return,
                }
            }
        }
        let start = *i;
        while *i < c.len() && is_ident(c[*i]) {
            *i += 1;
        }
        let name: String = c[start..*i].iter().collect();
        let last = name.is_empty() || c.get(*i) != Some(&':') || c.get(*i + 1) != Some(&':');
        if !name.is_empty() && name != "self" {
            path.push(name);
        }
        if last {
            out.push(path);
            return;
        }
        *i += 2;
    }
}

/// The code under `#[cfg(test)]` in `c` (the item after each: up to its `;` or through its
/// braces), and the names of the modules declared there with a file of their own
/// (`#[cfg(test)] mod testutil;`).
fn test_code(c: &[char]) -> (Vec<std::ops::Range<usize>>, Vec<String>) {
    let attribute: Vec<char> = "#[cfg(test)]".chars().collect();
    let (mut regions, mut modules) = (Vec::new(), Vec::new());
    let mut i = 0;
    while i < c.len() {
        if !c[i..].starts_with(&attribute) {
            i += 1;
            continue;
        }
        let start = i;
        i += attribute.len();
        while i < c.len() && c[i] != ';' && c[i] != '{' {
            i += 1;
        }
        if c.get(i) == Some(&'{') {
            let mut depth = 0;
            while i < c.len() {
                depth += match c[i] {
                    '{' => 1,
                    '}' => -1,
                    _ => 0,
                };
                i += 1;
                if depth == 0 {
                    break;
                }
            }
        } else {
            let item: String = c[start + attribute.len()..i].iter().collect();
            let words: Vec<&str> = item.split_whitespace().collect();
            if let [.., "mod", name] = words[..] {
                modules.push(name.to_string());
            }
        }
        regions.push(start..i);
    }
    (regions, modules)
}

/// What the file of one module refers to: the absolute paths (segments after `crate::`) it
/// names through `super::` (relative to the module the path is written in: the file's, or
/// an inline `mod … { … }` in it) or `crate::`, outside comments, strings and test code; and
/// its child modules that exist for tests only.
struct Refs {
    paths: Vec<Vec<String>>,
    test_modules: Vec<String>,
}

/// The [`Refs`] of the file of module `module`, whose text is `text`.
fn module_refs(module: &[String], text: &str) -> Refs {
    let c: Vec<char> = code_only(text).chars().collect();
    let (tests, test_modules) = test_code(&c);
    let in_tests = |i: usize| tests.iter().any(|r| r.contains(&i));
    let mut out = Vec::new();
    // The braces open at each point, with the inline module each opens (if any).
    let mut braces: Vec<Option<String>> = Vec::new();
    let starts = |i: usize, word: &str| {
        c[i..].starts_with(&word.chars().collect::<Vec<_>>())
            && (i == 0 || !(is_ident(c[i - 1]) || c[i - 1] == ':'))
    };
    let mut i = 0;
    while i < c.len() {
        if c[i] == '{' {
            // `mod name {`: the two words before the brace.
            let word_before = |end: usize| {
                let end = c[..end]
                    .iter()
                    .rposition(|x| !x.is_whitespace())
                    .map_or(0, |e| e + 1);
                let start = c[..end]
                    .iter()
                    .rposition(|&x| !is_ident(x))
                    .map_or(0, |s| s + 1);
                (start, c[start..end].iter().collect::<String>())
            };
            let (start, name) = word_before(i);
            let inline = (word_before(start).1 == "mod" && !name.is_empty()).then_some(name);
            braces.push(inline);
            i += 1;
        } else if c[i] == '}' {
            braces.pop();
            i += 1;
        } else if (starts(i, "super::") || starts(i, "crate::") || starts(i, "$crate::"))
            && in_tests(i)
        {
            i += 1;
        } else if starts(i, "super::") {
            let mut here: Vec<String> = module.to_vec();
            here.extend(braces.iter().flatten().cloned());
            while c[i..].starts_with(&['s', 'u', 'p', 'e', 'r', ':', ':']) {
                here.pop();
                i += "super::".len();
            }
            path_tree(&c, &mut i, &here, &mut out);
        } else if starts(i, "crate::") || starts(i, "$crate::") {
            i += "crate::".len() + usize::from(c[i] == '$');
            path_tree(&c, &mut i, &[], &mut out);
        } else {
            i += 1;
        }
    }
    Refs {
        paths: out,
        test_modules,
    }
}

/// The module of a source file under `src/`: `estimate/equilibrate/eet.rs` is
/// `estimate::equilibrate::eet`, `estimate/equilibrate/mod.rs` `estimate::equilibrate`.
fn module_of(rel: &Path) -> Vec<String> {
    let mut m: Vec<String> = rel
        .with_extension("")
        .components()
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .collect();
    if m.last().is_some_and(|l| l == "mod") {
        m.pop();
    }
    m
}

/// Which modules of the same layer each module uses: every path is taken to the longest of
/// its prefixes that is a module with a file (`super::topology::Topology` is
/// `…::topology`, `super::NONE` the parent `mod.rs`); a module's use of itself is no edge.
fn layer_graph(
    files: &[(Vec<String>, String)],
) -> std::collections::BTreeMap<String, BTreeSet<String>> {
    let refs: Vec<(&Vec<String>, Refs)> =
        files.iter().map(|(m, t)| (m, module_refs(m, t))).collect();
    // Modules for tests only (`#[cfg(test)] mod testutil;`, and their children) are no part
    // of the graph.
    let tests: Vec<Vec<String>> = refs
        .iter()
        .flat_map(|(m, r)| {
            r.test_modules
                .iter()
                .map(|t| [m.as_slice(), std::slice::from_ref(t)].concat())
        })
        .collect();
    let refs: Vec<_> = refs
        .into_iter()
        .filter(|(m, _)| !tests.iter().any(|t| m.starts_with(t)))
        .collect();
    let modules: BTreeSet<Vec<String>> = refs.iter().map(|(m, _)| (*m).clone()).collect();
    let mut graph = std::collections::BTreeMap::new();
    for (m, r) in refs {
        let uses: &mut BTreeSet<String> = graph.entry(m.join("::")).or_default();
        for path in r.paths {
            if path.first() != m.first() {
                continue; // another layer: the layering test's business
            }
            let Some(target) = (1..=path.len())
                .rev()
                .map(|k| path[..k].to_vec())
                .find(|p| modules.contains(p))
            else {
                continue;
            };
            if target != **m {
                uses.insert(target.join("::"));
            }
        }
    }
    graph
}

/// The import circles of `graph`: each strongly connected set of two or more modules, as one
/// circle through it (`a → b → c → a`) and the set.
fn circles(
    graph: &std::collections::BTreeMap<String, BTreeSet<String>>,
) -> Vec<(Vec<String>, BTreeSet<String>)> {
    let reach = |from: &str| {
        let mut seen = BTreeSet::new();
        let mut todo = vec![from.to_string()];
        while let Some(n) = todo.pop() {
            for m in graph.get(&n).into_iter().flatten() {
                if seen.insert(m.clone()) {
                    todo.push(m.clone());
                }
            }
        }
        seen
    };
    let reaches: std::collections::BTreeMap<&String, BTreeSet<String>> =
        graph.keys().map(|n| (n, reach(n))).collect();
    let mut found: Vec<(Vec<String>, BTreeSet<String>)> = Vec::new();
    for (n, r) in &reaches {
        if !r.contains(*n) || found.iter().any(|(_, set)| set.contains(*n)) {
            continue;
        }
        let set: BTreeSet<String> = r
            .iter()
            .filter(|m| reaches.get(m).is_some_and(|back| back.contains(*n)))
            .cloned()
            .collect();
        // One circle: the shortest way from n back to n (breadth first).
        let mut from = std::collections::BTreeMap::new();
        let mut queue = std::collections::VecDeque::from([(*n).clone()]);
        'search: while let Some(a) = queue.pop_front() {
            for b in &graph[&a] {
                if b == *n {
                    from.insert(b.clone(), a.clone());
                    break 'search;
                }
                if set.contains(b) && !from.contains_key(b) {
                    from.insert(b.clone(), a.clone());
                    queue.push_back(b.clone());
                }
            }
        }
        let mut circle = vec![(*n).clone()];
        let mut at = from[*n].clone();
        while at != **n {
            circle.push(at.clone());
            at = from[&at].clone();
        }
        circle[1..].reverse();
        circle.push((*n).clone());
        found.push((circle, set));
    }
    found
}

#[test]
fn no_layer_has_an_import_circle_inside() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut paths = Vec::new();
    sources(&src, &mut paths);
    let files: Vec<(Vec<String>, String)> = paths
        .iter()
        .map(|f| {
            let m = module_of(f.strip_prefix(&src).unwrap());
            (m, fs::read_to_string(f).unwrap())
        })
        .filter(|(m, _)| m.first().is_some_and(|l| rank(l).is_some()))
        .collect();
    let graph = layer_graph(&files);
    let new: Vec<String> = circles(&graph)
        .into_iter()
        .map(|(circle, set)| format!("{} (the circle of {set:?})", circle.join(" → ")))
        .collect();
    assert!(
        new.is_empty(),
        "modules of a layer that use each other in a circle:\n{}",
        new.join("\n")
    );
}

#[test]
fn the_module_reference_parser_reads_super_crate_groups_inline_and_test_modules() {
    let module: Vec<String> = ["io", "output", "h5"].map(String::from).to_vec();
    let text = "use super::team::{agree, Writers};\n\
        use super::{\n    entries,\n    xdmf::{self, Grid as G},\n};\n\
        // use super::atomic::write; a comment\n\
        let s = \"super::validate:: { in a string\";\n\
        let r = crate::io::monitor::say(x);\n\
        $crate::io::summary::Summary;\n\
        mod inner {\n    use super::*;\n    use super::super::fields;\n}\n\
        #[cfg(test)]\nmod testutil;\n\
        #[cfg(test)]\nmod tests {\n    use super::super::atomic;\n    fn f() { \"}\" }\n}\n\
        use super::validate;";
    let found = module_refs(&module, text);
    assert_eq!(found.test_modules, ["testutil"]);
    let refs: BTreeSet<String> = found.paths.into_iter().map(|p| p.join("::")).collect();
    let want: BTreeSet<String> = [
        "io::output::team::agree",
        "io::output::team::Writers",
        "io::output::entries",
        "io::output::xdmf",
        "io::output::xdmf::Grid",
        "io::monitor::say",
        "io::summary::Summary",
        "io::output::h5",
        "io::output::fields",
        "io::output::validate",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    assert_eq!(refs, want);
}

#[test]
fn the_circle_finder_finds_a_circle_through_an_items_module() {
    let file = |m: &str, text: &str| {
        let m: Vec<String> = m.split("::").map(String::from).collect();
        (m, text.to_string())
    };
    let files = [
        file(
            "qp",
            "pub mod a;\npub mod b;\npub mod c;\npub const N: usize = 1;",
        ),
        file("qp::a", "use super::b::f;\nuse super::N;"),
        file("qp::b", "pub fn f() { crate::qp::c::g() }"),
        file("qp::c", "pub fn g() { let _ = super::a::h; }"),
        file("fem", "pub mod d;"),
        file("fem::d", "use crate::qp::a;"),
        // Test code makes no circle: b's tests, and a module for tests only.
        file(
            "qp::b::x",
            "#[cfg(test)]\nmod t;\n#[cfg(test)]\nmod tests { use crate::qp::b; }",
        ),
        file("qp::b::x::t", "use crate::qp::b::x;"),
    ];
    let found = circles(&layer_graph(&files));
    assert_eq!(found.len(), 1, "{found:?}");
    assert_eq!(found[0].0, ["qp::a", "qp::b", "qp::c", "qp::a"]);
}
