// Sphere sets on the GPU (Ren et al. 2006's occluder model): one invocation per receiver, the
// twin of the CPU's `near_to_far` over `SphereVisibility` fields and `Shader::shade`. Each sphere
// is the closed-form cap √(4π)e₀ − cap(asin(R/d)) rotated onto its direction (zonal harmonics:
// c_l^m = 2π ∫_{cos A}^1 P_l · Y_l^m(axis)); the caps are multiplied near to far with the
// order-N Gaunt product (entries stored with i ≤ j); a sphere of radius 0 is skipped as the
// constant 1; a receiver inside a sphere sees nothing. E_ch = ⟨T_ch, V⟩.

@group(0) @binding(0) var<uniform> params: GpuSetParams;
@group(0) @binding(1) var<storage, read> points: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> spheres: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> gaunt: array<vec4<u32>>;
@group(0) @binding(4) var<storage, read> transfer: array<f32>;
@group(0) @binding(5) var<storage, read> knorm: array<f32>;
@group(0) @binding(6) var<storage, read_write> image: array<vec4<f32>>;

const TWO_PI_SET: f32 = 6.283185307179586;
const SQRT_FOUR_PI: f32 = 3.5449077018110318;

// Sphere `s` (centre xyz, radius w) seen from `p` into `v`: 0 when `p` is inside it, 1 for the
// constant 1 (radius 0), 2 for a cap.
fn sphere_visibility(p: vec3<f32>, s: vec4<f32>, v: ptr<function, array<f32, 64>>) -> u32 {
    let n = params.order;
    for (var i = 0u; i < 64u; i++) {
        (*v)[i] = 0.0;
    }
    if (s.w <= 0.0) {
        (*v)[0] = SQRT_FOUR_PI;
        return 1u;
    }
    let oc = s.xyz - p;
    let d = length(oc);
    if (d < s.w || d == 0.0) {
        return 0u;
    }
    // t = 1 − cos A with sin A = R/d and cos A = √((d − R)(d + R)) / d, as
    // t = sin²A / (1 + cos A): no asin (its slope is unbounded as R/d → 1, a receiver near the
    // sphere's surface, where f32 lost the cap's edge: 4.5e-4 of the irradiance on lavapipe) and
    // no cancellation for tiny caps (R ≪ d), where 1 − cos A would round to 0.
    let x = s.w / d;
    let t = x * x / (1.0 + sqrt(max((d - s.w) * (d + s.w), 0.0)) / d);
    // E_l = 1 − P_l(cos A), the cancellation-free recurrence of the CPU cap (sh/src/cap.rs).
    var e: array<f32, 10>;
    e[0] = 0.0;
    e[1] = t;
    for (var l = 1u; l < n; l++) {
        let lf = f32(l);
        e[l + 1u] = ((2.0 * lf + 1.0) * (t + (1.0 - t) * e[l]) - lf * e[l - 1u]) / (lf + 1.0);
    }
    var y: array<f32, 64>;
    sh_eval(oc / d, n, &y);
    for (var l = 0u; l < n; l++) {
        var integral = t;
        if (l > 0u) {
            integral = (e[l + 1u] - e[l - 1u]) / f32(2u * l + 1u);
        }
        let f = TWO_PI_SET * integral;
        for (var i = l * l; i < (l + 1u) * (l + 1u); i++) {
            (*v)[i] = -f * y[i];
        }
    }
    (*v)[0] += SQRT_FOUR_PI;
    return 2u;
}

@compute @workgroup_size(64)
fn shade_set(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
             @builtin(local_invocation_index) li: u32) {
    let r = (wg.y * nwg.x + wg.x) * 64u + li;
    if (r >= params.receivers) {
        return;
    }
    let p = points[r].xyz;
    let count = params.spheres;
    let nn = params.nn;
    // Near to far by the distance to each centre (a stable insertion sort, as the CPU's sort).
    var idx: array<u32, 64>;
    var dist: array<f32, 64>;
    for (var i = 0u; i < count; i++) {
        place_by_distance(&idx, &dist, i, length(spheres[i].xyz - p));
    }
    var acc: array<f32, 64>;
    var v: array<f32, 64>;
    acc[0] = SQRT_FOUR_PI;
    var first = true;
    for (var q = 0u; q < count; q++) {
        let kind = sphere_visibility(p, spheres[idx[q]], &v);
        if (kind == 1u) {
            continue;
        }
        if (kind == 0u) {
            image[r] = vec4<f32>(0.0, 0.0, 0.0, 1.0);
            return;
        }
        if (first) {
            acc = v;
            first = false;
            continue;
        }
        gaunt_product(&acc, &v, nn, params.entries);
    }
    shade_receiver(r, &acc);
}

// Receiver `r`'s irradiance from its visibility `acc`: E_ch = ⟨T_ch, V⟩ (grey: one channel
// copied to three).
fn shade_receiver(r: u32, acc: ptr<function, array<f32, 64>>) {
    let nn = params.nn;
    var e = vec3<f32>(0.0);
    for (var ch = 0u; ch < params.channels; ch++) {
        var s = 0.0;
        for (var j = 0u; j < nn; j++) {
            s += transfer[ch * nn + j] * (*acc)[j];
        }
        e[ch] = s;
    }
    if (params.channels == 1u) {
        e = vec3<f32>(e.x);
    }
    image[r] = vec4<f32>(e, 1.0);
}
