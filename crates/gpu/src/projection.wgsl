// SH conversion (Table 1 "SH conversion"): one workgroup of 64 per base-sphere sample. Each
// invocation sums w_j V_j Y(d_j) over its share of the sample's rays (entity frame, as the CPU's
// `Frame::Entity`), the workgroup reduces the N² partial sums through workgroup memory, and the
// closed-form back hemisphere (precomputed per sample on the host: it depends only on the fixed
// sample direction) is added.

@group(0) @binding(0) var<uniform> params: GpuParams;
@group(0) @binding(1) var<storage, read> samples: array<GpuSample>;
@group(0) @binding(2) var<storage, read> hemi: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> vis: array<u32>;
@group(0) @binding(4) var<storage, read> knorm: array<f32>;
@group(0) @binding(5) var<storage, read> back: array<f32>;
@group(0) @binding(6) var<storage, read_write> coeffs: array<f32>;

var<workgroup> partial: array<f32, 4096>; // 64 invocations × N² ≤ 64

@compute @workgroup_size(64)
fn project(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let si = wg.x;
    let nn = params.nn;
    let s = samples[si];
    var acc: array<f32, 64>;
    var y: array<f32, 64>;
    for (var j = li; j < params.rays; j += 64u) {
        if (vis[si * params.rays + j] != 0u) {
            let h = hemi[j];
            let d = h.x * s.fx.xyz + h.y * s.fy.xyz + h.z * s.fz.xyz;
            sh_eval(d, params.order, &y);
            for (var i = 0u; i < nn; i++) {
                acc[i] += h.w * y[i];
            }
        }
    }
    for (var i = 0u; i < nn; i++) {
        partial[li * nn + i] = acc[i];
    }
    workgroupBarrier();
    if (li < nn) {
        var sum = 0.0;
        for (var t = 0u; t < 64u; t++) {
            sum += partial[t * nn + li];
        }
        coeffs[si * nn + li] = sum + back[si * nn + li];
    }
}
