// Sphere sets combined by SH exponentiation on the GPU (Ren et al. 2006; the CPU's
// `SphereSetShexp` with `Exp::Hyb`, shscale_field::shexp_ol): per receiver, every sphere's
// tabulated zonal log (linear in t = 1 − cos A between the table's rows) rotated onto its
// direction and summed; then the HYB exponential — the sum halved until its non-DC magnitude is
// below the table's limit, the optimal linear approximation (a, b) looked up by that magnitude,
// and squared back by truncated Gaunt products. A receiver inside a sphere sees nothing; a
// sphere of radius 0 is skipped. Included after sphereset.wgsl (its bindings 0–6 and
// `shade_receiver`) and product.wgsl.
//
// `shexp_tables`: a header (OL rows R, table intervals T, the halving limit, unused), R rows
// (‖f̂‖, a, b) ascending in ‖f̂‖, then T + 1 rows of N zonal log coefficients at t = i/T.

@group(0) @binding(7) var<storage, read> shexp_tables: array<f32>;

// (a, b) at magnitude `m`: the CPU's `ol_coefficients` (clamped to the table's ends, linear
// between rows).
fn ol_coefficients(m: f32) -> vec2<f32> {
    let rows = u32(shexp_tables[0]);
    var lo = 0u;
    var hi = rows;
    while (lo < hi) {
        let mid = (lo + hi) / 2u;
        if (shexp_tables[4u + 3u * mid] < m) {
            lo = mid + 1u;
        } else {
            hi = mid;
        }
    }
    let k = min(lo, rows - 1u);
    let row = 4u + 3u * k;
    if (lo == 0u || lo >= rows) {
        return vec2<f32>(shexp_tables[row + 1u], shexp_tables[row + 2u]);
    }
    let prev = row - 3u;
    let m0 = shexp_tables[prev];
    let m1 = shexp_tables[row];
    var s = 0.0;
    if (m1 > m0) {
        s = (m - m0) / (m1 - m0);
    }
    return vec2<f32>(
        mix(shexp_tables[prev + 1u], shexp_tables[row + 1u], s),
        mix(shexp_tables[prev + 2u], shexp_tables[row + 2u], s),
    );
}

@compute @workgroup_size(64)
fn shade_shexp(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
               @builtin(local_invocation_index) li: u32) {
    let r = (wg.y * nwg.x + wg.x) * 64u + li;
    if (r >= params.receivers) {
        return;
    }
    let p = points[r].xyz;
    let n = params.order;
    let nn = params.nn;
    let rows = u32(shexp_tables[0]);
    let intervals = u32(shexp_tables[1]);
    let logs = 4u + 3u * rows;
    var f: array<f32, 64>;
    var y: array<f32, 64>;
    for (var q = 0u; q < params.spheres; q++) {
        let s = spheres[q];
        if (s.w <= 0.0) {
            continue;
        }
        let oc = s.xyz - p;
        let d = length(oc);
        if (d < s.w || d == 0.0) {
            image[r] = vec4<f32>(0.0, 0.0, 0.0, 1.0);
            return;
        }
        // t = 1 − cos A = sin²A / (1 + cos A), as the CPU and the chain's caps.
        let x = s.w / d;
        let t = x * x / (1.0 + sqrt(max((d - s.w) * (d + s.w), 0.0)) / d);
        let u = clamp(t, 0.0, 1.0) * f32(intervals);
        let i = min(u32(floor(u)), intervals - 1u);
        let w = u - f32(i);
        sh_eval(oc / d, n, &y);
        for (var l = 0u; l < n; l++) {
            let a = shexp_tables[logs + i * n + l];
            let b = shexp_tables[logs + (i + 1u) * n + l];
            let zl = (a + w * (b - a)) * sqrt(4.0 * 3.141592653589793 / f32(2u * l + 1u));
            for (var j = l * l; j < (l + 1u) * (l + 1u); j++) {
                f[j] += zl * y[j];
            }
        }
    }
    // HYB: halve into the table's range, OL, square back.
    var m2 = 0.0;
    for (var j = 1u; j < nn; j++) {
        m2 += f[j] * f[j];
    }
    var m = sqrt(m2);
    let limit = shexp_tables[2];
    var squarings = 0u;
    while (m >= limit && squarings < 64u) {
        for (var j = 0u; j < nn; j++) {
            f[j] *= 0.5;
        }
        m *= 0.5;
        squarings++;
    }
    let ab = ol_coefficients(m);
    let scale = exp(f[0] / SQRT_FOUR_PI);
    var acc: array<f32, 64>;
    for (var j = 0u; j < nn; j++) {
        acc[j] = scale * ab.y * f[j];
    }
    acc[0] = scale * ab.x * SQRT_FOUR_PI;
    var v: array<f32, 64>;
    for (var k = 0u; k < squarings; k++) {
        v = acc;
        gaunt_product(&acc, &v, nn, params.entries);
    }
    shade_receiver(r, &acc);
}
