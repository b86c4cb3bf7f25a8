//! `runs.schema.json`, written beside every `runs.csv`: each column's name, type (`integer`,
//! `float`, `bool`, `string`, `list`; `?` where a cell may be empty), unit, role (`id`,
//! `parameter`, `metric`, `time`, `provenance`) and description — read off the kind's parameter
//! and row structs, so it cannot drift from the header. Python's `load_results` applies it;
//! DuckDB and polars read it to type their columns (docs/provenance.md).

use crate::kind::DynKind;
use crate::manifest::RowProvenance;
use crate::records;
use crate::store::header;

/// The provenance columns, described.
const PROVENANCE: &[(&str, &str, &str)] = &[
    ("threads", "", "worker threads of the process"),
    ("timing_concurrent", "", "the row's times were taken while other runs of the process ran (not comparable)"),
    ("timing_warmup", "", "untimed calls before the timed ones"),
    ("timing_repeats", "", "timed calls; times are their median"),
    ("code", "", "numerical fingerprint of the binary that computed the row; a row whose code is not the binary's is stale"),
    ("inputs", "", "digest of the content of every input file the run read (`none` without inputs)"),
    ("other_cpu", "core", "cores other processes used on average while the run was measured"),
    ("steal", "fraction", "share of the machine's time the hypervisor stole meanwhile"),
    ("load_1m", "", "1-minute load average when the run finished"),
    ("contended", "", "measured on a busy machine (other_cpu >= 0.5 or steal >= 0.1): times not comparable"),
    ("git_revision", "", "git revision the binary was built from (informative; staleness is by `code`)"),
    ("git_dirty", "", "the checkout had local changes at build time"),
];

/// The unit of a column, from the naming conventions of docs/conventions.md (`_ms`, `_s`,
/// `_seconds`, `_deg`, `_bytes`, `fps`, `rays`): empty when the column is a ratio or a count
/// without a unit.
pub(crate) fn unit_of(name: &str) -> &'static str {
    let n = name;
    if n.ends_with("_ms") || n.contains("_ms_") {
        "ms"
    } else if n.ends_with("_seconds") || n.ends_with("_secs") || n.ends_with("_s") {
        "s"
    } else if n.ends_with("_deg") || n.contains("_deg_") {
        "degree"
    } else if n.ends_with("_bytes") || n.contains("_bytes_") {
        "byte"
    } else if n == "fps" || n.ends_with("_fps") {
        "1/s"
    } else if n == "rays" || n.ends_with("_rays") || n.starts_with("rays_") {
        "ray"
    } else {
        ""
    }
}

/// The schema of a kind's `runs.csv`, as JSON.
pub(crate) fn schema_json(kind: &dyn DynKind) -> String {
    let types: std::collections::HashMap<String, String> = (kind.column_types().into_iter())
        .chain(records::column_types::<RowProvenance>().unwrap_or_default())
        .collect();
    let params = kind.param_columns();
    let describe: std::collections::HashMap<&str, &str> = kind.describe().iter().copied().collect();
    let mut cols = Vec::new();
    for c in header(kind) {
        let prov = PROVENANCE.iter().find(|(n, _, _)| *n == c);
        let (role, unit, desc) = if c == "run_id" {
            (
                "id",
                "",
                "hash of the run's parameters (a string of 16 hex digits, never a number)"
                    .to_string(),
            )
        } else if c == "experiment" {
            ("id", "", "the experiment kind".to_string())
        } else if let Some((_, u, d)) = prov {
            ("provenance", *u, d.to_string())
        } else if params.contains(&c) {
            (
                "parameter",
                unit_of(&c),
                describe
                    .get(c.as_str())
                    .map_or(String::new(), |d| d.to_string()),
            )
        } else if kind.time_columns().contains(&c.as_str()) {
            (
                "time",
                unit_of(&c),
                "a time: machine-dependent, see `contended`".to_string(),
            )
        } else {
            ("metric", unit_of(&c), String::new())
        };
        let ty = match c.as_str() {
            "run_id" | "experiment" => "string".to_string(),
            _ => types.get(&c).cloned().unwrap_or_else(|| "string".into()),
        };
        cols.push(serde_json::json!({
            "name": c,
            "type": ty,
            "unit": unit,
            "role": role,
            "description": desc,
        }));
    }
    let v = serde_json::json!({
        "experiment": kind.name(),
        "code": crate::manifest::CODE_FINGERPRINT,
        "columns": cols,
    });
    serde_json::to_string_pretty(&v).unwrap_or_default() + "\n"
}

#[cfg(test)]
mod tests {
    #[test]
    fn every_column_of_the_tally_kind_has_its_type_and_the_header_order() {
        let kind: &dyn crate::DynKind = &crate::bench::TALLY;
        let v: serde_json::Value = serde_json::from_str(&super::schema_json(kind)).unwrap();
        let cols = v["columns"].as_array().unwrap();
        let names: Vec<&str> = cols.iter().map(|c| c["name"].as_str().unwrap()).collect();
        assert_eq!(names, crate::header(kind));
        let ty = |n: &str| {
            cols.iter().find(|c| c["name"] == n).unwrap()["type"]
                .as_str()
                .unwrap()
                .to_string()
        };
        assert_eq!(ty("run_id"), "string");
        assert_eq!(ty("contended"), "bool");
        assert_eq!(ty("other_cpu"), "float");
        assert_eq!(ty("threads"), "integer");
        assert_eq!(ty("code"), "string");
    }

    /// Every provenance column the runner writes is described (a field added to
    /// `RowProvenance` without a line here would read as an undescribed metric).
    #[test]
    fn every_provenance_column_is_described() {
        let (h, _) = crate::records::to_cells(&crate::manifest::RowProvenance::default()).unwrap();
        for c in &h {
            assert!(
                super::PROVENANCE
                    .iter()
                    .any(|(n, _, d)| n == c && !d.is_empty()),
                "{c} is not described in schema::PROVENANCE"
            );
        }
        assert_eq!(h.len(), super::PROVENANCE.len());
    }

    #[test]
    fn lists_options_and_numbers_are_told_apart() {
        #[derive(serde::Serialize, serde::Deserialize, Default)]
        #[serde(default)]
        struct P {
            n: usize,
            x: f64,
            o: Option<f64>,
            s: String,
            b: bool,
            #[serde(with = "crate::records::list")]
            l: Vec<f64>,
        }
        let t = crate::records::column_types::<P>().unwrap();
        let want = [
            ("n", "integer"),
            ("x", "float"),
            ("o", "float?"),
            ("s", "string"),
            ("b", "bool"),
            ("l", "list"),
        ];
        let got: Vec<(&str, &str)> = t.iter().map(|(a, b)| (a.as_str(), b.as_str())).collect();
        assert_eq!(got, want);
        assert_eq!(super::unit_of("frame_ms"), "ms");
        assert_eq!(super::unit_of("alpha_deg"), "degree");
        assert_eq!(super::unit_of("occ_rel_l2"), "");
    }
}
