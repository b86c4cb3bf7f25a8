//! `shscale probe`: extrapolated vs ray-traced visibility at the papers' probe radii.

use crate::args::{parse_list, Format, ProbeArgs};
use crate::geometry_cmd::occluder;
use crate::output::print_json;
use anyhow::anyhow;
use serde::Serialize;
use shscale_field::probe::{probe, ProbeRow};
use shscale_geometry::AnalyticSphere;
use shscale_lab::exp::probe::ProbeParams;
use std::process::ExitCode;

#[derive(Serialize)]
struct RowOut {
    radius: f64,
    k: f64,
    probes: usize,
    inside_count: usize,
    unoccluded_truth_count: usize,
    clamped_count: usize,
    vis_rel_l2_mean: Option<f64>,
    vis_rel_l2_max: Option<f64>,
    occ_rel_l2_mean: Option<f64>,
    occ_rel_l2_max: Option<f64>,
    on_surface_count: usize,
    vis_rel_l2_on_surface_mean: Option<f64>,
    occ_rel_l2_on_surface_mean: Option<f64>,
    occ_rel_l2_on_surface_max: Option<f64>,
    extrapolation_seconds: f64,
    truth_seconds: f64,
    /// docs/conventions.md §6: times carry the device they were measured on.
    device: &'static str,
    threads: usize,
}

impl From<&ProbeRow> for RowOut {
    fn from(r: &ProbeRow) -> Self {
        Self {
            radius: r.radius,
            k: r.k,
            probes: r.probes,
            inside_count: r.inside_count,
            unoccluded_truth_count: r.unoccluded_truth_count,
            clamped_count: r.clamped_count,
            vis_rel_l2_mean: r.vis_rel_l2_mean,
            vis_rel_l2_max: r.vis_rel_l2_max,
            occ_rel_l2_mean: r.occ_rel_l2_mean,
            occ_rel_l2_max: r.occ_rel_l2_max,
            on_surface_count: r.on_surface_count,
            vis_rel_l2_on_surface_mean: r.vis_rel_l2_on_surface_mean,
            occ_rel_l2_on_surface_mean: r.occ_rel_l2_on_surface_mean,
            occ_rel_l2_on_surface_max: r.occ_rel_l2_on_surface_max,
            extrapolation_seconds: r.extrapolation_seconds,
            truth_seconds: r.truth_seconds,
            device: "cpu",
            threads: rayon_threads(),
        }
    }
}

#[derive(Serialize)]
struct ProbeOut {
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
    rows: Vec<RowOut>,
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
        radii: parse_list("radii", &a.radii)?,
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
        rows: res.rows.iter().map(RowOut::from).collect(),
    };
    match a.format {
        Format::Json => print_json(&out)?,
        _ => {
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
        }
    }
    Ok(ExitCode::SUCCESS)
}

fn rayon_threads() -> usize {
    std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1)
}
