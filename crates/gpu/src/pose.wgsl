// The frame's pose and BVH refit on the device (docs/conventions.md §9; `pose.rs`): the deformer
// maps every rest vertex (the host's `shscale_geometry::deform` in f32), the leaves gather their
// triangles from the posed vertices into the traversal's triangle buffer and take their boxes,
// the inner nodes take the union of their children's boxes one tree level per dispatch (deepest
// first), and one workgroup sums every node's half area over the root's (the host's rebuild
// rule). Bindings are numbered across the four kernels, a buffer's number the same in each
// kernel that reads it (the pose's kinds: 0 none, 1 bend, 2 twist, 3 morph, 4 flap).

@group(0) @binding(0) var<uniform> pose: GpuPose;
@group(0) @binding(1) var<storage, read> rest: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> morph_target: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read_write> posed: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read> tri_verts: array<vec4<u32>>;
@group(0) @binding(5) var<storage, read> leaf_list: array<u32>;
@group(0) @binding(6) var<storage, read_write> nodes: array<GpuNode>;
@group(0) @binding(7) var<storage, read_write> tris: array<GpuTri>;
@group(0) @binding(8) var<storage, read_write> area: array<f32>;
@group(0) @binding(9) var<uniform> level: GpuLevel;
@group(0) @binding(10) var<storage, read> inner: array<u32>;
@group(0) @binding(11) var<storage, read_write> area_out: array<f32>;

fn index_64(wg: vec3<u32>, nwg: vec3<u32>, local: u32) -> u32 {
    return (wg.y * nwg.x + wg.x) * 64u + local;
}

// The bend in a form without the host's cancellation: x' = sin(κx)/κ − z sin(κx),
// z' = 2 sin²(κx/2)/κ + z cos(κx) equal the host's r sin, 1/κ − r cos with r = 1/κ − z, but keep
// their f32 precision as κ → 0 (where 1/κ − r cos subtracts two numbers near 1/κ).
fn bend(p: vec3<f32>, k: f32) -> vec3<f32> {
    if (abs(k) < 1e-12) {
        return p;
    }
    let a = k * p.x;
    let s = sin(a);
    let h = sin(0.5 * a);
    return vec3<f32>(s / k - p.z * s, p.y, 2.0 * h * h / k + p.z * cos(a));
}

fn twist(p: vec3<f32>, angle: f32, h: f32) -> vec3<f32> {
    let a = angle * p.z / h;
    let s = sin(a);
    let c = cos(a);
    return vec3<f32>(c * p.x - s * p.y, s * p.x + c * p.y, p.z);
}

fn flap(p: vec3<f32>, angle: f32, y0: f32) -> vec3<f32> {
    let d = abs(p.y) - y0;
    if (d <= 0.0) {
        return p;
    }
    let sg = select(-1.0, 1.0, p.y >= 0.0);
    let a = angle * (1.0 - exp(-d)) * sg;
    let s = sin(a);
    let c = cos(a);
    let yy = p.y - sg * y0;
    return vec3<f32>(p.x, sg * y0 + c * yy - s * p.z, s * yy + c * p.z);
}

@compute @workgroup_size(64)
fn deform(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
          @builtin(local_invocation_index) local: u32) {
    let i = index_64(wg, nwg, local);
    if (i >= pose.vertices) {
        return;
    }
    let p = rest[i].xyz;
    var q = p;
    switch pose.kind {
        case 1u: { q = bend(p, pose.scalar); }
        case 2u: { q = twist(p, pose.scalar, pose.constant); }
        case 3u: {
            let w = pose.scalar;
            q = p * (1.0 - w) + morph_target[i].xyz * w;
        }
        case 4u: { q = flap(p, pose.scalar, pose.constant); }
        default: {}
    }
    posed[i] = vec4<f32>(q, 0.0);
}

fn half_area(lo: vec3<f32>, hi: vec3<f32>) -> f32 {
    let d = hi - lo;
    return d.x * d.y + d.y * d.z + d.z * d.x;
}

// A leaf: its triangles gathered from the posed vertices (in the tree's order) and its box.
@compute @workgroup_size(64)
fn refit_leaves(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
                @builtin(local_invocation_index) local: u32) {
    let i = index_64(wg, nwg, local);
    if (i >= pose.leaves) {
        return;
    }
    let n = leaf_list[i];
    var node = nodes[n];
    var lo = vec3<f32>(3.4e38);
    var hi = vec3<f32>(-3.4e38);
    for (var t = node.first; t < node.first + node.count; t++) {
        let v = tri_verts[t];
        let a = posed[v.x];
        let b = posed[v.y];
        let c = posed[v.z];
        tris[t] = GpuTri(a, b, c);
        lo = min(lo, min(a.xyz, min(b.xyz, c.xyz)));
        hi = max(hi, max(a.xyz, max(b.xyz, c.xyz)));
    }
    node.min = lo;
    node.max = hi;
    nodes[n] = node;
    area[n] = half_area(lo, hi);
}

// The inner nodes of one level: each the union of its two children (refitted by the previous
// dispatch, a level deeper, or by `refit_leaves`).
@compute @workgroup_size(64)
fn refit_inner(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
               @builtin(local_invocation_index) local: u32) {
    let i = index_64(wg, nwg, local);
    if (i >= level.count) {
        return;
    }
    let n = inner[level.start + i];
    var node = nodes[n];
    let l = nodes[node.first];
    let r = nodes[node.first + 1u];
    node.min = min(l.min, r.min);
    node.max = max(l.max, r.max);
    nodes[n] = node;
    area[n] = half_area(node.min, node.max);
}

var<workgroup> partial: array<f32, 256>;

// The tree's relative area: every node's half area summed (f32, in a 256-wide tree reduction)
// over the root's.
@compute @workgroup_size(256)
fn area_sum(@builtin(local_invocation_index) local: u32) {
    var s = 0.0;
    for (var i = local; i < pose.nodes; i += 256u) {
        s += area[i];
    }
    partial[local] = s;
    workgroupBarrier();
    for (var w = 128u; w > 0u; w = w / 2u) {
        if (local < w) {
            partial[local] += partial[local + w];
        }
        workgroupBarrier();
    }
    if (local == 0u) {
        let root = area[0];
        area_out[0] = select(1.0, partial[0] / root, root > 0.0);
    }
}
