//! `shscale bench rays|bsv|sh`: the kernels timed the way the peers (Embree 4, sphericart) are
//! timed, so that a ratio measured minutes apart on one machine means something: a few warm-up
//! calls, then timed calls until they add up to at least `min_time` seconds (and at least
//! `min_reps` of them); the median is reported with the fastest and slowest call.
//!
//! Workloads (docs/BENCHMARKS.md):
//! - `bsv`: 12×20 lat-long cell centres on the minimal bounding sphere, 32×32 rays per sample
//!   over the hemisphere facing the centre in equal-solid-angle strata (`cosθ = (i+½)/32`,
//!   `φ = 2π(j+½)/32`) listed in 2×4 tiles of that grid as the BSV sampler lists them
//!   ([`shscale_sh::tile_order`]), every ray of a sample from its origin, `t ∈ (RAY_EPS·r, ∞)`;
//! - `random`: 10⁶ rays, origins uniform in the bounding box scaled 2× about its centre,
//!   directions uniform on the sphere (seeded), `t ∈ (0, ∞)`;
//! - a file in the peers' format (`<mesh>_{A,B}.rays.f32`: little-endian f32, N×3 origins then
//!   N×3 directions), optionally with Embree's answers (`.hits.bits`) to count disagreements.

use crate::error::Error;
use glam::DVec3;
use rayon::prelude::*;
use serde::Serialize;
use shscale_field::bsv::{Bsv, Layout};
use shscale_field::truth::SplitMix;
use shscale_field::visibility::VisibilitySampler;
use shscale_geometry::ray::UpdateStrategy;
use shscale_geometry::{Mesh, MeshBvh, Occluder, RAY_EPS};
use shscale_sh::simd::Level;
use shscale_sh::ShBasis;
use std::time::Instant;

/// How one measurement is repeated.
#[derive(Clone, Copy, Debug)]
pub struct Protocol {
    pub warmup: usize,
    pub min_reps: usize,
    pub min_time: f64,
}

impl Default for Protocol {
    fn default() -> Self {
        Self {
            warmup: 2,
            min_reps: 5,
            min_time: 1.0,
        }
    }
}

/// The timed calls of one measurement.
#[derive(Clone, Debug, Serialize)]
pub struct Timing {
    pub reps: usize,
    pub median_seconds: f64,
    pub min_seconds: f64,
    pub max_seconds: f64,
}

/// Run `f` by the protocol; the median of the timed calls.
pub(crate) fn time_reps(p: Protocol, mut f: impl FnMut()) -> Timing {
    for _ in 0..p.warmup {
        f();
    }
    let mut ts = Vec::new();
    let start = Instant::now();
    while ts.len() < p.min_reps.max(1) || start.elapsed().as_secs_f64() < p.min_time {
        let t = Instant::now();
        f();
        ts.push(t.elapsed().as_secs_f64());
    }
    ts.sort_by(f64::total_cmp);
    let n = ts.len();
    let median = if n % 2 == 1 {
        ts[n / 2]
    } else {
        0.5 * (ts[n / 2 - 1] + ts[n / 2])
    };
    Timing {
        reps: n,
        median_seconds: median,
        min_seconds: ts[0],
        max_seconds: ts[n - 1],
    }
}

/// The most rays a ray file may hold (2.4 GB of f32).
pub const MAX_FILE_RAYS: usize = 100_000_000;

/// Rays grouped by common origin (`groups[g]` = (origin, first ray, count)), with `t ∈ (tmin, ∞)`.
#[derive(Clone, Debug)]
pub struct RaySet {
    pub origins: Vec<DVec3>,
    pub dirs: Vec<DVec3>,
    pub groups: Vec<(DVec3, usize, usize)>,
    /// `dirs` in f32, what the fans are traced from (the precision of the BVH and of the
    /// peers' files).
    pub dirs32: Vec<[f32; 3]>,
    pub tmin: f64,
    /// Expected answers (from the peers' files), if any.
    pub expected: Option<Vec<bool>>,
}

