//! Parity of every GPU stage with its CPU twin on the same inputs (f32 on the GPU, f64 / obvhs
//! f32 on the CPU). Each test needs an adapter: without one it prints a notice and returns, unless
//! `SHSCALE_REQUIRE_GPU=1` (CI, with Mesa lavapipe), where it fails.
//!
//! Tolerances (named below) are set by f32 rounding: one ulp of f32 is 6e-8 relative; sums of
//! up to 1024 terms and recurrences up to l = 7 lose a few more digits. Visibility bits may differ
//! only for rays grazing an edge, where the GPU's f32 direction (frame applied in f32) and the
//! CPU's (f64, then rounded) disagree in the last bit.

mod common;
use common::ctx;
use glam::DVec3;
use shscale_field::receivers::ReceiverCache;
use shscale_field::{Bsv, Layout, LocalFrame, VisibilitySampler};
use shscale_geometry::ray::UpdateStrategy;
use shscale_geometry::{
    deform, min_enclosing_sphere, shapes, Mesh, MeshBvh, Occluder, Sphere, RAY_EPS,
};
use shscale_gpu::sampling::{sh_eval_gpu, GpuSampler};
use shscale_gpu::{GpuContext, GpuSequence, ReceiverSetup, Receivers};
use shscale_scaling::{Eta, Interp, KTable, Spacing, TauFamily};
use shscale_sh::{DirectionSet, ShBasis};

/// SH values: absolute error of f32 recurrences up to l = 7 (values ≤ 1.6).
const SH_TOL: f64 = 2e-6;
/// Projection: relative to the largest coefficient (sums of ≤ 1024 f32 terms).
const PROJ_TOL: f64 = 2e-6;
/// Fraction of rays whose visibility may differ (grazing rays).
const VIS_MISMATCH_TOL: f64 = 2e-3;
/// Shading: relative to the brightest receiver (f32 cache and coefficients).
const SHADE_TOL: f64 = 1e-5;

#[test]
fn sh_evaluation_matches_the_cpu_basis() {
    let Some(ctx) = ctx() else { return };
    // Poles, equator, axes and a Fibonacci spread.
    let mut dirs: Vec<DVec3> = vec![DVec3::Z, -DVec3::Z, DVec3::X, DVec3::Y, -DVec3::X];
    let n = 300;
    for i in 0..n {
        let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
        let a = i as f64 * 2.399963229728653;
        let s = (1.0 - z * z).sqrt();
        dirs.push(DVec3::new(s * a.cos(), s * a.sin(), z));
    }
    let d32: Vec<[f32; 3]> = dirs.iter().map(|d| d.as_vec3().to_array()).collect();
    for order in 1..=8 {
        let got = sh_eval_gpu(&ctx, order, &d32).unwrap();
        let basis = ShBasis::<f64>::new(order).unwrap();
        let nn = order * order;
        let mut worst: f64 = 0.0;
        for (j, d) in d32.iter().enumerate() {
            // The CPU at the same (f32-rounded) direction, renormalised in f64.
            let dd = DVec3::new(d[0] as f64, d[1] as f64, d[2] as f64).normalize();
            let want = basis.values(dd.to_array());
            for i in 0..nn {
                worst = worst.max((got[j * nn + i] as f64 - want[i]).abs());
            }
        }
        println!("order {order}: max |Y_gpu − Y_cpu| = {worst:.2e} (tol {SH_TOL:.0e})");
        assert!(worst < SH_TOL, "order {order}: {worst:.2e}");
    }
}

/// A flapping bird's pose, its fixed sampling sphere and a base-sphere layout.
fn bird_scene(t: f64) -> (Mesh, Sphere, Vec<DVec3>) {
    let rest = shapes::bird();
    let mut posed = rest.clone();
    let y0 = 0.3 * rest.bounding_sphere().radius / 2.3;
    deform::flap(&rest, &mut posed, y0, 0.8, t);
    let mut all = rest.positions.clone();
    let mut p = rest.clone();
    for f in 0..8 {
        deform::flap(&rest, &mut p, y0, 0.8, f as f64 / 8.0);
        all.extend_from_slice(&p.positions);
    }
    let sphere = min_enclosing_sphere(&all);
    let dirs = Layout::parse("cube:4").unwrap().directions();
    (posed, sphere, dirs)
}

