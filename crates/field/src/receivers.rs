//! Per-receiver precomputation for one occluder's extrapolated field under a fixed light and
//! shared normal — the "compute only what the scene requires" fast path.
//!
//! With `V(p) = R M_k Rᵀ B(p)` (R the local→entity rotation of p, `B(p) = Σᵢ wᵢ Bᵢ` the BSV
//! interpolated at p's direction) and `E = ⟨T, V⟩` (T the light contracted with the normal's lobe),
//! orthogonality of R gives
//!
//! ```text
//! E(p) = ⟨U(p), B(p)⟩ = Σᵢ wᵢ ⟨U(p), Bᵢ⟩,    U(p) = R M_kᵀ Rᵀ T
//! ```
//!
//! `U`, the three sample indices and weights depend only on where the receiver sits relative to
//! the sampling sphere, on the table and on the light — not on the BSV. As long as those are fixed
//! (a deforming entity sampled on a fixed sphere, static receivers and light), a frame costs three
//! N²-dot products per receiver and channel, whatever the BSV. If the entity moves or its sampling
//! sphere changes, rebuild the cache ([`ReceiverCache::matches`] tells).
//! Beyond `k_max` the receiver is unshadowed (`E = ⟨T, √(4π)e₀⟩`).

use crate::bsv::Bsv;
use crate::frame::LocalFrame;
use glam::DVec3;
use rayon::prelude::*;
use shscale_geometry::Sphere;
use shscale_scaling::{KLookup, KTable, ScalingMatrix};
use shscale_sh::ShRotation;

/// One receiver while building: sample indices, weights, U, or the unshadowed constant.
type Row = ([u32; 3], [f64; 3], Vec<f64>, Option<[f64; 3]>);

/// Cached per-receiver shading data.
pub struct ReceiverCache {
    nn: usize,
    channels: usize,
    sphere: Sphere,
    sampling_radius: f64,
    samples: usize,
    idx: Vec<[u32; 3]>,
    w: Vec<[f64; 3]>,
    /// `channels × N²` per receiver, stored in f32 (halves the per-frame memory traffic, which
    /// bounds this loop; relative error ~1e-7); zero rows for unshadowed receivers.
    u: Vec<f32>,
    /// `Some(E)` for receivers beyond `k_max`.
    constant: Vec<Option<[f64; 3]>>,
}

impl ReceiverCache {
    /// Precompute for `receivers` (points ≠ the centre). `transfer` is the per-channel `T` of the
    /// shared normal; a grey light (identical channels) is cached once.
    pub fn build(bsv: &Bsv, table: &KTable, transfer: &[Vec<f64>; 3], receivers: &[DVec3]) -> Self {
        let order = table.order();
        let nn = order * order;
        let channels = if transfer[0] == transfer[1] && transfer[1] == transfer[2] {
            1
        } else {
            3
        };
        let c = bsv.sphere.center;
        let one = (4.0 * std::f64::consts::PI).sqrt();
        let rows: Vec<Row> = receivers
            .par_iter()
            .map_init(
                || ScalingMatrix::identity(order).expect("valid order"),
                |m, &p| {
                    // A receiver at the centre has no direction: nudge it as the extrapolator does.
                    let tiny = 1e-12 * bsv.sampling_radius;
                    let p = if (p - c).length() < tiny {
                        c + tiny * DVec3::Z
                    } else {
                        p
                    };
                    let d = p - c;
                    let k = d.length() / bsv.radius_at(d / d.length());
                    let status = table.lookup(k, m).expect("finite k > 0");
                    if let KLookup::AboveMax { .. } = status {
                        return (
                            [0; 3],
                            [0.0; 3],
                            Vec::new(),
                            Some([0, 1, 2].map(|ch| one * transfer[ch][0])),
                        );
                    }
                    let loc = bsv.locate(d.normalize());
                    let f = LocalFrame::toward(p, c);
                    let rot = ShRotation::new(order, &f.matrix()).expect("valid order");
                    let mt = m.transpose();
                    let mut u = vec![0.0; channels * nn];
                    let (mut a, mut b) = (vec![0.0; nn], vec![0.0; nn]);
                    for ch in 0..channels {
                        rot.apply_inverse(&transfer[ch], &mut a)
                            .expect("lengths agree");
                        mt.apply_unchecked(&a, &mut b);
                        rot.apply(&b, &mut u[ch * nn..(ch + 1) * nn])
                            .expect("lengths agree");
                    }
                    (loc.map(|x| x.0), loc.map(|x| x.1), u, None)
                },
            )
            .collect();
        let mut cache = Self {
            nn,
            channels,
            sphere: bsv.sphere,
            sampling_radius: bsv.sampling_radius,
            samples: bsv.samples.len(),
            idx: Vec::with_capacity(rows.len()),
            w: Vec::with_capacity(rows.len()),
            u: Vec::with_capacity(rows.len() * channels * nn),
            constant: Vec::with_capacity(rows.len()),
        };
        for (i, w, u, k) in rows {
            cache.idx.push(i);
            cache.w.push(w);
            if k.is_none() {
                cache.u.extend(u.iter().map(|v| *v as f32));
            } else {
                cache.u.extend(std::iter::repeat_n(0.0, channels * nn));
            }
            cache.constant.push(k);
        }
        cache
    }

