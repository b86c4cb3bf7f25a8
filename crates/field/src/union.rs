//! A sphere set's joint visibility projected exactly in φ, ring by ring — the union of the
//! spheres' caps, with no products and no rays.
//!
//! Seen from a point p, each sphere (centre c, radius R, d = |c − p| > R) blocks the cap
//! `ω · u ≥ cos A` about `u = (c − p)/d`, with `cos A = √((d − R)(d + R))/d`. On the ring of
//! directions at height z (`s = √(1 − z²)`), that cap is the φ-interval `|φ − φ_u| ≤ h` with
//! `cos h = (cos A − z z_u)/(s s_u)` (the whole ring when that is ≤ −1, nothing when > 1). The
//! union of S caps on a ring is the union of S intervals, merged exactly; and since every real
//! SH is `Θ_lm(z)·T_m(φ)` with `T_m` one of `1, cos mφ, sin mφ`, its integral over a union of
//! intervals is closed form. Only z is sampled, by Gauss–Legendre rings `(z_j, w_j)`:
//!
//! `V_lm = √(4π)δ_l0 − Σ_j w_j Θ_lm(z_j) ∫_{union on ring j} T_m(φ) dφ`.
//!
//! The rings are placed per point ([`RingGrid`]): in a frame whose x-axis is the caps'
//! radius-weighted mean direction (so no cap covers a pole, where a ring turning full would be
//! a kink; the result is rotated back by the Euler SH rotation), over the union's z-range, cut
//! into panels at every cap's z-extremes when they all fit, each panel mapped by
//! `z = mid − half·cos u` (a cap's extreme is a square-root edge of the integrand, smooth in u at
//! a panel's end). With one or two caps the error falls spectrally (1e-13 at 32 rings); with
//! many, the other caps' edges inside a panel leave it about `rings^-1.5` (docs/math.md, "The
//! union of the caps", measured in `tests/union.rs`).
//!
//! This is the same quantity the quadrature combination ([`crate::sphereset::
//! SphereSetQuadrature`]) estimates with `2n²` directions × S ray–sphere tests, with φ integrated
//! exactly instead of by `2n` uniform nodes. Cost per point: S caps' set-up, a square root per
//! (cap, ring it meets) — the intervals' ends are ordered by a pseudo-angle, no inverse
//! trigonometric call — a sort of each ring's few intervals, two `atan2` per merged interval
//! (its length), `N²` multiply-adds per ring met, and one SH rotation.
//!
//! Domain: any point and any spheres; radius ≤ 0 occludes nothing; a point inside a sphere of
//! positive radius sees nothing (0, as the product chain and the quadrature), one on its surface
//! sees the hemisphere it faces blocked; no sphere at all is the constant 1; coincident spheres
//! are one sphere (their intervals merge). `rings` ≥ 1; the order N ≥ 1 of the basis it is
//! built with.

use crate::evaluator::VisibilityField;
use glam::DVec3;
use shscale_geometry::Sphere;
use shscale_sh::legendre::{tri_index, Legendre};
use shscale_sh::rotation::EulerRotator;
use shscale_sh::ShBasis;
use std::cell::RefCell;
use std::f64::consts::{PI, TAU};

/// The z-rings of [`SphereSetUnion`]: Gauss–Legendre rules of up to `rings` nodes in
/// u ∈ [0, π], shared out per point among the panels of the union's z-range and mapped onto each
/// by `z = mid − half·cos u` (see the module's documentation), the Euler rotator that takes the
/// result back from the local frame, and the normalised Legendre tables of order N
/// (`Y_lm = Θ_lm(z) T_m(φ)`,
/// docs/conventions.md §1: `Θ_l0 = P̄_l^0`, `Θ_l±m = √2 P̄_l^m`, `T_m = cos mφ` for m > 0,
/// `sin |m|φ` for m < 0).
pub struct RingGrid {
    order: usize,
    rotator: EulerRotator<f64>,
    legendre: Legendre<f64>,
    rings: usize,
    /// Gauss–Legendre rules on [0, π] of 0..=rings nodes, ascending in u: `(cos u, w·sin u)`
    /// (the map's `z = mid − half·cos u`, `dz = half·sin u du`).
    rules: Vec<(Vec<f64>, Vec<f64>)>,
}

