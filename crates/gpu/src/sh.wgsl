// Real SH evaluation for the GPU kernels; the including kernel binds `knorm`.

// Real orthonormal SH of docs/conventions.md (no Condon–Shortley phase) at the unit direction d,
// orders 0..order-1, written to y[l*l + l + m]. Recurrence in Cartesian form on
// P̄_l^m(z) = P_l^m(z) / sin^m θ, multiplied by Re/Im (x + iy)^m; `knorm[l*l+l+m]` (m ≥ 0) holds
// K_l^m, times √2 for m > 0, computed on the host in f64 from the factorial formula.
fn sh_eval(d: vec3<f32>, order: u32, y: ptr<function, array<f32, 64>>) {
    var c = 1.0;   // Re (x + iy)^m
    var s = 0.0;   // Im (x + iy)^m
    var pmm = 1.0; // P̄_m^m = (2m−1)!!
    for (var m = 0u; m < order; m++) {
        if (m > 0u) {
            let c2 = d.x * c - d.y * s;
            s = d.x * s + d.y * c;
            c = c2;
            pmm = pmm * f32(2u * m - 1u);
        }
        var p2 = 0.0;
        var p1 = pmm;
        for (var l = m; l < order; l++) {
            var p = p1;
            if (l == m + 1u) {
                p = d.z * f32(2u * m + 1u) * pmm;
            } else if (l > m + 1u) {
                p = (f32(2u * l - 1u) * d.z * p1 - f32(l + m - 1u) * p2) / f32(l - m);
            }
            let k = knorm[l * l + l + m] * p;
            if (m == 0u) {
                (*y)[l * l + l] = k;
            } else {
                (*y)[l * l + l + m] = k * c;
                (*y)[l * l + l - m] = k * s;
            }
            if (l > m) {
                p2 = p1;
            }
            p1 = p;
        }
    }
}

