//! The receiver plane's image measures and its figure (`budget_plane`): a truth's own error,
//! RMSE over a subset of receivers, temporal flicker, luminance, and the plane figure (the
//! full-frequency truth beside the papers' full field, the papers' extrapolation and the most
//! accurate other saved method at no more rays, with their differences from the truth).

use super::verdict::variant;
use shscale_field::shading::shade_rmse_rel;
use shscale_runner::records::Results;
use shscale_scene::method::{Method, Spec};
use shscale_scene::Error;
use std::path::Path;

/// RMS of a truth's per-pixel error estimate over the mean unshadowed irradiance
/// ([`crate::figures::own_err`]).
pub(super) fn own_err(e: &[[f32; 3]], open: &[f64]) -> f64 {
    crate::figures::own_err(e, open.iter().sum::<f64>() / open.len().max(1) as f64)
}

/// The runs of the plane figure among the saved ones (`rows`, one scene): the papers' full
/// field, the papers' extrapolation, and the most accurate other saved run (against
/// full-frequency truth) that casts no more rays than the extrapolation; `None` without the
/// first two.
pub(super) fn figure_runs(
    t: &Results,
    rows: &[usize],
    spec_of: &dyn Fn(usize) -> Option<Spec>,
) -> Option<Vec<usize>> {
    let specs: Vec<(usize, Spec)> = (rows.iter())
        .filter_map(|&r| Some((r, spec_of(r)?)))
        .collect();
    let find = |v: &str| specs.iter().find(|(_, s)| variant(s) == v).map(|(r, _)| *r);
    let ff = find("full field (papers')")?;
    let ex = find("extrapolation")?;
    let best = (specs.iter())
        .filter(|(_, s)| s.method() != Method::RayTraced)
        .map(|(r, _)| *r)
        .filter(|&r| r != ff && r != ex && t.num(r, "rays") <= t.num(ex, "rays"))
        .min_by(|&a, &b| {
            t.num(a, "rmse_vs_full_frequency")
                .total_cmp(&t.num(b, "rmse_vs_full_frequency"))
        });
    Some([Some(ff), Some(ex), best].into_iter().flatten().collect())
}

/// The plane figure: the full-frequency truth and each shown method's irradiance on one scale,
/// then each method's difference from the truth on a symmetric diverging scale.
pub(super) fn write_plane_figure(
    png: &Path,
    (w, h): (usize, usize),
    truth: &[[f32; 3]],
    shown: &[(String, Vec<[f32; 3]>)],
) -> Result<(), Error> {
    let tr = crate::figures::lum(truth);
    let mut top = vec![("full-frequency ray-traced truth".to_string(), tr.clone())];
    top.extend((shown.iter()).map(|(t, p)| (t.clone(), crate::figures::lum(p))));
    let methods = (shown.iter())
        .map(|(t, p)| {
            let name = t.split(" (").next().unwrap_or(t).to_string();
            (name, crate::figures::lum(p))
        })
        .collect();
    crate::figures::write_irradiance_figure(
        png,
        (w, h),
        (
            (0.0, w as f64, "receiver column"),
            (0.0, h as f64, "receiver row"),
        ),
        "irradiance on the receiver plane (in brackets: shade_rmse_rel vs full-frequency truth, rays per frame)",
        top,
        &tr,
        methods,
        300,
    )
}

/// `shade_rmse_rel` over the receivers where `keep` holds (RGB flattened, 3 values per receiver).
pub(super) fn rmse_where(
    e: &[f64],
    truth: &[f64],
    open: &[f64],
    keep: &[bool],
    want: bool,
) -> Option<f64> {
    let pick = |v: &[f64]| -> Vec<f64> {
        v.chunks(3)
            .zip(keep)
            .filter(|(_, k)| **k == want)
            .flat_map(|(c, _)| c.iter().copied())
            .collect()
    };
    shade_rmse_rel(&pick(e), &pick(truth), &pick(open))
}

/// Temporal flicker: the RMS over frames f ≥ 1 and receivers of the change of the error image
/// from frame f − 1 to f, `sqrt(mean_f mean_i ((e_f − t_f) − (e_{f−1} − t_{f−1}))²)`, over the
/// mean unshadowed irradiance — 0 when the error is the same in every frame (however large),
/// large when it jumps. `None` for fewer than two frames or a black unshadowed image.
pub fn flicker(images: &[Vec<f64>], truths: &[Vec<f64>], open: &[f64]) -> Option<f64> {
    let mean = open.iter().sum::<f64>() / open.len().max(1) as f64;
    if images.len() < 2 || mean <= 0.0 {
        return None;
    }
    let err = |f: usize| -> Vec<f64> {
        images[f]
            .iter()
            .zip(&truths[f])
            .map(|(a, b)| a - b)
            .collect()
    };
    let mut sum = 0.0;
    let mut n = 0usize;
    let mut prev = err(0);
    for f in 1..images.len() {
        let cur = err(f);
        sum += cur
            .iter()
            .zip(&prev)
            .map(|(a, b)| (a - b) * (a - b))
            .sum::<f64>();
        n += cur.len();
        prev = cur;
    }
    Some((sum / n.max(1) as f64).sqrt() / mean)
}

pub(super) fn lum(v: &[f64]) -> Vec<f64> {
    v.chunks(3).map(|c| c.iter().sum::<f64>() / 3.0).collect()
}

/// The run's image and the group's full-frequency truth (flat RGB) as EXR for the figure
/// (`plane_<run>.exr`, `plane_truth_<run>.exr` in `dir`).
pub(super) fn save_images(
    img: &shscale_scene::render::RenderOutput,
    truth: &[f64],
    (dir, run_id): (&Path, &str),
) -> Result<(), Error> {
    let (w, h) = (img.width, img.height);
    let exr = |name: &str| dir.join(format!("{name}_{run_id}.exr"));
    shscale_present::image::write_exr(&exr("plane"), w, h, &img.pixels)?;
    let truth: Vec<[f32; 3]> = (truth.chunks(3))
        .map(|c| [c[0] as f32, c[1] as f32, c[2] as f32])
        .collect();
    shscale_present::image::write_exr(&exr("plane_truth"), w, h, &truth)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::flicker;

    #[test]
    fn flicker_is_the_rms_change_of_the_error_between_frames() {
        let open = vec![2.0; 4];
        let truth = vec![vec![1.0, 2.0, 3.0, 4.0]; 3];
        // The same error in every frame, however large: no flicker.
        let steady = vec![vec![1.5, 2.5, 3.5, 4.5]; 3];
        assert_eq!(flicker(&steady, &truth, &open), Some(0.0));
        // An error alternating between +a and −a: every change is 2a; over the mean open 2.
        let a = 0.3;
        let alt: Vec<Vec<f64>> = (0..3)
            .map(|f| {
                let s = if f % 2 == 0 { a } else { -a };
                truth[0].iter().map(|t| t + s).collect()
            })
            .collect();
        let got = flicker(&alt, &truth, &open).unwrap();
        println!(
            "alternating ±{a}: flicker {got} (closed form {})",
            2.0 * a / 2.0
        );
        assert!((got - a).abs() < 1e-12);
        // One frame, or a black unshadowed image: none.
        assert_eq!(flicker(&alt[..1], &truth[..1], &open), None);
        assert_eq!(flicker(&alt, &truth, &[0.0; 4]), None);
    }
}