impl RingGrid {
    /// `rings` ≥ 1 rings for the order of `basis`.
    pub fn new(basis: &ShBasis<f64>, rings: usize) -> Self {
        assert!(rings >= 1, "a ring grid needs a ring");
        let order = basis.order();
        let rules = (0..=rings)
            .map(|k| {
                if k == 0 {
                    return (Vec::new(), Vec::new());
                }
                let mut nodes: Vec<(f64, f64)> =
                    shscale_sh::GaussLegendre::new(k).on(0.0, PI).collect();
                nodes.sort_by(|a, b| a.0.total_cmp(&b.0));
                (
                    nodes.iter().map(|n| n.0.cos()).collect(),
                    nodes.iter().map(|n| n.1 * n.0.sin()).collect(),
                )
            })
            .collect();
        Self {
            order,
            rotator: EulerRotator::new(order).expect("the basis's order is valid"),
            legendre: Legendre::new(order).expect("the basis's order is valid"),
            rings,
            rules,
        }
    }

    /// Rings in the grid.
    pub fn rings(&self) -> usize {
        self.rings
    }

    /// The order the grid projects to.
    pub fn order(&self) -> usize {
        self.order
    }

    /// The Gauss–Legendre rule of `k` ≤ [`Self::rings`] nodes on u ∈ [0, π], ascending in u, as
    /// `(cos u, w·sin u)` — what a panel of `k` rings maps by `z = mid − half·cos u` (the GPU's
    /// union reads its rules from here).
    pub fn rule(&self, k: usize) -> (&[f64], &[f64]) {
        let (c, w) = &self.rules[k];
        (c, w)
    }

    /// Bytes the grid holds.
    pub fn size_bytes(&self) -> usize {
        self.rings * (self.rings + 1) * 8
    }
}

/// One cap seen from a point: its axis (height `z_u`, `s_u = √(1 − z_u²)`, azimuth `φ_u` as
/// its sine and cosine and their pseudo-angle, [`pseudo_angle`]) and `cos A`.
#[derive(Clone, Copy)]
struct Cap {
    zu: f64,
    su: f64,
    /// `(sin φ_u, cos φ_u)`.
    sc_u: (f64, f64),
    /// The pseudo-angle of φ_u: the caps' order around the rings.
    key_u: f64,
    cos_a: f64,
    /// The cap's z-range, `[cos min(π, θ_u + A), cos max(0, θ_u − A)]`.
    z_lo: f64,
    z_hi: f64,
}

impl Cap {
    /// `None` when the sphere occludes nothing; `Err(())` when `p` is inside it (on its surface
    /// the cap is the hemisphere, A = 90°).
    fn seen(s: &Sphere, p: DVec3) -> Result<Option<Self>, ()> {
        if s.radius <= 0.0 {
            return Ok(None);
        }
        let oc = s.center - p;
        let d = oc.length();
        if d < s.radius {
            return Err(());
        }
        let u = oc / d;
        let cos_a = ((d - s.radius) * (d + s.radius)).sqrt() / d;
        let sin_a = (s.radius / d).min(1.0);
        let su = (u.x * u.x + u.y * u.y).sqrt();
        // cos(θ_u ∓ A) by the angle-sum formulas; the pole is inside the cap when θ_u ≤ A.
        let z_hi = if u.z >= cos_a {
            1.0
        } else {
            u.z * cos_a + su * sin_a
        };
        let z_lo = if -u.z >= cos_a {
            -1.0
        } else {
            u.z * cos_a - su * sin_a
        };
        let sc_u = if su > 0.0 {
            (u.y / su, u.x / su)
        } else {
            (0.0, 1.0)
        };
        Ok(Some(Self {
            zu: u.z,
            su,
            sc_u,
            key_u: pseudo_angle(sc_u.1, sc_u.0),
            cos_a,
            z_lo,
            z_hi,
        }))
    }

    /// The cap's φ-interval on the ring at height `z` (`s = √(1 − z²)`), pushed onto `bucket`
    /// as one or two pieces inside [0, 2π] ([`push_arc`]); nothing where the ring misses it. The
    /// ends' sines and cosines come from `cos h` and `sin h = √(1 − cos²h)` by the angle-sum
    /// formulas: no trigonometric call at all.
    fn on_ring(&self, z: f64, s: f64, bucket: &mut Vec<Arc>) {
        let ss = s * self.su;
        let num = self.cos_a - z * self.zu;
        if ss <= 1e-300 {
            if num <= 0.0 {
                bucket.push(FULL_RING);
            }
            return;
        }
        let c = num / ss;
        if c <= -1.0 {
            bucket.push(FULL_RING);
        } else if c < 1.0 {
            let sh = ((1.0 - c) * (1.0 + c)).sqrt();
            let (sp, cp) = self.sc_u;
            let lo = End::of(cp * c + sp * sh, sp * c - cp * sh);
            let hi = End::of(cp * c - sp * sh, sp * c + cp * sh);
            push_arc(bucket, lo, hi, c);
        }
    }
}

