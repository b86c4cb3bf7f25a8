//! Sequences: the cached single-occluder path equals the direct render; deforming occluders are
//! resampled every frame and static ones reused.

use shscale_scene::render::{render, render_sequence, Method};
use shscale_scene::scene::Scene;
use shscale_scene::settings::RenderSettings;
use std::path::Path;

fn scene(occluders: &str) -> (Scene, RenderSettings) {
    let text = format!(
        r#"
order = 4
layout = "fib:60"
hemisphere_res = 12
{occluders}
[receiver]
center = [0, 0, 0]
size = [5, 5]
resolution = [20, 20]

[light]
kind = "sky"
"#
    );
    Scene::parse("test.toml", &text, Path::new(".")).unwrap()
}

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

/// The GPU sphere-set sequence of `s` (3 frames) against the CPU render of each pose: the worst
/// difference over every pixel and channel, relative to the brightest CPU pixel, posed and
/// fitted on the host, then on the device (the area fit only; `None` for another fit). Checks on
/// the way that receivers inside the plane-cutting sphere see nothing on both paths and that the
/// frames move with the wings.
fn gpu_sets_vs_cpu(
    (s, rs): (&Scene, &RenderSettings),
    ctx: &shscale_gpu::GpuContext,
) -> (f32, Option<f32>) {
    use shscale_scene::combine::SphereFit;
    use shscale_scene::gpu_sets::SetPose;
    let host = gpu_sets_vs_cpu_posed((s, rs), ctx, SetPose::Host);
    let device = (rs.sphere_fit == SphereFit::Area)
        .then(|| gpu_sets_vs_cpu_posed((s, rs), ctx, SetPose::Device));
    (host, device)
}

fn gpu_sets_vs_cpu_posed(
    (s, rs): (&Scene, &RenderSettings),
    ctx: &shscale_gpu::GpuContext,
    pose: shscale_scene::gpu_sets::SetPose,
) -> f32 {
    use shscale_scene::gpu_sets::render_sequence_sphere_set_gpu_posed;
    let mut frames = Vec::new();
    let (last, stats) = render_sequence_sphere_set_gpu_posed(s, rs, 3, ctx, pose, &mut |f, px| {
        frames.push((f.t, px.to_vec()))
    })
    .unwrap();
    assert_eq!((stats.len(), frames.len()), (3, 3));
    assert_eq!(last.pixels, frames[2].1);
    let mut worst = 0.0f32;
    for (t, gpu) in &frames {
        let posed = Scene {
            pose_t: Some(*t),
            ..s.clone()
        };
        let cpu = render(&posed, &rs.with(Method::SphereSet)).unwrap();
        let top = cpu.pixels.iter().flatten().fold(0.0f32, |a, b| a.max(*b));
        for (g, c) in gpu.iter().zip(&cpu.pixels) {
            for ch in 0..3 {
                worst = worst.max((g[ch] - c[ch]).abs() / top);
            }
        }
        // Receivers inside the sphere that cuts the plane see nothing, on both paths.
        let inside = (gpu.iter().zip(&cpu.pixels))
            .filter(|(g, c)| **g == [0.0; 3] && **c == [0.0; 3])
            .count();
        assert!(inside > 0, "no receiver inside the plane-cutting sphere");
        // The shadows move with the wings: the frames differ.
        assert!(gpu.iter().zip(&frames[0].1).any(|(a, b)| a != b) || *t == 0.0);
    }
    println!(
        "GPU sphere sets ({}, posed {pose:?}) vs CPU render, 3 frames, {} receivers: worst difference {worst:.2e} of the brightest pixel ({})",
        rs.sphere_combine.name(),
        frames[0].1.len(),
        ctx.describe()
    );
    worst
}

/// The scene of the GPU sphere-set parity tests: a flapping bird of 4 spheres and three static
/// analytic spheres, one cutting the receiver plane (receivers inside it see nothing) and one
/// 10⁴ radii away (a cap of 1e-4 rad).
fn sphere_set_scene() -> (Scene, RenderSettings) {
    let (s, mut rs) = scene(
        "[[occluder]]\nmesh = \"bird\"\ncenter = [0, 0, 1.4]\nradius = 1.0\ndeformer = \"flap\"\n\n[[occluder]]\nmesh = \"sphere\"\ncenter = [1.5, 0.5, 0.9]\nradius = 0.4\n\n[[occluder]]\nmesh = \"sphere\"\ncenter = [-1.5, -1.5, 0.1]\nradius = 0.6\n\n[[occluder]]\nmesh = \"sphere\"\ncenter = [0, 0, 3000]\nradius = 0.3\n",
    );
    rs.parts = 4;
    (s, rs)
}