    /// Whether `bsv` was sampled on the same sphere and layout size this cache was built for.
    pub fn matches(&self, bsv: &Bsv) -> bool {
        bsv.sphere == self.sphere
            && bsv.sampling_radius == self.sampling_radius
            && bsv.samples.len() == self.samples
            && bsv.radii.is_empty()
    }

    /// Number of receivers.
    pub fn len(&self) -> usize {
        self.idx.len()
    }

    /// True without receivers.
    pub fn is_empty(&self) -> bool {
        self.idx.is_empty()
    }

    /// Channels cached per receiver: 1 for a grey light, else 3.
    pub fn channels(&self) -> usize {
        self.channels
    }

    /// The cached rows, for other evaluators of the same identity (the GPU path): per receiver
    /// the three sample indices and weights, `channels × N²` values of `U` (f32, zero for
    /// unshadowed receivers) and the constant irradiance of receivers beyond `k_max`.
    #[allow(clippy::type_complexity)]
    pub fn rows(&self) -> (&[[u32; 3]], &[[f64; 3]], &[f32], &[Option<[f64; 3]>]) {
        (&self.idx, &self.w, &self.u, &self.constant)
    }

    /// Irradiance of every receiver for this frame's BSV (`matches(bsv)` must hold).
    pub fn shade(&self, bsv: &Bsv, out: &mut [[f64; 3]]) {
        assert!(
            self.matches(bsv),
            "receiver cache built for another sampling sphere"
        );
        let nn = self.nn;
        let stride = self.channels * nn;
        // One contiguous copy of this frame's sample coefficients (30 KB at 240 samples, N = 4):
        // no pointer chasing through each sample's own allocation in the hot loop.
        let flat: Vec<f64> = bsv
            .samples
            .iter()
            .flat_map(|s| s.coeffs[..nn].iter().copied())
            .collect();
        out.par_iter_mut()
            .enumerate()
            .with_min_len(1024)
            .for_each(|(r, o)| {
                if let Some(e) = self.constant[r] {
                    *o = e;
                    return;
                }
                let u = &self.u[r * stride..(r + 1) * stride];
                let [i0, i1, i2] =
                    self.idx[r].map(|i| &flat[i as usize * nn..(i as usize + 1) * nn]);
                let [w0, w1, w2] = self.w[r];
                let mut e = [0.0; 3];
                for ch in 0..self.channels {
                    let uc = &u[ch * nn..(ch + 1) * nn];
                    // Four independent accumulators: the sum is latency-bound otherwise.
                    let mut acc = [0.0f64; 4];
                    let (full, rest) = (nn / 4 * 4, nn % 4);
                    for j in (0..full).step_by(4) {
                        for q in 0..4 {
                            let b = w0 * i0[j + q] + w1 * i1[j + q] + w2 * i2[j + q];
                            acc[q] += uc[j + q] as f64 * b;
                        }
                    }
                    for j in full..full + rest {
                        acc[0] += uc[j] as f64 * (w0 * i0[j] + w1 * i1[j] + w2 * i2[j]);
                    }
                    e[ch] = (acc[0] + acc[1]) + (acc[2] + acc[3]);
                }
                if self.channels == 1 {
                    e[1] = e[0];
                    e[2] = e[0];
                }
                *o = e;
            });
    }
}
