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
use crate::evaluator::FullField;
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

/// Cached per-receiver shading data of a fully sampled shadow field ([`FullField`], Zhou et al.
/// 2005) under a fixed light and shared normal: the same fast path for the baseline. The field
/// is a fixed linear interpolation of its samples, `V(p) = Σᵢ wᵢ(p) Vᵢ` (up to eight samples:
/// two shells × the layout's cell), all in the entity frame, so
///
/// ```text
/// E(p) = ⟨T, V(p)⟩ = Σᵢ wᵢ(p) ⟨T, Vᵢ⟩
/// ```
///
/// The weights depend only on where the receiver sits against the shells and the layout; a
/// frame re-samples the shells, takes one N²-dot product per sample and channel, and then an
/// at most eight-term sum per receiver. Receivers beyond the outermost shell are unshadowed
/// (`E = ⟨T, √(4π)e₀⟩`).
pub struct FieldShadingCache {
    samples: usize,
    order: usize,
    /// Receiver r's pairs are `pairs[start[r]..start[r + 1]]`; none for an unshadowed one.
    start: Vec<u32>,
    pairs: Vec<(u32, f64)>,
    unshadowed: Vec<bool>,
}

impl FieldShadingCache {
    /// The interpolation of every receiver in `field` ([`FullField::weights`]).
    pub fn build(field: &FullField, receivers: &[DVec3]) -> Self {
        let rows: Vec<Option<crate::evaluator::FieldWeights>> =
            receivers.par_iter().map(|p| field.weights(*p)).collect();
        let mut start = Vec::with_capacity(rows.len() + 1);
        let mut pairs = Vec::new();
        let mut unshadowed = Vec::with_capacity(rows.len());
        start.push(0u32);
        for r in rows {
            if let Some((w, n)) = r {
                pairs.extend_from_slice(&w[..n]);
            }
            unshadowed.push(r.is_none());
            start.push(pairs.len() as u32);
        }
        Self {
            samples: field.sample_count(),
            order: field.order(),
            start,
            pairs,
            unshadowed,
        }
    }

    /// Number of receivers.
    pub fn len(&self) -> usize {
        self.unshadowed.len()
    }

    /// True without receivers.
    pub fn is_empty(&self) -> bool {
        self.unshadowed.is_empty()
    }

    /// Whether `field` has the sample count and order this cache was built for (its shells and
    /// layout must also be the same: the weights index its samples).
    pub fn matches(&self, field: &FullField) -> bool {
        field.sample_count() == self.samples && field.order() == self.order
    }

    /// Irradiance of every receiver for this frame's field under `transfer` (per channel `T`
    /// of the shared normal; a grey light's channels are dotted once).
    pub fn shade(&self, field: &FullField, transfer: &[Vec<f64>; 3], out: &mut [[f64; 3]]) {
        assert!(
            self.matches(field),
            "full-field cache built for another field"
        );
        let nn = self.order * self.order;
        let grey = transfer[0] == transfer[1] && transfer[1] == transfer[2];
        let channels = if grey { 1 } else { 3 };
        let dots: Vec<[f64; 3]> = (0..self.samples)
            .into_par_iter()
            .with_min_len(256)
            .map(|i| {
                let c = &field.sample(i)[..nn];
                let mut d = [0.0; 3];
                for ch in 0..channels {
                    d[ch] = c.iter().zip(&transfer[ch][..nn]).map(|(a, b)| a * b).sum();
                }
                if grey {
                    d = [d[0]; 3];
                }
                d
            })
            .collect();
        let one = (4.0 * std::f64::consts::PI).sqrt();
        let open = [0, 1, 2].map(|ch| one * transfer[ch][0]);
        out.par_iter_mut()
            .enumerate()
            .with_min_len(1024)
            .for_each(|(r, o)| {
                if self.unshadowed[r] {
                    *o = open;
                    return;
                }
                let mut e = [0.0; 3];
                let (a, b) = (self.start[r] as usize, self.start[r + 1] as usize);
                for &(i, w) in &self.pairs[a..b] {
                    let d = dots[i as usize];
                    for ch in 0..3 {
                        e[ch] += w * d[ch];
                    }
                }
                *o = e;
            });
    }
}