impl RaySet {
    fn grouped(origins: Vec<DVec3>, dirs: Vec<DVec3>, tmin: f64) -> Self {
        let mut groups: Vec<(DVec3, usize, usize)> = Vec::new();
        for (i, o) in origins.iter().enumerate() {
            match groups.last_mut() {
                Some(g) if g.0 == *o => g.2 += 1,
                _ => groups.push((*o, i, 1)),
            }
        }
        let dirs32 = dirs.iter().map(|d| d.as_vec3().to_array()).collect();
        Self {
            origins,
            dirs,
            groups,
            dirs32,
            tmin,
            expected: None,
        }
    }

    /// The `bsv` workload on `mesh` (see the module docs).
    pub fn bsv(mesh: &Mesh, rows: usize, cols: usize, h: usize) -> Self {
        let s = mesh.bounding_sphere();
        let (mut origins, mut dirs) = (Vec::new(), Vec::new());
        for dir in (Layout::LatLong { rows, cols }).directions() {
            let o = s.center + s.radius * dir;
            // The sampler's local frame: z toward the centre.
            let f = shscale_field::LocalFrame::toward(o, s.center);
            // In the BSV sampler's order: 2×4 tiles of the (cosθ, φ) grid.
            for q in shscale_sh::tile_order(h, h) {
                let (i, j) = (q / h, q % h);
                let ct = (i as f64 + 0.5) / h as f64;
                let st = (1.0 - ct * ct).sqrt();
                let p = std::f64::consts::TAU * (j as f64 + 0.5) / h as f64;
                origins.push(o);
                dirs.push(
                    f.to_world(DVec3::new(st * p.cos(), st * p.sin(), ct))
                        .normalize(),
                );
            }
        }
        Self::grouped(origins, dirs, RAY_EPS * s.radius)
    }

    /// The `random` workload on `mesh`: `n` rays, seeded.
    pub fn random(mesh: &Mesh, n: usize, seed: u64) -> Self {
        let lo = mesh
            .positions
            .iter()
            .fold(DVec3::INFINITY, |a, p| a.min(*p));
        let hi = mesh
            .positions
            .iter()
            .fold(DVec3::NEG_INFINITY, |a, p| a.max(*p));
        let (c, e) = (0.5 * (lo + hi), hi - lo);
        let mut rng = SplitMix(seed);
        let (mut origins, mut dirs) = (Vec::with_capacity(n), Vec::with_capacity(n));
        for _ in 0..n {
            let u = DVec3::new(rng.unit(), rng.unit(), rng.unit()) * 2.0 - DVec3::ONE;
            origins.push(c + u * e);
            dirs.push(rng.direction());
        }
        Self::grouped(origins, dirs, 0.0)
    }

    /// Rays from a peers' `.rays.f32` file; `hits`: the matching `.hits.bits` file.
    pub fn from_file(
        path: &std::path::Path,
        hits: Option<&std::path::Path>,
    ) -> Result<Self, Error> {
        let size = std::fs::metadata(path)
            .map_err(|e| Error::io(path, e))?
            .len();
        if size > (MAX_FILE_RAYS * 24) as u64 {
            return Err(Error::config(format!(
                "{}: {size} bytes is more than {MAX_FILE_RAYS} rays (24 bytes each), the most a ray file may hold",
                path.display()
            )));
        }
        let bytes = shscale_files::input::read_regular(path)?;
        if bytes.is_empty() || bytes.len() % 24 != 0 {
            return Err(Error::config(format!(
                "{}: {} bytes is not a whole number of rays (24 bytes each: origin and direction, f32)",
                path.display(),
                bytes.len()
            )));
        }
        let n = bytes.len() / 24;
        let f = |i: usize| {
            f32::from_le_bytes(bytes[4 * i..4 * i + 4].try_into().expect("4 bytes")) as f64
        };
        let mut origins = Vec::with_capacity(n);
        let mut dirs = Vec::with_capacity(n);
        for r in 0..n {
            let o = DVec3::new(f(3 * r), f(3 * r + 1), f(3 * r + 2));
            let d = DVec3::new(f(3 * (n + r)), f(3 * (n + r) + 1), f(3 * (n + r) + 2));
            if !(o.is_finite() && d.is_finite() && (d.length() - 1.0).abs() < 1e-3) {
                return Err(Error::config(format!(
                    "{}: ray {r} is not a finite origin with a unit direction (o = {o}, d = {d})",
                    path.display()
                )));
            }
            origins.push(o);
            dirs.push(d.normalize());
        }
        let mut set = Self::grouped(origins, dirs, 0.0);
        if let Some(h) = hits {
            let b = shscale_files::input::read_regular(h)?;
            if b.len() != n.div_ceil(8) {
                return Err(Error::config(format!(
                    "{}: {} bytes, but {n} rays need {}",
                    h.display(),
                    b.len(),
                    n.div_ceil(8)
                )));
            }
            set.expected = Some((0..n).map(|i| b[i / 8] >> (i % 8) & 1 == 1).collect());
        }
        Ok(set)
    }