/// A monotone stand-in for the angle of the unit vector `(x, y)` = `(cos φ, sin φ)`, φ in
/// [0, 2π) → [0, 4) (the "diamond angle": one unit per quadrant, `y/(x + y)` in the first, so
/// opposite directions are exactly 2 apart): it orders directions as their angles do, its slope
/// between 1/2 and 1 per radian — bounded away from zero, so directions a rounding apart stay a
/// rounding apart — with no inverse trigonometric call.
fn pseudo_angle(x: f64, y: f64) -> f64 {
    // r = |y| / (|x| + |y|) is the first quadrant's key reflected into every quadrant: the key
    // is r, 2 − r, 2 + r, 4 − r in quadrants 1–4, picked by selects (no branch to mispredict
    // on the directions' random quadrants); opposite directions share r, so they are exactly 2
    // apart.
    let (ax, ay) = (x.abs(), y.abs());
    let r = ay / (ax + ay);
    let k = if x < 0.0 { 2.0 - r } else { r };
    if y < 0.0 {
        4.0 - k
    } else {
        k
    }
}

/// An end of a φ-interval: its direction's sine and cosine and their pseudo-angle (the sort
/// key; 4 for the end of the turn, 2π).
#[derive(Clone, Copy, Debug, PartialEq)]
struct End {
    key: f64,
    sin: f64,
    cos: f64,
}

impl End {
    /// The end at direction `(cos, sin)`.
    fn of(cos: f64, sin: f64) -> Self {
        Self {
            key: pseudo_angle(cos, sin),
            sin,
            cos,
        }
    }

    #[cfg(test)]
    fn at(angle: f64) -> Self {
        let (sin, cos) = angle.sin_cos();
        Self::of(cos, sin)
    }

    /// Its angle in [0, 2π] (one `atan2`; the turn's end is 2π).
    #[cfg(test)]
    fn angle(self) -> f64 {
        if self.key >= 4.0 {
            return TAU;
        }
        let a = self.sin.atan2(self.cos);
        if a < 0.0 {
            a + TAU
        } else {
            a
        }
    }
}

/// A piece of a ring: its ends, and the cosine of its half-width when it is one cap's whole
/// interval (its length is then `2·acos`), NaN for a piece cut at φ = 0.
type Arc = (End, End, f64);

/// The whole ring: from φ = 0 to the turn's end (half-width π).
const FULL_RING: Arc = (
    End {
        key: 0.0,
        sin: 0.0,
        cos: 1.0,
    },
    End {
        key: 4.0,
        sin: 0.0,
        cos: 1.0,
    },
    -1.0,
);

/// A sphere set combined as the exact union of its caps (see the module's documentation).
pub struct SphereSetUnion<'a> {
    spheres: Vec<Sphere>,
    grid: &'a RingGrid,
}

impl<'a> SphereSetUnion<'a> {
    /// Any number of spheres (none: the constant 1).
    pub fn new(spheres: &[Sphere], grid: &'a RingGrid) -> Self {
        Self {
            spheres: spheres.to_vec(),
            grid,
        }
    }

    /// Bytes a frame's set holds (centre and radius per sphere).
    pub fn size_bytes(&self) -> usize {
        self.spheres.len() * 32
    }
}

