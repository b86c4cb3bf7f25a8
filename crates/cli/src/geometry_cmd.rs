//! `shscale inspect` and `shscale visibility`.

use crate::args::{parse_list, FormatArgsExt, FrameArg, InspectArgs, Quadrature, VisibilityArgs};
use crate::flags;
use crate::output::{print_coeffs, print_json};
use anyhow::{bail, Context};
use serde::Serialize;
use shscale_field::Frame;
use shscale_geometry::{DVec3, Occluder};
use std::process::ExitCode;
use std::time::Instant;

/// Largest hemisphere resolution accepted (2H² rays; 1024 gives 2M rays).
use shscale_scene::vocab::MAX_VISIBILITY_RES as MAX_H;

/// The analytic unit sphere, or a mesh (procedural, bundled or a path) behind a BVH, in its own
/// coordinates — the one vocabulary of `shscale_scene::vocab`.
pub fn occluder(spec: &str) -> anyhow::Result<Box<dyn Occluder>> {
    Ok(shscale_scene::vocab::occluder(spec)?)
}

#[derive(Serialize)]
struct SphereOut {
    center: [f64; 3],
    radius: f64,
}

#[derive(Serialize)]
struct InspectOut {
    mesh: String,
    vertices: usize,
    triangles: usize,
    bounding_sphere: SphereOut,
    watertight: bool,
    boundary_edges: usize,
    non_manifold_edges: usize,
    degenerate_triangles: usize,
    unreferenced_vertices: usize,
}

pub fn inspect(a: InspectArgs) -> anyhow::Result<ExitCode> {
    let out = if a.mesh == "sphere" {
        InspectOut {
            mesh: "sphere (analytic unit sphere)".into(),
            vertices: 0,
            triangles: 0,
            bounding_sphere: SphereOut {
                center: [0.0; 3],
                radius: 1.0,
            },
            watertight: true,
            boundary_edges: 0,
            non_manifold_edges: 0,
            degenerate_triangles: 0,
            unreferenced_vertices: 0,
        }
    } else {
        let mesh = shscale_scene::vocab::mesh(&a.mesh)?;
        let r = mesh.inspect();
        InspectOut {
            mesh: a.mesh.clone(),
            vertices: r.vertices,
            triangles: r.triangles,
            bounding_sphere: SphereOut {
                center: r.bounding_sphere.center.to_array(),
                radius: r.bounding_sphere.radius,
            },
            watertight: r.watertight,
            boundary_edges: r.boundary_edges,
            non_manifold_edges: r.non_manifold_edges,
            degenerate_triangles: r.degenerate_triangles,
            unreferenced_vertices: r.unreferenced_vertices,
        }
    };
    if a.format.is_json() {
        print_json(&out)?;
    } else {
        println!("mesh                 {}", out.mesh);
        println!("vertices / triangles {} / {}", out.vertices, out.triangles);
        println!(
            "bounding sphere      centre {:?}, radius {}",
            out.bounding_sphere.center, out.bounding_sphere.radius
        );
        println!("watertight           {}", out.watertight);
        println!("boundary edges       {}", out.boundary_edges);
        println!("non-manifold edges   {}", out.non_manifold_edges);
        println!("degenerate triangles {}", out.degenerate_triangles);
        println!("unreferenced verts   {}", out.unreferenced_vertices);
    }
    Ok(ExitCode::SUCCESS)
}

#[derive(Serialize)]
struct VisOut<'a> {
    order: usize,
    frame: &'static str,
    quadrature: &'static str,
    rays: usize,
    seconds: f64,
    /// Stratified only: the estimated RMS error of `values` (`‖A − B‖/2`), and that relative to
    /// the occlusion `‖P_N(1 − V)‖` (absent when nothing is occluded).
    error_estimate: Option<f64>,
    rel_error_estimate: Option<f64>,
    values: &'a [f64],
}

pub fn visibility(a: VisibilityArgs) -> anyhow::Result<ExitCode> {
    shscale_sh::check_order(a.order).context("--order")?;
    flags::int("--hemisphere-res", a.hemisphere_res, 1, MAX_H)?;
    let p = parse_list("point", &a.point)?;
    if p.len() != 3 || p.iter().any(|v| !v.is_finite()) {
        bail!(
            "--point: expected 3 finite coordinates X,Y,Z, got {:?}",
            a.point
        );
    }
    let p = DVec3::new(p[0], p[1], p[2]);
    let occ = occluder(&a.mesh)?;
    shscale_scene::vocab::check_query_points(
        occ.as_ref(),
        &a.mesh,
        &[p],
        a.frame == FrameArg::Local,
    )
    .map_err(|m| {
        anyhow::anyhow!(
            "--point: {}",
            m.trim_start_matches("point 0 ")
                .trim_start_matches("point 0: ")
        )
    })?;
    flags::int(
        "--truth-res",
        a.truth_res,
        1,
        shscale_field::truth::MAX_TRUTH_RES,
    )?;
    let frame = match a.frame {
        FrameArg::Entity => Frame::Entity,
        FrameArg::Local => Frame::Local,
    };
    let t0 = Instant::now();
    let quadrature = match a.quadrature {
        Quadrature::Gauss => shscale_scene::vocab::Quadrature::Gauss,
        Quadrature::Stratified => shscale_scene::vocab::Quadrature::Stratified,
    };
    let query = shscale_scene::vocab::VisibilityQuery::new(
        quadrature,
        a.order,
        a.hemisphere_res,
        a.truth_res,
        a.seed,
    )?;
    let vis = query.at(occ.as_ref(), p, frame);
    let (values, rays, error, rel) = (vis.coeffs, vis.rays, vis.error, vis.rel_error);
    let seconds = t0.elapsed().as_secs_f64();
    if a.format.is_json() {
        print_json(&VisOut {
            order: a.order,
            frame: if frame == Frame::Entity {
                "entity"
            } else {
                "local"
            },
            quadrature: quadrature.name(),
            rays,
            seconds,
            error_estimate: error,
            rel_error_estimate: rel,
            values: &values,
        })?;
    } else {
        print_coeffs(&values, a.format);
    }
    Ok(ExitCode::SUCCESS)
}
