// Sphere sets combined as the exact union of their caps on the GPU (Ren et al. 2006's occluder
// model, `sphere_combine = "union"`): one invocation per receiver, the twin of the CPU's
// `SphereSetUnion` (crates/field/src/union.rs, docs/math.md "The union of the caps") in f32.
// In a local frame whose x-axis is opposite the caps' radius-weighted mean direction, each cap is
// a φ-interval on every z-ring it meets; a ring's intervals are ordered by their starts'
// pseudo-angles, merged, and every real SH's φ-integral over the merged runs is closed form; the
// rings are Gauss–Legendre in the cosine map over the union's z-range, cut into panels at the
// caps' z-extremes when they all fit. The shading is ⟨T_local, V_local⟩: the light's transfer
// taken into the local frame by an exact quadrature (N Gauss–Legendre nodes in z × 2N − 1
// uniform in φ integrate every product of two order-N harmonics exactly), so no SH rotation is
// needed. A receiver inside a sphere sees nothing; no sphere, or only spheres of radius 0, is the
// unshadowed √(4π)·T₀₀.
//
// `rules`: the ring rules (cos u, w·sin u) of k = 1..rings nodes at offset k(k − 1)/2, then the
// N-node Gauss–Legendre rule in z (z, w) at offset rings(rings + 1)/2.

@group(0) @binding(0) var<uniform> params: GpuSetParams;
@group(0) @binding(1) var<storage, read> points: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> spheres: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> rules: array<vec2<f32>>;
@group(0) @binding(4) var<storage, read> transfer: array<f32>;
@group(0) @binding(5) var<storage, read> knorm: array<f32>;
@group(0) @binding(6) var<storage, read_write> image: array<vec4<f32>>;

const U_PI: f32 = 3.14159265358979;
const U_TAU: f32 = 6.28318530717959;
const U_SQRT_FOUR_PI: f32 = 3.5449077018110318;
const U_SQRT_2: f32 = 1.4142135623730951;
// "Not one cap's whole interval": a run whose length is its ends' arc, not 2·acos(c).
const CUT: f32 = 2.0;
const MAX_RINGS: u32 = 32u;

// A cap seen from the receiver (the local frame): axis height, its √(1 − z²), azimuth's sine,
// cosine and pseudo-angle, cos A, z-range.
struct UCap {
    zu: f32,
    su: f32,
    sp: f32,
    cp: f32,
    key: f32,
    cos_a: f32,
    lo: f32,
    hi: f32,
};
// An end of a piece of a ring: its pseudo-angle, sine and cosine.
struct End {
    k: f32,
    s: f32,
    c: f32,
};
// A piece of a ring from a to b, with the cosine of its half-width (or CUT).
struct Piece {
    a: End,
    b: End,
    c: f32,
};
var<private> caps: array<UCap, 64>;
// One ring's pieces.
var<private> pieces: array<Piece, 128>;
var<private> arcs: u32;
var<private> ring_z: array<f32, 32>;
var<private> ring_w: array<f32, 32>;
var<private> cm: array<f32, 8>;
var<private> sm: array<f32, 8>;

// The diamond angle of (x, y): r, 2 − r, 2 + r, 4 − r in quadrants 1–4, r = |y| / (|x| + |y|).
fn pseudo_angle(x: f32, y: f32) -> f32 {
    let r = abs(y) / (abs(x) + abs(y));
    var k = r;
    if (x < 0.0) {
        k = 2.0 - r;
    }
    if (y < 0.0) {
        k = 4.0 - k;
    }
    return k;
}

// The start and the end of the turn (φ = 0 and 2π).
const TURN_START: End = End(0.0, 0.0, 1.0);
const TURN_END: End = End(4.0, 0.0, 1.0);

fn push(a: End, b: End, c: f32) {
    pieces[arcs] = Piece(a, b, c);
    arcs++;
}