/// The adapter, or `None` with a notice (a failure under `SHSCALE_REQUIRE_GPU=1`).
fn gpu_or_skip(what: &str) -> Option<shscale_gpu::GpuContext> {
    match shscale_gpu::GpuContext::new() {
        Ok(c) => Some(c),
        Err(e) => {
            assert!(!shscale_gpu::require_gpu_from_env(), "{e}");
            eprintln!("notice: {e}; the {what} test is skipped");
            None
        }
    }
}

/// Sphere sets on the GPU path against the CPU render of the same pose, frame by frame (7
/// spheres multiplied near to far, 3 frames of [`sphere_set_scene`]); bounded by f32 rounding.
/// Skips with a notice without an adapter unless `SHSCALE_REQUIRE_GPU=1`.
#[test]
fn gpu_sphere_sets_match_the_cpu_render_frame_by_frame() {
    use shscale_scene::gpu_sets::render_sequence_sphere_set_gpu;
    let Some(ctx) = gpu_or_skip("GPU sphere-set parity") else {
        return;
    };
    let (s, rs) = sphere_set_scene();
    let (host, device) = gpu_sets_vs_cpu((&s, &rs), &ctx);
    assert!(host < 1e-4, "{host}");
    // Posed and fitted on the device, within the same bound: the spheres' f32 pose and sums
    // (at most 1.4e-7 r from the host's, shscale_gpu's fit test) add nothing visible to it.
    let device = device.expect("area fit");
    assert!(device < 1e-4, "{device}");
    // Refused by name: a higher internal order, too many spheres, a combination without a GPU
    // form.
    let mut high = rs.clone();
    high.sphere_order = 8;
    let e = render_sequence_sphere_set_gpu(&s, &high, 1, &ctx, &mut |_, _| ())
        .err()
        .expect("refused");
    assert!(e.to_string().contains("sphere_order"), "{e}");
    let mut many = rs.clone();
    many.parts = 40;
    let e = render_sequence_sphere_set_gpu(&s, &many, 1, &ctx, &mut |_, _| ())
        .err()
        .expect("refused");
    assert!(e.to_string().contains("at most 64 spheres"), "{e}");
    let mut quad = rs.clone();
    quad.sphere_combine = shscale_scene::combine::Combine::Quadrature;
    let e = render_sequence_sphere_set_gpu(&s, &quad, 1, &ctx, &mut |_, _| ())
        .err()
        .expect("refused");
    assert!(
        e.to_string().contains("sphere_combine \"quadrature\""),
        "{e}"
    );
}

/// Sphere sets combined by SH exponentiation on the GPU (f32: the tabulated logs rotated and
/// summed, the HYB exponential's halvings, OL and squarings) against the CPU's (f64), frame by
/// frame, on [`sphere_set_scene`] — posed and fitted on the host and on the device — and at
/// N = 8 with 16 spheres a part; bounded by [`SHEXP_GPU_TOL`] (the worst printed). Skips as the
/// tests above.
#[test]
fn gpu_sphere_set_shexp_matches_the_cpu_render_frame_by_frame() {
    let Some(ctx) = gpu_or_skip("GPU sphere-set SH exponentiation parity") else {
        return;
    };
    let (s, mut rs) = sphere_set_scene();
    rs.sphere_combine = shscale_scene::combine::Combine::Shexp;
    let (host, device) = gpu_sets_vs_cpu((&s, &rs), &ctx);
    assert!(host < SHEXP_GPU_TOL, "{host}");
    assert!(device.expect("area fit") < SHEXP_GPU_TOL, "{device:?}");
    rs.order = 8;
    rs.parts = 16;
    let (host, _) = gpu_sets_vs_cpu((&s, &rs), &ctx);
    assert!(host < SHEXP_GPU_TOL, "{host}");
    // The combination matters here: the CPU's exponentiation and chain differ by far more than
    // the tolerance on this scene (so a kernel multiplying the caps would fail the bound).
    let (set, chain_rs) = sphere_set_scene();
    let posed = Scene {
        pose_t: Some(1.0 / 3.0),
        ..set
    };
    let chain = render(&posed, &chain_rs.with(Method::SphereSet)).unwrap();
    let shexp = render(
        &posed,
        &RenderSettings {
            sphere_combine: shscale_scene::combine::Combine::Shexp,
            ..chain_rs.with(Method::SphereSet)
        },
    )
    .unwrap();
    let top = chain.pixels.iter().flatten().fold(0.0f32, |a, b| a.max(*b));
    let apart = (chain
        .pixels
        .iter()
        .flatten()
        .zip(shexp.pixels.iter().flatten()))
    .map(|(a, b)| (a - b).abs() / top)
    .fold(0.0f32, f32::max);
    println!("CPU chain against CPU exponentiation: {apart:.2e} of the brightest pixel");
    assert!(apart > 10.0 * SHEXP_GPU_TOL, "{apart}");
}