    pub fn len(&self) -> usize {
        self.dirs.len()
    }

    pub fn is_empty(&self) -> bool {
        self.dirs.is_empty()
    }

    /// Every answer, through the fan query where rays share an origin.
    pub fn trace(&self, occ: &dyn Occluder, hit: &mut [bool]) {
        if self.groups.len() * 2 > self.len() {
            // Mostly distinct origins (random rays): one ray at a time, in chunks per thread.
            hit.par_chunks_mut(4096)
                .zip(
                    self.origins
                        .par_chunks(4096)
                        .zip(self.dirs.par_chunks(4096)),
                )
                .for_each(|(h, (o, d))| occ.occluded_many(o, d, self.tmin, h));
            return;
        }
        let mut rest = &mut hit[..];
        let mut parts = Vec::with_capacity(self.groups.len());
        for g in &self.groups {
            let (a, b) = rest.split_at_mut(g.2);
            parts.push((g, a));
            rest = b;
        }
        parts.into_par_iter().with_min_len(8).for_each(|(g, out)| {
            if g.2 > 1 {
                occ.occluded_fan_f32(g.0, &self.dirs32[g.1..g.1 + g.2], self.tmin, out);
            } else {
                out[0] = occ.occluded(g.0, self.dirs[g.1], self.tmin, f64::INFINITY);
            }
        });
    }
}

/// Run `f` on a pool of `threads` threads.
pub(crate) fn with_threads<R: Send>(
    threads: usize,
    f: impl FnOnce() -> R + Send,
) -> Result<R, Error> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| Error::config(format!("--threads {threads}: {e}")))?;
    Ok(pool.install(f))
}

/// The CPU a kernel benchmark ran on ([`shscale_sh::cpu::Cpu`]), as its rows report it.
#[derive(Clone, Debug, Serialize)]
pub struct CpuRow {
    pub vendor: String,
    pub family: u32,
    pub model: u32,
    pub microarchitecture: String,
    pub brand: String,
    /// The best SIMD level the CPU has (the row's `simd` is the one the kernel ran).
    pub simd_detected: String,
    /// The whole identity on one line.
    pub summary: String,
}

impl CpuRow {
    /// This machine's.
    pub fn this() -> Self {
        let c = shscale_sh::cpu::cpu();
        CpuRow {
            summary: c.summary(),
            vendor: c.vendor,
            family: c.family,
            model: c.model,
            microarchitecture: c.microarchitecture,
            brand: c.brand,
            simd_detected: c.simd_detected,
        }
    }
}

/// The result of `bench rays` and `bench bsv`.
#[derive(Clone, Debug, Serialize)]
pub struct RayBench {
    pub kernel: String,
    pub mesh: String,
    pub workload: String,
    pub triangles: usize,
    pub rays: usize,
    pub hits: usize,
    /// Disagreements with the expected answers of a peers' file (absent without one).
    pub mismatches: Option<usize>,
    /// The shape of the 8-wide tree traversed.
    pub tree: Tree,
    pub threads: usize,
    pub simd: String,
    pub cpu: CpuRow,
    pub median_seconds: f64,
    pub rays_per_second: f64,
    /// `bench bsv --write-rays`: the files the sampling's rays went to.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub written: Option<WrittenRays>,
    pub timing: Timing,
}

/// The shape of the 8-wide tree: `slots_used` is the mean number of occupied child slots
/// per node (of 8), `pack_fill` the mean number of triangles per pack (of
/// `shscale_geometry::wide::PACK`, 8).
#[derive(Clone, Debug, Serialize)]
pub struct Tree {
    pub nodes: usize,
    pub packs: usize,
    pub depth: usize,
    pub slots_used: f64,
    pub pack_fill: f64,
}

