//! Sequences: the cached single-occluder path equals the direct render; deforming occluders are
//! resampled every frame and static ones reused.

use shscale_scene::render::{render, render_sequence, Method};
use shscale_scene::scene::Scene;
use std::path::Path;

mod common;

use common::{scene, sphere_set_scene};

#[test]
fn one_frame_sequence_equals_the_direct_render() {
    let (s, rs) = scene("[[occluder]]\nmesh = \"duck\"\ncenter = [0, 0, 1.2]\nradius = 1.0\n");
    let direct = render(&s, &rs.with(Method::Extrapolated)).unwrap();
    let (seq, stats) = render_sequence(&s, &rs, 1).unwrap();
    assert_eq!(stats.len(), 1);
    let worst = direct
        .pixels
        .iter()
        .zip(&seq.pixels)
        .map(|(a, b)| ((a[0] - b[0]) / a[0].max(1e-6)).abs())
        .fold(0.0f32, f32::max);
    // The cached path stores U in f32 and the image is f32: agreement to ~1e-6.
    assert!(worst < 1e-5, "cached sequence vs direct render: {worst:e}");
}

#[test]
fn deforming_occluders_are_resampled_and_static_ones_reused() {
    let (s, rs) = scene(
        "[[occluder]]\nmesh = \"bird\"\ncenter = [0, 0, 1.4]\nradius = 1.0\ndeformer = \"flap\"\n\n[[occluder]]\nmesh = \"sphere\"\ncenter = [2, 0, 1.0]\nradius = 0.5\n",
    );
    let (img, stats) = render_sequence(&s, &rs, 3).unwrap();
    assert_eq!(stats.len(), 3);
    assert_eq!((stats[0].resampled, stats[0].reused), (2, 0));
    for st in &stats[1..] {
        assert_eq!((st.resampled, st.reused), (1, 1), "{st:?}");
        assert!(st.bsv_sampling_seconds > 0.0 && st.shading_seconds > 0.0);
    }
    assert!(img.pixels.iter().all(|p| p[0].is_finite() && p[0] > 0.0));
    // The flapping changes the image between frames.
    let (a, _) = render_sequence(&s, &rs, 1).unwrap();
    assert!(a
        .pixels
        .iter()
        .zip(&img.pixels)
        .any(|(x, y)| (x[0] - y[0]).abs() > 1e-4));
}

#[test]
fn bad_deformers_are_named() {
    let e = Scene::parse("d.toml", "[[occluder]]\nmesh = \"bird\"\ncenter = [0,0,1]\nradius = 1\ndeformer = \"wobble\"\n[receiver]\ncenter = [0,0,0]\nsize = [1,1]\nresolution = [4,4]\n[light]\nkind = \"sky\"\n", Path::new("."))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("d.toml:5") && e.contains("deformer") && e.contains("wobble"),
        "{e}"
    );
    let e = Scene::parse("s.toml", "[[occluder]]\nmesh = \"sphere\"\ncenter = [0,0,1]\nradius = 1\ndeformer = \"flap\"\n[receiver]\ncenter = [0,0,0]\nsize = [1,1]\nresolution = [4,4]\n[light]\nkind = \"sky\"\n", Path::new("."))
        .unwrap_err()
        .to_string();
    assert!(e.contains("cannot deform"), "{e}");
}