/// Two deforming meshes and an analytic sphere, posed and fitted on the device: each mesh's parts
/// fitted into its own slots (the second mesh's after the first's), the fixed sphere after both;
/// the frames are the CPU render's within the chain's bound, as posed on the host.
#[test]
fn gpu_sphere_sets_of_two_meshes_fit_on_the_device_into_their_own_slots() {
    let Some(ctx) = gpu_or_skip("GPU sphere sets of two meshes") else {
        return;
    };
    let (s, mut rs) = scene(
        "[[occluder]]\nmesh = \"bird\"\ncenter = [-1, 0, 1.4]\nradius = 0.8\ndeformer = \"flap\"\n\n[[occluder]]\nmesh = \"egg\"\ncenter = [1.2, 0.5, 1.2]\nradius = 0.7\ndeformer = \"morph\"\n\n[[occluder]]\nmesh = \"sphere\"\ncenter = [-1.5, -1.5, 0.1]\nradius = 0.6\n",
    );
    rs.parts = 3;
    let (host, device) = gpu_sets_vs_cpu((&s, &rs), &ctx);
    let device = device.expect("area fit");
    println!("two meshes, 3 parts each: host-posed {host:.2e}, device-posed {device:.2e}");
    assert!(host < 1e-4 && device < 1e-4, "{host} {device}");
}

/// The GPU exponentiation's tolerance, relative to the brightest pixel: f32 logs summed over up
/// to 19 spheres, and each halving's squaring doubling the exponential's relative rounding
/// (2.3e-5–2.6e-5 on lavapipe when written).
const SHEXP_GPU_TOL: f32 = 1e-4;

/// The union of the caps on the GPU (f32, the light's transfer taken into the union's frame by
/// quadrature) against the CPU's union (f64, the SH rotation), frame by frame, on
/// [`sphere_set_scene`] and at N = 8 with 16 spheres a part; bounded by f32 rounding. Skips as
/// the test above.
#[test]
fn gpu_sphere_set_unions_match_the_cpu_render_frame_by_frame() {
    let Some(ctx) = gpu_or_skip("GPU sphere-set union parity") else {
        return;
    };
    let (s, mut rs) = sphere_set_scene();
    rs.sphere_combine = shscale_scene::combine::Combine::Union;
    let (host, device) = gpu_sets_vs_cpu((&s, &rs), &ctx);
    assert!(host < UNION_GPU_TOL, "{host}");
    assert!(device.expect("area fit") < UNION_GPU_TOL, "{device:?}");
    rs.order = 8;
    rs.parts = 16;
    let (host, device) = gpu_sets_vs_cpu((&s, &rs), &ctx);
    assert!(host < UNION_GPU_TOL, "{host}");
    assert!(device.expect("area fit") < UNION_GPU_TOL, "{device:?}");
    // Each pose's inscribed balls instead of the parts' spheres: the same sets on both paths
    // (the device does not fit them: refused by name).
    rs.order = 4;
    rs.sphere_fit = shscale_scene::combine::SphereFit::Inscribed;
    let (host, device) = gpu_sets_vs_cpu((&s, &rs), &ctx);
    assert!(
        host < UNION_GPU_TOL && device.is_none(),
        "inscribed: {host}"
    );
    let e = shscale_scene::gpu_sets::render_sequence_sphere_set_gpu_posed(
        &s,
        &rs,
        1,
        &ctx,
        shscale_scene::gpu_sets::SetPose::Device,
        &mut |_, _| (),
    )
    .err()
    .expect("refused");
    assert!(
        e.to_string()
            .contains("sphere_fit \"inscribed\" is fitted on the host"),
        "{e}"
    );
}

