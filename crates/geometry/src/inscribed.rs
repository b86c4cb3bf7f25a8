//! Sphere sets inside the solid, nested in their count: the greedy cover of a mesh's interior by
//! inscribed balls.
//!
//! The rule, fixed before any score was seen: the mesh's bounding box is cut into cubic cells,
//! `res` along its longest side; a cell centre is *inside* when the mesh's generalised winding
//! number there (Jacobson, Kavan & Sorkine-Hornung 2013: the triangles' signed solid angles
//! summed over 4π, by Van Oosterom & Strackee's formula) has magnitude above ½ — robust to the
//! bundled meshes' holes and self-intersections; every inside centre is a candidate ball whose
//! radius is its distance to the surface (so the ball meets no triangle: it lies in the solid,
//! up to a hole in the surface it touches). Balls are then chosen greedily, each covering the
//! most inside centres not yet covered (ties to the lower cell), until `count` are chosen or
//! every inside centre is covered.
//!
//! Why: every ball lies in the solid, so the set's union blocks a subset of the directions the
//! mesh blocks, seen from any point, and the first `S` balls are the first `S − 1` and one more.
//! The union's visibility therefore falls toward the mesh's **pointwise in every direction** as
//! `S` grows: at full frequency the error of the exact union (`shscale_field::union`) cannot rise
//! with `S` (its SH projection's error can, in principle, but the full-frequency one cannot). The
//! area-weighted fit ([`crate::partition::fit_spheres`]) has no such order: its spheres also
//! bulge outside, and a finer partition can do worse.
//!
//! Cost: cells × triangles solid angles (the winding numbers, in parallel), the inside cells'
//! distances to the surface, and the greedy cover (lazily re-scored, each ball's cells listed
//! once). A one-off fit of a rest pose, not a per-frame one.

use crate::error::GeometryError;
use crate::mesh::Mesh;
use crate::ray::mesh_distance;
use crate::Sphere;
use glam::DVec3;
use rayon::prelude::*;
use std::collections::BinaryHeap;

/// The finest grid: `res` cells along the box's longest side, at most this (work grows as res³
/// × triangles).
pub const MAX_INSCRIBED_RES: usize = 128;

/// The grid of [`inscribed_set`]: 48 cells along the box's longest side. Chosen after probing
/// 32 and 48 on the `budget` study's four meshes with the union at N = 4 (S = 64: errors
/// 0.146 / 0.064 / 0.135 / 0.109 at 32, 0.130 / 0.056 / 0.109 / 0.081 at 48; bunny, duck, teapot,
/// knot; experiments/README.md) — a choice made after seeing scores, said here and there; 64
/// was not tried (the winding numbers' work grows as res³ × triangles).
pub const INSCRIBED_RES: usize = 48;

/// The first `count` balls of `mesh` at [`INSCRIBED_RES`] ([`inscribed_spheres`]) and the
/// seconds their fit took: each mesh's greedy order is computed once per process up to
/// `crate::partition::MAX_PARTS` balls and kept with its cost (keyed by the mesh's vertices and
/// triangles: a new pose is a new mesh) — the sets of every count are prefixes of one order, so
/// a sweep over counts fits each mesh once, and every caller is told what that fit cost. A mesh
/// with no inside (no ball at all) is an error ([`inscribable`] says so before any fit).
pub fn inscribed_set(mesh: &Mesh, count: usize) -> Result<(Vec<Sphere>, f64), GeometryError> {
    use std::hash::{Hash, Hasher};
    type Fits = Vec<(u64, (Vec<Sphere>, f64))>;
    static CACHE: std::sync::Mutex<Fits> = std::sync::Mutex::new(Vec::new());
    /// Poses kept at once (a sequence's frames each add one; the oldest goes first).
    const KEEP: usize = 16;
    let mut h = std::collections::hash_map::DefaultHasher::new();
    for p in &mesh.positions {
        p.to_array().map(f64::to_bits).hash(&mut h);
    }
    mesh.triangles.hash(&mut h);
    let key = h.finish();
    let hit = (CACHE
        .lock()
        .map_err(|_| GeometryError::Unknown("inscribed cache poisoned".into()))?)
    .iter()
    .find(|(k, _)| *k == key)
    .map(|(_, v)| v.clone());
    let (all, seconds) = match hit {
        Some(v) => v,
        None => {
            let t0 = std::time::Instant::now();
            let balls = inscribed_spheres(mesh, crate::partition::MAX_PARTS, INSCRIBED_RES)?;
            let v = (balls, t0.elapsed().as_secs_f64());
            let mut c = CACHE
                .lock()
                .map_err(|_| GeometryError::Unknown("inscribed cache poisoned".into()))?;
            // Two runs of one mesh on two threads may both have fitted it (the lock is not held
            // while fitting: the fit's parallel work could otherwise take up a run that waits on
            // it); the first one kept is everybody's, so every run reports the same fit.
            if let Some((_, kept)) = c.iter().find(|(k, _)| *k == key) {
                kept.clone()
            } else {
                if c.len() >= KEEP {
                    c.remove(0);
                }
                c.push((key, v.clone()));
                v
            }
        }
    };
    if all.is_empty() {
        return Err(match Grid::of(mesh, INSCRIBED_RES) {
            Ok(g) => no_inside(&g),
            Err(e) => e,
        });
    }
    Ok((all[..count.min(all.len())].to_vec(), seconds))
}

