//! Criterion benchmarks of geometry and BSV sampling: BVH build, rebuild and refit (the 8-wide
//! tree of `shscale_geometry::wide`) for ~20k and ~100k triangles; occlusion rays per second of the BSV workload on
//! dragon_19k with 1 and 2 threads; BSV sampling of the bunny at 12×20×32² and 6×8×8×32² with 2
//! threads. Run: `cargo bench -p shscale-field`; results in docs/BENCHMARKS.md.

use criterion::{black_box, criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use glam::DVec3;
use rayon::prelude::*;
use shscale_field::{Bsv, Layout, LocalFrame, VisibilitySampler};
use shscale_geometry::ray::UpdateStrategy;
use shscale_geometry::{bundled, deform, shapes, MeshBvh, Occluder, RAY_EPS};
use shscale_sh::DirectionSet;

fn pool(n: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(n)
        .build()
        .unwrap()
}

fn bvh_build_refit(c: &mut Criterion) {
    let mut g = c.benchmark_group("bvh");
    g.sample_size(10);
    for (label, rest) in [
        ("sphere_20k", shapes::uv_sphere(1.0, 100, 100)),
        ("sphere_100k", shapes::uv_sphere(1.0, 224, 224)),
    ] {
        let tris = rest.triangles.len();
        let mut bent = rest.clone();
        deform::twist(&rest, &mut bent, 0.2, 0.5);
        g.bench_function(
            BenchmarkId::new("build_wide", format!("{label}_{tris}")),
            |b| b.iter(|| black_box(MeshBvh::build(&rest, UpdateStrategy::Rebuild))),
        );
        let mut wide = MeshBvh::build(&rest, UpdateStrategy::Rebuild);
        g.bench_function(
            BenchmarkId::new("update_rebuild_wide", format!("{label}_{tris}")),
            |b| b.iter(|| wide.update(black_box(&bent))),
        );
        let mut bin = MeshBvh::build(&rest, UpdateStrategy::Refit);
        g.bench_function(
            BenchmarkId::new("update_refit", format!("{label}_{tris}")),
            |b| b.iter(|| bin.update(black_box(&bent))),
        );
    }
    g.finish();
}

/// The BSV ray workload: from every cube:8 sample on the bounding sphere, 32×32 rays over the
/// hemisphere facing the centre.
fn bsv_rays(occ: &dyn Occluder) -> Vec<(DVec3, DVec3)> {
    let s = occ.bounding_sphere();
    let hemi = DirectionSet::gauss_hemisphere(32);
    let mut rays = Vec::new();
    for dir in (Layout::Cube { n: 8 }).directions() {
        let p = s.center + s.radius * dir;
        let f = LocalFrame::toward(p, s.center);
        for d in &hemi.dirs {
            rays.push((p, f.to_world(DVec3::from_array(*d))));
        }
    }
    rays
}

fn occlusion_rays(c: &mut Criterion) {
    let mesh = bundled::load("dragon_19k").unwrap();
    let mut g = c.benchmark_group("occlusion_rays_dragon_19k_bsv");
    g.sample_size(10);
    for strategy in [UpdateStrategy::Rebuild, UpdateStrategy::Refit] {
        let bvh = MeshBvh::build(&mesh, strategy);
        let rays = bsv_rays(&bvh);
        let tmin = RAY_EPS * bvh.bounding_sphere().radius;
        g.throughput(Throughput::Elements(rays.len() as u64));
        for threads in [1usize, 2] {
            let p = pool(threads);
            g.bench_function(
                BenchmarkId::new(format!("{strategy:?}"), format!("{threads}_threads")),
                |b| {
                    b.iter(|| {
                        p.install(|| {
                            rays.par_iter()
                                .with_min_len(1024)
                                .filter(|(o, d)| bvh.occluded(*o, *d, tmin, f64::INFINITY))
                                .count()
                        })
                    })
                },
            );
        }
    }
    g.finish();
}

fn bsv_sampling(c: &mut Criterion) {
    let mesh = bundled::load("bunny").unwrap();
    let bvh = MeshBvh::build(&mesh, UpdateStrategy::Rebuild);
    let sampler = VisibilitySampler::new(4, 32).unwrap();
    let mut g = c.benchmark_group("bsv_sampling_bunny_n4_h32_2_threads");
    g.sample_size(10);
    let p = pool(2);
    for layout in ["latlong:12x20", "cube:8"] {
        let l = Layout::parse(layout).unwrap();
        g.bench_function(layout, |b| {
            b.iter(|| p.install(|| black_box(Bsv::sample(&bvh, l, &sampler, 1.0, 0.0).unwrap())))
        });
    }
    g.finish();
}

/// Per-frame cost of following a deformation: BVH update (rebuild vs refit) plus the BSV ray
/// workload (cube:8, 16×16 rays per sample, 2 threads), for each deforming scene.
fn frame_cost(c: &mut Criterion) {
    let bird = shapes::bird();
    let egg = shapes::egg(1.0, 0.5, 22, 24);
    let sphere = shapes::uv_sphere(1.0, 22, 24);
    let sponge = shapes::box_block(DVec3::new(1.0, 0.5, 0.3), 37);
    type Deform<'a> = Box<dyn Fn(&mut shscale_geometry::Mesh) + 'a>;
    let scenes: Vec<(&str, &shscale_geometry::Mesh, Deform)> = vec![
        (
            "bird_flap",
            &bird,
            Box::new(|m| deform::flap(&bird, m, 0.3, 0.8, 0.25)),
        ),
        (
            "egg_morph",
            &egg,
            Box::new(|m| deform::morph(&egg, &sphere, m, 0.3)),
        ),
        (
            "sponge_bend",
            &sponge,
            Box::new(|m| deform::bend(&sponge, m, 1.2, 0.5)),
        ),
        (
            "sponge_twist",
            &sponge,
            Box::new(|m| deform::twist(&sponge, m, 0.25, 0.5)),
        ),
    ];
    let sampler = VisibilitySampler::new(4, 16).unwrap();
    let p = pool(2);
    let mut g = c.benchmark_group("frame_update_plus_bsv_cube8_h16_2_threads");
    g.sample_size(10);
    for (name, rest, deformer) in &scenes {
        let mut posed = (*rest).clone();
        deformer(&mut posed);
        for strategy in [UpdateStrategy::Rebuild, UpdateStrategy::Refit] {
            let mut bvh = MeshBvh::build(rest, strategy);
            g.bench_function(BenchmarkId::new(*name, format!("{strategy:?}")), |b| {
                b.iter(|| {
                    bvh.update(&posed);
                    p.install(|| {
                        black_box(
                            Bsv::sample(&bvh, Layout::Cube { n: 8 }, &sampler, 1.0, 0.0).unwrap(),
                        )
                    })
                })
            });
        }
    }
    g.finish();
}

/// The bunny's BVH and a 160×160 receiver plane 2r × 2r, 0.1 r below its lowest point (y-up
/// mesh), with the base-sphere sampler (N = 4, H = 32) and layout (latlong:12x20) of the
/// receivers' benches.
fn bunny_plane() -> (MeshBvh, Vec<DVec3>, VisibilitySampler, Layout) {
    let mesh = bundled::load("bunny").unwrap();
    let bvh = MeshBvh::build(&mesh, UpdateStrategy::Rebuild);
    let s = bvh.bounding_sphere();
    let y0 = mesh.positions.iter().map(|p| p.y).fold(f64::MAX, f64::min) - 0.1 * s.radius;
    let grid = |i: usize| 2.0 * s.radius * ((i % 160) as f64 / 159.0 - 0.5);
    let recv: Vec<DVec3> = (0..160 * 160)
        .map(|i| DVec3::new(s.center.x + grid(i), y0, s.center.z + grid(i / 160)))
        .collect();
    let sampler = VisibilitySampler::new(4, 32).unwrap();
    (bvh, recv, sampler, Layout::LatLong { rows: 12, cols: 20 })
}

/// The receivers' benches' k-table: cone α = π/4, N = 4, K = 40 entries over k ∈ [0.2, 8].
fn bunny_table() -> shscale_scaling::KTable {
    use shscale_scaling::{Eta, Interp, KTable, Spacing, TauFamily};
    let alpha = 0.25 * std::f64::consts::PI;
    KTable::build(
        TauFamily::Cone { alpha },
        Eta::Plain,
        4,
        40,
        0.2,
        8.0,
        Spacing::Exp,
        Interp::Linear,
    )
    .unwrap()
}

/// Per-receiver visibility on a 160×160 receiver plane under the bunny ([`bunny_plane`]):
/// extrapolated (N = 4, latlong:12x20, K = 40), the cached shading and its build, and the full
/// field (16 shells).
fn receivers(c: &mut Criterion) {
    use shscale_field::evaluator::{FullField, Shells, VisibilityField};
    use shscale_field::extrapolate::Extrapolator;
    use shscale_scaling::ScalingMatrix;
    let (bvh, recv, sampler, layout) = bunny_plane();
    let bsv = Bsv::sample(&bvh, layout, &sampler, 1.0, 0.0).unwrap();
    let table = bunny_table();
    let ex = Extrapolator::new(&bsv, &table);
    let p2 = pool(2);
    let mut g = c.benchmark_group("receivers_160x160_bunny_n4");
    g.sample_size(10);
    g.throughput(Throughput::Elements(recv.len() as u64));
    g.bench_function("extrapolated_2_threads", |b| {
        b.iter(|| {
            p2.install(|| {
                let init = || (ScalingMatrix::identity(4).unwrap(), vec![0.0; 16]);
                recv.par_iter()
                    .map_init(init, |(m, out), p| {
                        ex.eval(*p, m, out);
                        out[0]
                    })
                    .sum::<f64>()
            })
        })
    });
    // The cached fast path: per frame three 16-dot products per receiver (grey sky, normal +z).
    let light = shscale_field::shading::EnvLight::sky(
        4,
        0.3,
        1.0,
        DVec3::Z,
        20.0,
        DVec3::new(0.2, 0.1, 1.0),
        0.1,
    )
    .unwrap();
    let transfer = shscale_field::shading::Shader::new(4)
        .unwrap()
        .transfer(&light, DVec3::Z);
    let cache = shscale_field::receivers::ReceiverCache::build(&bsv, &table, &transfer, &recv);
    let mut shaded = vec![[0.0; 3]; recv.len()];
    for threads in [1usize, 2] {
        let p = pool(threads);
        g.bench_function(format!("cached_shading_per_frame_{threads}_threads"), |b| {
            b.iter(|| p.install(|| cache.shade(&bsv, &mut shaded)))
        });
    }
    g.bench_function("cache_build_2_threads", |b| {
        b.iter(|| {
            p2.install(|| {
                black_box(
                    shscale_field::receivers::ReceiverCache::build(&bsv, &table, &transfer, &recv)
                        .len(),
                )
            })
        })
    });
    let full = FullField::build(&bvh, layout, &sampler, &Shells::PAPERS).unwrap();
    g.bench_function("full_field_eval_2_threads", |b| {
        b.iter(|| {
            p2.install(|| {
                recv.par_iter()
                    .map_init(
                        || vec![0.0; 16],
                        |out, p| {
                            full.eval(*p, out);
                            out[0]
                        },
                    )
                    .sum::<f64>()
            })
        })
    });
    g.finish();
}

/// The per-frame costs beside the receivers' evaluation on the bunny's plane
/// ([`bunny_plane`]): ray-traced truth (2·16² rays, a subset of 400 receivers) and the full
/// field's rebuild (16 shells).
fn receivers_per_frame_costs(c: &mut Criterion) {
    use shscale_field::evaluator::{FullField, RayTraced, Shells, VisibilityField};
    let (bvh, recv, sampler, layout) = bunny_plane();
    let p2 = pool(2);
    let mut g = c.benchmark_group("receivers_bunny_n4_per_frame_costs");
    g.sample_size(10);
    let sub: Vec<DVec3> = recv.iter().step_by(64).copied().collect();
    g.throughput(Throughput::Elements(sub.len() as u64));
    let rt_sampler = VisibilitySampler::new(4, 16).unwrap();
    let rt = RayTraced {
        occ: &bvh,
        sampler: &rt_sampler,
    };
    g.bench_function("raytraced_h16_2_threads_400_receivers", |b| {
        b.iter(|| {
            p2.install(|| {
                sub.par_iter()
                    .map_init(
                        || vec![0.0; 16],
                        |out, p| {
                            rt.eval(*p, out);
                            out[0]
                        },
                    )
                    .sum::<f64>()
            })
        })
    });
    g.bench_function("full_field_rebuild_16_shells", |b| {
        b.iter(|| {
            p2.install(|| {
                black_box(
                    FullField::build(&bvh, layout, &sampler, &Shells::PAPERS)
                        .unwrap()
                        .rays,
                )
            })
        })
    });
    g.finish();
}

criterion_group!(
    benches,
    bvh_build_refit,
    occlusion_rays,
    bsv_sampling,
    frame_cost,
    receivers,
    receivers_per_frame_costs
);
criterion_main!(benches);