/// The GPU union's tolerance, relative to the brightest pixel: f32 rounding of the caps'
/// half-widths (`cos h` from a difference of products, then `acos`) and of the rings' sums.
const UNION_GPU_TOL: f32 = 1e-4;

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

/// The worst difference, over every pixel and channel of `frames` (`(t, pixels)` of a GPU
/// sequence of `s`), from the CPU render by `method` of the same pose, relative to the brightest
/// CPU pixel; every frame after the first must differ from the first (the shadows move).
fn worst_against_cpu(
    (s, rs): (&Scene, &RenderSettings),
    method: Method,
    frames: &[(f64, Vec<[f32; 3]>)],
) -> f32 {
    let mut worst = 0.0f32;
    for (t, gpu) in frames {
        let posed = Scene {
            pose_t: Some(*t),
            ..s.clone()
        };
        let cpu = render(&posed, &rs.with(method)).unwrap();
        let top = cpu.pixels.iter().flatten().fold(0.0f32, |a, b| a.max(*b));
        for (g, c) in gpu.iter().zip(&cpu.pixels) {
            for ch in 0..3 {
                worst = worst.max((g[ch] - c[ch]).abs() / top);
            }
        }
        assert!(gpu.iter().zip(&frames[0].1).any(|(a, b)| a != b) || *t == 0.0);
    }
    worst
}

/// The papers' full field on the GPU path against the CPU render of the same pose, frame by
/// frame: a flapping bird, 3 frames, on a Fibonacci layout (barycentric between samples) and on
/// a latitude–longitude one (trilinear), 16 shells over [1, 8]·r. The worst difference over
/// every pixel and channel relative to the brightest CPU pixel is printed and bounded by
/// [`FIELD_GPU_TOL`]. Skips as the tests above.
#[test]
fn gpu_full_field_matches_the_cpu_render_frame_by_frame() {
    use shscale_scene::gpu_field::render_sequence_full_field_gpu;
    let Some(ctx) = gpu_or_skip("GPU full-field parity") else {
        return;
    };
    let bird =
        "[[occluder]]\nmesh = \"bird\"\ncenter = [0, 0, 1.4]\nradius = 1.0\ndeformer = \"flap\"\n";
    for layout in ["fib:60", "latlong:6x10"] {
        let (s, mut rs) = scene(bird);
        rs.layout = shscale_field::Layout::parse(layout).unwrap();
        let mut frames = Vec::new();
        let (last, stats) = render_sequence_full_field_gpu(&s, &rs, 3, &ctx, &mut |f, px| {
            frames.push((f.t, px.to_vec()))
        })
        .unwrap();
        assert_eq!((stats.len(), frames.len()), (3, 3));
        assert_eq!(last.pixels, frames[2].1);
        let worst = worst_against_cpu((&s, &rs), Method::FullField, &frames);
        println!(
            "GPU full field ({layout}) vs CPU render, 3 frames, {} receivers: worst difference {worst:.2e} of the brightest pixel ({})",
            frames[0].1.len(),
            ctx.describe()
        );
        assert!(worst < FIELD_GPU_TOL, "{layout}: {worst}");
    }
    // Refused by name: the analytic sphere (no triangles), several occluders.
    let (two, rs) = scene(&format!(
        "{bird}\n[[occluder]]\nmesh = \"sphere\"\ncenter = [1.5, 0.5, 0.9]\nradius = 0.4\n"
    ));
    let e = render_sequence_full_field_gpu(&two, &rs, 1, &ctx, &mut |_, _| ())
        .err()
        .expect("refused");
    assert!(e.to_string().contains("exactly one mesh occluder"), "{e}");
}

/// The GPU full field's tolerance, relative to the brightest pixel: f32 projection, weights and
/// shading (measured 5.5e-7 on lavapipe, where no ray of these frames was decided differently).
/// A ray grazing an edge, whose f32 direction on the GPU and f64 one on the CPU decide the hit
/// differently, would move one sample's coefficients by its quadrature weight (~1/H² of the
/// hemisphere): should this fail after a change of mesh or layout, count such rays first.
const FIELD_GPU_TOL: f32 = 2e-5;

