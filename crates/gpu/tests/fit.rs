//! Sphere sets posed and fitted on the device (`shscale_gpu::fit`) against the host: every
//! deformer at three times, 1, 4 and 16 parts (and a part left empty), the device's spheres
//! against `shscale_geometry::partition::fit_spheres` of the host's f64 pose; a whole frame shaded
//! from the device's spheres against the same kernel fed the host's spheres; and the refusals.
//! Without an adapter each test prints a notice and returns, unless `SHSCALE_REQUIRE_GPU=1` (CI,
//! Mesa lavapipe), where it fails.

mod common;
use common::ctx;
use glam::DVec3;
use shscale_geometry::deform::{twist_height, Deformer};
use shscale_geometry::partition::{fit_spheres, kmeans_parts};
use shscale_geometry::{shapes, Mesh, Sphere};
use shscale_gpu::fit::GpuSphereFit;
use shscale_gpu::sphereset::GpuSphereSet;
use shscale_gpu::GpuContext;
use shscale_sh::GauntTensor;

/// A sphere's centre and radius: absolute error over the mesh's bounding radius (f32 pose and
/// f32 sums over up to a few thousand triangles per part; the pose test's bound on the posed
/// vertices).
const FIT_TOL: f64 = 2e-6;

/// A set of `n × n` receivers on the plane z = 0 under the mesh, shaded at order 4 with a fixed
/// transfer (any vector: the tests compare the kernel with itself).
fn set(ctx: &GpuContext, n: usize, extent: f64) -> GpuSphereSet {
    let pts: Vec<DVec3> = (0..n * n)
        .map(|i| {
            let (x, y) = ((i % n) as f64 + 0.5, (i / n) as f64 + 0.5);
            DVec3::new(
                extent * (2.0 * x / n as f64 - 1.0),
                extent * (2.0 * y / n as f64 - 1.0),
                0.0,
            )
        })
        .collect();
    let transfer: Vec<f64> = (0..16).map(|i| 1.0 / (1.0 + i as f64)).collect();
    let gaunt = GauntTensor::<f64>::new(4).unwrap();
    GpuSphereSet::new(
        ctx,
        &pts,
        &[transfer.clone(), transfer.clone(), transfer],
        &gaunt,
    )
    .unwrap()
}

/// The deformers of the scenes, on `rest` (the morph's target: the rest pose pushed out).
fn deformers(rest: &Mesh) -> Vec<(&'static str, Option<Deformer>)> {
    let s = rest.bounding_sphere();
    let mut pushed = rest.clone();
    for p in &mut pushed.positions {
        *p = s.center + (*p - s.center) * (1.0 + 0.3 * ((p.x * 3.0).sin()).abs());
    }
    vec![
        ("none", None),
        (
            "bend",
            Some(Deformer::Bend {
                max_curvature: 1.2 / s.radius,
            }),
        ),
        (
            "twist",
            Some(Deformer::Twist {
                max_turns: 0.25,
                h: twist_height(rest),
            }),
        ),
        ("morph", Some(Deformer::Morph { target: pushed })),
        (
            "flap",
            Some(Deformer::Flap {
                y0: 0.3 * s.radius / 2.3,
                amplitude: 0.8,
            }),
        ),
    ]
}

/// The largest centre or radius difference between the device's spheres and `want`.
fn worst(got: &[[f32; 4]], want: &[Sphere]) -> f64 {
    got.iter()
        .zip(want)
        .map(|(g, w)| {
            let c = DVec3::new(g[0] as f64, g[1] as f64, g[2] as f64);
            (c - w.center).length().max((g[3] as f64 - w.radius).abs())
        })
        .fold(0.0, f64::max)
}

#[test]
fn device_fit_matches_the_host_fit_for_every_deformer_and_part_count() {
    let Some(ctx) = ctx() else { return };
    let meshes = [
        ("bird", shapes::bird()),
        ("block", shapes::box_block(DVec3::new(1.0, 0.5, 0.3), 12)),
    ];
    let set = set(&ctx, 4, 2.0);
    let mut overall: f64 = 0.0;
    for (name, rest) in &meshes {
        let r = rest.bounding_sphere().radius;
        for parts in [1, 4, 16] {
            let labels = kmeans_parts(rest, parts).unwrap();
            for (dname, d) in deformers(rest) {
                let mut fit = vec![GpuSphereFit::new(
                    &ctx,
                    rest,
                    d.as_ref(),
                    (&labels, parts),
                    (set.spheres_buffer(), 0),
                )
                .unwrap()];
                let mut e: f64 = 0.0;
                for t in [0.0, 0.3, 0.7] {
                    set.frame_on_device(&ctx, &mut fit, &[], t).unwrap();
                    let got = set.read_spheres(&ctx, parts).unwrap();
                    let mut posed = rest.clone();
                    if let Some(d) = &d {
                        d.apply(rest, t, &mut posed);
                    }
                    let want = fit_spheres(&posed, &labels, parts);
                    e = e.max(worst(&got, &want) / r);
                }
                println!("{name} {dname} {parts} part(s): worst sphere error {e:.2e} r");
                assert!(
                    e < FIT_TOL,
                    "{name} {dname} {parts}: {e:.2e} r > {FIT_TOL:e}"
                );
                overall = overall.max(e);
            }
        }
    }
    println!("worst over every mesh, deformer, part count and time: {overall:.2e} r");
    // A part without triangles (labels 0 and 1 of three): the host's sphere, centre 0, radius 0.
    let rest = shapes::bird();
    let labels = kmeans_parts(&rest, 2).unwrap();
    let mut fit =
        vec![
            GpuSphereFit::new(&ctx, &rest, None, (&labels, 3), (set.spheres_buffer(), 0)).unwrap(),
        ];
    set.frame_on_device(&ctx, &mut fit, &[], 0.0).unwrap();
    let got = set.read_spheres(&ctx, 3).unwrap();
    let want = fit_spheres(&rest, &labels, 3);
    println!("empty part: device {:?}, host {:?}", got[2], want[2]);
    assert_eq!(got[2], [0.0; 4]);
    assert_eq!((want[2].center, want[2].radius), (DVec3::ZERO, 0.0));
    assert!(worst(&got, &want) < FIT_TOL * rest.bounding_sphere().radius);
}

