// Common WGSL of the shscale kernels: constants, ray–box and ray–triangle tests. Struct
// declarations come first, generated from layout.rs.

const MAX_NN: u32 = 64u;   // N ≤ 8
const STACK: u32 = 64u;    // bvh::MAX_GPU_BVH_DEPTH

// Slab test with the ray's reciprocal direction; true when the box overlaps [tmin, ∞).
fn hit_box(n: GpuNode, o: vec3<f32>, inv: vec3<f32>, tmin: f32) -> bool {
    let t0 = (n.min - o) * inv;
    let t1 = (n.max - o) * inv;
    let lo = min(t0, t1);
    let hi = max(t0, t1);
    let near = max(max(max(lo.x, lo.y), lo.z), tmin);
    let far = min(min(hi.x, hi.y), hi.z);
    return near <= far;
}

// Möller–Trumbore in the operand order of obvhs' `Triangle::intersect` (so results agree with
// the CPU path up to the GPU's rounding): hit when u, v, w ≥ 0 and t ∈ [tmin, ∞).
fn hit_tri(t: GpuTri, o: vec3<f32>, d: vec3<f32>, tmin: f32) -> bool {
    let v0 = t.v0.xyz;
    let e1 = v0 - t.v1.xyz;
    let e2 = t.v2.xyz - v0;
    let n = cross(e1, e2);
    let c = v0 - o;
    let r = cross(d, c);
    let det = dot(n, d);
    if (det == 0.0) {
        return false;
    }
    let inv_det = 1.0 / det;
    let u = dot(r, e2) * inv_det;
    let v = dot(r, e1) * inv_det;
    let w = 1.0 - u - v;
    if (u < 0.0 || v < 0.0 || w < 0.0) {
        return false;
    }
    let tt = dot(n, c) * inv_det;
    return tt >= tmin;
}
