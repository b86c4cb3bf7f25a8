//! The cached plane (`shscale_scene::cached`): for the extrapolated field and the fully sampled
//! field alike, a cached frame's image equals the direct render's (the oracle: the render path
//! that evaluates every receiver from the field itself); where no cached path applies it says
//! so (`None`), never a wrong image.

use shscale_field::evaluator::{FieldInterp, ShellSpacing, Shells};
use shscale_scene::cached::CachedPlane;
use shscale_scene::render::{render, Method};
use shscale_scene::scene::Scene;
use shscale_scene::settings::RenderSettings;
use std::path::Path;

fn scene(extra: &str, occluders: &str) -> (Scene, RenderSettings) {
    let text = format!(
        "order = 4\nlayout = \"latlong:6x10\"\nhemisphere_res = 8\n{extra}\n{occluders}\n[receiver]\ncenter = [0, 0, 0]\nsize = [5, 5]\nresolution = [24, 24]\n[light]\nkind = \"sky\"\nsun = 30.0\nsun_dir = [0.4, 0.3, 1.0]\nsun_radius_deg = 8\n"
    );
    Scene::parse("test.toml", &text, Path::new(".")).unwrap()
}

const DUCK: &str = "[[occluder]]\nmesh = \"duck\"\ncenter = [0, 0, 1.1]\nradius = 1.0\n";

/// The largest difference of the cached frame from the direct render, relative to the largest
/// pixel.
fn worst((s, rs): &(Scene, RenderSettings), method: Method) -> f64 {
    let rs = rs.with(method);
    let direct = render(s, &rs).unwrap();
    let plane = CachedPlane::new(s, &rs).unwrap().expect("a cached path");
    let cached = plane.frame().unwrap();
    // Twice: a frame re-samples and re-shades, the same image.
    assert_eq!(cached, plane.frame().unwrap());
    let top = (direct.pixels.iter().flatten()).fold(0.0f32, |a, b| a.max(*b)) as f64;
    let w = (direct.pixels.iter().zip(&cached))
        .flat_map(|(a, b)| (0..3).map(move |c| (a[c] as f64 - b[c]).abs()))
        .fold(0.0f64, f64::max);
    assert!(plane.build_seconds > 0.0);
    w / top
}

#[test]
fn a_cached_extrapolated_frame_equals_the_direct_render() {
    let w = worst(&scene("", DUCK), Method::Extrapolated);
    println!("extrapolated: cached vs direct, worst {w:.2e} of the brightest pixel");
    // U in f32 (~6e-8 relative) and the f32 image: 1e-5 bounds both with room.
    assert!(w < 1e-5, "{w:e}");
}

#[test]
fn a_cached_full_field_frame_equals_the_direct_render_for_every_construction() {
    let mut s = scene("", DUCK);
    for (spacing, interp, count, max) in [
        (ShellSpacing::Uniform, FieldInterp::Trilinear, 16, 8.0),
        (ShellSpacing::Exp, FieldInterp::Barycentric, 4, 3.0),
        // Receivers beyond the outermost shell (1.5r): unshadowed through the cache too.
        (ShellSpacing::Uniform, FieldInterp::Trilinear, 3, 1.5),
    ] {
        s.1.full_field = Some(Shells {
            count,
            rho_min: 1.0,
            rho_max: max,
            spacing,
            interp,
        });
        let w = worst(&s, Method::FullField);
        println!("{count} shells to {max}r ({spacing:?}, {interp:?}): worst {w:.2e}");
        // f64 throughout, summed in another order; the image is f32.
        assert!(w < 1e-5, "{w:e}");
    }
}

#[test]
fn no_cached_path_where_the_cache_would_be_wrong() {
    let two =
        format!("{DUCK}[[occluder]]\nmesh = \"sphere\"\ncenter = [1.5, 0, 1.1]\nradius = 0.5\n");
    let clamp = scene("plausibility = \"clamp\"", DUCK);
    for (s, m) in [
        (scene("", &two), Method::Extrapolated),
        (clamp, Method::Extrapolated),
        (scene("", DUCK), Method::RayTraced),
        (scene("", DUCK), Method::SphereSet),
    ] {
        assert!(
            CachedPlane::new(&s.0, &s.1.with(m)).unwrap().is_none(),
            "{m:?}"
        );
    }
}