#[test]
fn local_hinged_light_renders_with_every_supported_method() {
    // Black environment, one hinged red/green light 2 units above the plane: every pixel's
    // irradiance comes from the local light. Plain-η extrapolation must beat energy-preserving
    // extrapolation against the ray-traced radiance (docs/math.md), and the band-limited
    // ray-traced image must approach the full-frequency one.
    let base = r#"
order = 4
layout = "fib:80"
hemisphere_res = 16

[receiver]
center = [0, 0, 0]
size = [4, 4]
resolution = [16, 16]

[light]
kind = "sky"
ambient = 0
zenith = 0
sun = 0

[[light_source]]
kind = "hinge"
center = [0, 0, 2]
size = 1.0
hinge_deg = 100
intensity = 5
"#;
    let (plain, rs) = Scene::parse("l.toml", base, Path::new(".")).unwrap();
    let (energy, _) = Scene::parse(
        "l.toml",
        &format!("{base}eta = \"energy\"\n"),
        Path::new("."),
    )
    .unwrap();
    let rt = render(&plain, &rs.with(Method::RayTraced)).unwrap();
    let full = render(&plain, &rs.with(Method::FullFrequency)).unwrap();
    let ex_p = render(&plain, &rs.with(Method::Extrapolated)).unwrap();
    let ex_e = render(&energy, &rs.with(Method::Extrapolated)).unwrap();
    let rel = |a: &[[f32; 3]], b: &[[f32; 3]], c: usize| {
        let e: Vec<f64> = a.iter().map(|p| p[c] as f64).collect();
        let t: Vec<f64> = b.iter().map(|p| p[c] as f64).collect();
        shscale_field::shading::shade_rmse_rel(&e, &t, &t).unwrap()
    };
    for c in [0usize, 1] {
        let (p, e, bl) = (
            rel(&ex_p.pixels, &rt.pixels, c),
            rel(&ex_e.pixels, &rt.pixels, c),
            rel(&rt.pixels, &full.pixels, c),
        );
        println!("channel {c}: plain {p:.3e}, energy {e:.3e} (vs ray traced); ray traced vs full frequency {bl:.3e}");
        assert!(p < e, "channel {c}: plain {p} should beat energy {e}");
        assert!(bl < 0.3, "channel {c}: band-limited vs full {bl}");
    }
    // Red and green both light the plane, blue is black (compute only what the scene requires).
    assert!(rt.pixels.iter().any(|p| p[0] > 0.01) && rt.pixels.iter().any(|p| p[1] > 0.01));
    assert!(rt.pixels.iter().all(|p| p[2] == 0.0));
    // The full field does not model lights: a clear error.
    assert!(render(&plain, &rs.with(Method::FullField))
        .err()
        .unwrap()
        .to_string()
        .contains("local light"));
}

#[test]
fn real_hdr_environment_map_loads_and_lights_a_scene() {
    let exr = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/envmaps/courtyard.exr");
    let (w, h, px) = shscale_present::image::read_exr(&exr).unwrap();
    assert_eq!((w, h), (1024, 512));
    assert!(px.iter().all(|p| p.iter().all(|v| v.is_finite())));
    // DWAB is lossy: a few texels come back slightly negative (clamped when used as a light).
    let min = px
        .iter()
        .flat_map(|p| p.iter())
        .fold(0f32, |a, b| a.min(*b));
    println!("courtyard.exr: min texel {min:e}");
    assert!(min > -1.0, "min {min}");
    let peak = px
        .iter()
        .flat_map(|p| p.iter())
        .fold(0f32, |a, b| a.max(*b));
    assert!(peak > 10.0, "HDR peak {peak}");
    let text = format!(
        "order = 3\nlayout = \"fib:40\"\nhemisphere_res = 8\n[[occluder]]\nmesh = \"sphere\"\ncenter = [0, 0, 1.2]\nradius = 1\n[receiver]\ncenter = [0, 0, 0]\nsize = [4, 4]\nresolution = [8, 8]\n[light]\nkind = \"exr\"\npath = {:?}\n",
        exr.to_str().unwrap()
    );
    let (s, rs) = Scene::parse("env.toml", &text, Path::new("/")).unwrap();
    let img = render(&s, &rs.with(Method::Extrapolated)).unwrap();
    assert!(img
        .pixels
        .iter()
        .all(|p| p.iter().all(|v| v.is_finite() && *v > 0.0)));
    // The unshadowed irradiance of a +z receiver equals ⟨T, 1⟩ of the projected map: a corner
    // receiver far from the sphere approaches it from below.
    let clamped: Vec<[f32; 3]> = px.iter().map(|p| p.map(|v| v.max(0.0))).collect();
    let light = shscale_field::shading::EnvLight::from_latlong(3, w, h, &clamped).unwrap();
    let lobe = shscale_sh::ClampedCosine::<f64>::new(3).unwrap();
    let open = lobe.irradiance(&light.rgb[1], [0.0, 0.0, 1.0]).unwrap();
    assert!(
        (img.pixels[0][1] as f64) < open * 1.001,
        "{} vs {open}",
        img.pixels[0][1]
    );
}