/// The arc from `lo` counter-clockwise to `hi` (half-width h, `c = cos h` in (−1, 1)) onto
/// `bucket`, split at φ = 0 where it crosses it, by the ends' key difference `d` ([`pseudo_angle`]:
/// an arc of exactly π spans 2, the turn 4). An arc narrower than π (c > 0) spans d in (0, 2)
/// when whole and d − 4 in (−4, −2) when it crosses; rounding moves d by a few ulps, so the
/// split is read with slack: it crosses when d < −1, is whole when 0 ≤ d < 3 (an arc a hair
/// under π whose keys rounded to d ≥ 2 is kept), and any other d is a rounding reversal of a
/// near-empty arc — d just under 0, or just under 4 at the seam φ = 0, where it would read as a
/// near-full one — and is dropped. An arc of π or more crosses when `lo` sorts after `hi` at
/// all (its ends are at least ~1e-8 apart: `c` within an ulp of −1 is √(2·2⁻⁵³) from it).
fn push_arc(bucket: &mut Vec<Arc>, lo: End, hi: End, c: f64) {
    let d = hi.key - lo.key;
    let (crosses, whole) = if c > 0.0 {
        (d < -1.0, (0.0..3.0).contains(&d))
    } else {
        (d < 0.0, d >= 0.0)
    };
    if crosses {
        bucket.push((lo, FULL_RING.1, f64::NAN));
        bucket.push((FULL_RING.0, hi, f64::NAN));
    } else if whole {
        bucket.push((lo, hi, c));
    }
}

/// The length of the arc from `a` counter-clockwise to `b` (`b` at or after `a`, no crossing of
/// φ = 0 — the turn's end may be `b`): one `atan2` of the ends' cross and dot products, in
/// (−π, π], lifted by 2π when the keys say the arc is π or longer ([`pseudo_angle`]: an arc of π
/// spans 2) and clamped at 0 when a rounding made a near-empty one negative.
fn arc_length(a: End, b: End) -> f64 {
    let len = (a.cos * b.sin - a.sin * b.cos).atan2(a.cos * b.cos + a.sin * b.sin);
    if b.key - a.key >= 2.0 {
        if len <= 0.0 {
            len + TAU
        } else {
            len
        }
    } else {
        len.max(0.0)
    }
}

/// A run's length: `2·acos(c)` for one cap's whole interval (c its half-width's cosine), else
/// [`arc_length`] of its ends.
fn run_length(a: End, b: End, c: f64) -> f64 {
    if c.is_nan() {
        arc_length(a, b)
    } else {
        2.0 * c.acos()
    }
}

/// Sorts a ring's intervals by their starts' keys: an insertion sort, since they arrive nearly
/// sorted (the caps in azimuth order) and few.
fn sort_by_start(bucket: &mut [Arc]) {
    for i in 1..bucket.len() {
        let x = bucket[i];
        let mut j = i;
        while j > 0 && bucket[j - 1].0.key > x.0.key {
            bucket[j] = bucket[j - 1];
            j -= 1;
        }
        bucket[j] = x;
    }
}

/// Adds `∫ T_m` over `[a, b]` (of length `len`) for m = 0..n to `c` (cos mφ, `c[0]` the
/// length) and `s` (sin mφ).
fn add_trig_integrals(a: End, b: End, len: f64, c: &mut [f64], s: &mut [f64]) {
    c[0] += len;
    let n = c.len();
    if n < 2 {
        return;
    }
    let (sa, ca, sb, cb) = (a.sin, a.cos, b.sin, b.cos);
    // sin(mx), cos(mx) by the Chebyshev recurrence from m − 1 and m − 2.
    let (mut sa0, mut ca0, mut sa1, mut ca1) = (0.0, 1.0, sa, ca);
    let (mut sb0, mut cb0, mut sb1, mut cb1) = (0.0, 1.0, sb, cb);
    for m in 1..n {
        let mf = m as f64;
        c[m] += (sb1 - sa1) / mf;
        s[m] += (ca1 - cb1) / mf;
        let (sa2, ca2) = (2.0 * ca * sa1 - sa0, 2.0 * ca * ca1 - ca0);
        let (sb2, cb2) = (2.0 * cb * sb1 - sb0, 2.0 * cb * cb1 - cb0);
        (sa0, ca0, sa1, ca1) = (sa1, ca1, sa2, ca2);
        (sb0, cb0, sb1, cb1) = (sb1, cb1, sb2, cb2);
    }
}