/// The CPU's BSV of `mesh` on `sphere` (cube:4 layout, the layout of [`bird_scene`]).
fn cpu_bsv(mesh: &Mesh, sphere: Sphere, order: usize, h: usize) -> Bsv {
    let sampler = VisibilitySampler::new(order, h).unwrap();
    let occ = MeshBvh::build(mesh, UpdateStrategy::Rebuild);
    Bsv::sample_on(
        &occ,
        Layout::parse("cube:4").unwrap(),
        &sampler,
        sphere,
        0.0,
    )
    .unwrap()
}

/// The CPU's ray directions for sample `pos`: the Gauss hemisphere in the frame toward `c`.
fn cpu_visibility(occ: &MeshBvh, pos: DVec3, c: DVec3, hemi: &DirectionSet) -> Vec<u32> {
    let f = LocalFrame::toward(pos, c);
    let tmin = RAY_EPS * occ.bounding_sphere().radius;
    hemi.dirs
        .iter()
        .map(|d| {
            let w = f.to_world(DVec3::new(d[0], d[1], d[2]));
            u32::from(!occ.occluded(pos, w, tmin, f64::INFINITY))
        })
        .collect()
}

/// Ray casting and projection of the bird at pose `t`, order `order`, `h × h` rays, against the
/// CPU on the same rays; returns the number of occluded rays.
fn check_bsv(ctx: &GpuContext, order: usize, h: usize, t: f64) -> (usize, usize) {
    let (mesh, sphere, dirs) = bird_scene(t);
    let cpu_occ = MeshBvh::build(&mesh, UpdateStrategy::Rebuild);
    let sampler = VisibilitySampler::new(order, h).unwrap();
    let layout = Layout::parse("cube:4").unwrap();
    let cpu = Bsv::sample_on(&cpu_occ, layout, &sampler, sphere, 0.0).unwrap();
    let nn = order * order;
    let scale = cpu
        .samples
        .iter()
        .flat_map(|s| s.coeffs.iter())
        .fold(0f64, |a, c| a.max(c.abs()));
    let tris = mesh.triangles.len();
    let mut gpu = GpuSampler::new(
        ctx,
        order,
        h,
        sphere.center,
        sphere.radius,
        &dirs,
        (2 * tris, tris),
    )
    .unwrap();
    let bvh = shscale_gpu::bvh::FlatBvh::build(&mesh, UpdateStrategy::Refit).unwrap();
    gpu.upload(ctx, &bvh, RAY_EPS * mesh.bounding_sphere().radius)
        .unwrap();
    let tag = format!("N = {order}, H = {h}, t = {t}");

    // (a) ray casting: the GPU's bits against the CPU's on the same rays.
    gpu.run(ctx, false).unwrap();
    let gv = gpu.read_visibility(ctx).unwrap();
    let hemi = DirectionSet::gauss_hemisphere(h);
    let mut cv = Vec::new();
    for d in &dirs {
        cv.extend(cpu_visibility(
            &cpu_occ,
            sphere.center + sphere.radius * *d,
            sphere.center,
            &hemi,
        ));
    }
    let mismatched = gv.iter().zip(&cv).filter(|(a, b)| a != b).count();
    let occluded = cv.iter().filter(|v| **v == 0).count();
    let frac = mismatched as f64 / cv.len() as f64;
    println!(
        "{tag}: {mismatched} of {} rays differ ({frac:.1e}, tol {VIS_MISMATCH_TOL:.0e}); {occluded} occluded",
        cv.len()
    );
    assert!(frac <= VIS_MISMATCH_TOL, "{tag}: {frac:.2e}");

    // (b) projection of the CPU's own bits: must reproduce the CPU BSV to f32 rounding.
    gpu.write_visibility(ctx, &cv).unwrap();
    gpu.run(ctx, true).unwrap();
    let gc = gpu.read_coeffs(ctx).unwrap();
    let mut worst: f64 = 0.0;
    for (s, sample) in cpu.samples.iter().enumerate() {
        for i in 0..nn {
            worst = worst.max((gc[s * nn + i] as f64 - sample.coeffs[i]).abs());
        }
    }
    println!("{tag}: projection max error {worst:.2e} of max |c| {scale:.2} (tol {PROJ_TOL:.0e} relative)");
    assert!(worst <= PROJ_TOL * scale, "{tag}: {worst:.2e}");
    (occluded, cv.len())
}

