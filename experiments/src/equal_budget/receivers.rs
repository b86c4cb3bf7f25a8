//! Where the equal-budget receivers sit and what they look at: the continuous layout's radii
//! (each spherical receiver its own distance) and its keys, the occluder turned against the
//! world-fixed sampling grids (each seed its own orientation), and the plane's receivers binned
//! by their distance to the surface.

use super::surface::surface_bin;
use shscale_geometry::ray::UpdateStrategy;
use shscale_geometry::MeshBvh;
use shscale_runner::check::Ends;
use shscale_runner::KeyError;
use shscale_scene::Error;

/// The receiver layout of independent radii.
pub const CONTINUOUS: &str = "continuous";

/// The continuous layout's radii: n values with ρ − 1 log-uniform over [lo − 1, hi − 1],
/// stratified (one in each of n equal strata of the log, jittered by the seed), so every octave
/// of clearance from the bounding sphere holds its share of receivers. Paired with the seeded
/// directions in order: the directions are independent of the index, so the pairing is random.
pub(crate) fn continuous_radii(seed: u64, n: usize, lo: f64, hi: f64) -> Vec<f64> {
    let mut rng = shscale_field::truth::SplitMix(seed ^ 0x7261_6469_7573_0001);
    let (a, b) = ((lo - 1.0).ln(), (hi - 1.0).ln());
    (0..n)
        .map(|i| {
            let u = (i as f64 + rng.unit()) / n as f64;
            1.0 + (a + u * (b - a)).exp()
        })
        .collect()
}

/// The unit occluder of `mesh` (bounding sphere as loaded), turned by the seeded rotation of
/// `orientation_seed` about its bounding sphere's centre (0: as loaded). The analytic sphere is
/// the same in every orientation. One BVH build, of the turned mesh.
pub(crate) fn oriented_occluder(
    mesh: &str,
    orientation_seed: u64,
) -> Result<shscale_scene::vocab::UnitOccluder, Error> {
    if orientation_seed == 0 || mesh == "sphere" {
        return shscale_scene::vocab::unit_occluder(mesh);
    }
    let mut m = shscale_scene::vocab::placed_mesh(mesh, glam::DVec3::ZERO, 1.0, false)?;
    let q = shscale_field::truth::SplitMix(orientation_seed).rotation();
    m.rotate_about(m.bounding_sphere().center, q);
    Ok(shscale_scene::vocab::UnitOccluder {
        occ: Box::new(MeshBvh::build(&m, UpdateStrategy::Rebuild)),
        analytic: None,
        mesh: Some(m),
    })
}

/// The receiver layout's keys checked: the layout named (`grid` or [`CONTINUOUS`]), the keys it
/// does not read at their defaults (the unread-key rule: `radii` under the continuous layout,
/// `rho_min`/`rho_max` on the grid), the continuous range inside (1, 1e3] and increasing.
pub fn check_layout(
    layout: &str,
    radii_default: bool,
    (rho_min, rho_max): (f64, f64),
    defaults: (f64, f64),
) -> Result<(), KeyError> {
    match layout {
        CONTINUOUS => {
            if !radii_default {
                return Err(KeyError::new(
                    "radii",
                    "`receiver_layout = \"continuous\"` draws each receiver's radius from [rho_min, rho_max]; `radii` must keep its default",
                ));
            }
            KeyError::real("rho_min", rho_min, 1.0, 1e3, Ends::OpenClosed)?;
            KeyError::real("rho_max", rho_max, 1.0, 1e3, Ends::OpenClosed)?;
            if rho_max <= rho_min {
                return Err(KeyError::new(
                    "rho_max",
                    format!("{rho_max} is not above rho_min = {rho_min}"),
                ));
            }
            Ok(())
        }
        "grid" => {
            for (key, v, dv) in [
                ("rho_min", rho_min, defaults.0),
                ("rho_max", rho_max, defaults.1),
            ] {
                if v != dv {
                    return Err(KeyError::new(
                        key,
                        "read with `receiver_layout = \"continuous\"` only; the grid's radii are `radii`",
                    ));
                }
            }
            Ok(())
        }
        other => Err(KeyError::new(
            "receiver_layout",
            format!("{other:?} is not grid or continuous"),
        )),
    }
}

/// The continuous layout in words, for a verdict's caption: `receivers` per seed, the range of
/// ρ − 1, the seeds.
pub(crate) fn continuous_words(
    receivers: usize,
    (rho_min, rho_max): (f64, f64),
    seeds: usize,
) -> String {
    // ρ − 1 to nine decimals: 1.02 − 1 prints 0.02, not 0.020000000000000018.
    let clearance = |rho: f64| ((rho - 1.0) * 1e9).round() / 1e9;
    format!(
        "Spherical receivers at every distance: {receivers} per seed, each its own seeded direction and radius (ρ − 1 log-uniform over [{}, {}]), binned by distance to the surface d; contact: the receiver's direction's point on the bounding sphere is ≥ 40 % occluded; {seeds} seed(s), each its own receivers, truth seed and occluder orientation",
        clearance(rho_min),
        clearance(rho_max),
    )
}

