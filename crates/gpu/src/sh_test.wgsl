// Test kernel: the SH values at given directions (parity of sh_eval with the CPU basis).

@group(0) @binding(0) var<uniform> params: GpuParams;
@group(0) @binding(1) var<storage, read> dirs: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> knorm: array<f32>;
@group(0) @binding(3) var<storage, read_write> values: array<f32>;

@compute @workgroup_size(64)
fn eval(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if (i >= params.samples) {
        return;
    }
    var y: array<f32, 64>;
    sh_eval(dirs[i].xyz, params.order, &y);
    for (var k = 0u; k < params.nn; k++) {
        values[i * params.nn + k] = y[k];
    }
}
