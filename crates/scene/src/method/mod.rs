//! The methods' vocabulary: every way this project computes the visibility a receiver sees,
//! spelled one way ([`Method`]: the config's `method` cell, the CSV column, `render --method`,
//! Python), and the typed spec of each method a budget study compares ([`Spec`]), parsed once
//! from a kind's keys ([`Keys`]) (docs/methods.md).
//!
//! One file per method: `extrapolated.rs` ([`Extrapolation`]), `sub_volumes.rs`
//! ([`SubVolumeSpec`]), `full_field.rs` ([`FieldSpec`]), `ray_traced.rs` ([`RayTracedSpec`]) and
//! `sphere_set.rs` ([`SetSpec`], with the one factory of its combinations' tables). Each holds
//! its parameters, how they are parsed from the keys and checked, the keys it reads, its cost
//! (rays, bytes, seconds) and how it sets a render's settings, behind [`MethodSpec`]; [`Spec`] is the enum
//! of those types and [`REGISTRY`] the one line per method that ties a name to its parse.
//!
//! A key that the chosen method does not read must keep its default: given any other value it
//! is refused, naming the key and the method (Mitsuba's rule for unqueried properties), so it
//! never changes a run id without changing the run.

use crate::settings::RenderSettings;
use shscale_field::bsv::Layout;
use shscale_runner::check::Ends;
use shscale_runner::KeyError;

mod extrapolated;
mod full_field;
mod full_frequency;
pub mod name;
mod ray_traced;
mod sphere_set;
mod sub_volumes;

pub use crate::combine::{Combine, SphereFit};
pub use extrapolated::{Alpha, Extrapolation};
pub(crate) use full_field::FULL_FIELD_KEYS;
pub use full_field::{full_field_shells, FieldSpec};
pub use name::Method;
pub use ray_traced::RayTracedSpec;
pub use sphere_set::{
    SetField, SetSpec, SetTables, SPHERE_DIRECTION_SECONDS, SPHERE_QUADRATURE_RES, SPHERE_SECONDS,
    SPHERE_TEST_SECONDS, UNION_RINGS,
};
pub(crate) use sub_volumes::check_log_space;
pub use sub_volumes::SubVolumeSpec;

/// The raw method keys of a kind's parameters (each kind fills the ones it has; a key it does
/// not offer is `None`, and the method uses the fixed value the kind documents).
#[derive(Clone, Copy, Debug)]
pub struct Keys<'a> {
    pub method: &'a str,
    pub parts: usize,
    pub layout: &'a str,
    pub hemisphere_res: usize,
    pub shells: usize,
    pub shell_max: f64,
    pub shell_spacing: &'a str,
    pub field_interp: &'a str,
    pub rt_res: usize,
    pub alpha_deg: f64,
    pub alpha_mode: Option<&'a str>,
    pub plausibility: &'a str,
    pub sampling_radius: f64,
    pub radial: &'a str,
    pub radial_delta: f64,
    pub radial_tau: Option<f64>,
    pub radial_max: Option<f64>,
    pub sphere_combine: Option<&'a str>,
    /// Which spheres a sphere set takes: `area` or `inscribed`.
    pub sphere_fit: Option<&'a str>,
    /// The internal order of a sphere set's products (0: the run's order).
    pub sphere_order: Option<usize>,
    /// How sub-volumes combine their parts: `product` or `shexp`.
    pub part_combine: Option<&'a str>,
    pub k_count: Option<usize>,
}

/// One method key's value as the kind holds it, compared by value (a number as a number:
/// `0.1` and `0.10`, `0` and `-0` are one value) — the unread-key rule's comparison — and shown
/// as its cell in messages.
#[derive(Clone, Copy, Debug)]
pub enum KeyValue<'a> {
    Int(usize),
    Real(f64),
    Text(&'a str),
}

