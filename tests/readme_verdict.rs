//! README.md's "Which method for my scene?" table against the study it quotes: the three
//! equal-budget configs are run from scratch and every error range the table quotes must stand
//! in the verdict table ("## The answer") that opens the summary of the config its row names.
//! Slow (about ten minutes on 2 cores): `cargo test --release --workspace --test readme_verdict
//! -- --ignored`.

mod common;
use common::shscale;

const ROOT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../..");

/// The README's table rows: (error cell, config file name).
fn readme_rows() -> Vec<(String, String)> {
    let readme = std::fs::read_to_string(format!("{ROOT}/README.md")).unwrap();
    let section = readme
        .split("### Which method for my scene?")
        .nth(1)
        .expect("README.md has its \"Which method\" section");
    (section.lines())
        .take_while(|l| !l.starts_with("Read it"))
        .filter(|l| l.starts_with("| ") && !l.starts_with("| regime"))
        .map(|l| {
            let cells: Vec<&str> = l.trim_matches('|').split(" | ").map(str::trim).collect();
            let file = cells[3]
                .trim_matches('`')
                .rsplit('/')
                .next()
                .unwrap()
                .to_string();
            (cells[2].to_string(), file)
        })
        .collect()
}

#[test]
fn the_readme_table_reads_its_config_files() {
    let rows = readme_rows();
    assert!(rows.len() >= 5, "{rows:?}");
    for (_, file) in &rows {
        let p = format!("{ROOT}/configs/experiments/{file}");
        assert!(std::path::Path::new(&p).exists(), "{p}");
    }
}

#[test]
#[ignore = "runs the three equal-budget configs (about ten minutes on 2 cores)"]
fn the_readme_table_matches_the_study() {
    let out = std::env::temp_dir().join(format!("shscale-readme-verdict-{}", std::process::id()));
    let rows = readme_rows();
    let mut answers = std::collections::BTreeMap::new();
    for (_, file) in &rows {
        if answers.contains_key(file) {
            continue;
        }
        let cfg = format!("{ROOT}/configs/experiments/{file}");
        let o = shscale(&[
            "run",
            &cfg,
            "--out-dir",
            out.to_str().unwrap(),
            "--format",
            "json",
        ]);
        assert!(
            o.status.success(),
            "{file}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        let dir = v["dir"].as_str().unwrap().to_string();
        let summary = std::fs::read_to_string(format!("{dir}/summary.md")).unwrap();
        let answer = summary
            .split("## The answer")
            .nth(1)
            .and_then(|a| a.split("## Our numbers").next())
            .unwrap_or_default()
            .to_string();
        answers.insert(file.clone(), answer);
    }
    for (errors, file) in &rows {
        // "0.085–0.114 [0.084–0.116]": the range and the seeds' range, each as the table has it.
        for part in errors
            .split(['[', ']'])
            .map(str::trim)
            .filter(|p| !p.is_empty())
        {
            assert!(
                answers[file].contains(part),
                "README quotes {part} for {file}; its verdict table says:\n{}",
                answers[file]
            );
        }
    }
    let _ = std::fs::remove_dir_all(&out);
}