/// The extrapolation from per-direction radii (`radial = "clearance"`, δ = 0.5r) on the GPU path
/// against the CPU render of the same pose, frame by frame: a flapping bird, 3 frames, the
/// radii, table and receivers' locations rebuilt every frame; bounded by [`RADIAL_GPU_TOL`]
/// (printed). The occlusion rule (rays on the CPU) is refused by name. Skips as the tests above.
#[test]
fn gpu_radial_extrapolation_matches_the_cpu_render_frame_by_frame() {
    use shscale_field::bsv::RadialRule;
    use shscale_scene::gpu_radial::render_sequence_radial_gpu;
    let Some(ctx) = gpu_or_skip("GPU per-direction radii parity") else {
        return;
    };
    let (s, mut rs) = scene(
        "[[occluder]]\nmesh = \"bird\"\ncenter = [0, 0, 1.4]\nradius = 1.0\ndeformer = \"flap\"\n",
    );
    rs.radial = RadialRule::Clearance { delta: 0.5 };
    let mut frames = Vec::new();
    let (last, stats) = render_sequence_radial_gpu(&s, &rs, 3, &ctx, &mut |f, px| {
        frames.push((f.t, px.to_vec()))
    })
    .unwrap();
    assert_eq!((stats.len(), frames.len()), (3, 3));
    assert_eq!(last.pixels, frames[2].1);
    let worst = worst_against_cpu((&s, &rs), Method::Extrapolated, &frames);
    println!(
        "GPU per-direction radii vs CPU render, 3 frames, {} receivers: worst difference {worst:.2e} of the brightest pixel ({})",
        frames[0].1.len(),
        ctx.describe()
    );
    assert!(worst < RADIAL_GPU_TOL, "{worst}");
    // The radii matter: the uniform sphere's render of the last pose is far from the radial one.
    let posed = Scene {
        pose_t: Some(frames[2].0),
        ..s.clone()
    };
    let uniform = RenderSettings {
        radial: RadialRule::Uniform,
        ..rs.with(Method::Extrapolated)
    };
    let (a, b) = (
        render(&posed, &rs.with(Method::Extrapolated)).unwrap(),
        render(&posed, &uniform).unwrap(),
    );
    let apart = (a.pixels.iter().flatten().zip(b.pixels.iter().flatten()))
        .map(|(x, y)| (x - y).abs())
        .fold(0.0f32, f32::max);
    assert!(
        apart > 100.0 * worst,
        "radial and uniform renders only {apart} apart"
    );
    let mut occ = rs.clone();
    occ.radial = RadialRule::Occlusion {
        tau: 0.05,
        t_max: 3.0,
    };
    let e = render_sequence_radial_gpu(&s, &occ, 1, &ctx, &mut |_, _| ())
        .err()
        .expect("refused");
    assert!(e.to_string().contains("clearance"), "{e}");
}

/// The GPU radial path's tolerance, relative to the brightest pixel: f32 rays, projection, k
/// and rotations as the papers' GPU path (`SHADE_TOL` of the GPU parity tests, 1e-5), and a ray
/// grazing an edge decided differently in f32 (see [`FIELD_GPU_TOL`]).
const RADIAL_GPU_TOL: f32 = 2e-5;

/// The papers' GPU sequence pipelined (the host posing and refitting frame i + 1 while the
/// device runs frame i) renders the sequential sequence's images bit for bit — the same uploads
/// in the same order —, keeps every frame's stages and reports each frame's period beside their
/// sum. No speed is asserted (a timed test would measure the machine). Skips as the tests above.
#[test]
fn pipelined_gpu_frames_render_the_sequential_images() {
    use shscale_scene::gpu_path::{render_sequence_gpu_with, GpuFrames};
    let Some(ctx) = gpu_or_skip("pipelined GPU sequence") else {
        return;
    };
    let (s, rs) = scene(
        "[[occluder]]\nmesh = \"bird\"\ncenter = [0, 0, 1.4]\nradius = 1.0\ndeformer = \"flap\"\n",
    );
    for frames in [1, 4] {
        let seq = render_sequence_gpu_with(&s, &rs, frames, &ctx, GpuFrames::Sequential).unwrap();
        let pip = render_sequence_gpu_with(&s, &rs, frames, &ctx, GpuFrames::Pipelined).unwrap();
        assert_eq!(seq.image.pixels, pip.image.pixels, "{frames} frames");
        assert_eq!(pip.frames.len(), frames);
        for (i, f) in pip.frames.iter().enumerate() {
            assert!(f.pipelined && f.frame == i);
            let g = &f.gpu;
            assert!(g.sampling_seconds > 0.0 && g.shading_seconds > 0.0 && g.bvh_seconds > 0.0);
            assert!(f.seconds() > 0.0 && f.stage_sum() > 0.0);
            println!(
                "frame {i}: stages {:.3} ms, period {:.3} ms",
                1e3 * f.stage_sum(),
                1e3 * f.seconds()
            );
        }
        assert!(seq.frames.iter().all(|f| !f.pipelined));
    }
}