impl PartialEq for KeyValue<'_> {
    fn eq(&self, o: &Self) -> bool {
        match (self, o) {
            (KeyValue::Int(a), KeyValue::Int(b)) => a == b,
            // Values of keys are finite (checked where they are read, or refused first).
            (KeyValue::Real(a), KeyValue::Real(b)) => a == b,
            (KeyValue::Text(a), KeyValue::Text(b)) => a == b,
            _ => false,
        }
    }
}

impl std::fmt::Display for KeyValue<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            KeyValue::Int(v) => write!(f, "{v}"),
            KeyValue::Real(v) => write!(f, "{v}"),
            KeyValue::Text(v) => f.write_str(v),
        }
    }
}

impl<'a> Keys<'a> {
    /// Every method key this kind offers with its value, in one order (the keys a kind does not
    /// offer, `None`, left out): the unread-key rule compares them with the defaults' by value.
    pub fn values(&self) -> Vec<(&'static str, KeyValue<'a>)> {
        use KeyValue::{Int, Real, Text};
        let mut v = vec![
            ("parts", Int(self.parts)),
            ("layout", Text(self.layout)),
            ("hemisphere_res", Int(self.hemisphere_res)),
            ("shells", Int(self.shells)),
            ("shell_max", Real(self.shell_max)),
            ("shell_spacing", Text(self.shell_spacing)),
            ("field_interp", Text(self.field_interp)),
            ("rt_res", Int(self.rt_res)),
            ("alpha_deg", Real(self.alpha_deg)),
            ("plausibility", Text(self.plausibility)),
            ("sampling_radius", Real(self.sampling_radius)),
            ("radial", Text(self.radial)),
            ("radial_delta", Real(self.radial_delta)),
        ];
        let offered = [
            ("alpha_mode", self.alpha_mode.map(Text)),
            ("radial_tau", self.radial_tau.map(Real)),
            ("radial_max", self.radial_max.map(Real)),
            ("sphere_combine", self.sphere_combine.map(Text)),
            ("sphere_fit", self.sphere_fit.map(Text)),
            ("sphere_order", self.sphere_order.map(Int)),
            ("part_combine", self.part_combine.map(Text)),
            ("k_count", self.k_count.map(Int)),
        ];
        v.extend(offered.into_iter().filter_map(|(k, c)| Some((k, c?))));
        v
    }

    /// [`Keys::values`] as cells (the GPU forms' [`crate::gpu_methods::unhonoured`]).
    pub fn cells(&self) -> Vec<(&'static str, String)> {
        (self.values().into_iter())
            .map(|(k, v)| (k, v.to_string()))
            .collect()
    }
}

/// What every method's spec answers (each method's file implements it for its type).
pub trait MethodSpec {
    /// The method keys this spec reads (the others must keep their defaults).
    fn reads(&self) -> Vec<&'static str>;
    /// The method's own domains at the run's order N, named by their keys (both budget kinds
    /// check it at plan time; `render` through the same code).
    fn check_order(&self, _order: usize) -> Result<(), KeyError> {
        Ok(())
    }
    /// Rays of one frame for `occluders` occluders and `receivers` receivers.
    fn rays(&self, occluders: f64, receivers: f64) -> f64;
    /// Bytes the method holds at order N for `occluders` occluders (`k_count` table entries
    /// where the spec leaves them to the scene).
    fn memory_bytes(&self, order: usize, occluders: f64, k_count: usize) -> f64;
    /// Seconds of one frame for the cost model: `rays` at `rays_per_second` unless the method
    /// prices its own work.
    fn seconds(&self, _order: usize, rays: f64, _receivers: f64, rays_per_second: f64) -> f64 {
        rays / rays_per_second
    }
    /// The method's parameters set on `rs` (the keys it does not read leave it as it is).
    fn apply(&self, rs: &mut RenderSettings);
    /// The spec as the vocabulary's enum.
    fn into_spec(self) -> Spec;
}