#[test]
fn a_frame_shaded_from_the_device_fit_is_the_host_fit_frame() {
    let Some(ctx) = ctx() else { return };
    // A flapping bird over the receivers, 4 parts, and a fixed analytic sphere beside it (the
    // fixed spheres follow the fitted ones).
    let mut rest = shapes::bird();
    for p in &mut rest.positions {
        *p += DVec3::new(0.0, 0.0, 1.4);
    }
    let s = rest.bounding_sphere();
    let d = Deformer::Flap {
        y0: 0.3 * s.radius / 2.3,
        amplitude: 0.8,
    };
    let labels = kmeans_parts(&rest, 4).unwrap();
    let fixed = Sphere {
        center: DVec3::new(1.5, 0.5, 1.0),
        radius: 0.4,
    };
    let set = set(&ctx, 24, 2.5);
    let mut fit = vec![GpuSphereFit::new(
        &ctx,
        &rest,
        Some(&d),
        (&labels, 4),
        (set.spheres_buffer(), 0),
    )
    .unwrap()];
    let t = 0.35;
    set.frame_on_device(&ctx, &mut fit, &[fixed], t).unwrap();
    let device = set.read_image(&ctx).unwrap();
    let mut posed = rest.clone();
    d.apply(&rest, t, &mut posed);
    let mut spheres = fit_spheres(&posed, &labels, 4);
    spheres.push(fixed);
    let (host, _, _) = set.frame(&ctx, &spheres).unwrap();
    let peak = host.iter().flatten().fold(0.0f32, |a, &b| a.max(b.abs())) as f64;
    let diff = device
        .iter()
        .flatten()
        .zip(host.iter().flatten())
        .map(|(a, b)| (a - b).abs() as f64)
        .fold(0.0, f64::max);
    // The spheres differ by the f32 fit (≤ FIT_TOL r); the image by as much times the caps'
    // slope — bounded here at 1e-3 of the brightest pixel.
    println!(
        "device-fit frame vs host-fit frame: largest difference {:.2e} of the peak {peak:.3}",
        diff / peak
    );
    assert!(peak > 0.0 && diff / peak < 1e-3, "{diff} of {peak}");
    // The shadow moves with the pose: another time's frame differs by far more.
    set.frame_on_device(&ctx, &mut fit, &[fixed], 0.8).unwrap();
    let other = set.read_image(&ctx).unwrap();
    let moved = other
        .iter()
        .flatten()
        .zip(device.iter().flatten())
        .map(|(a, b)| (a - b).abs() as f64)
        .fold(0.0, f64::max);
    println!("t = 0.35 against t = 0.8: {:.2e} of the peak", moved / peak);
    assert!(
        moved > 10.0 * diff.max(1e-6 * peak),
        "{moved} against {diff}"
    );
}

#[test]
fn device_fit_refuses_what_it_cannot_fit() {
    let Some(ctx) = ctx() else { return };
    let rest = shapes::bird();
    let set = set(&ctx, 2, 1.0);
    let labels = kmeans_parts(&rest, 2).unwrap();
    let buf = set.spheres_buffer();
    let err = |r: Result<GpuSphereFit, shscale_gpu::GpuError>| match r {
        Ok(_) => panic!("accepted"),
        Err(e) => e.to_string(),
    };
    let e = err(GpuSphereFit::new(
        &ctx,
        &rest,
        None,
        (&labels, 65),
        (buf, 0),
    ));
    println!("{e}");
    assert!(e.contains("65 parts"), "{e}");
    let e = err(GpuSphereFit::new(
        &ctx,
        &rest,
        None,
        (&labels, 2),
        (buf, 63),
    ));
    assert!(e.contains("slot 63"), "{e}");
    let e = err(GpuSphereFit::new(
        &ctx,
        &rest,
        None,
        (&labels[1..], 2),
        (buf, 0),
    ));
    assert!(e.contains("part labels"), "{e}");
    let e = err(GpuSphereFit::new(&ctx, &rest, None, (&labels, 1), (buf, 0)));
    assert!(e.contains("part labels below 1"), "{e}");
    let morph = Deformer::Morph {
        target: shapes::uv_sphere(1.0, 8, 8),
    };
    let e = err(GpuSphereFit::new(
        &ctx,
        &rest,
        Some(&morph),
        (&labels, 2),
        (buf, 0),
    ));
    assert!(e.contains("morph's target"), "{e}");
    // More spheres than the set takes, and none at all.
    let mut fit = vec![GpuSphereFit::new(&ctx, &rest, None, (&labels, 2), (buf, 0)).unwrap()];
    let many = vec![
        Sphere {
            center: DVec3::ZERO,
            radius: 1.0
        };
        63
    ];
    let e = set
        .frame_on_device(&ctx, &mut fit, &many, 0.0)
        .unwrap_err()
        .to_string();
    assert!(e.contains("65 spheres"), "{e}");
    let e = set
        .frame_on_device(&ctx, &mut [], &[], 0.0)
        .unwrap_err()
        .to_string();
    assert!(e.contains("0 spheres"), "{e}");
}