/// Every method renders a deforming sequence; each frame of a method without the cached path
/// is the single image of its pose (`pose_t = f / frames`), bit for bit, and each frame's error
/// against the band-limited truth equals the error computed from that image directly — at
/// every frame, the cached path's too.
#[test]
fn every_method_renders_sequences_frame_by_frame() {
    use shscale_scene::sequence::{cached_path, render_sequence_with};
    let (s, mut rs) = scene(
        "[[occluder]]\nmesh = \"bird\"\ncenter = [0, 0, 1.4]\nradius = 1.0\ndeformer = \"flap\"\n",
    );
    // Sub-volumes and sphere sets split the bird in three.
    rs.parts = 3;
    let frames = 3;
    let mut open = s.clone();
    open.occluders.clear();
    let flat = |p: &[[f32; 3]]| {
        p.iter()
            .flat_map(|p| p.map(f64::from))
            .collect::<Vec<f64>>()
    };
    let unshadowed = flat(&render(&open, &rs.with(Method::RayTraced)).unwrap().pixels);
    for method in [
        Method::Extrapolated,
        Method::FullField,
        Method::SubVolumes,
        Method::SphereSet,
    ] {
        let mut seen = 0;
        let (img, seq) = render_sequence_with(
            &s,
            &rs.with(method),
            frames,
            Some(Method::RayTraced),
            &mut |_, _| seen += 1,
        )
        .unwrap();
        assert_eq!((seq.len(), seen), (frames, frames), "{method}");
        for f in &seq {
            let posed = Scene {
                pose_t: Some(f.t),
                ..s.clone()
            };
            let truth = render(&posed, &rs.with(Method::RayTraced)).unwrap();
            let direct = render(&posed, &rs.with(method)).unwrap();
            let want = shscale_field::shading::shade_rmse_rel(
                &flat(&direct.pixels),
                &flat(&truth.pixels),
                &unshadowed,
            )
            .unwrap();
            let got = f.error.expect("a reference was given");
            println!(
                "{method} frame {}: shade_rmse_rel {got:.4} (direct {want:.4})",
                f.frame
            );
            if cached_path(&rs.with(method)) {
                // The cached path samples on the sequence's sphere and shades through f32
                // caches: its frames are not the direct images; its last frame's error is
                // checked against its own image below.
                assert!(got > 0.0 && got < 1.0, "{method} frame {}: {got}", f.frame);
            } else {
                assert_eq!(got, want, "{method} frame {}", f.frame);
            }
            assert!(f.seconds > 0.0 && !f.stages.is_empty());
        }
        let last = Scene {
            pose_t: Some((frames - 1) as f64 / frames as f64),
            ..s.clone()
        };
        if cached_path(&rs.with(method)) {
            let truth = render(&last, &rs.with(Method::RayTraced)).unwrap();
            let own = shscale_field::shading::shade_rmse_rel(
                &flat(&img.pixels),
                &flat(&truth.pixels),
                &unshadowed,
            )
            .unwrap();
            assert_eq!(
                seq[frames - 1].error,
                Some(own),
                "{method}: the last frame's error"
            );
        } else {
            let want = render(&last, &rs.with(method)).unwrap();
            assert_eq!(img.pixels, want.pixels, "{method}: the last frame");
        }
    }
    // Per-direction sampling radii leave the cached path (it samples one sphere).
    let mut radial = rs.with(Method::Extrapolated);
    radial.radial = shscale_field::bsv::RadialRule::Clearance { delta: 0.2 };
    assert!(!cached_path(&radial));
    let (_, seq) = render_sequence_with(&s, &radial, 2, None, &mut |_, _| ()).unwrap();
    assert!(
        seq.iter().all(|f| f.error.is_none()
            && f.stages
                .iter()
                .any(|(n, _)| n.contains("sampling") || n.contains("bsv"))),
        "{seq:?}"
    );
}

