//! One build for every command: the features Cargo resolves for each shared dependency are the
//! same whether the CLI alone is built (`cargo run`, the README's first command), the whole
//! workspace with its dev-dependencies is tested (`cargo test --workspace`, the second), or the
//! Python binding alone is built (maturin, `pip install ./python`). A dependency built with other
//! features is built again, with everything above it, so a difference here is a rebuild when a
//! user switches commands. crates/unify pins the union; docs/building.md explains it.
//!
//! Runs `cargo tree` offline against the lock file (the dependencies are fetched by the time the
//! tests run); it needs no network.

use std::collections::BTreeMap;
use std::process::Command;

/// `package version` → the features Cargo resolved for it, for one selection of packages.
fn features(selection: &[&str]) -> BTreeMap<String, String> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let root = concat!(env!("CARGO_MANIFEST_DIR"), "/../..");
    let out = Command::new(cargo)
        .current_dir(root)
        .args([
            "tree",
            "--offline",
            "--locked",
            "--prefix",
            "none",
            "-f",
            "{p}|{f}",
        ])
        .args(selection)
        .output()
        .expect("cargo tree runs");
    assert!(
        out.status.success(),
        "cargo tree {selection:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let mut map = BTreeMap::new();
    for line in String::from_utf8_lossy(&out.stdout).lines() {
        let Some((pkg, feats)) = line.trim_end_matches(" (*)").split_once('|') else {
            continue;
        };
        // A package path (`(/work/…)`) is not part of its identity across selections.
        let id: String = pkg.split(' ').take(2).collect::<Vec<_>>().join(" ");
        if let Some(prev) = map.insert(id.clone(), feats.trim_end_matches(" (*)").to_string()) {
            assert_eq!(prev, map[&id], "{id}: two feature sets in one selection");
        }
    }
    map
}

#[test]
fn every_command_resolves_the_same_features() {
    let workspace = features(&["--workspace"]);
    let commands: [(&str, &[&str]); 2] = [
        (
            "cargo run (the CLI alone)",
            &["-p", "shscale", "-e", "normal,build"],
        ),
        (
            "maturin (the Python binding alone)",
            &["-p", "shscale-python", "-e", "normal,build"],
        ),
    ];
    for (name, selection) in commands {
        let alone = features(selection);
        assert!(
            alone.len() > 50,
            "{name}: only {} packages listed",
            alone.len()
        );
        let differ: Vec<String> = alone
            .iter()
            .filter_map(|(id, f)| {
                let w = workspace.get(id)?;
                (w != f).then(|| format!("{id}: [{f}] there, [{w}] in cargo test --workspace"))
            })
            .collect();
        println!(
            "{name}: {} packages, {} with other features",
            alone.len(),
            differ.len()
        );
        assert!(
            differ.is_empty(),
            "{name} resolves other features than `cargo test --workspace`, so switching between \
             them rebuilds; add the union to crates/unify/Cargo.toml:\n{}",
            differ.join("\n")
        );
    }
}