#[test]
fn ray_casting_and_projection_match_the_cpu_bsv() {
    let Some(ctx) = ctx() else { return };
    for t in [0.1, 0.25] {
        let (occluded, rays) = check_bsv(&ctx, 4, 16, t);
        assert!(occluded > rays / 20, "the scene must occlude something");
    }
}

/// The edges of the GPU sampler's domain: order 1 (one coefficient) and the largest order 8
/// (64 accumulators, 16 KiB of workgroup memory); H = 1 (one ray per sample: fewer rays than
/// invocations in the projection workgroup) and H = 40 (1600 rays, more than 16 per invocation).
#[test]
fn sampler_edges_match_the_cpu() {
    let Some(ctx) = ctx() else { return };
    for (order, h) in [(1, 1), (1, 40), (8, 1), (8, 40), (5, 3)] {
        check_bsv(&ctx, order, h, 0.3);
    }
    // Outside the domain: clear errors, no panic.
    let dirs = [DVec3::Z, DVec3::X, -DVec3::Z, DVec3::Y];
    for (order, h) in [(0, 4), (9, 4), (4, 0)] {
        let e = GpuSampler::new(&ctx, order, h, DVec3::ZERO, 1.0, &dirs, (8, 4))
            .err()
            .unwrap_or_else(|| panic!("N = {order}, H = {h} accepted"));
        println!("N = {order}, H = {h}: {e}");
    }
}

fn transfer_rgb(order: usize) -> [Vec<f64>; 3] {
    let nn = order * order;
    [0, 1, 2].map(|ch| {
        (0..nn)
            .map(|i| ((i * 7 + ch * 3) % 11) as f64 / 11.0 - 0.3 + if i == 0 { 1.0 } else { 0.0 })
            .collect()
    })
}

fn cache_for(bsv: &Bsv, order: usize, receivers: &[DVec3]) -> (KTable, ReceiverCache) {
    cache_for_spacing(bsv, order, receivers, Spacing::Exp)
}

fn cache_for_spacing(
    bsv: &Bsv,
    order: usize,
    receivers: &[DVec3],
    spacing: Spacing,
) -> (KTable, ReceiverCache) {
    let c = bsv.sphere.center;
    let ks: Vec<f64> = receivers
        .iter()
        .map(|p| (*p - c).length() / bsv.sampling_radius)
        .collect();
    let lo = ks.iter().cloned().fold(f64::MAX, f64::min);
    let hi = ks.iter().cloned().fold(0.0, f64::max);
    let table = KTable::build(
        TauFamily::Cone {
            alpha: 45f64.to_radians(),
        },
        Eta::Plain,
        order,
        20,
        lo,
        0.8 * hi, // some receivers beyond k_max: the constant branch is exercised too
        spacing,
        Interp::Linear,
    )
    .unwrap();
    // A coloured transfer vector: three distinct channels.
    let cache = ReceiverCache::build(bsv, &table, &transfer_rgb(order), receivers);
    (table, cache)
}