static PROGRESS: std::sync::OnceLock<fn(&str)> = std::sync::OnceLock::new();

/// Where a long fit says how far it is (once per process; a program's front end sets it: the
/// CLI prints the line as progress). Without one, fits are silent.
pub fn set_progress(f: fn(&str)) {
    let _ = PROGRESS.set(f);
}

fn progress(line: &str) {
    if let Some(f) = PROGRESS.get() {
        f(line)
    }
}

/// Checks, before any fit runs, that [`inscribed_set`] can fit `mesh`: the grid's bounds
/// ([`MAX_INSCRIBED_WORK`]) and at least one cell centre inside the mesh — an open or flat
/// surface (a plane's fan) has no inside to inscribe a ball in, and is refused here rather than
/// handed on as an empty set. Returns the fit's work, cells × triangles (the winding numbers'
/// solid angles), for the cost model. Cost: the coarse-to-fine search for an inside cell, which
/// stops at the first one (a solid mesh: a few hundred cells × triangles).
pub fn inscribable(mesh: &Mesh) -> Result<f64, GeometryError> {
    if mesh.triangles.is_empty() {
        return Err(GeometryError::Domain {
            file: "inscribed spheres".into(),
            reason: "a mesh without triangles has no inside".into(),
        });
    }
    let grid = Grid::of(mesh, INSCRIBED_RES)?;
    if !grid.any_inside(mesh) {
        return Err(no_inside(&grid));
    }
    Ok(grid.cells() as f64 * mesh.triangles.len() as f64)
}

/// The work of a fit of `mesh` at [`INSCRIBED_RES`], cells × triangles, with the grid's bounds
/// checked (as [`inscribable`], without looking for an inside cell): for cost models.
pub fn inscribed_work(mesh: &Mesh) -> Result<f64, GeometryError> {
    let grid = Grid::of(mesh, INSCRIBED_RES)?;
    Ok(grid.cells() as f64 * mesh.triangles.len() as f64)
}

fn no_inside(grid: &Grid) -> GeometryError {
    GeometryError::Domain {
        file: "inscribed spheres".into(),
        reason: format!(
            "no centre of the {} × {} × {} cells lies inside the mesh (its winding number is at most ½ at every one: an open or flat surface, with no inside to inscribe a ball in); sphere_fit = \"area\" fits any mesh",
            grid.dims.x, grid.dims.y, grid.dims.z
        ),
    }
}

/// What the cost model counts for one fit at [`INSCRIBED_RES`] when its size is not known (rows
/// read back from a file), in the runner's reference seconds: [`inscribed_fit_seconds`] of the
/// bundled study meshes' largest fit, the teapot's (5.6·10⁸ solid angles).
pub const INSCRIBED_FIT_SECONDS: f64 = 13.0;

