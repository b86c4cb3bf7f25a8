//! README.md's "Which method for my scene?" table against the study it quotes: the three
//! equal-budget configs are run from scratch and every error the table quotes (each number of
//! its two budget columns) must stand in the summary of the config its row names — its opening
//! verdict ("## The answer") or the per-group and per-method tables of its discussion, which
//! carry the intervals. Slow (about ten minutes on 2 cores): `cargo test --release --workspace
//! --test readme_verdict -- --ignored`.

mod common;
use common::shscale;

const ROOT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../..");

/// The README's table rows: (the two budget cells, config file name).
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
            (format!("{} {}", cells[1], cells[2]), file)
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
            "--allow-large",
        ]);
        assert!(
            o.status.success(),
            "{file}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        let dir = v["dir"].as_str().unwrap().to_string();
        let summary = std::fs::read_to_string(format!("{dir}/summary.md")).unwrap();
        // The answer and the discussion's tables: everything before the list of runs.
        let answer = summary
            .split("## The answer")
            .nth(1)
            .and_then(|a| a.split("## Every run").next())
            .unwrap_or_default()
            .to_string();
        answers.insert(file.clone(), answer);
    }
    for (cells, file) in &rows {
        // Every error the row quotes ("0.061–0.218", "0.058 ± 0.009"): each number, as the
        // summary prints it (three decimals).
        let numbers = (cells.split(|c: char| !(c.is_ascii_digit() || c == '.')))
            .filter(|w| w.starts_with("0.") && w.len() == 5);
        for n in numbers {
            assert!(
                answers[file].contains(n),
                "README quotes {n} for {file}; its summary says:\n{}",
                answers[file]
            );
        }
    }
    let _ = std::fs::remove_dir_all(&out);
}
