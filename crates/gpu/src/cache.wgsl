// Receiver setup on the GPU: for every receiver p, U = R M_kᵀ Rᵀ T (see receivers.rs), k = |p − c| /
// r(q) with r(q) in points[r].w (the sampling sphere's radius, or per-direction radii), i.e. the
// k-table lookup (linear in ln k, as KTable's Interp::Linear) and both rotations, done by exact
// re-projection: for band-limited f, the coefficients of ω ↦ f(Rω) are Σ_q w_q Y(ω_q) f(R ω_q)
// over a Gauss sphere rule exact for products of two order-N functions (N × 2N points).
// Receivers beyond k_max get flag 1 and the unshadowed constant √(4π) T_ch[0]. The frame is
// LocalFrame::from_z (Duff et al.'s branchless basis) toward the sampling-sphere centre. Sample
// indices and weights (the spherical Delaunay location) come from the host.

@group(0) @binding(0) var<uniform> cp: GpuCacheParams;
@group(0) @binding(1) var<storage, read> points: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> xs: array<f32>;
@group(0) @binding(3) var<storage, read> mats: array<f32>;
@group(0) @binding(4) var<storage, read> transfer: array<f32>;
@group(0) @binding(5) var<storage, read> quad: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read> knorm: array<f32>;
@group(0) @binding(7) var<storage, read_write> receivers: array<GpuReceiver>;
@group(0) @binding(8) var<storage, read_write> u: array<f32>;

@compute @workgroup_size(64)
fn build_cache(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
               @builtin(local_invocation_index) li: u32) {
    let r = (wg.y * nwg.x + wg.x) * 64u + li;
    if (r >= cp.receivers) {
        return;
    }
    let nn = cp.nn;
    let ub = r * cp.channels * nn;
    var d = points[r].xyz - cp.center.xyz;
    let tiny = 1e-6 * cp.center.w;
    if (length(d) < tiny) {
        d = vec3<f32>(0.0, 0.0, tiny);
    }
    // The receiver's sampling radius r(q) (the sphere's, or a radial rule's radii interpolated
    // at its direction, in points[r].w): k = d / r(q), as the CPU's ReceiverCache.
    let k = length(d) / points[r].w;
    let kc = cp.k_count;
    var x = k;
    if (cp.log_k == 1u) {
        x = log(k);
    }
    // Ends within f32 rounding of the table are the ends (KTable's END_TOL, at f32 scale).
    let lo = xs[0];
    let hi = xs[kc - 1u];
    let tol = 4e-6 * max(1.0, abs(hi));
    if (x > hi + tol) {
        var rec = receivers[r];
        rec.flag = 1u;
        let s = sqrt(4.0 * 3.14159265358979);
        if (cp.channels == 3u) {
            rec.constant = vec4<f32>(s * transfer[0], s * transfer[nn], s * transfer[2u * nn], 0.0);
        } else {
            rec.constant = vec4<f32>(s * transfer[0], s * transfer[0], s * transfer[0], 0.0);
        }
        receivers[r] = rec;
        for (var j = 0u; j < cp.channels * nn; j++) {
            u[ub + j] = 0.0;
        }
        return;
    }
    x = clamp(x, lo, hi);
    // The interval j with xs[j] ≤ x < xs[j+1] (last interval at the top end).
    var j = 0u;
    for (var i = 1u; i + 1u < kc; i++) {
        if (xs[i] <= x) {
            j = i;
        }
    }
    let t = clamp((x - xs[j]) / (xs[j + 1u] - xs[j]), 0.0, 1.0);
    // Local frame: z toward the centre.
    let z = normalize(-d);
    let sg = select(-1.0, 1.0, z.z >= 0.0);
    let a = -1.0 / (sg + z.z);
    let b = z.x * z.y * a;
    let fx = vec3<f32>(1.0 + sg * z.x * z.x * a, sg * b, -sg * z.x);
    let fy = vec3<f32>(b, sg + z.y * z.y * a, -z.y);
    let m0 = j * nn * nn;
    let m1 = (j + 1u) * nn * nn;
    var yq: array<f32, 64>;
    var yr: array<f32, 64>;
    for (var ch = 0u; ch < cp.channels; ch++) {
        let tb = ch * nn;
        // aa = coefficients of ω ↦ T(R ω).
        var aa: array<f32, 64>;
        for (var q = 0u; q < cp.quad; q++) {
            let w = quad[q];
            sh_eval(w.xyz, cp.order, &yq);
            sh_eval(w.x * fx + w.y * fy + w.z * z, cp.order, &yr);
            var tv = 0.0;
            for (var i = 0u; i < nn; i++) {
                tv += transfer[tb + i] * yr[i];
            }
            for (var i = 0u; i < nn; i++) {
                aa[i] += w.w * tv * yq[i];
            }
        }
        // bb = M_kᵀ aa (row i of M is the output coefficient, column j the input).
        var bb: array<f32, 64>;
        for (var c = 0u; c < nn; c++) {
            var s0 = 0.0;
            var s1 = 0.0;
            for (var i = 0u; i < nn; i++) {
                s0 += mats[m0 + i * nn + c] * aa[i];
                s1 += mats[m1 + i * nn + c] * aa[i];
            }
            bb[c] = s0 + t * (s1 - s0);
        }
        // u = coefficients of ω ↦ bb(Rᵀ ω).
        var uu: array<f32, 64>;
        for (var q = 0u; q < cp.quad; q++) {
            let w = quad[q];
            sh_eval(w.xyz, cp.order, &yq);
            sh_eval(vec3<f32>(dot(fx, w.xyz), dot(fy, w.xyz), dot(z, w.xyz)), cp.order, &yr);
            var bv = 0.0;
            for (var i = 0u; i < nn; i++) {
                bv += bb[i] * yr[i];
            }
            for (var i = 0u; i < nn; i++) {
                uu[i] += w.w * bv * yq[i];
            }
        }
        for (var i = 0u; i < nn; i++) {
            u[ub + tb + i] = uu[i];
        }
    }
    var rec = receivers[r];
    rec.flag = 0u;
    receivers[r] = rec;
}
