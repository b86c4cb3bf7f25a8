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

// Caps seen from the receiver (the local frame): axis height, its √(1 − z²), azimuth's sine,
// cosine and pseudo-angle, cos A, z-range.
var<private> cap_zu: array<f32, 64>;
var<private> cap_su: array<f32, 64>;
var<private> cap_sp: array<f32, 64>;
var<private> cap_cp: array<f32, 64>;
var<private> cap_key: array<f32, 64>;
var<private> cap_cos_a: array<f32, 64>;
var<private> cap_lo: array<f32, 64>;
var<private> cap_hi: array<f32, 64>;
// One ring's pieces: start (key, sin, cos), end (key, sin, cos), cos of the half-width or CUT.
var<private> arc_ak: array<f32, 128>;
var<private> arc_as: array<f32, 128>;
var<private> arc_ac: array<f32, 128>;
var<private> arc_bk: array<f32, 128>;
var<private> arc_bs: array<f32, 128>;
var<private> arc_bc: array<f32, 128>;
var<private> arc_c: array<f32, 128>;
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

fn push(ak: f32, as_: f32, ac: f32, bk: f32, bs: f32, bc: f32, c: f32) {
    let i = arcs;
    arc_ak[i] = ak;
    arc_as[i] = as_;
    arc_ac[i] = ac;
    arc_bk[i] = bk;
    arc_bs[i] = bs;
    arc_bc[i] = bc;
    arc_c[i] = c;
    arcs = i + 1u;
}

fn push_full() {
    push(0.0, 0.0, 1.0, 4.0, 0.0, 1.0, -1.0);
}

// Cap `q`'s interval on the ring at height z (s = √(1 − z²)), split at φ = 0 where it crosses it;
// a rounding reversal of a near-empty interval is dropped (the CPU's `push_arc`).
fn on_ring(q: u32, z: f32, s: f32) {
    let ss = s * cap_su[q];
    let num = cap_cos_a[q] - z * cap_zu[q];
    if (ss <= 1e-30) {
        if (num <= 0.0) {
            push_full();
        }
        return;
    }
    let c = num / ss;
    if (c <= -1.0) {
        push_full();
        return;
    }
    if (c >= 1.0) {
        return;
    }
    let sh = sqrt((1.0 - c) * (1.0 + c));
    let sp = cap_sp[q];
    let cp = cap_cp[q];
    let lc = cp * c + sp * sh;
    let ls = sp * c - cp * sh;
    let hc = cp * c - sp * sh;
    let hs = sp * c + cp * sh;
    let lk = pseudo_angle(lc, ls);
    let hk = pseudo_angle(hc, hs);
    let d = hk - lk;
    var crosses = d < 0.0;
    var whole = d >= 0.0;
    if (c > 0.0) {
        crosses = d < -1.0;
        whole = d >= 0.0 && d < 3.0;
    }
    if (crosses) {
        push(lk, ls, lc, 4.0, 0.0, 1.0, CUT);
        push(0.0, 0.0, 1.0, hk, hs, hc, CUT);
    } else if (whole) {
        push(lk, ls, lc, hk, hs, hc, c);
    }
}

// The length of the run from a to b (counter-clockwise, no crossing of φ = 0): 2·acos(c) for one
// cap's whole interval, else one atan2 of the ends, lifted by 2π for a run of π or more.
fn run_length(ak: f32, as_: f32, ac: f32, bk: f32, bs: f32, bc: f32, c: f32) -> f32 {
    if (c != CUT) {
        return 2.0 * acos(clamp(c, -1.0, 1.0));
    }
    let len = atan2(ac * bs - as_ * bc, ac * bc + as_ * bs);
    if (bk - ak >= 2.0) {
        if (len <= 0.0) {
            return len + U_TAU;
        }
        return len;
    }
    return max(len, 0.0);
}