impl Tree {
    fn of(bvh: &MeshBvh) -> Self {
        let s = bvh.tree_stats();
        Tree {
            nodes: s.nodes,
            packs: s.packs,
            depth: s.depth,
            slots_used: (s.nodes - 1 + s.leaves) as f64 / s.nodes as f64,
            pack_fill: s.triangles as f64 / s.packs.max(1) as f64,
        }
    }
}

/// `bench rays`: occlusion throughput of [`MeshBvh`] on `set`.
pub fn bench_rays(
    mesh: &Mesh,
    name: &str,
    workload: &str,
    set: &RaySet,
    threads: usize,
    level: Level,
    p: Protocol,
) -> Result<RayBench, Error> {
    let bvh = MeshBvh::build(mesh, UpdateStrategy::Rebuild).with_level(level);
    let mut hit = vec![false; set.len()];
    let timing = with_threads(threads, || time_reps(p, || set.trace(&bvh, &mut hit)))?;
    let hits = hit.iter().filter(|h| **h).count();
    let mismatches = set
        .expected
        .as_ref()
        .map(|e| e.iter().zip(&hit).filter(|(a, b)| a != b).count());
    Ok(RayBench {
        kernel: "rays".into(),
        mesh: name.into(),
        workload: workload.into(),
        triangles: mesh.triangles.len(),
        rays: set.len(),
        hits,
        mismatches,
        tree: Tree::of(&bvh),
        threads,
        simd: bvh.level().name().into(),
        cpu: CpuRow::this(),
        median_seconds: timing.median_seconds,
        rays_per_second: set.len() as f64 / timing.median_seconds,
        written: None,
        timing,
    })
}

/// `bench bsv`: the whole base-sphere sampling (rays and SH projection) of `mesh`.
#[allow(clippy::too_many_arguments)]
pub fn bench_bsv(
    mesh: &Mesh,
    name: &str,
    layout: Layout,
    h: usize,
    order: usize,
    threads: usize,
    level: Level,
    p: Protocol,
) -> Result<RayBench, Error> {
    let bvh = MeshBvh::build(mesh, UpdateStrategy::Rebuild).with_level(level);
    let sampler = VisibilitySampler::new(order, h)?;
    let mut last = None;
    let timing = with_threads(threads, || {
        time_reps(p, || {
            last = Some(Bsv::sample(&bvh, layout, &sampler, 1.0, 0.0));
        })
    })?;
    let bsv = last.expect("timed at least once")?;
    Ok(RayBench {
        kernel: "bsv".into(),
        mesh: name.into(),
        workload: format!("{} H={h} N={order}", layout.name()),
        triangles: mesh.triangles.len(),
        rays: bsv.rays,
        hits: 0,
        mismatches: None,
        tree: Tree::of(&bvh),
        threads,
        simd: bvh.level().name().into(),
        cpu: CpuRow::this(),
        median_seconds: timing.median_seconds,
        rays_per_second: bsv.rays as f64 / timing.median_seconds,
        written: None,
        timing,
    })
}

/// An occluder that answers with a mesh BVH and records every fan it is asked (origin, f32
/// directions, `tmin`, answers), so the exact rays of a BSV sampling can be handed to a peer.
struct Recorder<'a> {
    bvh: &'a MeshBvh,
    fans: std::sync::Mutex<Vec<Fan>>,
}

/// One recorded fan: origin, directions, `tmin`, answers.
type Fan = ([f32; 3], Vec<[f32; 3]>, f64, Vec<bool>);

impl shscale_geometry::Occluder for Recorder<'_> {
    fn occluded(&self, o: DVec3, d: DVec3, tmin: f64, tmax: f64) -> bool {
        self.bvh.occluded(o, d, tmin, tmax)
    }
    fn occluded_fan_f32(&self, o: DVec3, dirs: &[[f32; 3]], tmin: f64, hit: &mut [bool]) {
        self.bvh.occluded_fan_f32(o, dirs, tmin, hit);
        let rec = (o.as_vec3().to_array(), dirs.to_vec(), tmin, hit.to_vec());
        self.fans.lock().expect("not poisoned").push(rec);
    }
    fn fans_in_f32(&self) -> bool {
        true
    }
    fn closest_hit(&self, o: DVec3, d: DVec3, tmin: f64, tmax: f64) -> Option<f64> {
        self.bvh.closest_hit(o, d, tmin, tmax)
    }
    fn bounding_sphere(&self) -> shscale_geometry::Sphere {
        self.bvh.bounding_sphere()
    }
    fn distance_to_surface(&self, p: DVec3) -> f64 {
        self.bvh.distance_to_surface(p)
    }
    fn farthest_distance(&self, p: DVec3) -> f64 {
        self.bvh.farthest_distance(p)
    }
}

