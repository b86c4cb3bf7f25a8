// The area fit of a sphere set on the device (`fit.rs`): the host's
// `shscale_geometry::partition::fit_spheres` in f32, one workgroup per part. The part's triangles
// are contiguous in `part_tris` (sorted by part at set-up; `ranges[k]` = first, end). Pass one
// (`fit_moments`) sums each part's area A, area-weighted centroid A·g and half the summed cross
// products A·m, about `fit.origin`; pass two (`fit_spheres`) sums the spread about g, then one
// thread places the sphere: radius ρ = √(spread / A), centre g + ρ·|m|·û with û = m/|m| turned
// toward the mesh's area centroid (the sum over every part), as the host does. A part without
// area gets the host's sphere: centre the origin of world space, radius 0.

@group(0) @binding(0) var<uniform> fit: GpuFit;
@group(0) @binding(1) var<storage, read> posed: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> part_tris: array<vec4<u32>>;
@group(0) @binding(3) var<storage, read> ranges: array<vec4<u32>>;
// Per part: (A·g, A), then (A·m, spread).
@group(0) @binding(4) var<storage, read_write> moments: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read_write> spheres: array<vec4<f32>>;

var<workgroup> sum_a: array<vec4<f32>, 256>;
var<workgroup> sum_b: array<vec4<f32>, 256>;

// A triangle's corners about the fit's origin.
fn corners(i: u32) -> array<vec3<f32>, 3> {
    let t = part_tris[i];
    let o = fit.origin.xyz;
    return array<vec3<f32>, 3>(posed[t.x].xyz - o, posed[t.y].xyz - o, posed[t.z].xyz - o);
}

// Tree sum of the workgroup's two slots; the totals end in slot 0.
fn reduce(li: u32) {
    for (var s = 128u; s > 0u; s = s >> 1u) {
        workgroupBarrier();
        if (li < s) {
            sum_a[li] = sum_a[li] + sum_a[li + s];
            sum_b[li] = sum_b[li] + sum_b[li + s];
        }
    }
    workgroupBarrier();
}

@compute @workgroup_size(256)
fn fit_moments(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let r = ranges[wg.x];
    var ag = vec4<f32>(0.0);
    var am = vec4<f32>(0.0);
    for (var i = r.x + li; i < r.y; i = i + 256u) {
        let c = corners(i);
        let cr = cross(c[1] - c[0], c[2] - c[0]);
        let ar = 0.5 * length(cr);
        ag = ag + vec4<f32>(ar * (c[0] + c[1] + c[2]) / 3.0, ar);
        am = am + vec4<f32>(0.5 * cr, 0.0);
    }
    sum_a[li] = ag;
    sum_b[li] = am;
    reduce(li);
    if (li == 0u) {
        moments[2u * wg.x] = sum_a[0];
        moments[2u * wg.x + 1u] = sum_b[0];
    }
}

@compute @workgroup_size(256)
fn fit_spheres(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let k = wg.x;
    let r = ranges[k];
    let ag = moments[2u * k];
    let area = ag.w;
    let g = select(vec3<f32>(0.0), ag.xyz / area, area > 0.0);
    var spread = 0.0;
    for (var i = r.x + li; i < r.y; i = i + 256u) {
        let c = corners(i);
        let ar = 0.5 * length(cross(c[1] - c[0], c[2] - c[0]));
        let d = c[0] - g;
        let e = c[1] - g;
        let f = c[2] - g;
        spread = spread + ar / 3.0 * (dot(d, d) + dot(e, e) + dot(f, f));
    }
    sum_a[li] = vec4<f32>(spread, 0.0, 0.0, 0.0);
    sum_b[li] = vec4<f32>(0.0);
    reduce(li);
    if (li != 0u) {
        return;
    }
    let slot = fit.slot + k;
    if (area <= 0.0) {
        spheres[slot] = vec4<f32>(0.0);
        return;
    }
    // The mesh's area centroid: every part's moments.
    var whole = vec4<f32>(0.0);
    for (var j = 0u; j < fit.parts; j = j + 1u) {
        whole = whole + moments[2u * j];
    }
    let centroid = select(vec3<f32>(0.0), whole.xyz / whole.w, whole.w > 0.0);
    let rho = sqrt(sum_a[0].x / area);
    let m = moments[2u * k + 1u].xyz / area;
    let len = length(m);
    var u = select(vec3<f32>(0.0), m / len, len > 0.0);
    let toward = centroid - g;
    if (dot(u, toward) < 0.0 || dot(toward, toward) == 0.0) {
        u = -u;
    }
    spheres[slot] = vec4<f32>(g + rho * len * u + fit.origin.xyz, rho);
}
