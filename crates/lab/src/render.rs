//! Rendering a scene's receiver plane (normal +z) with one of the three visibility evaluators
//! (DESIGN.md §4–5): extrapolated (BSV + k-table), full field (16 shells over [s, 8s]·r) or
//! ray-traced truth (2H² rays per receiver per occluder). Irradiance per pixel in linear RGB.
//! Stage times are reported so methods can be compared on the same scene.

use crate::scene::{LightSpec, Scene};
use crate::LabError;
use glam::DVec3;
use rayon::prelude::*;
use shscale_field::evaluator::{FullField, RayTraced, VisibilityField};
use shscale_field::extrapolate::Extrapolator;
use shscale_field::shading::{EnvLight, Shader};
use shscale_field::{Bsv, VisibilitySampler};
use shscale_geometry::ray::UpdateStrategy;
use shscale_geometry::{bundled, AnalyticSphere, MeshBvh, Occluder, Sphere};
use shscale_scaling::{Eta, Interp, KTable, Spacing, TauFamily};
use std::time::Instant;

/// The visibility evaluator used for every occluder.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    Extrapolated,
    FullField,
    /// Band-limited ray-traced visibility, shaded through SH like the others.
    RayTraced,
    /// Full-frequency truth: direct quadrature of `∫ L Π V cos⁺` with exact ray-cast visibility
    /// (`(2H)²` rays per receiver).
    FullFrequency,
}

/// A rendered receiver plane.
pub struct RenderOutput {
    pub width: usize,
    pub height: usize,
    /// Row-major, row 0 at +y (top of the image).
    pub pixels: Vec<[f32; 3]>,
    /// `(stage, seconds)` in execution order.
    pub stages: Vec<(String, f64)>,
    /// SH products computed and occluder evaluations skipped as unoccluded.
    pub products: usize,
    pub skipped: usize,
}

/// Build an occluder: the analytic sphere, or a mesh (bundled or path) rotated to z-up, scaled and
/// moved so its minimal bounding sphere is `(center, radius)`.
pub fn build_occluder(
    mesh: &str,
    center: DVec3,
    radius: f64,
    up_is_y: bool,
) -> Result<Box<dyn Occluder>, LabError> {
    let target = Sphere { center, radius };
    if mesh == "sphere" {
        return Ok(Box::new(AnalyticSphere { sphere: target }));
    }
    let mut m = bundled::resolve(mesh)?;
    if up_is_y {
        for p in &mut m.positions {
            *p = DVec3::new(p.x, -p.z, p.y);
        }
    }
    m.fit_to(&target);
    Ok(Box::new(MeshBvh::build(&m, UpdateStrategy::Rebuild)))
}

fn light_of(scene: &Scene) -> Result<EnvLight, LabError> {
    Ok(match &scene.light {
        LightSpec::Sky {
            ambient,
            zenith,
            sun,
            sun_dir,
            sun_radius,
        } => EnvLight::sky(
            scene.order,
            *ambient,
            *zenith,
            DVec3::Z,
            *sun,
            *sun_dir,
            *sun_radius,
        )?,
        LightSpec::Exr { path, intensity } => {
            let (w, h, px) = crate::io::read_exr(path)?;
            let px: Vec<[f32; 3]> = px
                .into_iter()
                .map(|p| p.map(|v| v * *intensity as f32))
                .collect();
            EnvLight::from_latlong(scene.order, w, h, &px)?
        }
    })
}