/// Reference seconds per solid angle of the winding numbers, the fit's work that grows with the
/// mesh (cells × triangles), and the seconds of the rest (the inside cells' distances and the
/// greedy cover), bounded by its worst case, one solid ball (~0.9 R⁶ cells walked at R cells of
/// radius). Measured on the 2-vCPU development VM of 2026-12-07 (Intel Xeon, Emerald Rapids),
/// which calibrated at 1.6–2.0× the reference in the same sitting (`--dry-run`'s speed line; 1.8
/// taken): `cargo run --release -p shscale-geometry --example inscribed_stages -- NAME` gave
/// bunny 3.07·10⁸ solid angles in 2.57 s, duck 3.09·10⁸ in 2.74 s, knot 3.32·10⁸ in 2.56 s,
/// teapot 5.62·10⁸ in 4.34 s, and a 6,240-triangle UV sphere (`… -- 40`) 6.90·10⁸ in 8.1 s, of
/// which 5.7 s were its winding numbers (8.3·10⁻⁹ s each, 1.5·10⁻⁸ reference seconds) and
/// 2.5 s the rest (4.5 reference seconds). The estimate is therefore about 2× high on the
/// study's meshes, whose covers are cheaper than a ball's, and right for a ball.
pub const INSCRIBED_SECONDS_PER_SOLID_ANGLE: f64 = 1.5e-8;
/// The fit's seconds that do not grow with the mesh (see [`INSCRIBED_SECONDS_PER_SOLID_ANGLE`]).
pub(crate) const INSCRIBED_COVER_SECONDS: f64 = 4.5;

/// The estimated reference seconds of one fit of `work` solid angles ([`inscribable`]).
pub fn inscribed_fit_seconds(work: f64) -> f64 {
    work * INSCRIBED_SECONDS_PER_SOLID_ANGLE + INSCRIBED_COVER_SECONDS
}

/// The most cells × triangles one fit may evaluate (the winding numbers' solid angles; the
/// study's largest, the teapot at 48 cells, is 5.6·10⁸ and took 4.3 s on two cores): a larger
/// mesh is refused by name. At the limit a fit takes about 3 minutes on the 2-vCPU development
/// VM; it is in the plan's estimate and says how far it is every 5 s.
pub const MAX_INSCRIBED_WORK: f64 = 2e10;

/// The signed solid angle of triangle `abc` seen from `p` (Van Oosterom & Strackee 1983): 2
/// atan2 of `a·(b×c)` over `|a||b||c| + (a·b)|c| + (a·c)|b| + (b·c)|a|`, with `a, b, c` the
/// corners relative to `p`; in (−2π, 2π), 0 for a point in the triangle's plane outside it.
pub(crate) fn solid_angle(p: DVec3, [a, b, c]: [DVec3; 3]) -> f64 {
    let (a, b, c) = (a - p, b - p, c - p);
    let (la, lb, lc) = (a.length(), b.length(), c.length());
    let num = a.dot(b.cross(c));
    let den = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
    2.0 * num.atan2(den)
}

/// The generalised winding number of `mesh` at `p`: its triangles' signed solid angles over 4π
/// (±1 inside a closed, consistently oriented surface, 0 outside; between for open ones).
pub(crate) fn winding_number(mesh: &Mesh, p: DVec3) -> f64 {
    (0..mesh.triangles.len())
        .map(|f| solid_angle(p, mesh.corners(f)))
        .sum::<f64>()
        / (4.0 * std::f64::consts::PI)
}

/// Up to `count` balls inside `mesh`, in the greedy order (module documentation): the first `S`
/// of `inscribed_spheres(m, count, res)` are `inscribed_spheres(m, S, res)`. Fewer when every
/// inside cell centre is covered first; none for a mesh with no inside cell (a flat one).
/// Domain: `2 ≤ res ≤ MAX_INSCRIBED_RES`, a non-empty mesh with a box of positive size.
pub fn inscribed_spheres(
    mesh: &Mesh,
    count: usize,
    res: usize,
) -> Result<Vec<Sphere>, GeometryError> {
    if mesh.triangles.is_empty() || count == 0 {
        return Ok(Vec::new());
    }
    let grid = Grid::of(mesh, res)?;
    let inside = grid.inside_cells(mesh);
    let radius: Vec<f64> = (inside.par_iter())
        .map(|&i| mesh_distance(&mesh.positions, &mesh.triangles, grid.centre(i)))
        .collect();
    let mut slot = vec![u32::MAX; grid.cells()];
    for (k, &i) in inside.iter().enumerate() {
        slot[i] = k as u32;
    }
    let centres: Vec<DVec3> = inside.iter().map(|&i| grid.centre(i)).collect();
    let members =
        |k: usize, f: &mut dyn FnMut(u32)| grid.ball_members(&slot, centres[k], radius[k], f);
    Ok(greedy_cover(inside.len(), inside.len(), count, &members)
        .into_iter()
        .map(|k| Sphere {
            center: grid.centre(inside[k]),
            radius: radius[k],
        })
        .collect())
}