/// One method with everything it reads, parsed: the enum of the methods' own types.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Spec {
    Extrapolated(Extrapolation),
    FullField(FieldSpec),
    RayTraced(RayTracedSpec),
    SubVolumes(SubVolumeSpec),
    SphereSet(SetSpec),
}

/// The one dispatch from [`Spec`] to its method's type.
macro_rules! each {
    ($spec:expr, $m:ident => $e:expr) => {
        match $spec {
            Spec::Extrapolated($m) => $e,
            Spec::FullField($m) => $e,
            Spec::RayTraced($m) => $e,
            Spec::SubVolumes($m) => $e,
            Spec::SphereSet($m) => $e,
        }
    };
}

/// A method's parse from a kind's keys (`rt_res_max`: the kind's largest `rt_res`).
type Parse = fn(&Keys, usize) -> Result<Spec, KeyError>;

/// Each method's CPU render, from its own file (the one place a method's name meets its render).
pub(crate) fn cpu_form(m: Method) -> &'static crate::render::form::CpuForm {
    match m {
        Method::Extrapolated => &extrapolated::CPU,
        Method::FullField => &full_field::CPU,
        Method::RayTraced => &ray_traced::CPU,
        Method::FullFrequency => &full_frequency::CPU,
        Method::SubVolumes => &sub_volumes::CPU,
        Method::SphereSet => &sphere_set::CPU,
    }
}

/// The budgeted methods, one registration line each: the name's variant and its parse.
pub const REGISTRY: [(Method, Parse); 5] = [
    (Method::Extrapolated, |k, _| {
        Extrapolation::parse(k).map(MethodSpec::into_spec)
    }),
    (Method::FullField, |k, _| {
        FieldSpec::parse(k).map(MethodSpec::into_spec)
    }),
    (Method::RayTraced, |k, max| {
        RayTracedSpec::parse(k.rt_res, max).map(MethodSpec::into_spec)
    }),
    (Method::SubVolumes, |k, _| {
        SubVolumeSpec::parse(k).map(MethodSpec::into_spec)
    }),
    (Method::SphereSet, |k, _| {
        SetSpec::parse(k).map(MethodSpec::into_spec)
    }),
];

impl Spec {
    /// Parse the method keys `k` once; `defaults` are the kind's defaults (the unread-key
    /// rule), `rt_res_max` the kind's largest `rt_res`. Errors name the key.
    pub fn parse(k: &Keys, defaults: &Keys, rt_res_max: usize) -> Result<Spec, KeyError> {
        let method = Method::parse_among(k.method, &Method::BUDGETED)
            .map_err(|m| KeyError::new("method", m))?;
        let parse = (REGISTRY.iter())
            .find(|(m, _)| *m == method)
            .map(|(_, p)| *p)
            .expect("every budgeted method is registered");
        let spec = parse(k, rt_res_max)?;
        let values = k.values();
        // The keys it reads among those the kind offers, for the message.
        let reads: Vec<&str> = (spec.reads().into_iter())
            .filter(|r| values.iter().any(|(c, _)| c == r))
            .collect();
        for ((key, v), (_, d)) in values.iter().zip(defaults.values()) {
            if *v != d && !reads.contains(key) {
                return Err(KeyError::new(
                    key,
                    format!(
                        "{v} is not read by method \"{method}\" (it reads {}); leave {key} at its default {d}",
                        reads.join(", ")
                    ),
                ));
            }
        }
        Ok(spec)
    }

    pub fn method(&self) -> Method {
        match self {
            Spec::Extrapolated(_) => Method::Extrapolated,
            Spec::FullField(_) => Method::FullField,
            Spec::RayTraced(_) => Method::RayTraced,
            Spec::SubVolumes(_) => Method::SubVolumes,
            Spec::SphereSet(_) => Method::SphereSet,
        }
    }

    /// The extrapolation of `extrapolated` and of each sub-volume.
    pub fn extrapolation(&self) -> Option<&Extrapolation> {
        match self {
            Spec::Extrapolated(e) | Spec::SubVolumes(SubVolumeSpec { ex: e, .. }) => Some(e),
            _ => None,
        }
    }