// ∫ T_m over [a, b] added to cm (cos mφ; cm[0] the length) and sm (sin mφ), m < n.
fn add_trig(as_: f32, ac: f32, bs: f32, bc: f32, len: f32, n: u32) {
    cm[0] += len;
    var sa0 = 0.0;
    var ca0 = 1.0;
    var sa1 = as_;
    var ca1 = ac;
    var sb0 = 0.0;
    var cb0 = 1.0;
    var sb1 = bs;
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
        z0 = min(z0, cap_lo[q]);
        z1 = max(z1, cap_hi[q]);
    }
    let panels_max = max(params.rings / params.panel_rings, 1u);
    var cuts: array<f32, 34>;
    var n_cuts = 0u;
    var fits = true;
    for (var e = 0u; e < 2u * count && fits; e++) {
        var x = cap_lo[e / 2u];
        if (e % 2u == 1u) {
            x = cap_hi[e / 2u];
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
        while (j > 0u && cap_key[j - 1u] > key) {
            cap_zu[j] = cap_zu[j - 1u];
            cap_su[j] = cap_su[j - 1u];
            cap_sp[j] = cap_sp[j - 1u];
            cap_cp[j] = cap_cp[j - 1u];
            cap_key[j] = cap_key[j - 1u];
            cap_cos_a[j] = cap_cos_a[j - 1u];
            cap_lo[j] = cap_lo[j - 1u];
            cap_hi[j] = cap_hi[j - 1u];
            j--;
        }
        cap_zu[j] = u.z;
        cap_su[j] = su;
        cap_sp[j] = sp;
        cap_cp[j] = cp;
        cap_key[j] = key;
        cap_cos_a[j] = cos_a;
        cap_lo[j] = z_lo;
        cap_hi[j] = z_hi;
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
                if (z >= cap_lo[q] && z <= cap_hi[q]) {
                    on_ring(q, z, s);
                }
            }
            if (arcs == 0u) {
                continue;
            }
            // Order the pieces by their starts (insertion: they arrive nearly sorted).
            for (var i = 1u; i < arcs; i++) {
                let ak = arc_ak[i];
                let as_ = arc_as[i];
                let ac = arc_ac[i];
                let bk = arc_bk[i];
                let bs = arc_bs[i];
                let bc = arc_bc[i];
                let c = arc_c[i];
                var k = i;
                while (k > 0u && arc_ak[k - 1u] > ak) {
                    arc_ak[k] = arc_ak[k - 1u];
                    arc_as[k] = arc_as[k - 1u];
                    arc_ac[k] = arc_ac[k - 1u];
                    arc_bk[k] = arc_bk[k - 1u];
                    arc_bs[k] = arc_bs[k - 1u];
                    arc_bc[k] = arc_bc[k - 1u];
                    arc_c[k] = arc_c[k - 1u];
                    k--;
                }
                arc_ak[k] = ak;
                arc_as[k] = as_;
                arc_ac[k] = ac;
                arc_bk[k] = bk;
                arc_bs[k] = bs;
                arc_bc[k] = bc;
                arc_c[k] = c;
            }
            for (var m = 0u; m < 8u; m++) {
                cm[m] = 0.0;
                sm[m] = 0.0;
            }
            // Runs of overlapping pieces.
            var ak = arc_ak[0];
            var as_ = arc_as[0];
            var ac = arc_ac[0];
            var bk = arc_bk[0];
            var bs = arc_bs[0];
            var bc = arc_bc[0];
            var c1 = arc_c[0];
            for (var i = 1u; i < arcs; i++) {
                if (arc_ak[i] <= bk) {
                    if (arc_bk[i] > bk) {
                        bk = arc_bk[i];
                        bs = arc_bs[i];
                        bc = arc_bc[i];
                        c1 = CUT;
                    }
                } else {
                    add_trig(as_, ac, bs, bc, run_length(ak, as_, ac, bk, bs, bc, c1), n);
                    ak = arc_ak[i];
                    as_ = arc_as[i];
                    ac = arc_ac[i];
                    bk = arc_bk[i];
                    bs = arc_bs[i];
                    bc = arc_bc[i];
                    c1 = arc_c[i];
                }
            }
            add_trig(as_, ac, bs, bc, run_length(ak, as_, ac, bk, bs, bc, c1), n);
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