// Cap `q`'s interval on the ring at height z (s = √(1 − z²)), split at φ = 0 where it crosses it;
// a rounding reversal of a near-empty interval is dropped (the CPU's `push_arc`).
fn on_ring(q: u32, z: f32, s: f32) {
    let cap = caps[q];
    let ss = s * cap.su;
    let num = cap.cos_a - z * cap.zu;
    if (ss <= 1e-30) {
        if (num <= 0.0) {
            push(TURN_START, TURN_END, -1.0);
        }
        return;
    }
    let c = num / ss;
    if (c <= -1.0) {
        push(TURN_START, TURN_END, -1.0);
        return;
    }
    if (c >= 1.0) {
        return;
    }
    let sh = sqrt((1.0 - c) * (1.0 + c));
    let sp = cap.sp;
    let cp = cap.cp;
    let lc = cp * c + sp * sh;
    let ls = sp * c - cp * sh;
    let hc = cp * c - sp * sh;
    let hs = sp * c + cp * sh;
    let lo = End(pseudo_angle(lc, ls), ls, lc);
    let hi = End(pseudo_angle(hc, hs), hs, hc);
    let d = hi.k - lo.k;
    var crosses = d < 0.0;
    var whole = d >= 0.0;
    if (c > 0.0) {
        crosses = d < -1.0;
        whole = d >= 0.0 && d < 3.0;
    }
    if (crosses) {
        push(lo, TURN_END, CUT);
        push(TURN_START, hi, CUT);
    } else if (whole) {
        push(lo, hi, c);
    }
}

// The length of the run from a to b (counter-clockwise, no crossing of φ = 0): 2·acos(c) for one
// cap's whole interval, else one atan2 of the ends, lifted by 2π for a run of π or more.
fn run_length(a: End, b: End, c: f32) -> f32 {
    if (c != CUT) {
        return 2.0 * acos(clamp(c, -1.0, 1.0));
    }
    let len = atan2(a.c * b.s - a.s * b.c, a.c * b.c + a.s * b.s);
    if (b.k - a.k >= 2.0) {
        if (len <= 0.0) {
            return len + U_TAU;
        }
        return len;
    }
    return max(len, 0.0);
}

// ∫ T_m over [a, b] added to cm (cos mφ; cm[0] the length) and sm (sin mφ), m < n.
fn add_trig(a: End, b: End, len: f32, n: u32) {
    let ac = a.c;
    let bc = b.c;
    cm[0] += len;
    var sa0 = 0.0;
    var ca0 = 1.0;
    var sa1 = a.s;
    var ca1 = ac;
    var sb0 = 0.0;
    var cb0 = 1.0;
    var sb1 = b.s;
    var cb1 = bc;
    for (var m = 1u; m < n; m++) {
        let mf = f32(m);
        cm[m] += (sb1 - sa1) / mf;
        sm[m] += (ca1 - cb1) / mf;
        let sa2 = 2.0 * ac * sa1 - sa0;
        let ca2 = 2.0 * ac * ca1 - ca0;
        let sb2 = 2.0 * bc * sb1 - sb0;
        let cb2 = 2.0 * bc * cb1 - cb0;
        sa0 = sa1;
        ca0 = ca1;
        sa1 = sa2;
        ca1 = ca2;
        sb0 = sb1;
        cb0 = cb1;
        sb1 = sb2;
        cb1 = cb2;
    }
}