/// A turned deforming occluder deforms in its own frame and is turned after: its posed mesh is
/// the turn of the unturned occluder's posed mesh (to rounding), and its rest pose the turn of
/// the rest; the turn keeps the bounding sphere.
#[test]
fn a_turned_occluder_deforms_in_its_own_frame() {
    let (s, _) = scene(
        "[[occluder]]\nmesh = \"bird\"\ncenter = [0, 0, 1.4]\nradius = 1.0\ndeformer = \"flap\"\n",
    );
    let plain = s.occluders[0].clone();
    let q = glam::DQuat::from_axis_angle(glam::DVec3::new(1.0, 2.0, 0.5).normalize(), 1.1);
    let mut turned = plain.clone();
    turned.turn = Some(q);
    let c = plain.placed().unwrap().bounding_sphere().center;
    let turn = |m: &shscale_geometry::Mesh| -> Vec<glam::DVec3> {
        m.positions.iter().map(|p| c + q * (*p - c)).collect()
    };
    for t in [None, Some(0.0), Some(0.3), Some(0.7)] {
        let a = shscale_scene::frame::occluder_mesh_at(&plain, t)
            .unwrap()
            .unwrap();
        let b = shscale_scene::frame::occluder_mesh_at(&turned, t)
            .unwrap()
            .unwrap();
        let worst = (turn(&a).iter().zip(&b.positions))
            .map(|(x, y)| (*x - *y).length())
            .fold(0.0f64, f64::max);
        println!("t = {t:?}: turned pose vs turn of the pose, worst {worst:.1e}");
        assert!(worst < 1e-12, "t = {t:?}: {worst:e}");
    }
    let (s0, s1) = (
        plain.placed().unwrap().bounding_sphere(),
        turned.placed().unwrap().bounding_sphere(),
    );
    assert!((s0.center - s1.center).length() < 1e-9 && (s0.radius - s1.radius).abs() < 1e-9);
}

/// `sphere_combine = "quadrature"` renders the sphere set's own quadrature (a 32 × 64 grid of
/// directions tested against the spheres), not the product chain: on [`sphere_set_scene`]
/// (whose parts' spheres overlap) it is closer to the union of the caps (which, like it, counts
/// an overlap once) than the truncated products are, and it differs from the products by far
/// more than rounding. Before the one factory (`method::SetTables`), a still render of the
/// quadrature computed the chain without a word (difference 0). Measured when written:
/// quadrature 1.27e-2 from the union, products 1.84e-2, quadrature vs products printed.
#[test]
fn a_sphere_set_quadrature_renders_the_quadrature_not_the_chain() {
    use shscale_scene::combine::Combine;
    let at = |c: Combine| {
        let (s, mut rs) = sphere_set_scene();
        rs.sphere_combine = c;
        render(&s, &rs.with(Method::SphereSet)).unwrap().pixels
    };
    let (union, quad, chain) = (
        at(Combine::Union),
        at(Combine::Quadrature),
        at(Combine::Product),
    );
    let top = union.iter().flatten().fold(0.0f32, |a, b| a.max(*b));
    let worst = |a: &[[f32; 3]], b: &[[f32; 3]]| {
        (a.iter().zip(b))
            .flat_map(|(x, y)| (0..3).map(move |c| (x[c] - y[c]).abs() / top))
            .fold(0.0f32, f32::max)
    };
    let (q, p, qp) = (
        worst(&quad, &union),
        worst(&chain, &union),
        worst(&quad, &chain),
    );
    println!("sphere set, worst difference of the brightest pixel: quadrature-union {q:.2e}, products-union {p:.2e}, quadrature-products {qp:.2e}");
    assert!(q < QUADRATURE_TOL, "quadrature {q}");
    assert!(
        q < p,
        "the quadrature ({q}) should be closer to the union than the products ({p})"
    );
    assert!(qp > 1e-3, "the quadrature rendered as the chain ({qp})");
}

/// The sphere-set quadrature's tolerance against the union of the caps, relative to the
/// brightest pixel: the grid's resolution of a cap's edge and the union's band limit at N = 4.
const QUADRATURE_TOL: f32 = 0.05;
