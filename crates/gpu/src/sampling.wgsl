// BSV sampling (Table 1 "BSV sampling"): one invocation per ray. Ray j of sample s starts at the
// sample position and leaves along the sample's local frame applied to the j-th Gauss hemisphere
// direction (z toward the entity centre); vis = 1 when it escapes the mesh.

@group(0) @binding(0) var<uniform> params: GpuParams;
@group(0) @binding(1) var<storage, read> samples: array<GpuSample>;
@group(0) @binding(2) var<storage, read> hemi: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> nodes: array<GpuNode>;
@group(0) @binding(4) var<storage, read> tris: array<GpuTri>;
@group(0) @binding(5) var<storage, read_write> vis: array<u32>;

fn occluded(o: vec3<f32>, d: vec3<f32>, tmin: f32) -> bool {
    let inv = 1.0 / d;
    var stack: array<u32, 64>;
    var sp = 0u;
    var node = 0u;
    loop {
        let n = nodes[node];
        var descend = false;
        if (hit_box(n, o, inv, tmin)) {
            if (n.count > 0u) {
                for (var i = n.first; i < n.first + n.count; i++) {
                    if (hit_tri(tris[i], o, d, tmin)) {
                        return true;
                    }
                }
            } else {
                // Visit the left child next, the right one later.
                if (sp < STACK) {
                    stack[sp] = n.first + 1u;
                    sp++;
                }
                node = n.first;
                descend = true;
            }
        }
        if (!descend) {
            if (sp == 0u) {
                break;
            }
            sp--;
            node = stack[sp];
        }
    }
    return false;
}

@compute @workgroup_size(64)
fn cast_rays(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
        @builtin(local_invocation_index) li: u32) {
    let id = (wg.y * nwg.x + wg.x) * 64u + li;
    if (id >= params.samples * params.rays) {
        return;
    }
    let s = samples[id / params.rays];
    let h = hemi[id % params.rays].xyz;
    let d = h.x * s.fx.xyz + h.y * s.fy.xyz + h.z * s.fz.xyz;
    vis[id] = select(1u, 0u, occluded(s.pos.xyz, d, params.tmin));
}
