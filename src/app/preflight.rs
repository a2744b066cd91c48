//! What is checked before PETSc starts. PETSc reads an `-options_file` on rank 0
//! and broadcasts its content: a file that rank 0 cannot read stops rank 0 inside
//! `PetscInitialize` while the other ranks wait for the broadcast for ever. So every rank
//! first checks, itself, that each options file of the command line can be read, and the
//! files these name (PETSc follows `-options_file` lines inside a file), and the ranks agree
//! on the outcome before PETSc starts.

use std::path::{Path, PathBuf};

/// Options that name a file PETSc reads at initialisation.
const FILE_OPTIONS: [&str; 2] = ["-options_file", "-options_file_yaml"];

/// Files nested deeper than this are taken as a cycle.
const MAX_DEPTH: usize = 16;

/// `Ok` if every options file named on the command line `args` (and in those files) can be
/// read; else the one-line reason, naming the option and the file.
pub fn options_files(args: &[String]) -> Result<(), String> {
    check_tokens(&mut args.iter().skip(1).map(String::as_str), None, 0)
}

fn check_tokens(
    tokens: &mut dyn Iterator<Item = &str>,
    within: Option<&Path>,
    depth: usize,
) -> Result<(), String> {
    let mut tokens = tokens.peekable();
    while let Some(t) = tokens.next() {
        let Some(option) = FILE_OPTIONS.iter().find(|o| **o == t) else {
            continue;
        };
        let place = within.map_or(String::new(), |f| format!(" (in {})", f.display()));
        let Some(name) = tokens.next_if(|v| !v.starts_with('-') || v.len() == 1) else {
            return Err(format!("{option} needs a file name{place}"));
        };
        let path = expand_home(name);
        let text = std::fs::read(&path)
            .map_err(|e| format!("{option} {name}{place}: cannot read the file ({e})"))?;
        if *option == "-options_file" {
            if depth >= MAX_DEPTH {
                return Err(format!(
                    "{option} {name}{place}: options files nested more than {MAX_DEPTH} deep (a cycle?)"
                ));
            }
            let text = String::from_utf8_lossy(&text);
            let mut words = Vec::new();
            for (k, line) in text.lines().enumerate() {
                let tokens = line_tokens(line);
                check_line(&tokens)
                    .map_err(|why| format!("{option} {name}{place}: line {}: {why}", k + 1))?;
                words.extend(tokens);
            }
            check_tokens(&mut words.into_iter(), Some(&path), depth + 1)?;
        }
    }
    Ok(())
}

/// The words of one line of an options file as PETSc 3.18 splits them
/// (`PetscOptionsInsertFilePetsc`): the text after `#` is a comment, words are separated by
/// blanks, and a word in double quotes may contain blanks.
fn line_tokens(line: &str) -> Vec<&str> {
    let line = line.split('#').next().unwrap_or("");
    let mut tokens = Vec::new();
    let mut rest = line.trim_start();
    while !rest.is_empty() {
        let end = if let Some(quoted) = rest.strip_prefix('"') {
            quoted.find('"').map_or(rest.len(), |e| e + 2)
        } else {
            rest.find(char::is_whitespace).unwrap_or(rest.len())
        };
        tokens.push(rest[..end].trim_matches('"'));
        rest = rest[end..].trim_start();
    }
    tokens
}

/// PETSc's rule for a line of an options file: `-name [value]`, or `alias NAME VALUE`.
/// PETSc stops at anything else on rank 0 alone, with a page of errors, after the other ranks
/// went on; here every rank finds it first.
fn check_line(tokens: &[&str]) -> Result<(), String> {
    let Some(first) = tokens.first() else {
        return Ok(());
    };
    let most = if first.eq_ignore_ascii_case("alias") {
        if tokens.len() < 3 {
            return Err("must be 'alias NAME VALUE'".into());
        }
        3
    } else if first.starts_with('-') && first.len() > 1 {
        2
    } else {
        return Err(format!(
            "'{first}' is not an option (a line is '-name value', e.g. '-nndd_tol 1e-8')"
        ));
    };
    match tokens.get(most) {
        Some(extra) => Err(format!(
            "extra word '{extra}' after '{}' (a line is one option and at most one value, e.g. '-nndd_tol 1e-8', without '=')",
            tokens[..most].join(" ")
        )),
        None => Ok(()),
    }
}

