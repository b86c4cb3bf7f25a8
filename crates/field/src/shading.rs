//! Diffuse shading with SH visibility (docs/conventions.md §5; Zhou et al. 2005 §5):
//! `E(p) = ∫ L(ω) Πⱼ Vⱼ(ω) max(0, n·ω) dω`.
//!
//! Per normal n, the light is contracted with the clamped-cosine lobe once,
//! `T(n) = P_N(L · lobe(n))` (a triple product), so a receiver costs one dot product
//! `E = ⟨T(n), V⟩` with its combined visibility `V`; receivers that share a normal share `T`.
//! Several occluders combine by SH products taken near to far (the shadow-field convention; the
//! truncated product is commutative, so two occluders commute exactly, but it is not associative,
//! so the order matters from three on). An occluder whose field reports "unoccluded" (visibility
//! exactly the constant 1) is skipped: no product is computed for it.
//!
//! Exactness: with no occluder, `E = ⟨T, √(4π)e₀⟩ = Σᵢ Lᵢ lobeᵢ(n)` — the band-limited irradiance of
//! Ramamoorthi & Hanrahan (2001) — exactly (tested).

use crate::evaluator::VisibilityField;
use glam::DVec3;
use shscale_geometry::Occluder;
use shscale_sh::{
    cap_zonal, clamped_cosine_zonal, rotate_zonal, ClampedCosine, GauntTensor, ShBasis,
};

/// An environment light: RGB radiance as SH coefficients (entity/world frame).
#[derive(Clone, Debug, PartialEq)]
pub struct EnvLight {
    pub rgb: [Vec<f64>; 3],
}

impl EnvLight {
    /// Order N of the light.
    pub fn order(&self) -> usize {
        (self.rgb[0].len() as f64).sqrt().round() as usize
    }

    /// Project a lat-long map (`width × height` RGB texels, row 0 at θ = 0, i.e. +z; texel
    /// centres; weights the exact texel solid angles) to order N.
    pub fn from_latlong(
        order: usize,
        width: usize,
        height: usize,
        rgb: &[[f32; 3]],
    ) -> Result<Self, crate::FieldError> {
        if rgb.len() != width * height || width == 0 || height == 0 {
            return Err(crate::FieldError::Spec(format!(
                "lat-long map: {} texels for {width}×{height}",
                rgb.len()
            )));
        }
        if let Some(i) = rgb
            .iter()
            .position(|t| t.iter().any(|v| !v.is_finite() || *v < 0.0))
        {
            return Err(crate::FieldError::Spec(format!(
                "lat-long map: texel {i} (row {}, column {}) is negative or not finite",
                i / width,
                i % width
            )));
        }
        let basis = ShBasis::<f64>::new(order)?;
        let set = shscale_sh::DirectionSet::latlong(height, width);
        let mut out = [
            vec![0.0; order * order],
            vec![0.0; order * order],
            vec![0.0; order * order],
        ];
        let mut y = vec![0.0; order * order];
        for ((d, &w), t) in set.dirs.iter().zip(&set.weights).zip(rgb) {
            basis.eval(*d, &mut y);
            for c in 0..3 {
                let f = w * t[c] as f64;
                out[c].iter_mut().zip(&y).for_each(|(o, v)| *o += f * v);
            }
        }
        Ok(Self { rgb: out })
    }

    /// A procedural sky in closed form: `L(ω) = a + b·max(0, ω·up) + sun·[ω within `sun_radius` of
    /// `sun_dir`]`, grey (equal channels). Each term's SH is exact: constant, clamped-cosine lobe,
    /// and a cap.
    pub fn sky(
        order: usize,
        a: f64,
        b: f64,
        up: DVec3,
        sun: f64,
        sun_dir: DVec3,
        sun_radius: f64,
    ) -> Result<Self, crate::FieldError> {
        let basis = ShBasis::<f64>::new(order)?;
        let mut l = vec![0.0; order * order];
        l[0] = a * (4.0 * std::f64::consts::PI).sqrt();
        let mut tmp = vec![0.0; order * order];
        rotate_zonal(
            &basis,
            &clamped_cosine_zonal(order),
            up.normalize().to_array(),
            &mut tmp,
        )?;
        l.iter_mut().zip(&tmp).for_each(|(o, v)| *o += b * v);
        rotate_zonal(
            &basis,
            &cap_zonal(order, sun_radius)?,
            sun_dir.normalize().to_array(),
            &mut tmp,
        )?;
        l.iter_mut().zip(&tmp).for_each(|(o, v)| *o += sun * v);
        Ok(Self {
            rgb: [l.clone(), l.clone(), l],
        })
    }
}