    /// The method keys this spec reads (the others must keep their defaults).
    pub fn reads(&self) -> Vec<&'static str> {
        each!(self, m => m.reads())
    }

    /// The method's domains at the run's order N ([`MethodSpec::check_order`]).
    pub fn check_order(&self, order: usize) -> Result<(), KeyError> {
        each!(self, m => m.check_order(order))
    }

    /// Rays of one frame ([`MethodSpec::rays`]; docs/methods.md, "Rays, bytes and time").
    pub fn rays(&self, occluders: f64, receivers: f64) -> f64 {
        each!(self, m => m.rays(occluders, receivers))
    }

    /// Bytes held ([`MethodSpec::memory_bytes`]).
    pub fn memory_bytes(&self, order: usize, occluders: f64, k_count: usize) -> f64 {
        each!(self, m => m.memory_bytes(order, occluders, k_count))
    }

    /// Seconds of one frame for the cost model ([`MethodSpec::seconds`]). The rates are the
    /// development VM's; `--dry-run` scales them by the running machine's measured ray rate.
    pub fn seconds(&self, order: usize, rays: f64, receivers: f64, rays_per_second: f64) -> f64 {
        each!(self, m => m.seconds(order, rays, receivers, rays_per_second))
    }

    /// `rs` set to render with this method ([`MethodSpec::apply`]): its method and the
    /// parameters it reads. `rt_res` must be below the settings' `truth_res` (checked by the
    /// kinds at plan time).
    pub fn apply(&self, rs: &mut RenderSettings) {
        rs.method = self.method();
        each!(self, m => m.apply(rs))
    }
}

/// The cost model's time per receiver of SH exponentiation's HYB exponential on the 2-core
/// development VM (both threads), at N = 4 (its squarings are truncated products, about
/// `(N/4)⁵` times an order-4 one's): sphere sets and sub-volumes in log space.
pub(crate) const SHEXP_SECONDS: f64 = 1.0e-6;

/// A truncated product's work at order M against one at 4: its Gaunt entries, ~`(M/4)⁵`.
fn product_work(m: usize) -> f64 {
    (m as f64 / 4.0).powi(5).max(1.0)
}

/// Base-sphere samples of a layout (0 for one without a count).
fn samples(l: Layout) -> f64 {
    l.sample_count().unwrap_or(0) as f64
}

/// SH exponentiation's order domain, named by `key`: orders up to
/// `shscale_field::shexp_ol::MAX_SHEXP_ORDER` (its exact exponential's eigenproblem is N² × N²).
fn check_shexp_order(key: &str, order: usize) -> Result<(), KeyError> {
    let max = shscale_field::shexp_ol::MAX_SHEXP_ORDER;
    if order > max {
        return Err(KeyError::new(
            key,
            format!("\"shexp\" takes orders up to {max} (its exact exponential's eigenproblem is N² × N²), not {order}"),
        ));
    }
    Ok(())
}

fn layout(s: &str) -> Result<Layout, KeyError> {
    Layout::parse(s).map_err(|e| KeyError::new("layout", e.to_string()))
}

fn hemisphere_res(h: usize) -> Result<usize, KeyError> {
    KeyError::int("hemisphere_res", h, 1, crate::vocab::MAX_HEMISPHERE_RES)
}

/// The sampling sphere (and innermost shell) in bounding radii, [1, 1000].
fn sampling_radius(s: f64) -> Result<f64, KeyError> {
    KeyError::real("sampling_radius", s, 1.0, 1e3, Ends::Closed)
}

/// A sub-volume's or sphere set's parts.
fn parts(p: usize) -> Result<usize, KeyError> {
    KeyError::int("parts", p, 1, shscale_geometry::partition::MAX_PARTS)
}

#[cfg(test)]
mod tests;