/// Frames posed and refitted on the device against the same frames posed on the host (the
/// host's f64 pose and obvhs refit, uploaded): a flapping bird, a bending sponge-like block and a
/// morphing egg, 4 frames each. The f32 pose moves vertices by ≤ 1.2e-7 r (`gpu/tests/pose.rs`),
/// so only rays grazing an edge may be decided differently; the images agree within
/// [`DEVICE_POSE_TOL`] of the brightest pixel (the worst printed; 0 on lavapipe when written),
/// while the pose moves the image by more than ten times that; the device stages are timed.
/// Skips as the tests above.
#[test]
fn device_posed_gpu_frames_match_the_host_posed_ones() {
    use shscale_scene::gpu_path::{render_sequence_gpu_with, GpuFrames};
    let Some(ctx) = gpu_or_skip("device-posed GPU sequence") else {
        return;
    };
    for (mesh, deformer) in [("bird", "flap"), ("sponge", "bend"), ("egg", "morph")] {
        let (s, rs) = scene(&format!(
            "[[occluder]]\nmesh = \"{mesh}\"\ncenter = [0, 0, 1.4]\nradius = 1.0\ndeformer = \"{deformer}\"\n"
        ));
        let host = render_sequence_gpu_with(&s, &rs, 4, &ctx, GpuFrames::Sequential).unwrap();
        let dev = render_sequence_gpu_with(&s, &rs, 4, &ctx, GpuFrames::DevicePose).unwrap();
        let bright = host
            .image
            .pixels
            .iter()
            .flatten()
            .fold(0f32, |a, &v| a.max(v));
        let worst = (host.image.pixels.iter().zip(&dev.image.pixels))
            .flat_map(|(a, b)| (0..3).map(move |c| (a[c] - b[c]).abs()))
            .fold(0f32, f32::max)
            / bright;
        println!(
            "{mesh} {deformer}: device-posed vs host-posed last frame, worst {worst:.2e} of the brightest pixel"
        );
        assert!(worst <= DEVICE_POSE_TOL, "{mesh}: {worst:.2e}");
        // The pose matters: the rest pose (t = 0) renders the plane otherwise.
        let rest = render_sequence_gpu_with(&s, &rs, 1, &ctx, GpuFrames::DevicePose).unwrap();
        let moved = (rest.image.pixels.iter().zip(&dev.image.pixels))
            .flat_map(|(a, b)| (0..3).map(move |c| (a[c] - b[c]).abs()))
            .fold(0f32, f32::max)
            / bright;
        assert!(
            moved > 10.0 * DEVICE_POSE_TOL,
            "{mesh}: the pose moved the image by {moved:.2e}"
        );
        for f in &dev.frames {
            let g = &f.gpu;
            assert!(
                g.deform_seconds > 0.0 && g.refit_seconds > 0.0,
                "{mesh}: {g:?}"
            );
            assert_eq!(f.deform_seconds, 0.0);
            assert!(f.stage_sum() >= g.deform_seconds + g.refit_seconds + g.sampling_seconds);
        }
    }
}

