//! Criterion benchmarks of the SH core: evaluation per direction (N = 4, 8, 16; f32, f64),
//! rotation including its construction (N = 4, 8), and the triple product at N = 4.
//! Run: `cargo bench -p shscale-sh` (single-threaded code; record results in docs/BENCHMARKS.md).

use criterion::{black_box, criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use shscale_sh::{euler_zyz, DirectionSet, EulerRotator, GauntTensor, Real, ShBasis, ShRotator};

fn eval_bench<T: Real>(c: &mut Criterion, label: &str) {
    let mut g = c.benchmark_group(format!("sh_eval_{label}"));
    let dirs: Vec<[T; 3]> = DirectionSet::fibonacci_sphere(1024)
        .dirs
        .iter()
        .map(|d| d.map(T::c))
        .collect();
    g.throughput(Throughput::Elements(dirs.len() as u64));
    for order in [4usize, 8, 16] {
        let b = ShBasis::<T>::new(order).unwrap();
        let mut out = vec![T::zero(); order * order];
        g.bench_with_input(BenchmarkId::from_parameter(order), &order, |bch, _| {
            bch.iter(|| {
                for d in &dirs {
                    b.eval(black_box(*d), &mut out);
                    black_box(&out);
                }
            })
        });
    }
    g.finish();
}

fn evals(c: &mut Criterion) {
    eval_bench::<f64>(c, "f64");
    eval_bench::<f32>(c, "f32");
}

fn rotation(c: &mut Criterion) {
    let mut g = c.benchmark_group("sh_rotate_build_and_apply");
    for order in [4usize, 8] {
        let r = euler_zyz(0.3, 1.1, -0.7);
        let x: Vec<f64> = (0..order * order).map(|i| i as f64 * 0.1).collect();
        let mut y = vec![0.0; order * order];
        // The order's tables are built once; each iteration builds D(R) and applies it.
        let rotator = ShRotator::<f64>::new(order).unwrap();
        let mut d = rotator.empty();
        g.bench_with_input(BenchmarkId::from_parameter(order), &order, |bch, _| {
            bch.iter(|| {
                rotator.build_into(black_box(&r), &mut d);
                d.apply(black_box(&x), &mut y).unwrap();
                black_box(&y);
            })
        });
    }
    g.finish();
    let mut g = c.benchmark_group("sh_rotate_euler_apply");
    for order in [4usize, 8] {
        let r = euler_zyz(0.3, 1.1, -0.7);
        let x: Vec<f64> = (0..order * order).map(|i| i as f64 * 0.1).collect();
        let mut y = vec![0.0; order * order];
        let er = EulerRotator::<f64>::new(order).unwrap();
        g.bench_with_input(BenchmarkId::from_parameter(order), &order, |bch, _| {
            bch.iter(|| {
                er.apply(black_box(&r), black_box(&x), &mut y).unwrap();
                black_box(&y);
            })
        });
    }
    g.finish();
}

fn triple(c: &mut Criterion) {
    let g4 = GauntTensor::<f64>::new(4).unwrap();
    let a: Vec<f64> = (0..16).map(|i| (i as f64 * 0.37).sin()).collect();
    let b: Vec<f64> = (0..16).map(|i| (i as f64 * 0.91).cos()).collect();
    let mut out = vec![0.0; 16];
    c.bench_function("sh_triple_product_n4", |bch| {
        bch.iter(|| {
            g4.product(black_box(&a), black_box(&b), &mut out).unwrap();
            black_box(&out);
        })
    });
}

criterion_group!(benches, evals, rotation, triple);
criterion_main!(benches);