/// The cubic cells of a box: `dims` cells of side `h` from `lo`, numbered x fastest.
struct Grid {
    lo: DVec3,
    h: f64,
    dims: glam::UVec3,
}

impl Grid {
    /// The grid of a fit of `mesh` at `res` cells along its box's longest side, its bounds
    /// checked: `2 ≤ res ≤ MAX_INSCRIBED_RES`, a box of positive finite size, and cells ×
    /// triangles at most [`MAX_INSCRIBED_WORK`].
    fn of(mesh: &Mesh, res: usize) -> Result<Self, GeometryError> {
        let domain = |reason: String| GeometryError::Domain {
            file: "inscribed spheres".into(),
            reason,
        };
        if !(2..=MAX_INSCRIBED_RES).contains(&res) {
            return Err(domain(format!(
                "res = {res} cells is outside 2..={MAX_INSCRIBED_RES}"
            )));
        }
        let lo = (mesh.positions.iter()).fold(DVec3::INFINITY, |a, p| a.min(*p));
        let hi = (mesh.positions.iter()).fold(DVec3::NEG_INFINITY, |a, p| a.max(*p));
        let h = (hi - lo).max_element() / res as f64;
        if !(h.is_finite() && h > 0.0) {
            return Err(domain(format!("a bounding box of size {:?}", hi - lo)));
        }
        let grid = Grid {
            lo,
            h,
            dims: ((hi - lo) / h).ceil().max(DVec3::ONE).as_uvec3(),
        };
        let work = grid.cells() as f64 * mesh.triangles.len() as f64;
        if work > MAX_INSCRIBED_WORK {
            return Err(domain(format!(
                "{} cells × {} triangles = {work:.2e} solid angles, above the limit {MAX_INSCRIBED_WORK:.0e} (a coarser mesh, or sphere_fit = \"area\")",
                grid.cells(),
                mesh.triangles.len()
            )));
        }
        Ok(grid)
    }

    /// Whether any cell centre is inside `mesh` (winding number above ½), looked for coarse to
    /// fine — every 8th cell along each axis, then every 4th, 2nd and the rest, each cell once —
    /// and stopping at the first found: a solid mesh answers after a few hundred cells, a mesh
    /// with no inside after every cell (at most [`MAX_INSCRIBED_WORK`] solid angles).
    fn any_inside(&self, mesh: &Mesh) -> bool {
        let level = |i: usize| {
            let (nx, ny) = (self.dims.x as usize, self.dims.y as usize);
            let (x, y, z) = (i % nx, (i / nx) % ny, i / (nx * ny));
            let coarsest = [8usize, 4, 2]
                .into_iter()
                .find(|s| x % s == 0 && y % s == 0 && z % s == 0);
            coarsest.unwrap_or(1)
        };
        [8usize, 4, 2, 1].into_iter().any(|stride| {
            (0..self.cells())
                .into_par_iter()
                .filter(|&i| level(i) == stride)
                .any(|i| winding_number(mesh, self.centre(i)).abs() > 0.5)
        })
    }

