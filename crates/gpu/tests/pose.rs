//! The pose and BVH refit on the device (`shscale_gpu::pose`) against the host: every deformer's
//! f32 pose against its f64 map (the bend at a curvature where the host's own formula would lose
//! every digit in f32), the refitted tree bit for bit against the host's refit of the same
//! (device-posed) vertices, the rebuild rule's relative area, a rebuild frame, and whole frames
//! posed on the device against frames posed on the host. Without an adapter each test prints a
//! notice and returns, unless `SHSCALE_REQUIRE_GPU=1` (CI, Mesa lavapipe), where it fails.

mod common;
use common::ctx;
use glam::DVec3;
use shscale_field::Layout;
use shscale_geometry::deform::{twist_height, Deformer};
use shscale_geometry::ray::UpdateStrategy;
use shscale_geometry::{shapes, Mesh};
use shscale_gpu::bvh::FlatBvh;
use shscale_gpu::pose::GpuPoser;
use shscale_gpu::sampling::GpuSampler;
use shscale_gpu::GpuContext;

/// Posed vertices: absolute error over the mesh's bounding radius (f32 rounding of coordinates
/// of size ≤ the radius, and the adapter's f32 sin/cos/exp).
const POSE_TOL: f64 = 2e-6;

/// A sampler whose tree buffers hold `mesh`'s tree (a few samples: only its buffers are used).
fn sampler_for(ctx: &GpuContext, mesh: &Mesh) -> GpuSampler {
    let s = mesh.bounding_sphere();
    let dirs = Layout::parse("cube:2").unwrap().directions();
    let n = mesh.triangles.len();
    GpuSampler::new(ctx, 2, 2, s.center, 1.5 * s.radius, &dirs, (2 * n, n)).unwrap()
}

/// The four deformers at the strengths of the scenes, on `rest`.
fn deformers(rest: &Mesh) -> Vec<(&'static str, Deformer)> {
    let r = rest.bounding_sphere().radius;
    // The morph needs the same vertex count: a target made from the rest pose itself, pushed
    // out radially.
    let c = rest.bounding_sphere().center;
    let mut pushed = rest.clone();
    for p in &mut pushed.positions {
        *p = c + (*p - c) * (1.0 + 0.3 * ((p.x * 3.0).sin()).abs());
    }
    vec![
        (
            "bend",
            Deformer::Bend {
                max_curvature: 1.2 / r,
            },
        ),
        (
            "twist",
            Deformer::Twist {
                max_turns: 0.25,
                h: twist_height(rest),
            },
        ),
        ("morph", Deformer::Morph { target: pushed }),
        (
            "flap",
            Deformer::Flap {
                y0: 0.3 * r / 2.3,
                amplitude: 0.8,
            },
        ),
    ]
}

/// `rest` with the device's posed vertices (f32, exactly as f64).
fn device_pose(rest: &Mesh, poser: &GpuPoser, ctx: &GpuContext) -> Mesh {
    let mut m = rest.clone();
    for (p, q) in m.positions.iter_mut().zip(poser.read_posed(ctx).unwrap()) {
        *p = DVec3::new(q[0] as f64, q[1] as f64, q[2] as f64);
    }
    m
}

fn worst_pose_error(got: &[[f32; 4]], want: &Mesh) -> f64 {
    got.iter()
        .zip(&want.positions)
        .map(|(g, w)| (DVec3::new(g[0] as f64, g[1] as f64, g[2] as f64) - *w).length())
        .fold(0.0, f64::max)
}

