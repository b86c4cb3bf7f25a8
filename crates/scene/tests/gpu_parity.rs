//! The GPU sequences against the CPU render of every pose, method by method (sphere sets,
//! the full field, per-direction radii, sub-volumes, the ray-traced reference), and the GPU
//! frames pipelined and posed on the device; each skips with a notice without an adapter
//! unless `SHSCALE_REQUIRE_GPU=1`.

mod common;

use common::{scene, sphere_set_scene};
use shscale_scene::render::{render, Method};
use shscale_scene::scene::Scene;
use shscale_scene::settings::RenderSettings;

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
