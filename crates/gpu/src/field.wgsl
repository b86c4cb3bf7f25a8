// The fully sampled shadow field (Zhou et al. 2005) shaded on the GPU: one invocation per
// receiver, the twin of the CPU's `FullField::eval` and `Shader::shade`. The shells' samples were
// cast and projected by the sampling kernels into `coeffs` (entity frame); each receiver's
// interpolation weights — up to eight (flat sample index, weight) pairs, trilinear in the shell
// coordinate and the layout's cell or barycentric in its triangle — come from the host
// (`FullField::weights`); a first index of 0xFFFFFFFF marks a receiver beyond the outermost
// shell, which the entity does not occlude (V = √(4π)e₀). E_ch = ⟨T_ch, V⟩.

@group(0) @binding(0) var<uniform> params: GpuSetParams;
@group(0) @binding(1) var<storage, read> weights: array<vec2<u32>>;
@group(0) @binding(2) var<storage, read> coeffs: array<f32>;
@group(0) @binding(3) var<storage, read> transfer: array<f32>;
@group(0) @binding(4) var<storage, read_write> image: array<vec4<f32>>;

const FIELD_SQRT_FOUR_PI: f32 = 3.5449077018110318;

@compute @workgroup_size(64)
fn shade_field(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
               @builtin(local_invocation_index) li: u32) {
    let r = (wg.y * nwg.x + wg.x) * 64u + li;
    if (r >= params.receivers) {
        return;
    }
    let nn = params.nn;
    var v: array<f32, 64>;
    for (var i = 0u; i < 64u; i++) {
        v[i] = 0.0;
    }
    if (weights[r * 8u].x == 0xFFFFFFFFu) {
        v[0] = FIELD_SQRT_FOUR_PI;
    } else {
        for (var k = 0u; k < 8u; k++) {
            let e = weights[r * 8u + k];
            let w = bitcast<f32>(e.y);
            if (w != 0.0) {
                for (var i = 0u; i < nn; i++) {
                    v[i] += w * coeffs[e.x * nn + i];
                }
            }
        }
    }
    var out = vec3<f32>(0.0);
    for (var ch = 0u; ch < params.channels; ch++) {
        var s = 0.0;
        for (var j = 0u; j < nn; j++) {
            s += transfer[ch * nn + j] * v[j];
        }
        out[ch] = s;
    }
    if (params.channels == 1u) {
        out = vec3<f32>(out.x);
    }
    image[r] = vec4<f32>(out, 1.0);
}
