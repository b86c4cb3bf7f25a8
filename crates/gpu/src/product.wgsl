// The truncated SH product for the kernels that multiply visibilities (sphere sets, sub-volumes),
// and their order near to far;
// the including kernel binds the order-N Gaunt tensor as `gaunt` (entries (i, j, k, bits of the
// value) with i ≤ j, the CPU's GauntTensor::entries).

// acc ← P_N(acc · v): Σ over the `entries` entries G_ijk (acc_i v_j + acc_j v_i) (once for
// i = j) into coefficient k, the first `nn` coefficients.
fn gaunt_product(acc: ptr<function, array<f32, 64>>, v: ptr<function, array<f32, 64>>,
                 nn: u32, entries: u32) {
    var tmp: array<f32, 64>;
    for (var i = 0u; i < nn; i++) {
        tmp[i] = 0.0;
    }
    for (var g = 0u; g < entries; g++) {
        let en = gaunt[g];
        let gi = en.x;
        let gj = en.y;
        var ab = (*acc)[gi] * (*v)[gi];
        if (gi != gj) {
            ab = (*acc)[gi] * (*v)[gj] + (*acc)[gj] * (*v)[gi];
        }
        tmp[en.z] += bitcast<f32>(en.w) * ab;
    }
    *acc = tmp;
}

// Occluder `i` (of those placed so far, 0..i) at distance `d` into the near-to-far order
// `idx`/`dist`: a stable insertion (ties keep the earlier occluder first, as the CPU's stable
// sort). At most 64 occluders.
fn place_by_distance(idx: ptr<function, array<u32, 64>>, dist: ptr<function, array<f32, 64>>,
                     i: u32, d: f32) {
    var j = i;
    while (j > 0u && (*dist)[j - 1u] > d) {
        (*dist)[j] = (*dist)[j - 1u];
        (*idx)[j] = (*idx)[j - 1u];
        j--;
    }
    (*dist)[j] = d;
    (*idx)[j] = i;
}
