//! The numerical fingerprint: a hash of the content of the sources that compute numbers — the
//! numerical crates, the experiment kinds' work, the method vocabulary, the row formatting, the
//! dependency lock and the build profile — and of nothing else (not the CLI, its help text, the
//! docs, the configs, the report writer or the kinds' discussions, verdicts and figures). Rows
//! record the fingerprint of the binary that computed them; a row whose fingerprint is not the
//! binary's is *stale* (docs/provenance.md). A dirty tree has an identity like any commit, and a
//! docs-only commit keeps every row valid.
//!
//! The build script (`crates/runner/build.rs`) includes this file and computes
//! [`crate::manifest::CODE_FINGERPRINT`] when the runner is compiled; tests call [`of_tree`] on
//! copies of the workspace. Only `std` and `blake3`: the build script compiles it too.

use std::path::{Path, PathBuf};

/// Folders (relative to the workspace root) whose every source file counts, recursively.
pub const NUMERICAL_DIRS: &[&str] = &[
    "crates/names/src",
    "crates/sh/src",
    "crates/scaling/src",
    "crates/geometry/src",
    "crates/field/src",
    "crates/scene/src",
    "crates/gpu/src",
    "experiments/src",
];

/// Single files that count: the manifests of the numerical crates (features, dependencies), the
/// workspace's (profiles), the lock (dependency versions: glam, obvhs, spade compute numbers),
/// the runner's row formatting and timing procedure, and the reading of an environment map
/// (`shscale_present::image`: its texels checked and its ringing clamped, so a scene's light).
pub const NUMERICAL_FILES: &[&str] = &[
    "Cargo.toml",
    "Cargo.lock",
    "crates/names/Cargo.toml",
    "crates/sh/Cargo.toml",
    "crates/scaling/Cargo.toml",
    "crates/geometry/Cargo.toml",
    "crates/field/Cargo.toml",
    "crates/scene/Cargo.toml",
    "crates/gpu/Cargo.toml",
    "experiments/Cargo.toml",
    "crates/runner/src/records.rs",
    "crates/runner/src/timing.rs",
    "crates/present/src/image.rs",
];

/// File names inside [`NUMERICAL_DIRS`] that write words and pictures from rows, never rows:
/// the kinds' discussions, verdicts and figures, and test modules.
pub const PRESENTATION_NAMES: &[&str] = &[
    "discussion.rs",
    "verdict.rs",
    "figure.rs",
    "figures.rs",
    "tests.rs",
];

/// Whether a file inside [`NUMERICAL_DIRS`] counts: a source (`.rs`, `.wgsl`) that is not
/// presentation — named in [`PRESENTATION_NAMES`], `*_tests.rs` or `*_report.rs` (a kind's
/// report, verdict and discussion), or inside a folder so named (`verdict/`, `tests/`: a module
/// split into files keeps its classification).
pub fn counts(path: &Path) -> bool {
    let name = path
        .file_name()
        .map_or(String::new(), |n| n.to_string_lossy().to_string());
    let source = name.ends_with(".rs") || name.ends_with(".wgsl");
    let in_presentation_folder = path.parent().is_some_and(|p| {
        p.components().any(|c| {
            let folder = format!("{}.rs", c.as_os_str().to_string_lossy());
            PRESENTATION_NAMES.contains(&folder.as_str())
        })
    });
    source
        && !PRESENTATION_NAMES.contains(&name.as_str())
        && !name.ends_with("_tests.rs")
        && !name.ends_with("_report.rs")
        && !in_presentation_folder
}

/// Every file that counts under `root`, relative to it, sorted (absent ones left out).
pub fn files(root: &Path) -> Vec<PathBuf> {
    let mut out: Vec<PathBuf> = NUMERICAL_FILES
        .iter()
        .map(PathBuf::from)
        .filter(|p| root.join(p).is_file())
        .collect();
    for d in NUMERICAL_DIRS {
        walk(root, Path::new(d), &mut out);
    }
    out.sort();
    out.dedup();
    out
}

fn walk(root: &Path, rel: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(root.join(rel)) else {
        return;
    };
    for e in entries.flatten() {
        let r = rel.join(e.file_name());
        match e.file_type() {
            Ok(t) if t.is_dir() => walk(root, &r, out),
            Ok(t) if t.is_file() && counts(&r) => out.push(r),
            _ => {}
        }
    }
}

/// What of a counted file is hashed: for sources (`.rs`, `.wgsl`) every line but those that are
/// only a comment (`//`, `///`, `//!` after indentation), with trailing spaces dropped — so a
/// doc comment edited in a numerical crate keeps every row valid; other files (manifests, the
/// lock) whole.
pub fn hashed_text(name: &str, bytes: &[u8]) -> Vec<u8> {
    if !(name.ends_with(".rs") || name.ends_with(".wgsl")) {
        return bytes.to_vec();
    }
    let text = String::from_utf8_lossy(bytes);
    let mut out = Vec::with_capacity(bytes.len());
    for line in text.lines() {
        if line.trim_start().starts_with("//") {
            continue;
        }
        out.extend_from_slice(line.trim_end().as_bytes());
        out.push(b'\n');
    }
    out
}