/// Render `scene` with `method`.
pub fn render(scene: &Scene, method: Method) -> Result<RenderOutput, LabError> {
    let mut stages = Vec::new();
    let t = Instant::now();
    let light = light_of(scene)?;
    stages.push(("light_projection".to_string(), t.elapsed().as_secs_f64()));
    let t = Instant::now();
    let occs: Vec<Box<dyn Occluder>> = scene
        .occluders
        .iter()
        .map(|o| build_occluder(&o.mesh, o.center, o.radius, o.up_is_y))
        .collect::<Result<_, _>>()?;
    stages.push(("bvh_build".to_string(), t.elapsed().as_secs_f64()));
    let [w, h] = scene.resolution;
    let [sx, sy] = scene.receiver_size;
    let c = scene.receiver_center;
    let recv: Vec<DVec3> = (0..w * h)
        .map(|k| {
            let (i, j) = (k % w, k / w);
            DVec3::new(
                c.x + sx * (i as f64 / (w - 1) as f64 - 0.5),
                c.y + sy * (0.5 - j as f64 / (h - 1) as f64),
                c.z,
            )
        })
        .collect();
    let sampler = VisibilitySampler::new(scene.order, scene.hemisphere_res)?;
    // Per-occluder fields (kept alive for the borrows below).
    let mut bsvs = Vec::new();
    let mut tables = Vec::new();
    let mut fulls = Vec::new();
    match method {
        Method::Extrapolated => {
            let t = Instant::now();
            for o in &occs {
                bsvs.push(Bsv::sample(
                    o.as_ref(),
                    scene.layout,
                    &sampler,
                    scene.sampling_radius,
                    0.0,
                )?);
            }
            stages.push(("bsv_sampling".to_string(), t.elapsed().as_secs_f64()));
            let t = Instant::now();
            for (o, b) in occs.iter().zip(&bsvs) {
                let s = o.bounding_sphere();
                let ks = recv
                    .iter()
                    .map(|p| (*p - s.center).length() / b.sampling_radius);
                let (lo, hi) = ks.fold((f64::MAX, f64::MIN), |(a, z), k| (a.min(k), z.max(k)));
                let (lo, hi) = (lo.max(1e-3), hi.max(lo.max(1e-3) * 1.01));
                tables.push(
                    KTable::build(
                        TauFamily::Cone { alpha: scene.alpha },
                        Eta::Plain,
                        scene.order,
                        scene.k_count,
                        lo,
                        hi,
                        Spacing::Exp,
                        Interp::Linear,
                    )
                    .map_err(|e| LabError::Config(format!("{}: k-table: {e}", scene.file)))?,
                );
            }
            stages.push(("table_build".to_string(), t.elapsed().as_secs_f64()));
        }
        Method::FullField => {
            let t = Instant::now();
            for o in &occs {
                fulls.push(FullField::build(
                    o.as_ref(),
                    scene.layout,
                    &sampler,
                    16,
                    scene.sampling_radius,
                    8.0 * scene.sampling_radius,
                )?);
            }
            stages.push(("full_field_build".to_string(), t.elapsed().as_secs_f64()));
        }
        Method::RayTraced | Method::FullFrequency => {}
    }
    let exs: Vec<Extrapolator> = bsvs
        .iter()
        .zip(&tables)
        .map(|(b, t)| Extrapolator::new(b, t))
        .collect();
    let rts: Vec<RayTraced> = if method == Method::RayTraced {
        occs.iter()
            .map(|o| RayTraced {
                occ: o.as_ref(),
                sampler: &sampler,
            })
            .collect()
    } else {
        Vec::new()
    };
    let fields: Vec<&dyn VisibilityField> = match method {
        Method::Extrapolated => exs.iter().map(|e| e as &dyn VisibilityField).collect(),
        Method::FullField => fulls.iter().map(|f| f as &dyn VisibilityField).collect(),
        Method::RayTraced => rts.iter().map(|r| r as &dyn VisibilityField).collect(),
        Method::FullFrequency => Vec::new(),
    };
    let centers: Vec<DVec3> = occs.iter().map(|o| o.bounding_sphere().center).collect();
    if method == Method::FullFrequency {
        let t = Instant::now();
        let refs: Vec<&dyn Occluder> = occs.iter().map(|o| o.as_ref()).collect();
        let pixels: Vec<[f32; 3]> = recv
            .par_iter()
            .map(|p| {
                shscale_field::shading::irradiance_full_frequency(
                    &light,
                    &refs,
                    *p,
                    DVec3::Z,
                    2 * scene.hemisphere_res,
                )
                .map(|x| x as f32)
            })
            .collect();
        stages.push((
            "full_frequency_truth".to_string(),
            t.elapsed().as_secs_f64(),
        ));
        return Ok(RenderOutput {
            width: w,
            height: h,
            pixels,
            stages,
            products: 0,
            skipped: 0,
        });
    }
    let t = Instant::now();
    let shader = Shader::new(scene.order)?;
    let transfer = shader.transfer(&light, DVec3::Z);
    let shaded: Vec<([f32; 3], usize, usize)> = recv
        .par_iter()
        .map(|p| {
            let (v, products, skipped) = shader.combined_visibility_counted(&fields, &centers, *p);
            (
                Shader::shade(&transfer, &v).map(|x| x as f32),
                products,
                skipped,
            )
        })
        .collect();
    stages.push(("shading".to_string(), t.elapsed().as_secs_f64()));
    Ok(RenderOutput {
        width: w,
        height: h,
        pixels: shaded.iter().map(|s| s.0).collect(),
        stages,
        products: shaded.iter().map(|s| s.1).sum(),
        skipped: shaded.iter().map(|s| s.2).sum(),
    })
}