impl VisibilityField for SphereSetUnion<'_> {
    /// `out`: N² coefficients, N at most the grid's order.
    fn eval(&self, p: DVec3, out: &mut [f64]) {
        let g = self.grid;
        let nn = g.order * g.order;
        assert!(out.len() <= nn, "coefficients beyond the grid's order");
        out.iter_mut().for_each(|o| *o = 0.0);
        // The local frame: its x-axis along the caps' mean direction, so the union sits about
        // the equator, away from the poles, and its rings are short.
        let axis = (self.spheres.iter())
            .filter(|s| s.radius > 0.0)
            .map(|s| (s.center - p).normalize_or_zero() * s.radius)
            .sum::<DVec3>()
            .try_normalize()
            .unwrap_or(DVec3::X);
        // The x-axis opposite the mean direction: the union sits about φ = π, away from the
        // seam φ = 0 where a cap's interval would be cut in two (and lose its 2·acos length).
        let e2 = axis.any_orthonormal_vector();
        let b = [-axis, -e2, axis.cross(e2)];
        SCRATCH.with(|cell| {
            let scratch = &mut *cell.borrow_mut();
            scratch.caps.clear();
            for s in &self.spheres {
                let oc = s.center - p;
                let local = Sphere {
                    center: DVec3::new(b[0].dot(oc), b[1].dot(oc), b[2].dot(oc)),
                    radius: s.radius,
                };
                match Cap::seen(&local, DVec3::ZERO) {
                    Err(()) => return, // inside a sphere: nothing is visible
                    Ok(Some(c)) => scratch.caps.push(c),
                    Ok(None) => {}
                }
            }
            // Caps in azimuth order: each ring's intervals then arrive nearly sorted by their
            // starts (they differ by the half-widths only), which the sort below finishes fast.
            let Scratch {
                caps,
                sorted,
                order,
                ..
            } = scratch;
            sort_by_azimuth(caps, sorted, order);
            let mut local = std::mem::take(&mut scratch.local);
            local.clear();
            local.resize(nn, 0.0);
            local[0] = (4.0 * PI).sqrt();
            if !scratch.caps.is_empty() {
                subtract_union(g, scratch, &mut local);
            }
            // f(ω) = f_local(Bω): the active rotation by Bᵀ.
            let bt = [0, 1, 2].map(|i| [b[0][i], b[1][i], b[2][i]]);
            let mut world = std::mem::take(&mut scratch.world);
            world.clear();
            world.resize(nn, 0.0);
            (g.rotator.apply(&bt, &local, &mut world)).expect("the grid's order");
            out.copy_from_slice(&world[..out.len()]);
            scratch.local = local;
            scratch.world = world;
        });
    }
}

/// What one evaluation reuses: the caps seen, the rings' heights and radii, and per ring the
/// intervals of the caps that meet it.
#[derive(Default)]
struct Scratch {
    caps: Vec<Cap>,
    sorted: Vec<Cap>,
    order: Vec<u64>,
    local: Vec<f64>,
    world: Vec<f64>,
    z: Vec<f64>,
    w: Vec<f64>,
    s: Vec<f64>,
    buckets: Vec<Vec<Arc>>,
    cm: Vec<f64>,
    sm: Vec<f64>,
    leg: Vec<f64>,
}

thread_local! {
    static SCRATCH: RefCell<Scratch> = RefCell::new(Scratch::default());
}

/// Sorts `caps` by their azimuths' pseudo-angles. The keys, in [0, 4), are positive, so their
/// bits sort as they do; each is packed with its cap's index in the low 16 bits of its mantissa
/// (an order within 2⁻³⁶ of the key's value, which only guides the rings' insertion sorts) and
/// the `u64`s sorted, which measured faster than sorting the caps themselves. More than 2¹⁶ caps
/// are sorted directly.
fn sort_by_azimuth(caps: &mut Vec<Cap>, sorted: &mut Vec<Cap>, order: &mut Vec<u64>) {
    const BITS: u32 = 16;
    if caps.len() > 1 << BITS {
        caps.sort_unstable_by(|a, b| a.key_u.total_cmp(&b.key_u));
        return;
    }
    let mask = (1u64 << BITS) - 1;
    order.clear();
    order.extend((caps.iter().enumerate()).map(|(i, c)| (c.key_u.to_bits() & !mask) | i as u64));
    order.sort_unstable();
    sorted.clear();
    sorted.extend(order.iter().map(|k| caps[(k & mask) as usize]));
    std::mem::swap(caps, sorted);
}

/// The fewest rings per panel.
pub const PANEL_RINGS: usize = 4;