/// The fingerprint of the tree at `root`: 16 hex digits of BLAKE3 over each counted file's
/// relative path, length and [`hashed_text`], in path order; `None` when no file counts (not a
/// checkout: a crate built out of its workspace).
pub fn of_tree(root: &Path) -> Option<String> {
    let files = files(root);
    if files.is_empty() {
        return None;
    }
    let mut h = blake3::Hasher::new();
    for f in &files {
        let name = f.to_string_lossy().replace('\\', "/");
        let bytes = hashed_text(&name, &std::fs::read(root.join(f)).ok()?);
        h.update(name.as_bytes());
        h.update(&[0]);
        h.update(&(bytes.len() as u64).to_le_bytes());
        h.update(&bytes);
    }
    Some(h.finalize().to_hex()[..16].to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tree(tag: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("shscale-fp-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        for (f, text) in [
            ("Cargo.lock", "lock"),
            ("crates/sh/src/lib.rs", "pub fn y() -> f64 { 1.0 }"),
            ("crates/gpu/src/sh.wgsl", "fn f() {}"),
            ("experiments/src/probe/mod.rs", "run"),
            ("experiments/src/probe/discussion.rs", "words"),
            ("experiments/src/equal_budget/verdict.rs", "verdict"),
            ("experiments/src/equal_budget/surface_tests.rs", "tests"),
            ("experiments/src/equal_budget/spheres_report.rs", "report"),
            (
                "experiments/src/equal_budget/verdict2/prose.rs",
                "a counted folder",
            ),
            ("experiments/src/verdict/prose.rs", "verdict, split"),
            ("crates/scene/src/method/tests.rs", "tests"),
            ("crates/cli/src/args.rs", "help text"),
            ("crates/runner/src/report.rs", "report"),
            ("crates/runner/src/records.rs", "cells"),
            ("docs/provenance.md", "docs"),
            ("README.md", "readme"),
        ] {
            let p = d.join(f);
            std::fs::create_dir_all(p.parent().unwrap()).unwrap();
            std::fs::write(p, text).unwrap();
        }
        d
    }

    /// Docs, the README, the CLI's help text, the report writer, the kinds' discussions and
    /// verdicts and test modules leave the fingerprint as it is; a numerical source, a shader,
    /// a kind's work, the row formatting or the lock change it.
    #[test]
    fn docs_only_changes_keep_the_fingerprint_and_numerical_ones_change_it() {
        let d = tree("edits");
        let base = of_tree(&d).unwrap();
        assert_eq!(base.len(), 16);
        for f in [
            "docs/provenance.md",
            "README.md",
            "crates/cli/src/args.rs",
            "crates/runner/src/report.rs",
            "experiments/src/probe/discussion.rs",
            "experiments/src/equal_budget/verdict.rs",
            "experiments/src/equal_budget/surface_tests.rs",
            "experiments/src/equal_budget/spheres_report.rs",
            "experiments/src/verdict/prose.rs",
            "crates/scene/src/method/tests.rs",
        ] {
            std::fs::write(d.join(f), "edited").unwrap();
            assert_eq!(of_tree(&d).unwrap(), base, "{f} changed the fingerprint");
        }
        std::fs::write(d.join("docs/new.md"), "a new page").unwrap();
        assert_eq!(of_tree(&d).unwrap(), base);
        // A comment (doc or plain, indented) added to a numerical source: the same code.
        std::fs::write(
            d.join("crates/sh/src/lib.rs"),
            "/// Y, documented.\n    // a note\npub fn y() -> f64 { 1.0 }   \n//! end",
        )
        .unwrap();
        assert_eq!(
            of_tree(&d).unwrap(),
            base,
            "a comment changed the fingerprint"
        );
        let mut seen = vec![base.clone()];
        for f in [
            "crates/sh/src/lib.rs",
            "crates/gpu/src/sh.wgsl",
            "experiments/src/probe/mod.rs",
            "experiments/src/equal_budget/verdict2/prose.rs",
            "crates/runner/src/records.rs",
            "Cargo.lock",
        ] {
            std::fs::write(d.join(f), format!("edited {f}")).unwrap();
            let now = of_tree(&d).unwrap();
            assert!(!seen.contains(&now), "{f} left the fingerprint as it was");
            seen.push(now);
        }
        // A new numerical file counts; renaming one counts.
        std::fs::write(d.join("crates/sh/src/new.rs"), "x").unwrap();
        let with_new = of_tree(&d).unwrap();
        assert!(!seen.contains(&with_new));
        std::fs::rename(
            d.join("crates/sh/src/new.rs"),
            d.join("crates/sh/src/renamed.rs"),
        )
        .unwrap();
        assert_ne!(of_tree(&d).unwrap(), with_new);
        assert_eq!(of_tree(&d.join("nothing-here")), None);
        std::fs::remove_dir_all(&d).ok();
    }

    /// The binary's fingerprint is the workspace's as it is now: the build script reran on
    /// every counted change (a stale build would record rows under the wrong code). Every crate
    /// of the workspace is classified: numerical (its sources count) or not (listed here).
    #[test]
    fn the_compiled_fingerprint_is_the_workspaces_and_every_crate_is_classified() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
        let now = of_tree(&root).expect("the workspace has numerical sources");
        assert_eq!(crate::manifest::CODE_FINGERPRINT, now);
        let not_numerical = ["cli", "files", "present", "runner", "unify"];
        for e in std::fs::read_dir(root.join("crates")).unwrap().flatten() {
            let name = e.file_name().to_string_lossy().to_string();
            let numerical = NUMERICAL_DIRS.contains(&format!("crates/{name}/src").as_str());
            assert!(
                numerical || not_numerical.contains(&name.as_str()),
                "crates/{name} is neither counted in the fingerprint nor listed as not numerical"
            );
        }
    }
}