// The rings for the `count` caps (the CPU's `rings_of`): their z-range cut into panels at every
// cap's z-extreme when they all fit in rings / panel_rings panels, else one panel; returns the
// number of rings.
fn rings_of(count: u32) -> u32 {
    var z0 = 1e30;
    var z1 = -1e30;
    for (var q = 0u; q < count; q++) {
        z0 = min(z0, caps[q].lo);
        z1 = max(z1, caps[q].hi);
    }
    let panels_max = max(params.rings / params.panel_rings, 1u);
    var cuts: array<f32, 34>;
    var n_cuts = 0u;
    var fits = true;
    for (var e = 0u; e < 2u * count && fits; e++) {
        var x = caps[e / 2u].lo;
        if (e % 2u == 1u) {
            x = caps[e / 2u].hi;
        }
        if (!(x > z0 && x < z1)) {
            continue;
        }
        var seen = false;
        for (var i = 0u; i < n_cuts; i++) {
            if (abs(cuts[i] - x) <= 1e-6) {
                seen = true;
            }
        }
        if (seen) {
            continue;
        }
        if (n_cuts + 2u > panels_max) {
            n_cuts = 0u;
            fits = false;
            break;
        }
        // Insert in ascending order.
        var j = n_cuts;
        while (j > 0u && cuts[j - 1u] > x) {
            cuts[j] = cuts[j - 1u];
            j--;
        }
        cuts[j] = x;
        n_cuts++;
    }
    let panels = n_cuts + 1u;
    var k_ring = 0u;
    for (var i = 0u; i < panels; i++) {
        var lo = z0;
        if (i > 0u) {
            lo = cuts[i - 1u];
        }
        var hi = z1;
        if (i < n_cuts) {
            hi = cuts[i];
        }
        var k = params.rings / panels;
        if (i < params.rings % panels) {
            k++;
        }
        let mid = 0.5 * (lo + hi);
        let half = 0.5 * (hi - lo);
        let off = k * (k - 1u) / 2u;
        for (var a = 0u; a < k; a++) {
            let r = rules[off + a];
            ring_z[k_ring] = mid - half * r.x;
            ring_w[k_ring] = r.y * half;
            k_ring++;
        }
    }
    return k_ring;
}