/// Device-posed frames two in flight (frame i + 1 submitted before frame i is waited for) render
/// the images of device-posed frames one at a time bit for bit — the same pose and refit
/// kernels; the rebuild rule, reading each frame's area when it completes, may rebuild later,
/// which changes the tree's shape and never a ray's answer (the bending sponge rebuilds, the
/// flapping bird refits) — in frame order, every frame with its five device stages and a period.
/// No speed is asserted. Skips as the tests above.
#[test]
fn device_posed_frames_in_flight_render_the_one_at_a_time_images() {
    use shscale_scene::gpu_path::{render_sequence_gpu_with, GpuFrames};
    let Some(ctx) = gpu_or_skip("device-posed GPU frames in flight") else {
        return;
    };
    for (mesh, deformer) in [("bird", "flap"), ("sponge", "bend")] {
        let (s, rs) = scene(&format!(
            "[[occluder]]\nmesh = \"{mesh}\"\ncenter = [0, 0, 1.4]\nradius = 1.0\ndeformer = \"{deformer}\"\n"
        ));
        for frames in [1, 2, 5] {
            let one =
                render_sequence_gpu_with(&s, &rs, frames, &ctx, GpuFrames::DevicePose).unwrap();
            let fly =
                render_sequence_gpu_with(&s, &rs, frames, &ctx, GpuFrames::DeviceInFlight).unwrap();
            assert_eq!(
                one.image.pixels, fly.image.pixels,
                "{mesh}, {frames} frames"
            );
            assert_eq!(fly.frames.len(), frames);
            for (i, f) in fly.frames.iter().enumerate() {
                let g = &f.gpu;
                assert!(f.pipelined && f.frame == i, "{mesh}: {f:?}");
                assert!(
                    g.deform_seconds > 0.0
                        && g.refit_seconds > 0.0
                        && g.sampling_seconds > 0.0
                        && g.shading_seconds > 0.0
                        && f.seconds() > 0.0,
                    "{mesh}: {g:?}"
                );
            }
            println!(
                "{mesh}, {frames} frames: identical images; host rebuilds one at a time {}, in flight {}",
                one.host_rebuilds, fly.host_rebuilds
            );
        }
    }
}

/// The device pose's image tolerance, relative to the brightest pixel: a ray grazing an edge may
/// flip when a vertex moves by an f32 rounding (as [`FIELD_GPU_TOL`]'s grazing rays).
const DEVICE_POSE_TOL: f32 = 1e-3;

/// Sub-volumes on the GPU path against the CPU render of the same pose, frame by frame: a
/// flapping bird in 3 parts (each part's own sphere, table and extrapolation, the parts
/// multiplied near to far), 3 frames; bounded by [`PARTS_GPU_TOL`] (printed). Too many parts and
/// the clearance rule are refused by name. Skips as the tests above.
#[test]
fn gpu_sub_volumes_match_the_cpu_render_frame_by_frame() {
    use shscale_field::bsv::RadialRule;
    use shscale_scene::gpu_parts::render_sequence_sub_volumes_gpu;
    let Some(ctx) = gpu_or_skip("GPU sub-volumes parity") else {
        return;
    };
    let (s, mut rs) = scene(
        "[[occluder]]\nmesh = \"bird\"\ncenter = [0, 0, 1.4]\nradius = 1.0\ndeformer = \"flap\"\n",
    );
    rs.parts = 3;
    let mut frames = Vec::new();
    let (last, stats) = render_sequence_sub_volumes_gpu(&s, &rs, 3, &ctx, &mut |f, px| {
        frames.push((f.t, px.to_vec()))
    })
    .unwrap();
    assert_eq!((stats.len(), frames.len()), (3, 3));
    assert_eq!(last.pixels, frames[2].1);
    let worst = worst_against_cpu((&s, &rs), Method::SubVolumes, &frames);
    println!(
        "GPU sub-volumes (3 parts) vs CPU render, 3 frames, {} receivers: worst difference {worst:.2e} of the brightest pixel ({})",
        frames[0].1.len(),
        ctx.describe()
    );
    assert!(worst < PARTS_GPU_TOL, "{worst}");
    // The parts matter: one part (the plain extrapolation) renders the last pose differently.
    let posed = Scene {
        pose_t: Some(frames[2].0),
        ..s.clone()
    };
    let one = render(
        &posed,
        &RenderSettings {
            parts: 1,
            ..rs.with(Method::SubVolumes)
        },
    )
    .unwrap();
    let apart = (one
        .pixels
        .iter()
        .flatten()
        .zip(frames[2].1.iter().flatten()))
    .map(|(x, y)| (x - y).abs())
    .fold(0.0f32, f32::max);
    assert!(apart > 100.0 * worst, "1 and 3 parts only {apart} apart");
    for (bad, needle) in [
        (
            RenderSettings {
                parts: 17,
                ..rs.clone()
            },
            "at most 16",
        ),
        (
            RenderSettings {
                radial: RadialRule::Clearance { delta: 0.1 },
                ..rs.clone()
            },
            "per-direction radii",
        ),
    ] {
        let e = render_sequence_sub_volumes_gpu(&s, &bad, 1, &ctx, &mut |_, _| ())
            .err()
            .expect("refused");
        assert!(e.to_string().contains(needle), "{e}");
    }
}