/// `~/…` as PETSc reads it (the home directory).
fn expand_home(name: &str) -> PathBuf {
    match (name.strip_prefix("~/"), std::env::var_os("HOME")) {
        (Some(rest), Some(home)) => Path::new(&home).join(rest),
        _ => PathBuf::from(name),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(v: &[&str]) -> Vec<String> {
        std::iter::once("nndd")
            .chain(v.iter().copied())
            .map(String::from)
            .collect()
    }

    #[test]
    fn missing_and_nested_options_files_are_named() {
        let dir = std::env::temp_dir().join(format!("nndd-preflight-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let inner = dir.join("inner.opts");
        let outer = dir.join("outer.opts");
        let cyclic = dir.join("cyclic.opts");
        std::fs::write(
            &inner,
            "-nndd_n 4 # a comment -options_file not-this.opts\n",
        )
        .unwrap();
        std::fs::write(
            &outer,
            format!("-nndd_tol 1e-6\n-options_file {}\n", inner.display()),
        )
        .unwrap();
        std::fs::write(&cyclic, format!("-options_file {}\n", cyclic.display())).unwrap();
        let o = outer.to_str().unwrap();
        assert_eq!(
            options_files(&args(&["-options_file", o, "-nndd_n", "8"])),
            Ok(())
        );
        assert_eq!(options_files(&args(&["-nndd_n", "8"])), Ok(()));

        let e = options_files(&args(&["-options_file", "missing.opts"])).unwrap_err();
        assert!(
            e.starts_with("-options_file missing.opts: cannot read the file"),
            "{e}"
        );
        assert_eq!(e.lines().count(), 1);
        let e = options_files(&args(&["-nndd_n", "2", "-options_file"])).unwrap_err();
        assert_eq!(e, "-options_file needs a file name");

        // A missing file named inside another is reported with the file that names it.
        std::fs::remove_file(&inner).unwrap();
        let e = options_files(&args(&["-options_file", o])).unwrap_err();
        assert!(
            e.contains("inner.opts") && e.contains(&format!("(in {o})")),
            "{e}"
        );
        let e = options_files(&args(&["-options_file", cyclic.to_str().unwrap()])).unwrap_err();
        assert!(e.contains("nested more than 16 deep"), "{e}");

        // PETSc's line syntax: one option and at most one value per line.
        let bad = dir.join("bad.opts");
        for (text, line, word) in [
            (
                "-nndd_problem paper\n-nndd_tol = 1e-8\n",
                2,
                "extra word '1e-8'",
            ),
            ("-nndd_n 8 -nndd_tol 1e-8\n", 1, "extra word '-nndd_tol'"),
            ("# c\n\nnndd_tol 1e-8\n", 3, "'nndd_tol' is not an option"),
            ("alias -a\n", 1, "alias NAME VALUE"),
        ] {
            std::fs::write(&bad, text).unwrap();
            let e = options_files(&args(&["-options_file", bad.to_str().unwrap()])).unwrap_err();
            assert!(e.contains(&format!("bad.opts: line {line}: ")), "{e}");
            assert!(e.contains(word), "{e}");
        }
        std::fs::write(
            &bad,
            "-a -1 # -b 2\n  -c \"x y\"\nalias -d -e\n-f\n\n-g -2.5e3\n",
        )
        .unwrap();
        assert_eq!(
            options_files(&args(&["-options_file", bad.to_str().unwrap()])),
            Ok(())
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