/// Each receiver of a scene's plane by its distance-to-surface bin ([`surface_bin`]), the scene
/// posed at its `pose_t`: the distance to the nearest occluder's surface, in that occluder's
/// radii (exact point-to-triangle through its BVH; the analytic sphere's in closed form).
pub(crate) fn plane_bins(scene: &shscale_scene::scene::Scene) -> Result<Vec<usize>, Error> {
    use rayon::prelude::*;
    let occs = (scene.occluders.iter())
        .map(|o| {
            Ok((
                shscale_scene::frame::build_occluder_at(o, scene.pose_t)?,
                o.radius,
            ))
        })
        .collect::<Result<Vec<_>, Error>>()?;
    let grid = shscale_scene::frame::receiver_grid(scene);
    Ok((grid.par_iter())
        .map(|q| {
            let d = (occs.iter())
                .map(|(o, r)| o.distance_to_surface(*q) / r)
                .fold(f64::INFINITY, f64::min);
            surface_bin(d)
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The continuous radii: inside [lo, hi], one in each of the n equal strata of ln(ρ − 1) in
    /// order, so a band of the log range of fraction f holds within one of n·f of them;
    /// reproducible from the seed, different across seeds.
    #[test]
    fn continuous_radii_are_stratified_in_the_log_of_the_clearance() {
        let (n, lo, hi) = (200, 1.02, 3.0);
        let rho = continuous_radii(7, n, lo, hi);
        assert_eq!(rho.len(), n);
        let (a, b) = ((lo - 1.0f64).ln(), (hi - 1.0f64).ln());
        for (i, r) in rho.iter().enumerate() {
            assert!(*r >= lo && *r <= hi, "{r}");
            let u = ((r - 1.0).ln() - a) / (b - a);
            // Stratum i is [i/n, (i+1)/n); rounding at its ends within 1e-12.
            assert!(u >= i as f64 / n as f64 - 1e-12 && u <= (i + 1) as f64 / n as f64 + 1e-12);
        }
        // Octave bins of the clearance ρ − 1 from 0.02: each is ln 2 / ln 100 of the range.
        let f = 2f64.ln() / 100f64.ln();
        for k in 0..6 {
            let (x0, x1) = (0.02 * 2f64.powi(k), 0.02 * 2f64.powi(k + 1));
            let c = rho
                .iter()
                .filter(|r| **r - 1.0 >= x0 && **r - 1.0 < x1)
                .count();
            let want = n as f64 * f;
            println!("octave {k}: {c} receivers, n·f = {want:.2}");
            // One receiver per stratum: the band covers ⌊nf⌋ − 1 strata whole at least and
            // touches ⌈nf⌉ + 1 at most.
            let c = c as f64;
            assert!(
                c >= want.floor() - 1.0 && c <= want.ceil() + 1.0,
                "{c} vs {want}"
            );
        }
        assert_eq!(rho, continuous_radii(7, n, lo, hi));
        assert_ne!(rho, continuous_radii(8, n, lo, hi));
        // The edges: one receiver lies in [lo, hi]; a degenerate-free narrow range stays in it.
        let one = continuous_radii(1, 1, lo, hi);
        assert!(one[0] >= lo && one[0] <= hi);
        let narrow = continuous_radii(1, 10, 1.5, 1.5 + 1e-9);
        assert!(narrow.iter().all(|r| (1.5..=1.5 + 1e-9).contains(r)));
    }

    /// An orientation seed turns the mesh about its bounding sphere's centre: the sphere and
    /// every edge length are kept, the vertices move; seed 0 is the mesh as loaded; the sphere
    /// is the same in every orientation.
    #[test]
    fn an_orientation_turns_the_mesh_about_its_bounding_sphere() {
        let base = oriented_occluder("duck", 0).unwrap();
        let m0 = base.mesh.as_ref().unwrap();
        let plain = shscale_scene::vocab::unit_occluder("duck").unwrap();
        assert_eq!(m0.positions, plain.mesh.unwrap().positions);
        let turned = oriented_occluder("duck", 31).unwrap();
        let m1 = turned.mesh.as_ref().unwrap();
        let (s0, s1) = (m0.bounding_sphere(), m1.bounding_sphere());
        let dc = (s0.center - s1.center).length();
        let dr = (s0.radius - s1.radius).abs();
        println!("bounding sphere moved {dc:.1e}, radius changed {dr:.1e}");
        assert!(dc < 1e-9 && dr < 1e-9);
        let moved = (m0.positions.iter().zip(&m1.positions))
            .map(|(a, b)| (*a - *b).length())
            .fold(0.0f64, f64::max);
        assert!(
            moved > 0.1 * s0.radius,
            "the vertices did not move: {moved}"
        );
        let worst_edge = (m0.triangles.iter())
            .flat_map(|t| [(t[0], t[1]), (t[1], t[2])])
            .map(|(i, j)| {
                let (i, j) = (i as usize, j as usize);
                let a = (m0.positions[i] - m0.positions[j]).length();
                let b = (m1.positions[i] - m1.positions[j]).length();
                (a - b).abs()
            })
            .fold(0.0f64, f64::max);
        assert!(worst_edge < 1e-12, "an edge changed by {worst_edge:.1e}");
        // The BVH answers for the turned mesh: the turned image of a surface point is on it.
        let c = s0.center;
        let q = shscale_field::truth::SplitMix(31).rotation();
        let p = m0.positions[0];
        let d = turned.occ.distance_to_surface(c + q * (p - c));
        assert!(
            d < 1e-9,
            "a turned vertex is {d:.1e} from the turned surface"
        );
        let sphere = oriented_occluder("sphere", 31).unwrap();
        assert!(sphere.mesh.is_none() && sphere.analytic.is_some());
    }
}