    /// The cells whose centres are inside `mesh`, in order: the winding numbers in 64 slices of
    /// the cells, each in parallel, saying how far they are through [`progress`] (every 5 s of
    /// a fit that takes longer than that).
    fn inside_cells(&self, mesh: &Mesh) -> Vec<usize> {
        const SLICES: usize = 64;
        let (cells, t0) = (self.cells(), std::time::Instant::now());
        let mut last = t0;
        let mut inside = Vec::new();
        for s in 0..SLICES {
            let (a, b) = (cells * s / SLICES, cells * (s + 1) / SLICES);
            inside.extend(
                (a..b)
                    .into_par_iter()
                    .filter(|&i| winding_number(mesh, self.centre(i)).abs() > 0.5)
                    .collect::<Vec<_>>(),
            );
            if last.elapsed().as_secs_f64() >= 5.0 && s + 1 < SLICES {
                last = std::time::Instant::now();
                let done = b as f64 / cells as f64;
                let secs = t0.elapsed().as_secs_f64();
                progress(&format!(
                    "inscribed fit of {} ({} triangles): winding numbers {:.0} % of {:.2e} solid angles after {secs:.0} s, about {:.0} s to go",
                    mesh.name,
                    mesh.triangles.len(),
                    100.0 * done,
                    cells as f64 * mesh.triangles.len() as f64,
                    secs * (1.0 - done) / done
                ));
            }
        }
        inside
    }

    fn cells(&self) -> usize {
        (self.dims.x * self.dims.y * self.dims.z) as usize
    }

    fn centre(&self, i: usize) -> DVec3 {
        let (nx, ny) = (self.dims.x as usize, self.dims.y as usize);
        let (x, y, z) = (i % nx, (i / nx) % ny, i / (nx * ny));
        self.lo + self.h * DVec3::new(x as f64 + 0.5, y as f64 + 0.5, z as f64 + 0.5)
    }

    /// The inside cells whose centres the ball of inside cell `k` holds (`slot`: each cell's
    /// index into the inside cells, `u32::MAX` outside; `centres[k]`, `radius[k]`: the ball),
    /// each handed to `f` as its index into the inside cells. Nothing is stored: a solid's
    /// balls together hold ~0.9 R⁶ cells at R cells of radius (1.7·10⁸ for a ball at 48 cells,
    /// 0.7 GB as lists), so the greedy cover walks each ball's box when it needs it.
    fn ball_members(&self, slot: &[u32], c: DVec3, r: f64, f: &mut dyn FnMut(u32)) {
        let (nx, ny) = (self.dims.x as usize, self.dims.y as usize);
        let a = ((c - r - self.lo) / self.h)
            .floor()
            .max(DVec3::ZERO)
            .as_uvec3();
        let b = (((c + r - self.lo) / self.h).ceil().as_uvec3()).min(self.dims);
        // The cell centres as `centre` computes them (the same rounding), without its divisions.
        let at = |x: u32, y: u32, z: u32| {
            self.lo + self.h * DVec3::new(x as f64 + 0.5, y as f64 + 0.5, z as f64 + 0.5)
        };
        for z in a.z..b.z {
            for y in a.y..b.y {
                let row = nx * (y as usize + ny * z as usize);
                for x in a.x..b.x {
                    let k = slot[x as usize + row];
                    if k != u32::MAX && (at(x, y, z) - c).length() <= r {
                        f(k);
                    }
                }
            }
        }
    }
}

/// The members of set `k`, each handed to the callback.
type Members<'a> = dyn Fn(usize, &mut dyn FnMut(u32)) + Sync + 'a;

