//! The source layout is the pipeline: each stage of the library may use only
//! the stages before it, and the binary's subcommands share only `cli/args`.
//! This reads `src/` as text, so a new upward `crate::` path fails here.

use std::path::{Path, PathBuf};

/// The library's stages in pipeline order; a stage may use any stage at or
/// before its own position.
const STAGES: &[&str] = &[
    "file", "types", "expr", "lang", "proof", "formula", "bounds", "ray", "scene", "mesh", "render",
];

/// Every `.rs` file below `dir`, walked with an explicit stack.
fn rust_files(dir: &Path) -> Vec<PathBuf> {
    let mut files = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
            } else if path.extension().is_some_and(|e| e == "rs") {
                files.push(path);
            }
        }
    }
    files.sort();
    files
}

/// The code lines of a file (comments and doc comments, with their doctests, left out).
fn code_lines(path: &Path) -> Vec<(usize, String)> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim_start().starts_with("//"))
        .map(|(i, l)| (i + 1, l.to_string()))
        .collect()
}

/// The identifiers that follow each occurrence of `prefix` in `line`.
fn paths_after<'a>(line: &'a str, prefix: &str) -> Vec<&'a str> {
    line.match_indices(prefix)
        .map(|(i, _)| {
            let rest = &line[i + prefix.len()..];
            let end = rest
                .find(|c: char| !(c.is_alphanumeric() || c == '_'))
                .unwrap_or(rest.len());
            &rest[..end]
        })
        .collect()
}

fn src() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("src")
}

/// The stage a library file belongs to: its folder, or `formula` for `src/formula.rs`.
fn stage_of(path: &Path) -> Option<&'static str> {
    let rel = path.strip_prefix(src()).unwrap();
    let first = rel.components().next()?.as_os_str().to_str()?;
    let name = first.strip_suffix(".rs").unwrap_or(first);
    STAGES.iter().copied().find(|&s| s == name)
}

#[test]
fn no_stage_uses_a_later_one() {
    let rank = |s: &str| STAGES.iter().position(|&t| t == s);
    let mut wrong = Vec::new();
    let mut checked = 0;
    for path in rust_files(&src()) {
        let Some(stage) = stage_of(&path) else {
            continue;
        };
        checked += 1;
        for (n, line) in code_lines(&path) {
            assert!(
                !line.contains("crate::{"),
                "{}:{n}: write one `use crate::stage::…` per stage, so this test can read it",
                path.display()
            );
            for used in paths_after(&line, "crate::") {
                match rank(used) {
                    Some(r) if r > rank(stage).unwrap() => wrong.push(format!(
                        "{}:{n}: `{stage}` uses the later stage `{used}`",
                        path.display()
                    )),
                    Some(_) => {}
                    None => wrong.push(format!(
                        "{}:{n}: `crate::{used}` is not a stage",
                        path.display()
                    )),
                }
            }
        }
    }
    assert!(checked > 20, "only {checked} library files found");
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
}

#[test]
fn the_library_does_not_use_binary_only_crates() {
    for path in rust_files(&src()) {
        if stage_of(&path).is_none() {
            continue;
        }
        for (n, line) in code_lines(&path) {
            for krate in ["clap::", "anyhow::", "indicatif::", "plotters::", "libc::"] {
                assert!(
                    !line.contains(krate),
                    "{}:{n}: `{krate}` belongs to the binary",
                    path.display()
                );
            }
        }
    }
}

/// The command line's modules every subcommand may use: its options and
/// its figures.
const SHARED: [&str; 2] = ["args", "plot"];

#[test]
fn subcommands_share_only_the_argument_and_plot_modules() {
    let cli = src().join("cli");
    for path in rust_files(&cli) {
        let file = path.file_name().unwrap().to_str().unwrap();
        // How far below `cli` the file's module is: 1 for `cli/x.rs` and a
        // subcommand folder's `mod.rs`, 2 for the other files of the folder
        // (which may use each other as `super::`).
        let depth =
            path.strip_prefix(&cli).unwrap().components().count() - usize::from(file == "mod.rs");
        let to_cli = match depth {
            0 => continue,
            1 => "super::",
            _ => "super::super::",
        };
        // The shared modules themselves use none of the others.
        let shared = path.parent() == Some(cli.as_path())
            && SHARED.iter().any(|s| file == format!("{s}.rs"));
        for (n, line) in code_lines(&path) {
            assert!(
                !line.contains("crate::"),
                "{}:{n}: the binary reaches the library as `lgc::`",
                path.display()
            );
            for used in paths_after(&line, to_cli) {
                assert!(
                    SHARED.contains(&used) && !shared,
                    "{}:{n}: a subcommand may use only {SHARED:?} of the command line, not `{used}`",
                    path.display()
                );
            }
        }
    }
}

/// The proof checker must not trust what it checks: it reads the formula
/// with the parser and computes with the interval type, and uses nothing
/// else of lgc (no expression graph, simplifier, tapes or bound methods).
#[test]
fn the_proof_checker_uses_only_the_parser_and_the_interval_type() {
    let files = rust_files(&src().join("proof"));
    assert!(files.len() >= 3, "src/proof/ holds the checker");
    for path in files {
        for (n, line) in code_lines(&path) {
            for stage in paths_after(&line, "crate::") {
                assert!(
                    matches!(stage, "lang" | "types")
                        && !line.contains("lower")
                        && !line.contains("expr"),
                    "{}:{n}: the checker uses crate::{stage}: {line}",
                    path.display()
                );
            }
        }
    }
}
