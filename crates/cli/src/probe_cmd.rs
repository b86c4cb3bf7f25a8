//! `shscale probe`: extrapolated vs ray-traced visibility at the papers' probe radii.

use crate::args::{parse_list, Format, ProbeArgs};
use crate::geometry_cmd::occluder;
use crate::output::print_json;
use anyhow::anyhow;
use serde::Serialize;
use shscale_experiments::probe::driver::probe;
use shscale_experiments::probe::{ProbeParams, ProbeRow};
use shscale_geometry::AnalyticSphere;
use std::process::ExitCode;

#[derive(Serialize)]
struct RowOut<'a> {
    #[serde(flatten)]
    row: &'a ProbeRow,
    /// docs/conventions.md §6: times carry the device they were measured on.
    device: &'static str,
    threads: usize,
}

#[derive(Serialize)]
struct ProbeOut<'a> {
    mesh: String,
    order: usize,
    alpha_deg: f64,
    layout: String,
    hemisphere_res: usize,
    sampling_radius: f64,
    k_count: usize,
    k_min: f64,
    k_max: f64,
    samples: usize,
    on_surface_samples: usize,
    bsv_rays: usize,
    bsv_sampling_seconds: f64,
    table_build_seconds: f64,
    threads: usize,
    truth_res: usize,
    truth_rays_per_probe: usize,
    probe_dirs: String,
    contact_samples: usize,
    rows: Vec<RowOut<'a>>,
}

pub fn run(a: ProbeArgs) -> anyhow::Result<ExitCode> {
    // The same parameters, bounds and cost model as `experiment = "probe"` (one vocabulary):
    // an error names the flag of the key at fault.
    let params = ProbeParams {
        mesh: a.mesh.clone(),
        order: a.order,
        alpha_deg: a.alpha_deg,
        layout: a.layout.clone(),
        hemisphere_res: a.hemisphere_res,
        sampling_radius: a.sampling_radius,
        k_count: a.k_count,
        on_surface_eps: a.on_surface_eps,
        truth_res: a.truth_res,
        probe_dirs: a.probe_dirs.clone(),
        radii: match &a.radii {
            Some(r) => parse_list("radii", r)?,
            None => shscale_field::probe::DEFAULT_RADII.to_vec(),
        },
        ..ProbeParams::default()
    };
    let spec = params.checked_spec(a.allow_large).map_err(|e| {
        if e.key.is_empty() {
            anyhow!("{}", e.message)
        } else {
            anyhow!("--{}: {}", e.key.replace('_', "-"), e.message)
        }
    })?;
    let occ = occluder(&a.mesh)?;
    let analytic = (a.mesh == "sphere").then(|| AnalyticSphere::unit().sphere);
    let res = probe(occ.as_ref(), analytic, &spec)?;
    let out = ProbeOut {
        mesh: a.mesh.clone(),
        order: a.order,
        alpha_deg: a.alpha_deg,
        layout: spec.layout.name(),
        hemisphere_res: a.hemisphere_res,
        sampling_radius: a.sampling_radius,
        k_count: a.k_count,
        k_min: res.k_min,
        k_max: res.k_max,
        samples: res.samples,
        on_surface_samples: res.on_surface_samples,
        bsv_rays: res.bsv_rays,
        bsv_sampling_seconds: res.bsv_sampling_seconds,
        table_build_seconds: res.table_build_seconds,
        threads: rayon_threads(),
        truth_res: a.truth_res,
        truth_rays_per_probe: res.truth_rays_per_probe,
        probe_dirs: a.probe_dirs.clone(),
        contact_samples: res.contact_samples,
        rows: res
            .rows
            .iter()
            .map(|row| RowOut {
                row,
                device: "cpu",
                threads: rayon_threads(),
            })
            .collect(),
    };
    match a.format {
        Format::Json => print_json(&out)?,
        Format::Csv => print_csv(&out)?,
        Format::Pretty => print_pretty(&out)?,
    }
    Ok(ExitCode::SUCCESS)
}