/// Shading tables of one order: Gaunt tensor and cosine lobe.
pub struct Shader {
    order: usize,
    gaunt: GauntTensor<f64>,
    lobe: ClampedCosine<f64>,
}

impl Shader {
    /// Tables for order N (≤ 32, the Gaunt tensor's limit).
    pub fn new(order: usize) -> Result<Self, crate::FieldError> {
        Ok(Self {
            order,
            gaunt: GauntTensor::new(order)?,
            lobe: ClampedCosine::new(order)?,
        })
    }

    /// `T(n) = P_N(L · max(0, n·ω))` per channel, for unit normal `n`.
    pub fn transfer(&self, light: &EnvLight, n: DVec3) -> [Vec<f64>; 3] {
        let nn = self.order * self.order;
        let mut lobe = vec![0.0; nn];
        self.lobe
            .lobe(n.to_array(), &mut lobe)
            .expect("lengths agree");
        let mut out = [vec![0.0; nn], vec![0.0; nn], vec![0.0; nn]];
        for c in 0..3 {
            self.gaunt
                .product(&light.rgb[c], &lobe, &mut out[c])
                .expect("lengths agree");
        }
        out
    }

    /// Combined visibility at `p` of `fields`, multiplied near to far (by distance from `p` to each
    /// field's `centers` entry); fields that return the unoccluded constant are skipped.
    /// Returns the product and how many products were computed.
    pub fn combined_visibility(
        &self,
        fields: &[&dyn VisibilityField],
        centers: &[DVec3],
        p: DVec3,
    ) -> (Vec<f64>, usize) {
        let (v, products, _) = self.combined_visibility_counted(fields, centers, p);
        (v, products)
    }

    /// As [`Shader::combined_visibility`], also counting the fields skipped as unoccluded.
    pub fn combined_visibility_counted(
        &self,
        fields: &[&dyn VisibilityField],
        centers: &[DVec3],
        p: DVec3,
    ) -> (Vec<f64>, usize, usize) {
        let nn = self.order * self.order;
        let mut order: Vec<usize> = (0..fields.len()).collect();
        order.sort_by(|&a, &b| {
            (centers[a] - p)
                .length()
                .total_cmp(&(centers[b] - p).length())
        });
        let mut acc = vec![0.0; nn];
        acc[0] = (4.0 * std::f64::consts::PI).sqrt();
        let mut v = vec![0.0; nn];
        let mut tmp = vec![0.0; nn];
        let mut first = true;
        let mut products = 0;
        let mut skipped = 0;
        for j in order {
            fields[j].eval(p, &mut v);
            if v[1..].iter().all(|x| *x == 0.0) && (v[0] - acc_one()).abs() == 0.0 {
                skipped += 1;
                continue; // unoccluded: nothing to multiply
            }
            if first {
                acc.copy_from_slice(&v);
                first = false;
            } else {
                self.gaunt
                    .product(&acc, &v, &mut tmp)
                    .expect("lengths agree");
                std::mem::swap(&mut acc, &mut tmp);
                products += 1;
            }
        }
        (acc, products, skipped)
    }

    /// Irradiance from one channel of a local light with radiance SH `l` at a receiver with normal
    /// `n` and visibility `v`: `⟨P_N(l · lobe(n)), v⟩` (a triple product per receiver: the light
    /// varies from receiver to receiver).
    pub fn shade_local(&self, l: &[f64], n: DVec3, v: &[f64]) -> f64 {
        let nn = self.order * self.order;
        let mut lobe = vec![0.0; nn];
        self.lobe
            .lobe(n.to_array(), &mut lobe)
            .expect("lengths agree");
        let mut t = vec![0.0; nn];
        self.gaunt.product(l, &lobe, &mut t).expect("lengths agree");
        t.iter().zip(v).map(|(a, b)| a * b).sum()
    }