/// What `bench bsv --write-rays PREFIX` wrote.
#[derive(Clone, Debug, Serialize)]
pub struct WrittenRays {
    /// `PREFIX.rays.f32`: N origins then N directions, little-endian f32 (the peer kit's format).
    pub rays: String,
    /// `PREFIX.hits.bits`: our answers, one bit per ray, least significant bit first.
    pub hits: String,
    /// `PREFIX.obj`: the mesh the rays were traced against, in the rays' coordinates.
    pub mesh: String,
    pub count: usize,
    /// The rays' `tmin` (world units; every fan of one sampling shares it).
    pub tnear: f64,
    pub hit_fraction: f64,
}

/// The rays of one BSV sampling of `mesh` (`layout`, `H = h`), written for a peer: every fan the
/// sampling traced, in the order the samples were traced, with our answers and the mesh.
pub fn write_bsv_rays(
    mesh: &Mesh,
    layout: Layout,
    h: usize,
    order: usize,
    prefix: &std::path::Path,
) -> Result<WrittenRays, Error> {
    let bvh = MeshBvh::build(mesh, UpdateStrategy::Rebuild);
    let sampler = VisibilitySampler::new(order, h)?;
    let rec = Recorder {
        bvh: &bvh,
        fans: std::sync::Mutex::new(Vec::new()),
    };
    Bsv::sample(&rec, layout, &sampler, 1.0, 0.0)?;
    let fans = rec.fans.into_inner().expect("not poisoned");
    let tnear = fans.first().map_or(0.0, |f| f.2);
    if fans.iter().any(|f| f.2 != tnear) {
        return Err(Error::config(
            "the sampling's fans differ in tmin".to_string(),
        ));
    }
    let (mut origins, mut dirs, mut hits) = (Vec::new(), Vec::new(), Vec::new());
    for (o, d, _, h) in &fans {
        origins.extend(std::iter::repeat_n(*o, d.len()));
        dirs.extend_from_slice(d);
        hits.extend_from_slice(h);
    }
    let n = dirs.len();
    let mut bytes = Vec::with_capacity(24 * n);
    for v in origins.iter().chain(&dirs) {
        for x in v {
            bytes.extend_from_slice(&x.to_le_bytes());
        }
    }
    let mut bits = vec![0u8; n.div_ceil(8)];
    for (i, &h) in hits.iter().enumerate() {
        bits[i / 8] |= u8::from(h) << (i % 8);
    }
    let mut obj = String::new();
    for p in &mesh.positions {
        obj.push_str(&format!("v {:?} {:?} {:?}\n", p.x, p.y, p.z));
    }
    for t in &mesh.triangles {
        obj.push_str(&format!("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1));
    }
    let path = |ext: &str| std::path::PathBuf::from(format!("{}.{ext}", prefix.display()));
    let (rp, hp, mp) = (path("rays.f32"), path("hits.bits"), path("obj"));
    shscale_runner::write_atomic_bytes(&rp, &bytes)?;
    shscale_runner::write_atomic_bytes(&hp, &bits)?;
    shscale_runner::write_atomic(&mp, &obj)?;
    Ok(WrittenRays {
        rays: rp.display().to_string(),
        hits: hp.display().to_string(),
        mesh: mp.display().to_string(),
        count: n,
        tnear,
        hit_fraction: hits.iter().filter(|h| **h).count() as f64 / n.max(1) as f64,
    })
}

/// The result of `bench sh`.
#[derive(Clone, Debug, Serialize)]
pub struct ShBench {
    pub kernel: String,
    pub order: usize,
    pub precision: String,
    pub points: usize,
    pub threads: usize,
    pub simd: String,
    pub cpu: CpuRow,
    pub ns_per_point: f64,
    pub median_seconds: f64,
    pub timing: Timing,
}

/// `n` copies of `fill` in memory advised for transparent huge pages before it is first
/// touched — as NumPy allocates every array of 4 MiB or more on Linux, so that `bench sh` and
/// the kit's sphericart write the same kind of pages (4 KiB pages cost this kernel a page walk
/// every 4 KiB of a streamed output). Elsewhere, or if the advice is refused, ordinary pages.
fn advised_vec<T: Copy>(n: usize, fill: T) -> Vec<T> {
    let mut v: Vec<T> = Vec::with_capacity(n);
    #[cfg(target_os = "linux")]
    {
        const PAGE: usize = 4096;
        let start = v.as_ptr() as usize;
        let end = start + n * std::mem::size_of::<T>();
        let first = start.div_ceil(PAGE) * PAGE;
        if end > first + (4 << 20) {
            // SAFETY: the range lies inside `v`'s allocation; advice changes no contents.
            unsafe {
                libc::madvise(first as *mut libc::c_void, end - first, libc::MADV_HUGEPAGE);
            }
        }
    }
    v.resize(n, fill);
    v
}

fn sh_points(points: usize) -> Vec<[f64; 3]> {
    let mut rng = SplitMix(12345);
    (0..points).map(|_| rng.direction().to_array()).collect()
}

fn bench_sh_t<T: shscale_sh::Real>(
    order: usize,
    points: usize,
    level: Level,
    p: Protocol,
) -> Result<Timing, Error> {
    let basis = ShBasis::<T>::new(order).map_err(|e| Error::config(format!("--order: {e}")))?;
    let mut dirs = advised_vec(points, [T::zero(); 3]);
    for (d, s) in dirs.iter_mut().zip(sh_points(points)) {
        *d = s.map(T::c);
    }
    let mut out = advised_vec(points * order * order, T::one());
    Ok(time_reps(p, || {
        basis.eval_batch_with(level, &dirs, &mut out);
        std::hint::black_box(&out);
    }))
}

/// `bench sh`: all `N²` values at `points` random unit directions, one thread, written point by
/// point into a preallocated (already touched) array advised for huge pages, from directions in
/// such memory — as the kit times sphericart on NumPy arrays.
pub fn bench_sh(
    order: usize,
    f32: bool,
    points: usize,
    level: Level,
    p: Protocol,
) -> Result<ShBench, Error> {
    let level = level.usable();
    let timing = if f32 {
        bench_sh_t::<f32>(order, points, level, p)?
    } else {
        bench_sh_t::<f64>(order, points, level, p)?
    };
    Ok(ShBench {
        kernel: "sh".into(),
        order,
        precision: if f32 { "f32" } else { "f64" }.into(),
        points,
        threads: 1,
        // The SH kernels have no AVX-512 code: at that level they run their AVX2 code.
        simd: level.min(Level::Avx2Fma).name().into(),
        cpu: CpuRow::this(),
        ns_per_point: timing.median_seconds * 1e9 / points as f64,
        median_seconds: timing.median_seconds,
        timing,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The advised buffer holds `n` copies of the fill, below and above the advice's 4 MiB.
    #[test]
    fn advised_vec_holds_its_fill() {
        for n in [0, 1, 1000, 600_000] {
            let v = advised_vec(n, [1.5f64, -2.0, 3.0]);
            assert_eq!(v.len(), n);
            assert!(v.iter().all(|&x| x == [1.5, -2.0, 3.0]), "n = {n}");
        }
    }

    /// A ray file larger than [`MAX_FILE_RAYS`] rays is refused from its size, before it is
    /// read (a sparse 3 GB file: no disk space, no memory).
    #[test]
    fn oversized_ray_file_is_refused_unread() {
        let dir = std::env::temp_dir().join(format!("shscale-huge-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("huge.rays.f32");
        std::fs::File::create(&p)
            .unwrap()
            .set_len(3_000_000_000)
            .unwrap();
        let e = RaySet::from_file(&p, None).unwrap_err().to_string();
        std::fs::remove_dir_all(&dir).unwrap();
        assert!(
            e.contains("huge.rays.f32") && e.contains("100000000 rays"),
            "{e}"
        );
    }
}