/// The rings (heights `z`, ascending, and weights `w` in z) for `caps`: their z-range
/// `[z₀, z₁]`, cut into panels at every cap's z-extremes (each a square-root edge of the
/// integrand) when they all fit in `rings / PANEL_RINGS` panels, else one panel; each panel
/// with its share of the rings mapped by `z = mid − half·cos u` (which makes an edge at a
/// panel's end smooth in u).
fn rings_of(g: &RingGrid, caps: &[Cap], z: &mut Vec<f64>, w: &mut Vec<f64>) {
    let z0 = caps.iter().map(|c| c.z_lo).fold(f64::INFINITY, f64::min);
    let z1 = caps
        .iter()
        .map(|c| c.z_hi)
        .fold(f64::NEG_INFINITY, f64::max);
    let panels_max = (g.rings / PANEL_RINGS).max(1);
    // The distinct edges (within 1e-12) inside the range, gathered until they no longer fit:
    // with many caps the search stops at the ninth, not after sorting all 2S of them.
    let mut cuts: Vec<f64> = Vec::with_capacity(panels_max);
    let inside = (caps.iter())
        .flat_map(|c| [c.z_lo, c.z_hi])
        .filter(|e| *e > z0 && *e < z1);
    for e in inside {
        if cuts.iter().any(|x| (x - e).abs() <= 1e-12) {
            continue;
        }
        if cuts.len() + 2 > panels_max {
            // Too many edges to cut at them all: one panel (cutting at some of them measured
            // worse than none, 2–3× at S = 32–64 and 32 rings).
            cuts.clear();
            break;
        }
        cuts.push(e);
    }
    cuts.sort_unstable_by(f64::total_cmp);
    let edges: Vec<f64> = std::iter::once(z0)
        .chain(cuts)
        .chain(std::iter::once(z1))
        .collect();
    let panels = edges.len() - 1;
    z.clear();
    w.clear();
    for (i, pair) in edges.windows(2).enumerate() {
        // The rings shared out as evenly as they go, the first panels taking the remainder.
        let k = g.rings / panels + usize::from(i < g.rings % panels);
        let (mid, half) = ((pair[0] + pair[1]) / 2.0, (pair[1] - pair[0]) / 2.0);
        let (cos_u, w_sin_u) = &g.rules[k];
        for (c, ws) in cos_u.iter().zip(w_sin_u) {
            z.push(mid - half * c);
            w.push(ws * half);
        }
    }
}