    /// `E = ⟨T, V⟩` per channel.
    pub fn shade(t: &[Vec<f64>; 3], v: &[f64]) -> [f64; 3] {
        [0, 1, 2].map(|c| t[c].iter().zip(v).map(|(a, b)| a * b).sum())
    }
}

#[inline]
fn acc_one() -> f64 {
    (4.0 * std::f64::consts::PI).sqrt()
}

/// `shade_rmse_rel` (docs/conventions.md §6): RMSE of `E` over receivers divided by the mean unshadowed `E`.
pub fn shade_rmse_rel(e: &[f64], truth: &[f64], unshadowed: &[f64]) -> Option<f64> {
    if e.is_empty() || e.len() != truth.len() || e.len() != unshadowed.len() {
        return None;
    }
    let rmse = (e
        .iter()
        .zip(truth)
        .map(|(a, b)| (a - b) * (a - b))
        .sum::<f64>()
        / e.len() as f64)
        .sqrt();
    let mean = unshadowed.iter().sum::<f64>() / unshadowed.len() as f64;
    (mean > 0.0).then(|| rmse / mean)
}

/// Full-frequency irradiance truth: `E = ∫ L(ω) Πⱼ Vⱼ(ω) max(0, n·ω) dω` by Gauss–Legendre
/// quadrature over the hemisphere about the unit normal `n` (`h × h` rays), with the exact
/// (ray-cast, not band-limited) visibility of every occluder and the light's SH evaluated per
/// direction. What a path tracer would see with this light; the reference for `shade_rmse_rel`
/// against full-frequency truth (docs/conventions.md §6).
pub fn irradiance_full_frequency(
    light: &EnvLight,
    occs: &[&dyn shscale_geometry::Occluder],
    p: DVec3,
    n: DVec3,
    h: usize,
) -> [f64; 3] {
    irradiance_full_frequency_with(light, occs, &[], p, n, h)
}

/// As [`irradiance_full_frequency`], plus local lights (one optional emitter per channel per
/// light): a ray adds an emitter's radiance when it reaches the emitter before any occluder.
/// Emitters do not block the environment (as in the SH methods, where lights cast no shadows).
pub fn irradiance_full_frequency_with(
    light: &EnvLight,
    occs: &[&dyn shscale_geometry::Occluder],
    emitters: &[[Option<&crate::radiance::Emitter>; 3]],
    p: DVec3,
    n: DVec3,
    h: usize,
) -> [f64; 3] {
    let order = light.order();
    let basis = ShBasis::<f64>::new(order).expect("valid order");
    let set = shscale_sh::DirectionSet::gauss_hemisphere(h.max(1));
    let f = crate::frame::LocalFrame::from_z(n.normalize());
    let mut y = vec![0.0; order * order];
    let mut e = [0.0; 3];
    let mut e_local = [0.0; 3];
    for (d, &w) in set.dirs.iter().zip(&set.weights) {
        let local = DVec3::from_array(*d);
        let dir = f.to_world(local);
        let t_occ = occs
            .iter()
            .filter_map(|o| {
                o.closest_hit(
                    p,
                    dir,
                    shscale_geometry::RAY_EPS * o.bounding_sphere().radius,
                    f64::INFINITY,
                )
            })
            .fold(f64::INFINITY, f64::min);
        for em in emitters {
            for (c, slot) in em.iter().enumerate() {
                if let Some(e) = slot {
                    let tmin = shscale_geometry::RAY_EPS * e.bvh.bounding_sphere().radius;
                    if e.bvh.closest_hit(p, dir, tmin, t_occ).is_some() {
                        e_acc_add(&mut e_local, c, w * e.radiance_along(p, dir) * local.z);
                    }
                }
            }
        }
        if t_occ < f64::INFINITY {
            continue;
        }
        basis.eval(dir.to_array(), &mut y);
        for c in 0..3 {
            let l: f64 = light.rgb[c].iter().zip(&y).map(|(a, b)| a * b).sum();
            e[c] += w * l * local.z;
        }
    }
    [0, 1, 2].map(|c| e[c] + e_local[c])
}

#[inline]
fn e_acc_add(e: &mut [f64; 3], c: usize, v: f64) {
    e[c] += v;
}
