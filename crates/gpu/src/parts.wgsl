// Sub-volumes on the GPU (TR §6, SHS §5: an object split into parts, each extrapolated from its
// own sphere): one invocation per receiver, the twin of the CPU's `SubVolumeField` through
// `near_to_far` and `Shader::shade`. Per part, nearest centre first (ties: the lower part): k =
// d / r_p, the part's k-table (linear in ln k or k); beyond its k_max the part is the constant 1
// and skipped; else V_p = R M_k Rᵀ B with B the part's BSV interpolated at the receiver's
// direction (its three samples and weights from the host's triangulation) and R the frame toward
// the part's centre (LocalFrame::toward, Duff et al.'s basis), the rotations by exact
// re-projection on a Gauss sphere rule (as cache.wgsl); the parts multiplied near to far with
// the order-N Gaunt product. E_ch = ⟨T_ch, V⟩.
//
// `geo`: receivers (xyz, 1), then parts (centre xyz, sampling radius w). `locs`: per part, per
// receiver, three sample indices and weights. `tables`: per part k_count abscissae (k or ln k),
// then per part k_count dense N² × N² matrices (row = output), then the transfer (channels × N²).
// `coeffs`: per part, per sample, N² (entity frame).

@group(0) @binding(0) var<uniform> pp: GpuPartsParams;
@group(0) @binding(1) var<storage, read> geo: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> locs: array<GpuReceiver>;
@group(0) @binding(3) var<storage, read> tables: array<f32>;
@group(0) @binding(4) var<storage, read> coeffs: array<f32>;
@group(0) @binding(5) var<storage, read> gaunt: array<vec4<u32>>;
@group(0) @binding(6) var<storage, read> quad: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read> knorm: array<f32>;
@group(0) @binding(8) var<storage, read_write> image: array<vec4<f32>>;

// Part `p`'s visibility at `x` into `v`; false when beyond its table (the constant 1).
fn part_visibility(p: u32, r: u32, x: vec3<f32>, v: ptr<function, array<f32, 64>>) -> bool {
    let nn = pp.nn;
    let part = geo[pp.receivers + p];
    var d = x - part.xyz;
    let tiny = 1e-6 * part.w;
    if (length(d) < tiny) {
        d = vec3<f32>(0.0, 0.0, tiny);
    }
    let kc = pp.k_count;
    let xs0 = p * kc;
    var k = length(d) / part.w;
    if (pp.log_k == 1u) {
        k = log(k);
    }
    let lo = tables[xs0];
    let hi = tables[xs0 + kc - 1u];
    let tol = 4e-6 * max(1.0, abs(hi));
    if (k > hi + tol) {
        return false;
    }
    k = clamp(k, lo, hi);
    var j = 0u;
    for (var i = 1u; i + 1u < kc; i++) {
        if (tables[xs0 + i] <= k) {
            j = i;
        }
    }
    let t = clamp((k - tables[xs0 + j]) / (tables[xs0 + j + 1u] - tables[xs0 + j]), 0.0, 1.0);
    let mats0 = pp.parts * kc;
    let m0 = mats0 + (p * kc + j) * nn * nn;
    let m1 = m0 + nn * nn;
    // B: the part's BSV interpolated at the receiver's direction.
    let loc = locs[p * pp.receivers + r];
    let cb = p * pp.samples * nn;
    var b: array<f32, 64>;
    for (var i = 0u; i < nn; i++) {
        b[i] = loc.w.x * coeffs[cb + loc.idx.x * nn + i] + loc.w.y * coeffs[cb + loc.idx.y * nn + i]
            + loc.w.z * coeffs[cb + loc.idx.z * nn + i];
    }
    // The local frame: z toward the centre.
    let z = normalize(-d);
    let sg = select(-1.0, 1.0, z.z >= 0.0);
    let a = -1.0 / (sg + z.z);
    let bb0 = z.x * z.y * a;
    let fx = vec3<f32>(1.0 + sg * z.x * z.x * a, sg * bb0, -sg * z.x);
    let fy = vec3<f32>(bb0, sg + z.y * z.y * a, -z.y);
    var yq: array<f32, 64>;
    var yr: array<f32, 64>;
    // aa = coefficients of ω ↦ B(R ω) (Rᵀ B).
    var aa: array<f32, 64>;
    for (var q = 0u; q < pp.quad; q++) {
        let w = quad[q];
        sh_eval(w.xyz, pp.order, &yq);
        sh_eval(w.x * fx + w.y * fy + w.z * z, pp.order, &yr);
        var bv = 0.0;
        for (var i = 0u; i < nn; i++) {
            bv += b[i] * yr[i];
        }
        for (var i = 0u; i < nn; i++) {
            aa[i] += w.w * bv * yq[i];
        }
    }
    // cc = M_k aa.
    var cc: array<f32, 64>;
    for (var i = 0u; i < nn; i++) {
        var s0 = 0.0;
        var s1 = 0.0;
        for (var c = 0u; c < nn; c++) {
            s0 += tables[m0 + i * nn + c] * aa[c];
            s1 += tables[m1 + i * nn + c] * aa[c];
        }
        cc[i] = s0 + t * (s1 - s0);
    }
    // V = coefficients of ω ↦ cc(Rᵀ ω).
    for (var i = 0u; i < 64u; i++) {
        (*v)[i] = 0.0;
    }
    for (var q = 0u; q < pp.quad; q++) {
        let w = quad[q];
        sh_eval(w.xyz, pp.order, &yq);
        sh_eval(vec3<f32>(dot(fx, w.xyz), dot(fy, w.xyz), dot(z, w.xyz)), pp.order, &yr);
        var cv = 0.0;
        for (var i = 0u; i < nn; i++) {
            cv += cc[i] * yr[i];
        }
        for (var i = 0u; i < nn; i++) {
            (*v)[i] += w.w * cv * yq[i];
        }
    }
    return true;
}

@compute @workgroup_size(64)
fn shade_parts(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
               @builtin(local_invocation_index) li: u32) {
    let r = (wg.y * nwg.x + wg.x) * 64u + li;
    if (r >= pp.receivers) {
        return;
    }
    let x = geo[r].xyz;
    let nn = pp.nn;
    // Near to far by the distance to each part's centre (a stable insertion sort).
    var idx: array<u32, 64>;
    var dist: array<f32, 64>;
    for (var i = 0u; i < pp.parts; i++) {
        place_by_distance(&idx, &dist, i, length(geo[pp.receivers + i].xyz - x));
    }
    var acc: array<f32, 64>;
    var v: array<f32, 64>;
    acc[0] = 3.5449077018110318;
    var first = true;
    for (var q = 0u; q < pp.parts; q++) {
        if (!part_visibility(idx[q], r, x, &v)) {
            continue;
        }
        if (first) {
            acc = v;
            first = false;
            continue;
        }
        gaunt_product(&acc, &v, nn, pp.entries);
    }
    let tb = pp.parts * pp.k_count * (1u + nn * nn);
    var e = vec3<f32>(0.0);
    for (var ch = 0u; ch < pp.channels; ch++) {
        var s = 0.0;
        for (var j = 0u; j < nn; j++) {
            s += tables[tb + ch * nn + j] * acc[j];
        }
        e[ch] = s;
    }
    if (pp.channels == 1u) {
        e = vec3<f32>(e.x);
    }
    image[r] = vec4<f32>(e, 1.0);
}