/// Subtracts from `out` (the grid's N² coefficients) the projection of the union of
/// `scratch.caps`.
fn subtract_union(g: &RingGrid, scratch: &mut Scratch, out: &mut [f64]) {
    let n = g.order;
    let Scratch {
        caps,
        sorted: _,
        order: _,
        local: _,
        world: _,
        z,
        w,
        s,
        buckets,
        cm,
        sm,
        leg,
    } = scratch;
    rings_of(g, caps, z, w);
    s.clear();
    s.extend(z.iter().map(|z| ((1.0 - z) * (1.0 + z)).max(0.0).sqrt()));
    buckets.resize_with(z.len(), Vec::new);
    buckets.iter_mut().for_each(Vec::clear);
    for cap in caps.iter() {
        let first = z.partition_point(|x| *x < cap.z_lo);
        let last = z.partition_point(|x| *x <= cap.z_hi);
        for j in first..last {
            cap.on_ring(z[j], s[j], &mut buckets[j]);
        }
    }
    cm.resize(n, 0.0);
    sm.resize(n, 0.0);
    leg.resize(g.order * (g.order + 1) / 2, 0.0);
    for (j, bucket) in buckets.iter_mut().enumerate() {
        if bucket.is_empty() {
            continue;
        }
        sort_by_start(bucket);
        cm.iter_mut().for_each(|x| *x = 0.0);
        sm.iter_mut().for_each(|x| *x = 0.0);
        // Runs of overlapping pieces; a run that stayed one cap's whole interval (others at most
        // inside it) has the length 2·acos(cos h), any other one its ends' arc_length.
        let (mut a, mut b, mut c1) = bucket[0];
        for &(lo, hi, c) in &bucket[1..] {
            if lo.key <= b.key {
                if hi.key > b.key {
                    b = hi;
                    c1 = f64::NAN;
                }
            } else {
                add_trig_integrals(a, b, run_length(a, b, c1), cm, sm);
                (a, b, c1) = (lo, hi, c);
            }
        }
        add_trig_integrals(a, b, run_length(a, b, c1), cm, sm);
        g.legendre.eval(z[j], s[j], leg);
        let w = w[j];
        let w2 = w * std::f64::consts::SQRT_2;
        for l in 0..n {
            let base = l * l + l;
            out[base] -= w * leg[tri_index(l, 0)] * cm[0];
            for m in 1..=l {
                let t = w2 * leg[tri_index(l, m)];
                out[base + m] -= t * cm[m];
                out[base - m] -= t * sm[m];
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn trig_integrals_match_their_closed_forms() {
        let (a, b) = (0.3, 2.9);
        let (mut c, mut s) = (vec![0.0; 6], vec![0.0; 6]);
        add_trig_integrals(End::at(a), End::at(b), b - a, &mut c, &mut s);
        assert!((c[0] - (b - a)).abs() < 1e-15);
        for m in 1..6 {
            let mf = m as f64;
            let wc = ((mf * b).sin() - (mf * a).sin()) / mf;
            let ws = ((mf * a).cos() - (mf * b).cos()) / mf;
            assert!(
                (c[m] - wc).abs() < 1e-13 && (s[m] - ws).abs() < 1e-13,
                "m {m}"
            );
        }
    }

    /// The ends' sines and cosines by the angle-sum formulas agree with the angles' own, and
    /// their angles are φ_u ∓ h.
    #[test]
    fn interval_ends_carry_their_sines_and_cosines() {
        let p = DVec3::new(0.1, -0.2, 0.3);
        let s = Sphere {
            center: DVec3::new(1.5, 1.0, 0.8),
            radius: 0.6,
        };
        let cap = Cap::seen(&s, p).unwrap().unwrap();
        let z = (cap.z_lo + cap.z_hi) / 2.0;
        let sz = (1.0 - z * z).sqrt();
        let mut b = Vec::new();
        cap.on_ring(z, sz, &mut b);
        assert_eq!(b.len(), 1);
        let phi_u = cap.sc_u.0.atan2(cap.sc_u.1).rem_euclid(TAU);
        let h = ((cap.cos_a - z * cap.zu) / (sz * cap.su)).acos();
        for (e, want) in [(b[0].0, phi_u - h), (b[0].1, phi_u + h)] {
            let w = End::at(want);
            assert!((e.sin - w.sin).abs() < 1e-14 && (e.cos - w.cos).abs() < 1e-14);
            assert!((e.angle() - want.rem_euclid(TAU)).abs() < 1e-14);
        }
    }

    /// The pseudo-angle orders directions as their angles, opposite ones exactly 2 apart.
    #[test]
    fn the_pseudo_angle_is_monotone_in_the_angle() {
        let mut last = -1.0;
        for i in 0..4096 {
            let a = TAU * i as f64 / 4096.0;
            let k = End::at(a).key;
            assert!(k > last && (0.0..4.0).contains(&k), "{a}: {k} after {last}");
            last = k;
            let opposite = End::at(a + PI).key;
            assert!(((opposite - k).rem_euclid(4.0) - 2.0).abs() < 1e-12);
        }
        assert_eq!(End::at(0.0).key, 0.0);
        assert_eq!(End::at(0.0).angle(), 0.0);
        assert_eq!(FULL_RING.1.angle(), TAU);
    }

    #[test]
    fn caps_sort_by_azimuth_through_packed_keys_as_by_their_keys() {
        // Caps of spheres all round the origin (keys over [0, 4)), some sharing an azimuth
        // (keys equal or a rounding apart): the packed sort leaves the keys in order to the
        // packing's 2⁻³⁶ of a key and keeps every cap once.
        let mut caps: Vec<Cap> = (0..300)
            .map(|i| {
                let a = TAU * ((i * 37) % 100) as f64 / 100.0;
                let z = ((i % 7) as f64 - 3.0) / 4.0;
                let sphere = Sphere {
                    center: DVec3::new(3.0 * a.cos(), 3.0 * a.sin(), z),
                    radius: 0.1 + (i % 5) as f64 / 10.0,
                };
                Cap::seen(&sphere, DVec3::ZERO).unwrap().unwrap()
            })
            .collect();
        let mut want: Vec<(f64, f64)> = caps.iter().map(|c| (c.key_u, c.cos_a)).collect();
        want.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
        let (mut sorted, mut order) = (Vec::new(), Vec::new());
        sort_by_azimuth(&mut caps, &mut sorted, &mut order);
        let slack = 2f64.powi(-36);
        for w in caps.windows(2) {
            assert!(
                w[0].key_u <= w[1].key_u * (1.0 + slack),
                "{} after {}",
                w[1].key_u,
                w[0].key_u
            );
        }
        let mut got: Vec<(f64, f64)> = caps.iter().map(|c| (c.key_u, c.cos_a)).collect();
        got.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
        assert_eq!(got, want);
        // Beyond 2¹⁶ caps (no room for the index) the caps are sorted directly.
        let mut many = caps.repeat(230);
        many.reverse();
        sort_by_azimuth(&mut many, &mut sorted, &mut order);
        assert_eq!(many.len(), 69_000);
        assert!(many.windows(2).all(|w| w[0].key_u <= w[1].key_u));
    }

    /// An arc across φ = 0 splits there; one just off it does not; an arc reversed by rounding
    /// alone is dropped, not taken for a near-full ring; a wide arc across 0 splits however
    /// close its ends.
    #[test]
    fn arcs_split_where_they_cross_zero() {
        let mut b = Vec::new();
        push_arc(&mut b, End::at(-0.5), End::at(0.5), 0.5f64.cos());
        assert_eq!(b.len(), 2);
        assert!((b[0].0.angle() - (TAU - 0.5)).abs() < 1e-15 && b[0].1.angle() == TAU);
        assert!(b[1].0.angle() == 0.0 && (b[1].1.angle() - 0.5).abs() < 1e-15);
        let (mut c, mut s) = (vec![0.0; 3], vec![0.0; 3]);
        for &(lo, hi, h) in &b {
            add_trig_integrals(lo, hi, run_length(lo, hi, h), &mut c, &mut s);
        }
        assert!((c[0] - 1.0).abs() < 1e-15, "length {}", c[0]);
        b.clear();
        push_arc(&mut b, End::at(0.1), End::at(0.3), 0.1f64.cos());
        assert_eq!((b.len(), b[0].0, b[0].1), (1, End::at(0.1), End::at(0.3)));
        assert!((run_length(b[0].0, b[0].1, b[0].2) - 0.2).abs() < 1e-14);
        b.clear();
        // Near-empty arcs whose ends came out in reverse order: at the seam φ = 0 (where the
        // reversal reads as a near-full arc) and elsewhere.
        push_arc(
            &mut b,
            End::of(1.0, 1e-17),
            End::of(1.0, -1e-17),
            1.0 - 1e-34,
        );
        push_arc(&mut b, End::at(1.0 + 1e-15), End::at(1.0), 1.0 - 1e-30);
        let (mut c, mut s) = (vec![0.0; 1], vec![0.0; 1]);
        for &(lo, hi, h) in &b {
            add_trig_integrals(lo, hi, run_length(lo, hi, h), &mut c, &mut s);
        }
        assert!(c[0] < 1e-12, "a near-empty arc became {}", c[0]);
        b.clear();
        // A near-full arc across 0 (h just under π): its ends nearly meet at π.
        let h = PI - 1e-9;
        push_arc(&mut b, End::at(-h), End::at(h), h.cos());
        let (mut c, mut s) = (vec![0.0; 1], vec![0.0; 1]);
        for &(lo, hi, h) in &b {
            add_trig_integrals(lo, hi, run_length(lo, hi, h), &mut c, &mut s);
        }
        assert!((c[0] - 2.0 * h).abs() < 1e-12, "{}", c[0]);
        // Arcs a hair under π (c a rounding above 0) whose keys span 2 or a few ulps over: kept
        // whole (away from the seam) or split (across it), never dropped.
        for (lo, hi) in [
            (End::of(0.0, 1.0), End::of(-1e-17, -1.0)),
            (End::of(0.0, 1.0), End::of(1e-17, -1.0)),
            (End::of(-1.0, 1e-17), End::of(1.0, -1e-17)),
            (End::of(0.0, -1.0), End::of(1e-17, 1.0)),
        ] {
            b.clear();
            let c_h = 1e-17;
            push_arc(&mut b, lo, hi, c_h);
            let (mut c, mut s) = (vec![0.0; 1], vec![0.0; 1]);
            for &(lo, hi, h) in &b {
                add_trig_integrals(lo, hi, run_length(lo, hi, h), &mut c, &mut s);
            }
            println!("key span {}: length {}", hi.key - lo.key, c[0]);
            assert!((c[0] - PI).abs() < 1e-12, "a half ring became {}", c[0]);
        }
    }
}
