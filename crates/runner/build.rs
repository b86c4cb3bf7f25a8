//! Build script: the git revision of the checkout this crate is built from (and whether it had
//! local changes), recorded for `shscale --version` and the provenance of every manifest and row
//! (`manifest::BUILD_REVISION`); and the numerical fingerprint — a hash of the content of the
//! sources that compute numbers (`src/fingerprint.rs` says which), `manifest::CODE_FINGERPRINT`
//! — which decides whether rows are stale. "unknown" outside a git checkout or the workspace.
//! The repository around the working directory at run time is never consulted.

use std::path::Path;
use std::process::Command;

#[path = "src/fingerprint.rs"]
#[allow(dead_code)]
mod fingerprint;

fn git(args: &[&str]) -> Option<String> {
    // GIT_OPTIONAL_LOCKS=0: `git status` must not refresh the index it is watched through
    // (below), or each build would make the next one rerun this script.
    let out = Command::new("git")
        .args(args)
        .env("GIT_OPTIONAL_LOCKS", "0")
        .output()
        .ok()?;
    out.status
        .success()
        .then(|| String::from_utf8_lossy(&out.stdout).trim().to_string())
}

fn main() {
    // Run in the crate's own folder (cargo's working directory for build scripts).
    let rev = git(&["rev-parse", "--short=12", "HEAD"]).filter(|r| !r.is_empty());
    let dirty =
        git(&["status", "--porcelain", "--untracked-files=no"]).is_some_and(|s| !s.is_empty());
    let text = match rev {
        Some(r) if dirty => format!("{r}+dirty"),
        Some(r) => r,
        None => "unknown".into(),
    };
    println!("cargo:rustc-env=SHSCALE_GIT_REVISION={text}");
    // Rebuilt when the checkout moves or its index changes.
    if let Some(dir) = git(&["rev-parse", "--absolute-git-dir"]) {
        println!("cargo:rerun-if-changed={dir}/HEAD");
        println!("cargo:rerun-if-changed={dir}/index");
        if let Some(r) = git(&["symbolic-ref", "-q", "HEAD"]) {
            println!("cargo:rerun-if-changed={dir}/{r}");
        }
    }
    let manifest = std::env::var("CARGO_MANIFEST_DIR").unwrap_or_else(|_| ".".into());
    let root = Path::new(&manifest).join("../..");
    let code = fingerprint::of_tree(&root).unwrap_or_else(|| "unknown".into());
    println!("cargo:rustc-env=SHSCALE_CODE_FINGERPRINT={code}");
    // Rebuilt when any counted file changes (cargo scans a folder recursively).
    for d in fingerprint::NUMERICAL_DIRS {
        println!("cargo:rerun-if-changed={}", root.join(d).display());
    }
    for f in fingerprint::NUMERICAL_FILES {
        println!("cargo:rerun-if-changed={}", root.join(f).display());
    }
    println!("cargo:rerun-if-changed=src/fingerprint.rs");
}
