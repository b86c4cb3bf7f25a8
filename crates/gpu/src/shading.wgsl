// Shadowing (Table 1 "shadowing"): one invocation per receiver, the GPU twin of
// `ReceiverCache::shade`. E_ch = Σ_j U_ch[j] · (w0 B_i0[j] + w1 B_i1[j] + w2 B_i2[j]): the BSV
// interpolated at the receiver's direction, scaled by the k-table and rotated into its frame —
// the latter two folded into U, which depends only on the receiver's place, the table and the
// light (see receivers.rs for the identity).

@group(0) @binding(0) var<uniform> params: GpuParams;
@group(0) @binding(1) var<storage, read> receivers: array<GpuReceiver>;
@group(0) @binding(2) var<storage, read> u: array<f32>;
@group(0) @binding(3) var<storage, read> coeffs: array<f32>;
@group(0) @binding(4) var<storage, read_write> image: array<vec4<f32>>;

@compute @workgroup_size(64)
fn shade(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
         @builtin(local_invocation_index) li: u32) {
    let r = (wg.y * nwg.x + wg.x) * 64u + li;
    if (r >= params.receivers) {
        return;
    }
    let rec = receivers[r];
    if (rec.flag == 1u) {
        image[r] = vec4<f32>(rec.constant.xyz, 1.0);
        return;
    }
    let nn = params.nn;
    let b0 = rec.idx.x * nn;
    let b1 = rec.idx.y * nn;
    let b2 = rec.idx.z * nn;
    let ub = r * params.channels * nn;
    var e = vec3<f32>(0.0);
    for (var ch = 0u; ch < params.channels; ch++) {
        var acc = 0.0;
        for (var j = 0u; j < nn; j++) {
            let b = rec.w.x * coeffs[b0 + j] + rec.w.y * coeffs[b1 + j] + rec.w.z * coeffs[b2 + j];
            acc += u[ub + ch * nn + j] * b;
        }
        e[ch] = acc;
    }
    if (params.channels == 1u) {
        e = vec3<f32>(e.x);
    }
    image[r] = vec4<f32>(e, 1.0);
}