fn plane(n: usize, z: f64, half: f64) -> Vec<DVec3> {
    (0..n * n)
        .map(|i| {
            let (x, y) = ((i % n) as f64 + 0.5, (i / n) as f64 + 0.5);
            DVec3::new(
                -half + 2.0 * half * x / n as f64,
                half - 2.0 * half * y / n as f64,
                z,
            )
        })
        .collect()
}

#[test]
fn shading_matches_the_receiver_cache_and_sequences_run_end_to_end() {
    let Some(ctx) = ctx() else { return };
    let (order, h) = (4, 16);
    let (mesh, sphere, dirs) = bird_scene(0.2);
    let bsv = cpu_bsv(&mesh, sphere, order, h);
    let receivers = plane(48, sphere.center.z - 1.6, 2.5);
    let (_table, cache) = cache_for(&bsv, order, &receivers);
    assert_eq!(cache.channels(), 3);
    let mut want = vec![[0.0; 3]; receivers.len()];
    cache.shade(&bsv, &mut want);
    let bright = want.iter().flatten().fold(0f64, |a, e| a.max(e.abs()));

    let mut seq = GpuSequence::new(
        &ctx,
        &mesh,
        UpdateStrategy::Refit,
        order,
        h,
        sphere,
        &dirs,
        Receivers::Cache(&cache),
    )
    .unwrap();
    // (c) shading alone, on the CPU's coefficients.
    let flat: Vec<f32> = bsv
        .samples
        .iter()
        .flat_map(|s| s.coeffs.iter().map(|c| *c as f32))
        .collect();
    seq.sampler().write_coeffs(&ctx, &flat).unwrap();
    seq.shade_only(&ctx).unwrap();
    let got = seq.read_image(&ctx).unwrap();
    let worst = got
        .iter()
        .zip(&want)
        .flat_map(|(g, w)| (0..3).map(move |c| (g[c] as f64 - w[c]).abs()))
        .fold(0f64, f64::max);
    println!("shading: max error {worst:.2e} of max E {bright:.3} (tol {SHADE_TOL:.0e} relative)");
    assert!(worst <= SHADE_TOL * bright, "{worst:.2e}");
    let constants = cache.rows().3.iter().filter(|c| c.is_some()).count();
    assert!(
        constants > 0 && constants < receivers.len(),
        "both branches exercised: {constants}"
    );

    // End to end: the full GPU frame against the CPU frame; differences come only from the few
    // grazing rays, so the image RMSE is bounded by their share.
    let times = seq.frame(&ctx, &mesh).unwrap();
    let got = seq.read_image(&ctx).unwrap();
    let rmse = (got
        .iter()
        .zip(&want)
        .flat_map(|(g, w)| (0..3).map(move |c| (g[c] as f64 - w[c]).powi(2)))
        .sum::<f64>()
        / (3 * got.len()) as f64)
        .sqrt();
    println!("end to end: image RMSE {rmse:.2e} of max E {bright:.3}; {times:?}");
    assert!(rmse <= 1e-3 * bright, "{rmse:.2e}");
    assert!(times.frame_seconds > 0.0 && times.sampling_seconds > 0.0);

    // Frames in flight: posed on the device only, at most two submitted and not finished; none
    // in flight finishes nothing. (The images: scene/tests/gpu_parity.rs.)
    let e = seq.submit_at(&ctx, 0.0).unwrap_err().to_string();
    assert!(e.contains("pose_on_device"), "{e}");
    seq.pose_on_device(&ctx, &mesh, None, UpdateStrategy::Refit)
        .unwrap();
    if ctx.timestamps {
        assert!(seq.finish_oldest(&ctx).unwrap().is_none());
        seq.submit_at(&ctx, 0.0).unwrap();
        seq.submit_at(&ctx, 0.5).unwrap();
        let e = seq.submit_at(&ctx, 0.7).unwrap_err().to_string();
        assert!(e.contains("2 frames are in flight"), "{e}");
        for _ in 0..2 {
            let t = seq.finish_oldest(&ctx).unwrap().expect("a frame in flight");
            assert!(t.deform_seconds > 0.0 && t.sampling_seconds > 0.0, "{t:?}");
        }
        assert!(seq.finish_oldest(&ctx).unwrap().is_none());
    } else {
        let e = seq.submit_at(&ctx, 0.0).unwrap_err().to_string();
        assert!(e.contains("timestamp queries"), "{e}");
    }
}

