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

/// An environment light: RGB radiance as SH coefficients (entity/world frame), and where known the
/// environment itself (`source`) for full-frequency truth.
#[derive(Clone, Debug, PartialEq)]
pub struct EnvLight {
    pub rgb: [Vec<f64>; 3],
    /// The environment at full frequency (closed-form sky or the map at its own resolution);
    /// `None` when only the SH projection is known (full-frequency truth then lights with the
    /// band-limited light and says so, [`EnvLight::truth_light`]).
    pub source: Option<EnvSource>,
}

/// The environment at full frequency.
#[derive(Clone, Debug, PartialEq)]
pub enum EnvSource {
    /// `L(ω) = a + b·max(0, ω·up) + sun·[ω within sun_radius of sun_dir]` (grey).
    Sky {
        a: f64,
        b: f64,
        up: DVec3,
        sun: f64,
        sun_dir: DVec3,
        sun_radius: f64,
    },
    /// A lat-long map (row 0 at +z, texel-constant radiance) with its sampling tables.
    Map(std::sync::Arc<EnvMap>),
}

/// A lat-long radiance map and the tables that sample it in proportion to luminance × solid angle.
#[derive(Debug, PartialEq)]
pub struct EnvMap {
    pub width: usize,
    pub height: usize,
    pub rgb: Vec<[f32; 3]>,
    /// Cumulative weight per row (`height + 1` entries from 0) and per texel within each row
    /// (`height × (width + 1)`), weights `(luminance + ε) · Ω_texel`.
    rows: Vec<f64>,
    cols: Vec<f64>,
}

impl EnvMap {
    /// Build the tables (ε = 1e-3 of the mean luminance keeps every texel reachable, so the
    /// estimator stays unbiased where the map is black).
    pub fn new(width: usize, height: usize, rgb: Vec<[f32; 3]>) -> Self {
        let lum = |t: &[f32; 3]| 0.2126 * t[0] as f64 + 0.7152 * t[1] as f64 + 0.0722 * t[2] as f64;
        let mean = rgb.iter().map(lum).sum::<f64>() / rgb.len().max(1) as f64;
        let eps = 1e-3 * mean.max(1e-30);
        let mut rows = vec![0.0];
        let mut cols = Vec::with_capacity(height * (width + 1));
        for j in 0..height {
            let (t0, t1) = (
                std::f64::consts::PI * j as f64 / height as f64,
                std::f64::consts::PI * (j + 1) as f64 / height as f64,
            );
            let omega = (t0.cos() - t1.cos()) * std::f64::consts::TAU / width as f64;
            let mut acc = 0.0;
            cols.push(0.0);
            for i in 0..width {
                acc += (lum(&rgb[j * width + i]) + eps) * omega;
                cols.push(acc);
            }
            rows.push(rows[j] + acc);
        }
        Self {
            width,
            height,
            rgb,
            rows,
            cols,
        }
    }

    /// A direction drawn from `(u, v, s, t) ∈ [0, 1)⁴` with density ∝ weight (uniform in solid
    /// angle within the texel), the texel's radiance and the density (per steradian).
    fn sample(&self, u: f64, v: f64, s: f64, t: f64) -> (DVec3, [f64; 3], f64) {
        let total = self.rows[self.height];
        let j = (self.rows.partition_point(|&c| c <= u * total).max(1) - 1).min(self.height - 1);
        let row = &self.cols[j * (self.width + 1)..(j + 1) * (self.width + 1)];
        let rt = row[self.width];
        let i = (row.partition_point(|&c| c <= v * rt).max(1) - 1).min(self.width - 1);
        let (t0, t1) = (
            std::f64::consts::PI * j as f64 / self.height as f64,
            std::f64::consts::PI * (j + 1) as f64 / self.height as f64,
        );
        let z = t0.cos() + s * (t1.cos() - t0.cos());
        let phi = std::f64::consts::TAU * (i as f64 + t) / self.width as f64;
        let r = (1.0 - z * z).max(0.0).sqrt();
        let omega = (t0.cos() - t1.cos()) * std::f64::consts::TAU / self.width as f64;
        let p_texel = (row[i + 1] - row[i]) / total;
        let texel = self.rgb[j * self.width + i];
        (
            DVec3::new(r * phi.cos(), r * phi.sin(), z),
            texel.map(f64::from),
            p_texel / omega,
        )
    }

