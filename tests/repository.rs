//! Capability: the repository speaks of nndd as it is. No file under docs/, src/, tests/ or
//! jobs/, nor the README, cites an issue number, a work session or a work-log date: how a
//! figure improved belongs in git log, the docs give the current figures and the commands
//! behind them.

use std::path::{Path, PathBuf};

fn files(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        let p = e.path();
        if p.is_dir() {
            files(&p, out);
        } else if p
            .extension()
            .and_then(|x| x.to_str())
            .is_some_and(|x| ["rs", "md", "py", "sh", "geo", "opts", "sbatch", "txt"].contains(&x))
            || p.extension().is_none()
        {
            out.push(p);
        }
    }
}

/// What in `line` reads as a work log: "issue" + a number, "session", or a date YYYY-MM-DD.
fn work_log(line: &str) -> Option<&'static str> {
    let lower = line.to_lowercase();
    let b = lower.as_bytes();
    // The words are put together here so that this file does not name them.
    let issue = ["iss", "ue "].concat();
    let session = ["sess", "ion"].concat();
    for (i, _) in lower.match_indices(&issue) {
        let rest = lower[i + issue.len()..].trim_start_matches('#');
        if rest.starts_with(|c: char| c.is_ascii_digit()) {
            return Some("an issue number");
        }
    }
    if lower.contains(&session) {
        return Some("a work session");
    }
    let digit = |k: usize| b.get(k).is_some_and(|c| c.is_ascii_digit());
    for i in 0..b.len() {
        if b[i] == b'2'
            && b.get(i + 1) == Some(&b'0')
            && (2..4).all(|k| digit(i + k))
            && b.get(i + 4) == Some(&b'-')
            && (5..7).all(|k| digit(i + k))
            && b.get(i + 7) == Some(&b'-')
            && (8..10).all(|k| digit(i + k))
        {
            return Some("a date");
        }
    }
    None
}

#[test]
fn no_file_reads_as_a_work_log() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut all = vec![root.join("README.md")];
    for dir in ["docs", "src", "tests", "jobs"] {
        files(&root.join(dir), &mut all);
    }
    let mut found = Vec::new();
    // This file names what it looks for.
    let this = root.join("tests/repository.rs");
    for f in all.iter().filter(|f| **f != this) {
        let Ok(text) = std::fs::read_to_string(f) else {
            continue; // not text (pictures)
        };
        for (k, line) in text.lines().enumerate() {
            if let Some(what) = work_log(line) {
                found.push(format!(
                    "{}:{}: {what}: {}",
                    f.strip_prefix(root).unwrap().display(),
                    k + 1,
                    line.trim()
                ));
            }
        }
    }
    assert!(all.len() > 100, "only {} files read", all.len());
    assert!(found.is_empty(), "{}", found.join("\n"));
}

#[test]
fn the_check_finds_what_it_looks_for() {
    let issue = ["Iss", "ue 11"].concat();
    assert_eq!(
        work_log(&format!("## The cost ({issue})")),
        Some("an issue number")
    );
    let session = ["the second sess", "ion"].concat();
    assert_eq!(work_log(&session), Some("a work session"));
    assert_eq!(work_log("measured on 2026-11-24"), Some("a date"));
    assert_eq!(work_log("the issue is the θ of body 1; E = 2.1e11"), None);
}