/// Every deformer at several times, the bend also at t = 1e-6 (κ ≈ 4e-6 / r: the host's
/// `1/κ − r cos` subtracts numbers near 2.6e5 r, which in f32 would leave an error near 0.02 r)
/// and t = 0 (the identity), against the host's f64 map.
#[test]
fn device_pose_matches_the_host_deformers() {
    let Some(ctx) = ctx() else { return };
    let rest = shapes::bird();
    let r = rest.bounding_sphere().radius;
    let sampler = sampler_for(&ctx, &rest);
    for (name, d) in deformers(&rest) {
        let mut poser =
            GpuPoser::new(&ctx, &rest, Some(&d), UpdateStrategy::Refit, &sampler).unwrap();
        let mut host = rest.clone();
        for t in [0.0, 1e-6, 0.13, 0.5, 0.77] {
            poser.run(&ctx, t).unwrap();
            d.apply(&rest, t, &mut host);
            let err = worst_pose_error(&poser.read_posed(&ctx).unwrap(), &host) / r;
            println!("{name} t = {t}: worst vertex error {err:.2e} r (tol {POSE_TOL:.0e})");
            assert!(err <= POSE_TOL, "{name} t = {t}: {err:.2e}");
        }
    }
    // No deformer: the rest pose.
    let mut poser = GpuPoser::new(&ctx, &rest, None, UpdateStrategy::Refit, &sampler).unwrap();
    poser.run(&ctx, 0.4).unwrap();
    let err = worst_pose_error(&poser.read_posed(&ctx).unwrap(), &rest) / r;
    assert!(err <= POSE_TOL, "rest pose: {err:.2e}");
}

/// The host's refit of the device's own posed vertices (f32 exactly, so min and max are the
/// same operations on the same numbers): the device's tree must equal it bit for bit, nodes and
/// gathered triangles; and the device's relative area (an f32 sum) the host's f64 one.
#[test]
fn device_refit_is_the_host_refit_bit_for_bit() {
    let Some(ctx) = ctx() else { return };
    let rest = shapes::bird();
    let sampler = sampler_for(&ctx, &rest);
    for (name, d) in deformers(&rest) {
        let mut host = FlatBvh::build(&rest, UpdateStrategy::Refit).unwrap();
        for t in [0.21, 0.5] {
            // A poser per frame: its first frame refits the tree built at rest, as the host's.
            let mut poser =
                GpuPoser::new(&ctx, &rest, Some(&d), UpdateStrategy::Adaptive, &sampler).unwrap();
            poser.run(&ctx, t).unwrap();
            host.update(&device_pose(&rest, &poser, &ctx)).unwrap();
            let (nodes, tris) = sampler
                .read_tree(&ctx, host.nodes.len(), host.gpu_tris.len())
                .unwrap();
            let nodes_off = nodes
                .iter()
                .zip(&host.nodes)
                .filter(|(a, b)| a != b)
                .count();
            let tris_off = tris
                .iter()
                .zip(&host.gpu_tris)
                .filter(|(a, b)| a != b)
                .count();
            let area = (poser.last_area - host.relative_area()).abs() / host.relative_area();
            println!(
                "{name} t = {t}: {nodes_off} of {} nodes and {tris_off} of {} triangles differ; \
                 relative area {:.6} vs host {:.6} ({area:.1e})",
                nodes.len(),
                tris.len(),
                poser.last_area,
                host.relative_area()
            );
            assert_eq!((nodes_off, tris_off), (0, 0), "{name} t = {t}");
            // An f32 sum of ~2 500 positive terms: relative error ≤ n·ε ≈ 1.5e-4, far less
            // than the rule's 15 % margin.
            assert!(area <= 2e-4, "{name} t = {t}: area {area:.1e}");
        }
    }
}

/// A block and a quarter-turn twist, which grows a tree built at rest past the rebuild rule, with
/// a sampler holding its tree buffers.
fn twisted_block(ctx: &GpuContext) -> (Mesh, GpuSampler, Deformer) {
    let rest = shapes::box_block(DVec3::new(1.0, 0.5, 0.3), 12);
    let sampler = sampler_for(ctx, &rest);
    let d = Deformer::Twist {
        max_turns: 0.25,
        h: twist_height(&rest),
    };
    (rest, sampler, d)
}

/// Whether the tree on the device is the host's build of `rest` posed by `d` at `t`, refitted
/// to the device's pose, bit for bit.
fn tree_is_host_build_refitted(
    ctx: &GpuContext,
    (rest, d, t): (&Mesh, &Deformer, f64),
    poser: &GpuPoser,
    sampler: &GpuSampler,
) -> bool {
    let mut host_pose = rest.clone();
    d.apply(rest, t, &mut host_pose);
    let mut want = FlatBvh::build(&host_pose, UpdateStrategy::Refit).unwrap();
    want.update(&device_pose(rest, poser, ctx)).unwrap();
    let (nodes, tris) = sampler
        .read_tree(ctx, want.nodes.len(), want.gpu_tris.len())
        .unwrap();
    nodes == want.nodes && tris == want.gpu_tris
}