@compute @workgroup_size(64)
fn shade_union(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
               @builtin(local_invocation_index) li: u32) {
    let r = (wg.y * nwg.x + wg.x) * 64u + li;
    if (r >= params.receivers) {
        return;
    }
    let p = points[r].xyz;
    let n = params.order;
    let nn = params.nn;
    // The local frame: x opposite the caps' radius-weighted mean direction (glam's
    // any_orthonormal_vector for the second axis, as the CPU).
    var mean = vec3<f32>(0.0);
    for (var i = 0u; i < params.spheres; i++) {
        let s = spheres[i];
        if (s.w > 0.0) {
            let oc = s.xyz - p;
            let l = length(oc);
            if (l > 0.0) {
                mean += oc / l * s.w;
            }
        }
    }
    var axis = vec3<f32>(1.0, 0.0, 0.0);
    if (length(mean) > 0.0) {
        axis = normalize(mean);
    }
    let sign = select(-1.0, 1.0, axis.z >= 0.0);
    let a_ = -1.0 / (sign + axis.z);
    let e2 = vec3<f32>(axis.x * axis.y * a_, sign + axis.y * axis.y * a_, -axis.y);
    let b0 = -axis;
    let b1 = -e2;
    let b2 = cross(axis, e2);
    // The caps, in azimuth order (insertion).
    var count = 0u;
    for (var i = 0u; i < params.spheres; i++) {
        let s = spheres[i];
        if (s.w <= 0.0) {
            continue;
        }
        let oc = s.xyz - p;
        let u3 = vec3<f32>(dot(b0, oc), dot(b1, oc), dot(b2, oc));
        let d = length(u3);
        if (d < s.w) {
            image[r] = vec4<f32>(0.0, 0.0, 0.0, 1.0);
            return;
        }
        let u = u3 / d;
        let cos_a = sqrt(max((d - s.w) * (d + s.w), 0.0)) / d;
        let sin_a = min(s.w / d, 1.0);
        let su = sqrt(u.x * u.x + u.y * u.y);
        var z_hi = u.z * cos_a + su * sin_a;
        if (u.z >= cos_a) {
            z_hi = 1.0;
        }
        var z_lo = u.z * cos_a - su * sin_a;
        if (-u.z >= cos_a) {
            z_lo = -1.0;
        }
        var sp = 0.0;
        var cp = 1.0;
        if (su > 0.0) {
            sp = u.y / su;
            cp = u.x / su;
        }
        let key = pseudo_angle(cp, sp);
        var j = count;
        while (j > 0u && caps[j - 1u].key > key) {
            caps[j] = caps[j - 1u];
            j--;
        }
        caps[j] = UCap(u.z, su, sp, cp, key, cos_a, z_lo, z_hi);
        count++;
    }
    // V in the local frame: √(4π)e₀ minus the union's projection, ring by ring.
    var v: array<f32, 64>;
    for (var i = 0u; i < 64u; i++) {
        v[i] = 0.0;
    }
    v[0] = U_SQRT_FOUR_PI;
    var y: array<f32, 64>;
    if (count > 0u) {
        let rings = rings_of(count);
        for (var j = 0u; j < rings; j++) {
            let z = ring_z[j];
            let s = sqrt(max((1.0 - z) * (1.0 + z), 0.0));
            arcs = 0u;
            for (var q = 0u; q < count; q++) {
                if (z >= caps[q].lo && z <= caps[q].hi) {
                    on_ring(q, z, s);
                }
            }
            if (arcs == 0u) {
                continue;
            }
            // Order the pieces by their starts (insertion: they arrive nearly sorted).
            for (var i = 1u; i < arcs; i++) {
                let x = pieces[i];
                var k = i;
                while (k > 0u && pieces[k - 1u].a.k > x.a.k) {
                    pieces[k] = pieces[k - 1u];
                    k--;
                }
                pieces[k] = x;
            }
            for (var m = 0u; m < 8u; m++) {
                cm[m] = 0.0;
                sm[m] = 0.0;
            }
            // Runs of overlapping pieces.
            var run = pieces[0];
            for (var i = 1u; i < arcs; i++) {
                let x = pieces[i];
                if (x.a.k <= run.b.k) {
                    if (x.b.k > run.b.k) {
                        run.b = x.b;
                        run.c = CUT;
                    }
                } else {
                    add_trig(run.a, run.b, run_length(run.a, run.b, run.c), n);
                    run = x;
                }
            }
            add_trig(run.a, run.b, run_length(run.a, run.b, run.c), n);
            // Θ_lm(z) from the basis at φ = 0: Y_l0 = Θ_l0, Y_lm = Θ_lm (m > 0).
            sh_eval(vec3<f32>(s, 0.0, z), n, &y);
            let w = ring_w[j];
            for (var l = 0u; l < n; l++) {
                let base = l * l + l;
                v[base] -= w * y[base] * cm[0];
                for (var m = 1u; m <= l; m++) {
                    let t = w * y[base + m];
                    v[base + m] -= t * cm[m];
                    v[base - m] -= t * sm[m];
                }
            }
        }
    }
    // The transfer in the local frame, T_local(ω) = T(Bᵀω), projected exactly.
    var tl: array<f32, 192>;
    for (var i = 0u; i < 192u; i++) {
        tl[i] = 0.0;
    }
    var yw: array<f32, 64>;
    let zoff = params.rings * (params.rings + 1u) / 2u;
    let nphi = 2u * n - 1u;
    for (var a = 0u; a < n; a++) {
        let gz = rules[zoff + a];
        let sz = sqrt(max((1.0 - gz.x) * (1.0 + gz.x), 0.0));
        for (var b = 0u; b < nphi; b++) {
            let phi = U_TAU * f32(b) / f32(nphi);
            let wl = vec3<f32>(sz * cos(phi), sz * sin(phi), gz.x);
            // Bᵀω: the world direction of the local ω.
            let ww = wl.x * b0 + wl.y * b1 + wl.z * b2;
            sh_eval(wl, n, &y);
            sh_eval(ww, n, &yw);
            let wt = gz.y * U_TAU / f32(nphi);
            for (var ch = 0u; ch < params.channels; ch++) {
                var t = 0.0;
                for (var i = 0u; i < nn; i++) {
                    t += transfer[ch * nn + i] * yw[i];
                }
                for (var i = 0u; i < nn; i++) {
                    tl[ch * 64u + i] += wt * t * y[i];
                }
            }
        }
    }
    var e = vec3<f32>(0.0);
    for (var ch = 0u; ch < params.channels; ch++) {
        var acc = 0.0;
        for (var i = 0u; i < nn; i++) {
            acc += tl[ch * 64u + i] * v[i];
        }
        e[ch] = acc;
    }
    if (params.channels == 1u) {
        e = vec3<f32>(e.x);
    }
    image[r] = vec4<f32>(e, 1.0);
}
