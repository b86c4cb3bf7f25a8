//! Criterion benchmarks of SH scaling: one application of M at N = 4 (f32, f64), batch
//! throughput, and k-table builds for N = 4, 8, 16 with K = 40.
//! Run: `cargo bench -p shscale-scaling` (single-threaded code; record in docs/BENCHMARKS.md).

use criterion::{black_box, criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use shscale_scaling::{Cone, Eta, Interp, KTable, ScalingMatrix, Spacing, TauFamily};

fn apply(c: &mut Criterion) {
    let m = ScalingMatrix::compute(
        &Cone::new(2.0, 0.25 * std::f64::consts::PI).unwrap(),
        Eta::Plain,
        4,
    )
    .unwrap();
    let x: Vec<f64> = (0..16).map(|i| (i as f64 * 0.3).sin()).collect();
    let mut y = vec![0.0; 16];
    c.bench_function("scaling_apply_n4_f64", |b| {
        b.iter(|| {
            m.apply_unchecked(black_box(&x), &mut y);
            black_box(&y);
        })
    });
    let m32 = m.cast::<f32>();
    let x32: Vec<f32> = x.iter().map(|&v| v as f32).collect();
    let mut y32 = vec![0.0f32; 16];
    c.bench_function("scaling_apply_n4_f32", |b| {
        b.iter(|| {
            m32.apply_unchecked(black_box(&x32), &mut y32);
            black_box(&y32);
        })
    });
    let n = 25_600; // a 160×160 receiver plane
    let xs: Vec<f32> = (0..n * 16).map(|i| (i as f32 * 0.001).sin()).collect();
    let mut ys = vec![0.0f32; n * 16];
    let mut g = c.benchmark_group("scaling_apply_batch_n4_f32");
    g.throughput(Throughput::Elements(n as u64));
    g.bench_function("25600", |b| {
        b.iter(|| {
            m32.apply_batch(black_box(&xs), &mut ys).unwrap();
            black_box(&ys);
        })
    });
    let mut soa_y = vec![0.0f32; n * 16];
    g.bench_function("25600_soa", |b| {
        b.iter(|| {
            m32.apply_batch_soa(black_box(&xs), &mut soa_y, n).unwrap();
            black_box(&soa_y);
        })
    });
    g.finish();
}

fn tables(c: &mut Criterion) {
    let mut g = c.benchmark_group("ktable_build_k40");
    g.sample_size(10);
    for order in [4usize, 8, 16] {
        g.bench_with_input(BenchmarkId::from_parameter(order), &order, |b, &n| {
            b.iter(|| {
                let t = KTable::build(
                    TauFamily::Cone {
                        alpha: 0.25 * std::f64::consts::PI,
                    },
                    Eta::Plain,
                    n,
                    40,
                    0.1,
                    10.0,
                    Spacing::Exp,
                    Interp::Linear,
                )
                .unwrap();
                black_box(t.size_bytes())
            })
        });
    }
    g.finish();
}

criterion_group!(benches, apply, tables);
criterion_main!(benches);