/// `U = R M_kᵀ Rᵀ T` built on the GPU (k-table lookup and rotations by re-projection) against
/// `ReceiverCache::build` (Ivanic–Ruedenberg rotations in f64), for RGB and grey transfers, a
/// receiver plane below the entity and receivers around it on every side (every frame
/// orientation, the z = ±1 branch of the basis included) — then shading from it.
#[test]
fn receiver_setup_on_the_gpu_matches_the_cpu_cache() {
    /// Relative to max |U|: f32 quadrature of ≤ 2N² points, two rotations, one matvec.
    const U_TOL: f64 = 2e-5;
    let Some(ctx) = ctx() else { return };
    let (order, h) = (4, 8);
    let (mesh, sphere, dirs) = bird_scene(0.2);
    let bsv = cpu_bsv(&mesh, sphere, order, h);
    let mut receivers = plane(24, sphere.center.z - 1.6, 2.5);
    let n = 200;
    for i in 0..n {
        let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
        let a = i as f64 * 2.399963229728653;
        let s = (1.0 - z * z).sqrt();
        let rho = sphere.radius * (1.05 + 2.0 * (i % 7) as f64 / 7.0);
        receivers.push(sphere.center + rho * DVec3::new(s * a.cos(), s * a.sin(), z));
    }
    receivers.push(sphere.center + 2.0 * sphere.radius * DVec3::Z);
    receivers.push(sphere.center - 2.0 * sphere.radius * DVec3::Z);
    let grey = {
        let t = transfer_rgb(order);
        [t[0].clone(), t[0].clone(), t[0].clone()]
    };
    // RGB on an exponential table, grey on a uniform one (both interpolate in ln k).
    for (name, transfer, spacing) in [
        ("rgb", transfer_rgb(order), Spacing::Exp),
        ("grey", grey, Spacing::Uniform),
    ] {
        let (table, _) = cache_for_spacing(&bsv, order, &receivers, spacing);
        let cpu = ReceiverCache::build(&bsv, &table, &transfer, &receivers);
        let locations: Vec<[(u32, f64); 3]> = receivers
            .iter()
            .map(|p| bsv.locate((*p - sphere.center).normalize()))
            .collect();
        let setup = ReceiverSetup {
            table: &table,
            transfer: &transfer,
            receivers: &receivers,
            locations: &locations,
            sampling: sphere,
            radii: None,
        };
        let seq = GpuSequence::new(
            &ctx,
            &mesh,
            UpdateStrategy::Refit,
            order,
            h,
            sphere,
            &dirs,
            Receivers::Build(setup),
        )
        .unwrap();
        let (rows, u) = seq.shader().read_cache(&ctx).unwrap();
        let (_, _, cu, cconst) = cpu.rows();
        assert_eq!(u.len(), cu.len(), "{name}");
        let flags_differ = rows
            .iter()
            .zip(cconst)
            .filter(|(r, c)| (r.flag == 1) != c.is_some())
            .count();
        assert_eq!(flags_differ, 0, "{name}: beyond-k_max flags");
        let scale = cu.iter().fold(0f64, |a, v| a.max(v.abs() as f64));
        let worst = u
            .iter()
            .zip(cu)
            .fold(0f64, |a, (g, c)| a.max((*g as f64 - *c as f64).abs()));
        let beyond = cconst.iter().filter(|c| c.is_some()).count();
        println!("{name}: GPU U vs CPU U max error {worst:.2e} of max |U| {scale:.3} (tol {U_TOL:.0e} relative); {beyond} receivers beyond k_max; setup {:.2} ms", 1e3 * seq.receiver_setup_seconds);
        assert!(worst <= U_TOL * scale, "{name}: {worst:.2e}");
        assert!(beyond > 0, "the constant branch must be exercised");
        for (r, c) in rows.iter().zip(cconst) {
            if let Some(e) = c {
                for ch in 0..3 {
                    assert!(
                        (r.constant[ch] as f64 - e[ch]).abs() <= 1e-6 * e[ch].abs().max(1.0),
                        "{name}: constant {:?} vs {e:?}",
                        r.constant
                    );
                }
            }
        }
        // Shading from the GPU-built cache equals shading from the CPU cache.
        let flat: Vec<f32> = bsv
            .samples
            .iter()
            .flat_map(|s| s.coeffs.iter().map(|c| *c as f32))
            .collect();
        seq.sampler().write_coeffs(&ctx, &flat).unwrap();
        seq.shade_only(&ctx).unwrap();
        let got = seq.read_image(&ctx).unwrap();
        let mut want = vec![[0.0; 3]; receivers.len()];
        cpu.shade(&bsv, &mut want);
        let bright = want.iter().flatten().fold(0f64, |a, e| a.max(e.abs()));
        let worst = got
            .iter()
            .zip(&want)
            .flat_map(|(g, w)| (0..3).map(move |c| (g[c] as f64 - w[c]).abs()))
            .fold(0f64, f64::max);
        println!("{name}: shading from the GPU cache, max error {worst:.2e} of {bright:.3}");
        assert!(worst <= U_TOL * bright, "{name}: {worst:.2e}");
    }
}