/// The GPU sub-volumes' tolerance, relative to the brightest pixel: f32 rays, projections, k
/// and rotations per part (as [`RADIAL_GPU_TOL`]) and the f32 Gaunt products between them
/// (measured 2.2e-6 on lavapipe).
const PARTS_GPU_TOL: f32 = 2e-5;

/// The band-limited ray-traced reference on the GPU path (two Gauss hemispheres of
/// `H = round(√2·T)` rays per receiver, `shscale_scene::gpu_truth`) against the CPU's (4T²
/// stratified rays), frame by frame on a flapping bird: both estimate one projection, so each is
/// held against the CPU's at 4× the resolution (T = 64, its own error printed), and the GPU's
/// distance from it must not exceed [`TRUTH_GPU_FACTOR`] times the CPU's at the same T. Skips
/// as the tests above.
#[test]
fn gpu_ray_traced_reference_converges_with_the_cpu_one() {
    use shscale_scene::gpu_truth::render_sequence_ray_traced_gpu;
    let Some(ctx) = gpu_or_skip("GPU ray-traced reference") else {
        return;
    };
    let (s, mut rs) = scene(
        "[[occluder]]\nmesh = \"bird\"\ncenter = [0, 0, 1.4]\nradius = 1.0\ndeformer = \"flap\"\n",
    );
    rs.truth_res = 16;
    let mut frames = Vec::new();
    let (last, stats) = render_sequence_ray_traced_gpu(&s, &rs, 3, &ctx, &mut |f, px| {
        frames.push((f.t, px.to_vec()))
    })
    .unwrap();
    assert_eq!((stats.len(), frames.len()), (3, 3));
    assert_eq!(last.pixels, frames[2].1);
    let (mut gpu_worst, mut cpu_worst, mut own) = (0f32, 0f32, 0f32);
    for (t, gpu) in &frames {
        let posed = Scene {
            pose_t: Some(*t),
            ..s.clone()
        };
        let at = |truth_res| RenderSettings {
            truth_res,
            ..rs.with(Method::RayTraced)
        };
        let cpu = render(&posed, &at(16)).unwrap();
        let fine = render(&posed, &at(64)).unwrap();
        let top = fine.pixels.iter().flatten().fold(0f32, |a, b| a.max(*b));
        let worst = |img: &[[f32; 3]]| {
            (img.iter().zip(&fine.pixels))
                .flat_map(|(a, b)| (0..3).map(move |c| (a[c] - b[c]).abs()))
                .fold(0f32, f32::max)
                / top
        };
        gpu_worst = gpu_worst.max(worst(gpu));
        cpu_worst = cpu_worst.max(worst(&cpu.pixels));
        own = own.max(fine.error.iter().flatten().fold(0f32, |a, b| a.max(*b)) / top);
    }
    println!(
        "ray-traced reference, 3 frames, T = 16, against the CPU's at T = 64 (own error ≤ {own:.1e}): GPU (H = {}) worst {gpu_worst:.2e}, CPU worst {cpu_worst:.2e} of the brightest pixel ({})",
        shscale_scene::gpu_truth::gauss_res(16),
        ctx.describe()
    );
    assert!(
        gpu_worst <= TRUTH_GPU_FACTOR * cpu_worst,
        "{gpu_worst} vs {cpu_worst}"
    );
    assert!(gpu_worst > 0.0);
    // A frame's per-ray visibility beyond the adapter's binding is refused by name, before any
    // buffer is made (160 × 160 receivers at T = 256: ~27 GB).
    let mut big = s.clone();
    big.resolution = [160, 160];
    let mut big_rs = rs.clone();
    big_rs.truth_res = 256;
    let e = render_sequence_ray_traced_gpu(&big, &big_rs, 1, &ctx, &mut |_, _| ())
        .err()
        .expect("refused")
        .to_string();
    assert!(
        e.contains("truth_res") && e.contains("storage binding"),
        "{e}"
    );
}

/// How much farther than the CPU's own quadrature at the same `T` the GPU's may lie from the
/// finer reference (both quadratures of one projection; the GPU's Gauss rule is not worse in
/// kind, so a factor of 2 leaves room for where its rays fall).
const TRUTH_GPU_FACTOR: f32 = 2.0;

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