    /// The radiance of the texel containing `d`.
    pub fn radiance(&self, d: DVec3) -> [f64; 3] {
        let theta = d.z.clamp(-1.0, 1.0).acos();
        let phi = d.y.atan2(d.x).rem_euclid(std::f64::consts::TAU);
        let j = ((theta / std::f64::consts::PI * self.height as f64) as usize).min(self.height - 1);
        let i = ((phi / std::f64::consts::TAU * self.width as f64) as usize).min(self.width - 1);
        self.rgb[j * self.width + i].map(f64::from)
    }
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
    ) -> Result<Self, crate::error::FieldError> {
        if rgb.len() != width * height || width == 0 || height == 0 {
            return Err(crate::error::FieldError::Spec(format!(
                "lat-long map: {} texels for {width}×{height}",
                rgb.len()
            )));
        }
        if let Some(i) = rgb
            .iter()
            .position(|t| t.iter().any(|v| !v.is_finite() || *v < 0.0))
        {
            return Err(crate::error::FieldError::Spec(format!(
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
        Ok(Self {
            rgb: out,
            source: Some(EnvSource::Map(std::sync::Arc::new(EnvMap::new(
                width,
                height,
                rgb.to_vec(),
            )))),
        })
    }

    /// What full-frequency truth lights with: `"closed-form sky"`, `"map texels"` or
    /// `"band-limited light"` (only the SH projection is known).
    pub fn truth_light(&self) -> &'static str {
        match &self.source {
            Some(EnvSource::Sky { .. }) => "closed-form sky",
            Some(EnvSource::Map(_)) => "map texels",
            None => "band-limited light",
        }
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
    ) -> Result<Self, crate::error::FieldError> {
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
            source: Some(EnvSource::Sky {
                a,
                b,
                up: up.normalize(),
                sun,
                sun_dir: sun_dir.normalize(),
                sun_radius,
            }),
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
    pub fn new(order: usize) -> Result<Self, crate::error::FieldError> {
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
        let mut v = vec![0.0; self.order * self.order];
        let (products, skipped) =
            crate::subvolume::near_to_far(&self.gaunt, fields, centers, p, &mut v);
        (v, products, skipped)
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

/// Bands of the sun's cap in [`irradiance_exact`] at resolution `res` (`2·bands²` rays per
/// estimate).
pub fn sun_bands(res: usize) -> usize {
    (res / 2).max(4)
}

/// Full-frequency irradiance and its own estimated error (per channel).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Irradiance {
    pub e: [f64; 3],
    /// `|A − B| / 2` of the two independent estimates (0 for parts integrated deterministically).
    pub err: [f64; 3],
}

/// Full-frequency irradiance truth lit by the environment itself ([`EnvLight::source`]):
/// `E = ∫ L(ω) Πⱼ Vⱼ(ω) max(0, n·ω) dω` with the exact (ray-cast) visibility. Two independent
/// stratified estimates A, B (each from [`crate::truth::SplitMix::at`] of `seed` and the point),
/// their mean returned with the error estimate `|A − B|/2`:
///
/// * closed-form sky: the smooth part `a + b·max(0, ω·up)` over the hemisphere about `n`
///   (`res` bands of equal solid angle × `2res` sectors, one jittered ray each, the pattern turned
///   about `n` by a random angle), the sun disc separately over its own cap (`max(4, res/2)` bands ×
///   twice as many sectors), so the disc's edge and brightness cost no resolution;
/// * a map: `2res²` rays per estimate drawn in proportion to texel luminance × solid angle
///   (stratified over the unit square), each weighted by `L / pdf` — unbiased for the texel-constant
///   map at its own resolution.
///
/// Without a source the band-limited light is integrated as [`irradiance_full_frequency_with`]
/// does (`err` = 0, and [`EnvLight::truth_light`] says so). Local lights (`emitters`) are added
/// as by [`irradiance_full_frequency_with`] with `2res` Gauss–Legendre rings (deterministic).
#[allow(clippy::too_many_arguments)]
pub fn irradiance_exact(
    light: &EnvLight,
    occs: &[&dyn shscale_geometry::Occluder],
    emitters: &[[Option<&crate::radiance::Emitter>; 3]],
    p: DVec3,
    n: DVec3,
    res: usize,
    seed: u64,
) -> Irradiance {
    let n = n.normalize();
    let res = res.max(1);
    let Some(source) = &light.source else {
        return Irradiance {
            e: irradiance_full_frequency_with(light, occs, emitters, p, n, 2 * res),
            err: [0.0; 3],
        };
    };
    let visible = |d: DVec3| {
        !occs.iter().any(|o| {
            o.occluded(
                p,
                d,
                shscale_geometry::RAY_EPS * o.bounding_sphere().radius,
                f64::INFINITY,
            )
        })
    };
    let mut rng = crate::truth::SplitMix::at(seed, p);
    let mut est = [[0.0f64; 3]; 2];
    for e in est.iter_mut() {
        *e = source_estimate(source, n, res, &mut rng, &visible);
    }
    let local = if emitters.is_empty() {
        [0.0; 3]
    } else {
        let none = EnvLight {
            rgb: [0, 1, 2].map(|_| vec![0.0; light.rgb[0].len()]),
            source: None,
        };
        irradiance_full_frequency_with(&none, occs, emitters, p, n, 2 * res)
    };
    Irradiance {
        e: [0, 1, 2].map(|c| 0.5 * (est[0][c] + est[1][c]) + local[c]),
        err: [0, 1, 2].map(|c| 0.5 * (est[0][c] - est[1][c]).abs()),
    }
}

/// One stratified estimate of `∫ L V max(0, n·ω) dω` of the environment's full-frequency
/// source (see [`irradiance_exact`]): the sky's smooth part over the hemisphere about `n` and
/// its sun over the sun's own cap, or the map by luminance-proportional sampling.
fn source_estimate(
    source: &EnvSource,
    n: DVec3,
    res: usize,
    rng: &mut crate::truth::SplitMix,
    visible: &dyn Fn(DVec3) -> bool,
) -> [f64; 3] {
    match source {
        EnvSource::Sky {
            a,
            b,
            up,
            sun,
            sun_dir,
            sun_radius,
        } => {
            let fh = crate::frame::LocalFrame::from_z(n);
            let fs = crate::frame::LocalFrame::from_z(*sun_dir);
            // Hemisphere about n (z = cos θ ∈ [0, 1]), then the sun disc over its own cap.
            let mut acc = stratified_cap(&fh, 1.0, res, rng, |d, z| {
                if visible(d) {
                    (a + b * d.dot(*up).max(0.0)) * z
                } else {
                    0.0
                }
            });
            if *sun > 0.0 && *sun_radius > 0.0 {
                let cap = 1.0 - sun_radius.cos();
                acc += stratified_cap(&fs, cap, sun_bands(res), rng, |d, _| {
                    let c = d.dot(n);
                    if c > 0.0 && visible(d) {
                        sun * c
                    } else {
                        0.0
                    }
                });
            }
            [acc; 3]
        }
        EnvSource::Map(map) => {
            let m = 2 * res * res;
            let mut acc = [0.0; 3];
            for i in 0..res {
                for j in 0..2 * res {
                    let u = (i as f64 + rng.unit()) / res as f64;
                    let v = (j as f64 + rng.unit()) / (2 * res) as f64;
                    let (d, l, pdf) = map.sample(u, v, rng.unit(), rng.unit());
                    let c = d.dot(n);
                    if c > 0.0 && pdf > 0.0 && visible(d) {
                        for k in 0..3 {
                            acc[k] += l[k] * c / pdf;
                        }
                    }
                }
            }
            acc.map(|x| x / m as f64)
        }
    }
}

/// `∫ f` over the cap `z ∈ [1 − height, 1]` about the z axis of `frame`, by `bands` bands of equal
/// solid angle × `2·bands` sectors, one jittered direction in each, the pattern turned about the
/// axis by a random angle; `f` gets the direction (world) and its `z`.
fn stratified_cap(
    frame: &crate::frame::LocalFrame,
    height: f64,
    bands: usize,
    rng: &mut crate::truth::SplitMix,
    mut f: impl FnMut(DVec3, f64) -> f64,
) -> f64 {
    let rot = std::f64::consts::TAU * rng.unit();
    let w = std::f64::consts::TAU * height / (2 * bands * bands) as f64;
    let mut acc = 0.0;
    for i in 0..bands {
        for j in 0..2 * bands {
            let z = 1.0 - height * (i as f64 + rng.unit()) / bands as f64;
            let phi = rot + std::f64::consts::PI * (j as f64 + rng.unit()) / bands as f64;
            let r = (1.0 - z * z).max(0.0).sqrt();
            acc += w * f(
                frame.to_world(DVec3::new(r * phi.cos(), r * phi.sin(), z)),
                z,
            );
        }
    }
    acc
}

#[inline]
fn e_acc_add(e: &mut [f64; 3], c: usize, v: f64) {
    e[c] += v;
}

#[cfg(test)]
mod exact_light_tests {
    use super::*;
    use shscale_geometry::AnalyticSphere;
    use std::f64::consts::PI;

    /// Oracles in closed form for the sky with its sun: an unshadowed receiver
    /// (`aπ + 2πb/3 + sun·π sin²r cos θ_s`, the projected solid angle of a cap above the horizon),
    /// and a receiver under the unit sphere at height 2 that hides the 30° cap about the zenith
    /// (`aπ cos²30° + (2π/3) b cos³30° + sun·π sin²r cos θ_s`, the sun outside the shadow). The
    /// error estimate covers the actual error; the SH-projected light is far from both.
    #[test]
    fn exact_sky_irradiance_matches_the_closed_forms() {
        let (a, b, sun, r) = (0.2, 0.6, 40.0, 8f64.to_radians());
        for (theta_s, occluded) in [(30f64.to_radians(), false), (50f64.to_radians(), true)] {
            let sun_dir = DVec3::new(theta_s.sin(), 0.0, theta_s.cos());
            let light = EnvLight::sky(8, a, b, DVec3::Z, sun, sun_dir, r).unwrap();
            assert_eq!(light.truth_light(), "closed-form sky");
            let shifted = AnalyticSphere {
                sphere: shscale_geometry::Sphere {
                    center: DVec3::new(0.0, 0.0, 2.0),
                    radius: 1.0,
                },
            };
            let occs: Vec<&dyn shscale_geometry::Occluder> =
                if occluded { vec![&shifted] } else { vec![] };
            let c = 30f64.to_radians().cos();
            let (ka, kb) = if occluded {
                (c * c, c * c * c)
            } else {
                (1.0, 1.0)
            };
            let want =
                a * PI * ka + b * 2.0 * PI / 3.0 * kb + sun * PI * r.sin().powi(2) * theta_s.cos();
            let got = irradiance_exact(&light, &occs, &[], DVec3::ZERO, DVec3::Z, 48, 7);
            let band = irradiance_full_frequency_with(
                &EnvLight {
                    source: None,
                    ..light.clone()
                },
                &occs,
                &[],
                DVec3::ZERO,
                DVec3::Z,
                96,
            );
            let rel = (got.e[0] - want).abs() / want;
            println!(
                "θ_s = {:.0}°, occluded {occluded}: exact-light {:.6} (± {:.1e}), closed form {want:.6}, rel {rel:.1e}; band-limited light {:.6} ({:+.1}%)",
                theta_s.to_degrees(), got.e[0], got.err[0], band[0], 100.0 * (band[0] / want - 1.0)
            );
            assert!(rel < 2e-3, "{rel:e}");
            assert!((got.e[0] - want).abs() < 4.0 * got.err[0] + 1e-3 * want);
            assert_eq!(got.e[0], got.e[1]);
        }
    }

    /// A map: a constant map gives π (the cosine integral) to its estimated error; a random
    /// 32 × 16 map agrees with brute-force texel quadrature (8 × 8 sub-samples per texel).
    #[test]
    fn map_irradiance_matches_texel_quadrature() {
        let (w, h) = (32, 16);
        let mut rng = crate::truth::SplitMix(5);
        let rgb: Vec<[f32; 3]> = (0..w * h)
            .map(|i| {
                let hot = if i % 37 == 3 { 40.0 } else { 0.0 };
                [0, 1, 2].map(|_| (rng.unit() + hot) as f32)
            })
            .collect();
        let light = EnvLight::from_latlong(4, w, h, &rgb).unwrap();
        assert_eq!(light.truth_light(), "map texels");
        let n = DVec3::new(0.3, -0.2, 0.9).normalize();
        let mut want = [0.0; 3];
        let sub = 8;
        for j in 0..h {
            for i in 0..w {
                for sj in 0..sub {
                    for si in 0..sub {
                        let t0 = PI * (j as f64 + sj as f64 / sub as f64) / h as f64;
                        let t1 = PI * (j as f64 + (sj + 1) as f64 / sub as f64) / h as f64;
                        let phi = 2.0 * PI * (i as f64 + (si as f64 + 0.5) / sub as f64) / w as f64;
                        let th = 0.5 * (t0 + t1);
                        let d = DVec3::new(th.sin() * phi.cos(), th.sin() * phi.sin(), th.cos());
                        let omega = (t0.cos() - t1.cos()) * 2.0 * PI / (w * sub) as f64;
                        for (k, x) in want.iter_mut().enumerate() {
                            *x += rgb[j * w + i][k] as f64 * d.dot(n).max(0.0) * omega;
                        }
                    }
                }
            }
        }
        let got = irradiance_exact(&light, &[], &[], DVec3::ZERO, n, 64, 3);
        for k in 0..3 {
            let rel = (got.e[k] - want[k]).abs() / want[k];
            println!(
                "channel {k}: {:.5} ± {:.1e} vs texel quadrature {:.5} (rel {rel:.1e})",
                got.e[k], got.err[k], want[k]
            );
            assert!(rel < 5e-3, "{rel:e}");
        }
        let flat = EnvLight::from_latlong(4, w, h, &vec![[1.0; 3]; w * h]).unwrap();
        let c = irradiance_exact(&flat, &[], &[], DVec3::ZERO, DVec3::Z, 48, 1);
        println!("constant map: {:.6} ± {:.1e} vs π", c.e[0], c.err[0]);
        assert!(
            (c.e[0] - PI).abs() < 5e-3 * PI && (c.e[0] - PI).abs() < 4.0 * c.err[0],
            "{}",
            c.e[0]
        );
    }
}