/// The wall-clock fallback (no timestamp queries) times every stage and renders the same frame.
#[test]
fn wall_clock_fallback_times_every_stage_and_renders_the_same_frame() {
    let Some(ctx) = ctx() else { return };
    let plain = GpuContext::without_timestamps().expect("the same adapter again");
    assert!(!plain.timestamps);
    let (order, h) = (3, 8);
    let (mesh, sphere, dirs) = bird_scene(0.3);
    let bsv = cpu_bsv(&mesh, sphere, order, h);
    let receivers = plane(16, sphere.center.z - 1.6, 2.5);
    let (_, cache) = cache_for(&bsv, order, &receivers);
    let mut images = Vec::new();
    for c in [&ctx, &plain] {
        let mut seq = GpuSequence::new(
            c,
            &mesh,
            UpdateStrategy::Refit,
            order,
            h,
            sphere,
            &dirs,
            Receivers::Cache(&cache),
        )
        .unwrap();
        let t = seq.frame(c, &mesh).unwrap();
        println!("timestamps {}: {t:?}", c.timestamps);
        assert_eq!(t.timestamps, c.timestamps);
        for v in [
            t.sampling_seconds,
            t.projection_seconds,
            t.shading_seconds,
            t.frame_seconds,
        ] {
            assert!(v > 0.0 && v.is_finite(), "{t:?}");
        }
        assert!(
            t.sampling_seconds + t.projection_seconds + t.shading_seconds
                <= t.frame_seconds * 1.05 + 1e-3,
            "{t:?}"
        );
        images.push(seq.read_image(c).unwrap());
    }
    assert_eq!(
        images[0], images[1],
        "same inputs, same device: bit-identical frames"
    );
}

/// A storage binding over the adapter's limit is refused with both sizes named, before any
/// buffer is made (the driver would fail on it otherwise); one within it is accepted.
#[test]
fn bindings_over_the_adapter_limit_are_refused_by_name() {
    let Some(ctx) = ctx() else { return };
    let max = ctx.device.limits().max_storage_buffer_binding_size;
    assert!(ctx.check_binding("sixteen bytes", 16).is_ok());
    let e = ctx
        .check_binding("the receivers' weights", max + 1)
        .unwrap_err();
    let text = e.to_string();
    println!("{text}");
    assert!(
        text.contains("the receivers' weights") && text.contains(&max.to_string()),
        "{text}"
    );
}