fn rayon_threads() -> usize {
    std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1)
}

/// The columns `--format pretty` shows, in order, with their headings.
const PRETTY: &[(&str, &str)] = &[
    ("radius", "radius (×r)"),
    ("k", "k"),
    ("probes", "probes"),
    ("inside_count", "inside"),
    ("occ_rel_l2_mean", "occ err mean"),
    ("occ_rel_l2_max", "occ err max"),
    ("vis_rel_l2_mean", "vis err mean"),
    ("truth_rel_err_mean", "truth err"),
];

/// The rows as an aligned table of the headline columns (the run's keys on a line above it);
/// `--format csv` or `json` give every column.
fn print_pretty(out: &ProbeOut) -> anyhow::Result<()> {
    println!(
        "probe: {}, order {}, α = {}°, layout {}, H = {}, sampling radius {}r, K = {}; {} samples ({} on the surface), {} BSV rays",
        out.mesh,
        out.order,
        out.alpha_deg,
        out.layout,
        out.hemisphere_res,
        out.sampling_radius,
        out.k_count,
        out.samples,
        out.on_surface_samples,
        out.bsv_rays
    );
    let v = serde_json::to_value(&out.rows)?;
    let rows = v.as_array().map(Vec::as_slice).unwrap_or_default();
    let cols: Vec<(&str, &str)> = (PRETTY.iter().copied())
        .filter(|(k, _)| rows.first().is_some_and(|r| r.get(k).is_some()))
        .collect();
    let cell = |v: &serde_json::Value| match v {
        serde_json::Value::Number(n) if n.is_u64() || n.is_i64() => n.to_string(),
        serde_json::Value::Number(n) => format!("{:.4}", n.as_f64().unwrap_or(f64::NAN)),
        serde_json::Value::Null => "—".into(),
        other => other.to_string(),
    };
    let table: Vec<Vec<String>> = rows
        .iter()
        .map(|r| cols.iter().map(|(k, _)| cell(&r[*k])).collect())
        .collect();
    let width: Vec<usize> = (cols.iter().enumerate())
        .map(|(i, (_, h))| {
            (table.iter().map(|r| r[i].chars().count()))
                .chain([h.chars().count()])
                .max()
                .unwrap_or(0)
        })
        .collect();
    let line = |cells: Vec<String>| {
        (cells.iter().zip(&width))
            .map(|(c, w)| format!("{c:>w$}", w = *w))
            .collect::<Vec<_>>()
            .join("  ")
    };
    println!(
        "{}",
        line(cols.iter().map(|(_, h)| h.to_string()).collect())
    );
    for r in table {
        println!("{}", line(r));
    }
    println!("(errors: relative L2 of the occlusion 1 − V and of V, against the ray-traced truth; --format csv or json for every column)");
    Ok(())
}

/// The rows as CSV: the run's keys, then every column of a row in the struct's field order.
fn print_csv(out: &ProbeOut) -> anyhow::Result<()> {
    let v = serde_json::to_value(&out.rows)?;
    let rows = v.as_array().expect("array");
    let keys: Vec<String> = rows[0]
        .as_object()
        .expect("object")
        .keys()
        .cloned()
        .collect();
    let head = [
        "mesh",
        "order",
        "alpha_deg",
        "layout",
        "hemisphere_res",
        "sampling_radius",
        "k_count",
    ];
    // Rows keep the struct's field order (serde_json preserve_order).
    println!("{},{}", head.join(","), keys.join(","));
    for r in rows {
        let cells: Vec<String> = keys
            .iter()
            .map(|k| match &r[k] {
                serde_json::Value::Null => String::new(),
                serde_json::Value::String(x) => x.clone(),
                v => v.to_string(),
            })
            .collect();
        println!(
            "{},{},{},{},{},{},{},{}",
            out.mesh,
            out.order,
            out.alpha_deg,
            out.layout,
            out.hemisphere_res,
            out.sampling_radius,
            out.k_count,
            cells.join(",")
        );
    }
    Ok(())
}