/// A twist of a quarter turn grows the boxes of a tree built at rest past the rebuild rule: the
/// device reads the area, the next frame builds on the host (counted), and that frame's tree is
/// the host's build of the host pose refitted to the device's pose, bit for bit. `Refit` never
/// rebuilds.
#[test]
fn a_grown_tree_is_rebuilt_on_the_host_the_next_frame() {
    let Some(ctx) = ctx() else { return };
    let (rest, sampler, d) = twisted_block(&ctx);
    let mut refit_only =
        GpuPoser::new(&ctx, &rest, Some(&d), UpdateStrategy::Refit, &sampler).unwrap();
    refit_only.run(&ctx, 0.5).unwrap();
    refit_only.run(&ctx, 0.5).unwrap();
    assert_eq!(refit_only.rebuilds, 0);
    assert!(refit_only.last_area.is_nan(), "Refit reads no area");

    let mut poser =
        GpuPoser::new(&ctx, &rest, Some(&d), UpdateStrategy::Adaptive, &sampler).unwrap();
    let built = poser.host_tree().built_area();
    poser.run(&ctx, 0.5).unwrap();
    println!(
        "twisted: relative area {:.3} against {built:.3} at the build",
        poser.last_area
    );
    assert!(
        poser.last_area > 1.15 * built,
        "the twist should grow the tree"
    );
    assert_eq!(poser.rebuilds, 0, "the rebuild is the next frame's");
    let host_seconds = poser.run(&ctx, 0.5).unwrap();
    assert_eq!(poser.rebuilds, 1);
    assert!(host_seconds > 0.0);
    assert!(tree_is_host_build_refitted(
        &ctx,
        (&rest, &d, 0.5),
        &poser,
        &sampler
    ));
    assert!(
        !poser.last_area.is_nan() && poser.last_area < 1.15 * poser.host_tree().built_area(),
        "the rebuilt tree is not due again: {:.3}",
        poser.last_area
    );
}

/// Rebuilt in the background: the due tree is built on a host thread (posed at the frame found
/// due) while frames go on refitting the old one — no frame pays the build —, and once swapped in
/// it is the host's build at that pose refitted to the device's pose, bit for bit, as in place.
#[test]
fn a_grown_tree_is_rebuilt_in_the_background() {
    let Some(ctx) = ctx() else { return };
    let (rest, sampler, d) = twisted_block(&ctx);
    let mut poser =
        GpuPoser::new(&ctx, &rest, Some(&d), UpdateStrategy::Adaptive, &sampler).unwrap();
    poser.rebuild_in_background();
    poser.run(&ctx, 0.5).unwrap();
    assert_eq!(poser.rebuilds, 0, "due, not yet built");
    // The frames go on with the old tree until the build is done (at most a few seconds).
    let mut frames = 0;
    let t0 = std::time::Instant::now();
    while poser.rebuilds == 0 {
        poser.run(&ctx, 0.5).unwrap();
        frames += 1;
        assert!(
            t0.elapsed().as_secs() < 60,
            "the background build never landed"
        );
    }
    println!(
        "swapped in after {frames} frame(s); built in {:.2} ms on a host thread",
        1e3 * poser.background_seconds
    );
    assert!(poser.background_seconds > 0.0);
    // The swap uploads the tree; the frame that swapped it refitted it.
    assert!(tree_is_host_build_refitted(
        &ctx,
        (&rest, &d, 0.5),
        &poser,
        &sampler
    ));
    poser.run(&ctx, 0.5).unwrap();
    assert!(
        poser.last_area < 1.15 * poser.host_tree().built_area(),
        "the rebuilt tree is not due again: {:.3}",
        poser.last_area
    );
    assert_eq!(poser.rebuilds, 1);
}

/// A morph whose target has another vertex count is refused by name.
#[test]
fn a_morph_target_of_another_size_is_refused() {
    let Some(ctx) = ctx() else { return };
    let rest = shapes::bird();
    let sampler = sampler_for(&ctx, &rest);
    let d = Deformer::Morph {
        target: shapes::uv_sphere(1.0, 8, 8),
    };
    let e = GpuPoser::new(&ctx, &rest, Some(&d), UpdateStrategy::Refit, &sampler)
        .err()
        .expect("refused")
        .to_string();
    assert!(e.contains("morph's target"), "{e}");
}