/// Up to `count` of `sets` sets over the elements `0..elements` (`members(k, f)` hands set
/// `k`'s elements to `f`) in the greedy order: each covering the most elements no earlier one
/// covered (ties to the lower index), stopping when nothing is left to cover. Lazy: a set's
/// gain only falls as others are chosen, so a popped set whose re-counted gain is still its heap
/// key is the best now.
fn greedy_cover(sets: usize, elements: usize, count: usize, members: &Members) -> Vec<usize> {
    let size = |k: usize, covered: &[bool]| {
        let mut n = 0;
        members(k, &mut |j| n += usize::from(!covered[j as usize]));
        n
    };
    let mut covered = vec![false; elements];
    let gains: Vec<usize> = (0..sets)
        .into_par_iter()
        .map(|k| size(k, &covered))
        .collect();
    let mut heap: BinaryHeap<(usize, std::cmp::Reverse<usize>)> = (gains.into_iter().enumerate())
        .map(|(k, g)| (g, std::cmp::Reverse(k)))
        .collect();
    let mut out = Vec::with_capacity(count);
    while out.len() < count {
        let Some((gain, std::cmp::Reverse(k))) = heap.pop() else {
            break;
        };
        if gain == 0 {
            break;
        }
        let now = size(k, &covered);
        if now < gain {
            heap.push((now, std::cmp::Reverse(k)));
            continue;
        }
        members(k, &mut |j| covered[j as usize] = true);
        out.push(k);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shapes;

    /// Winding numbers of a closed sphere mesh: 1 (or −1) inside, 0 outside, to the mesh's
    /// rounding; and a small triangle's solid angle seen from its normal's side: −area·h/|d|³
    /// (negative from the side its counter-clockwise normal faces, as a closed outward mesh's
    /// outside; the small-triangle limit, exact to (size/d)²).
    #[test]
    fn winding_numbers_and_solid_angles_against_closed_forms() {
        let s = shapes::uv_sphere(1.0, 24, 32);
        for (p, want) in [
            (DVec3::ZERO, 1.0),
            (DVec3::new(0.3, -0.2, 0.5), 1.0),
            (DVec3::new(1.5, 0.0, 0.0), 0.0),
            (DVec3::new(0.0, 0.0, -3.0), 0.0),
        ] {
            let w = winding_number(&s, p).abs();
            println!("winding number at {p}: {w:.2e} (want {want})");
            assert!((w - want).abs() < 1e-9, "{p}: {w}");
        }
        let tri = [
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(1e-3, 0.0, 0.0),
            DVec3::new(0.0, 1e-3, 0.0),
        ];
        let p = DVec3::new(0.0, 0.0, 1.0);
        let want = -0.5e-6;
        let got = solid_angle(p, tri);
        assert!((got - want).abs() < 1e-9, "{got:e} vs {want:e}");
        assert_eq!(solid_angle(DVec3::new(2.0, 2.0, 0.0), tri), 0.0);
    }

    /// A sphere mesh's first ball is (nearly) the sphere itself; every ball lies inside the
    /// solid (centre inside, radius its distance to the surface); and the sets are nested: the
    /// first S of 12 are the S asked for.
    #[test]
    fn balls_are_inscribed_nested_and_the_first_is_the_largest() {
        let s = shapes::uv_sphere(1.0, 24, 32);
        let all = inscribed_spheres(&s, 12, 16).unwrap();
        assert!(!all.is_empty());
        let first = all[0];
        println!(
            "first ball: centre {} radius {:.4}",
            first.center, first.radius
        );
        // The cell centre nearest the origin is (±h/2)³, h = 1/8, and the facets lie within
        // 1 − cos(π/24) ≈ 0.009 of the sphere: radius ≥ 1 − 0.009 − √3/16.
        assert!(
            first.radius > 0.88 && first.center.length() < 0.11,
            "{first:?}"
        );
        for b in &all {
            // Inside the unit ball up to the tessellation (its facets are within 0.01 of it).
            assert!(b.center.length() + b.radius <= 1.0 + 1e-9, "{b:?}");
            assert!(b.radius > 0.0);
        }
        for n in [1, 3, 7] {
            assert_eq!(
                inscribed_spheres(&s, n, 16).unwrap(),
                all[..n.min(all.len())]
            );
        }
    }

    /// The lazy greedy cover against the cover worked by hand: the largest set first, then the
    /// most new elements (ties to the lower index), a set adding nothing never chosen.
    #[test]
    fn greedy_cover_takes_the_most_new_elements_first() {
        let lists = |covers: &'static [&'static [u32]], count: usize| {
            let members = |k: usize, f: &mut dyn FnMut(u32)| covers[k].iter().for_each(|&j| f(j));
            greedy_cover(covers.len(), 5, count, &members)
        };
        let covers: &[&[u32]] = &[&[0, 1, 2], &[2, 3], &[3], &[4]];
        assert_eq!(lists(covers, 10), vec![0, 1, 3]);
        assert_eq!(lists(covers, 2), vec![0, 1]);
        assert!(lists(covers, 0).is_empty());
        assert!(lists(&[], 3).is_empty());
    }

    /// The lazy cover without stored lists against a brute-force greedy computed another way:
    /// each ball's members listed by testing every inside cell against it, every set re-scored
    /// at every step (no heap, no laziness), the largest gain first, ties to the lower index.
    #[test]
    fn the_fit_matches_a_brute_force_greedy_cover() {
        for (mesh, res) in [
            (crate::bundled::load("duck").unwrap(), 12),
            (shapes::box_block(DVec3::new(1.0, 0.6, 0.3), 3), 14),
        ] {
            let grid = Grid::of(&mesh, res).unwrap();
            let inside: Vec<usize> = (0..grid.cells())
                .filter(|&i| winding_number(&mesh, grid.centre(i)).abs() > 0.5)
                .collect();
            let radius: Vec<f64> = (inside.iter())
                .map(|&i| mesh_distance(&mesh.positions, &mesh.triangles, grid.centre(i)))
                .collect();
            let members: Vec<Vec<usize>> = (0..inside.len())
                .map(|k| {
                    let c = grid.centre(inside[k]);
                    (0..inside.len())
                        .filter(|&j| (grid.centre(inside[j]) - c).length() <= radius[k])
                        .collect()
                })
                .collect();
            let mut covered = vec![false; inside.len()];
            let mut want = Vec::new();
            while want.len() < 20 {
                let gain = |k: usize| members[k].iter().filter(|&&j| !covered[j]).count();
                let best = (0..inside.len()).max_by_key(|&k| (gain(k), std::cmp::Reverse(k)));
                match best {
                    Some(k) if gain(k) > 0 => {
                        members[k].iter().for_each(|&j| covered[j] = true);
                        want.push(Sphere {
                            center: grid.centre(inside[k]),
                            radius: radius[k],
                        });
                    }
                    _ => break,
                }
            }
            let got = inscribed_spheres(&mesh, 20, res).unwrap();
            println!(
                "{}: {} balls, the brute force {}",
                mesh.name,
                got.len(),
                want.len()
            );
            assert!(!got.is_empty());
            assert_eq!(got.len(), want.len());
            for (g, w) in got.iter().zip(&want) {
                assert_eq!((g.center, g.radius), (w.center, w.radius));
            }
        }
    }

    /// A mesh with no inside is refused before any fit, naming why, and never becomes an empty
    /// set: an open fan, a flat grid, one triangle, no triangle; a closed mesh passes
    /// with its work (cells × triangles) and the fit's estimate grows with it.
    #[test]
    fn a_mesh_without_inside_is_refused_and_a_solid_one_priced() {
        let tri = Mesh {
            name: "one triangle".into(),
            positions: vec![DVec3::ZERO, DVec3::X, DVec3::Y],
            triangles: vec![[0, 1, 2]],
        };
        let no_tris = Mesh {
            name: "empty".into(),
            positions: vec![DVec3::ZERO],
            triangles: vec![],
        };
        // An open, flat fan of four triangles (as the vocabulary's `plane`). (A raised centre
        // makes a tent whose inside sees it over more than a hemisphere: |w| > ½ there, an
        // inside by the rule's own robust reading.)
        let fan = Mesh {
            name: "fan".into(),
            positions: vec![
                DVec3::new(0.0, 0.0, 0.0),
                DVec3::new(-1.0, -1.0, 0.0),
                DVec3::new(1.0, -1.0, 0.0),
                DVec3::new(1.0, 1.0, 0.0),
                DVec3::new(-1.0, 1.0, 0.0),
            ],
            triangles: vec![[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 1]],
        };
        for m in [fan, shapes::plane(2.0, 1.0, 6, 3), tri, no_tris] {
            let e = inscribable(&m).unwrap_err().to_string();
            println!("{}: {e}", m.name);
            assert!(e.contains("inside"), "{}: {e}", m.name);
            if !m.triangles.is_empty() {
                let e = inscribed_set(&m, 4).unwrap_err().to_string();
                assert!(e.contains("no centre"), "{}: {e}", m.name);
            }
        }
        let small = inscribable(&shapes::uv_sphere(1.0, 8, 16)).unwrap();
        let large = inscribable(&shapes::uv_sphere(1.0, 32, 64)).unwrap();
        assert_eq!(
            small,
            inscribed_work(&shapes::uv_sphere(1.0, 8, 16)).unwrap()
        );
        println!("work {small:.3e} → {large:.3e}");
        assert!(
            large > 15.0 * small && inscribed_fit_seconds(large) > inscribed_fit_seconds(small)
        );
    }

    /// Edges: no balls asked, a flat mesh (no inside cell), res out of range, a box.
    #[test]
    fn edges_of_the_inscribed_fit() {
        let s = shapes::uv_sphere(1.0, 8, 8);
        assert!(inscribed_spheres(&s, 0, 8).unwrap().is_empty());
        for res in [0, 1, MAX_INSCRIBED_RES + 1] {
            let e = inscribed_spheres(&s, 4, res).unwrap_err().to_string();
            assert!(e.contains("res"), "{e}");
        }
        let flat = Mesh {
            name: "one triangle".into(),
            positions: vec![DVec3::ZERO, DVec3::X, DVec3::Y],
            triangles: vec![[0, 1, 2]],
        };
        assert!(inscribed_spheres(&flat, 4, 8).unwrap().is_empty());
        // Unbounded work refused by name: 128³ cells × a 37²-per-face box's 16k triangles.
        let big = shapes::box_block(DVec3::ONE, 37);
        let e = inscribed_spheres(&big, 4, MAX_INSCRIBED_RES)
            .unwrap_err()
            .to_string();
        assert!(e.contains("solid angles") && e.contains("limit"), "{e}");
        let b = shapes::box_block(DVec3::new(1.0, 0.5, 0.25), 4);
        let balls = inscribed_spheres(&b, 64, 16).unwrap();
        assert!(!balls.is_empty() && balls.len() <= 64);
        for ball in &balls {
            let c = ball.center.abs();
            assert!(c.x + ball.radius <= 1.0 + 1e-9 && c.z + ball.radius <= 0.25 + 1e-9);
        }
    }

    /// The property the fit exists for, on the knot (a closed mesh, 6,400 triangles): a ray
    /// from outside the bounding sphere that meets any ball must meet the mesh (every ball lies
    /// in the solid), so the union of the first S balls blocks a subset of what the mesh blocks,
    /// and of what the first S + 1 block (nesting) — checked on 6,000 rays at a coarse grid.
    #[test]
    fn a_ray_that_meets_a_ball_meets_the_mesh() {
        use crate::ray::{MeshBvh, Occluder, UpdateStrategy};
        let knot = crate::bundled::load("knot").unwrap();
        let balls = inscribed_spheres(&knot, 24, 20).unwrap();
        assert_eq!(balls.len(), 24);
        let bvh = MeshBvh::build(&knot, UpdateStrategy::Rebuild);
        let bs = knot.bounding_sphere();
        let meets = |b: &Sphere, o: DVec3, d: DVec3| {
            let oc = b.center - o;
            let t = oc.dot(d);
            t > 0.0 && (oc - t * d).length_squared() <= b.radius * b.radius
        };
        let (mut hits, mut bad, mut nested_bad) = (0, 0, 0);
        for i in 0..6000 {
            let a = i as f64 * 2.399963;
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / 6000.0;
            let s = (1.0 - z * z).sqrt();
            let o = bs.center + 1.5 * bs.radius * DVec3::new(s * a.cos(), s * a.sin(), z);
            // Aim at a point of the box, so most rays pass through the solid's region.
            let target = bs.center
                + 0.6 * bs.radius * DVec3::new((a * 3.7).sin(), (a * 1.3).cos(), (a * 0.7).sin());
            let d = (target - o).normalize();
            let upto = |n: usize| balls[..n].iter().any(|b| meets(b, o, d));
            if upto(24) {
                hits += 1;
                bad += usize::from(!bvh.occluded(o, d, 0.0, f64::INFINITY));
            }
            for n in 1..24 {
                nested_bad += usize::from(upto(n) && !upto(n + 1));
            }
        }
        println!("{hits} of 6000 rays meet a ball; {bad} of them miss the mesh");
        assert!(hits > 1000, "{hits}");
        assert_eq!((bad, nested_bad), (0, 0));
    }
}
