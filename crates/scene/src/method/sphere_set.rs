//! `sphere_set` (Ren et al. 2006's occluder model): one sphere per part (or the mesh's inscribed
//! balls), closed-form caps combined by truncated products, the quadrature, the exact union of
//! the caps or SH exponentiation; no rays on the mesh. Its parameters, keys, domains, cost, how
//! it sets a render's settings, and the one factory of each combination's tables that `render` and the
//! budget frames both use ([`SetTables`]).

use super::{product_work, Keys, MethodSpec, Spec, SHEXP_SECONDS};
use crate::combine::{Combine, SphereFit};
use crate::error::Error;
use crate::render::form::{partitioned, Built, CpuForm, Inputs, LocalLights};
use crate::settings::RenderSettings;
use shscale_field::evaluator::VisibilityField;
use shscale_field::shexp_ol::{Exp, SphereSetShexp, ZonalLogTable, SHEXP_EPS};
use shscale_field::sphereset::{QuadratureGrid, SphereSetField, SphereSetQuadrature};
use shscale_field::union::{RingGrid, SphereSetUnion};
use shscale_geometry::Sphere;
use shscale_runner::KeyError;
use shscale_sh::{GauntTensor, ShBasis};

/// Rings of [`Combine::Union`], fixed before the study's runs from its convergence on random
/// sets (`cargo test --release -p shscale-field --test union -- --ignored --nocapture`,
/// docs/math.md "The union of the caps"): at 32 rings at most 2.1 % of the occlusion against
/// 2,048 rings for S = 2–64, N = 4 and 8, where the 64 × 128 quadrature errs 1.4–7.5 %.
pub const UNION_RINGS: usize = 32;

/// Gauss–Legendre nodes in cos θ of [`Combine::Quadrature`] (× twice as many φ).
pub const SPHERE_QUADRATURE_RES: usize = 64;

/// The highest internal order of a sphere set's products (a product at M = 16 does about
/// 1,150× the work of one at 4: docs/math.md, "Combining many spheres").
pub(crate) const MAX_SPHERE_ORDER: usize = 16;

/// The cost model's time per receiver of [`Combine::Union`] on the 2-core development VM
/// (both threads): a fixed part (the frame, the rotation back) and a part per sphere, from
/// one thread's 2.1 / 3.1 / 5.6 / 8.4 µs at S = 2 / 8 / 32 / 64, N = 4, 32 rings.
pub(crate) const UNION_SECONDS: f64 = 0.9e-6;
pub(crate) const UNION_SPHERE_SECONDS: f64 = 0.05e-6;

/// The cost model's time per receiver and sphere of [`Combine::Shexp`] (a table lookup and a
/// zonal rotation; the exponential per receiver is [`SHEXP_SECONDS`]).
pub(crate) const SHEXP_SPHERE_SECONDS: f64 = 0.05e-6;

/// The cost model's time per receiver of a sphere set, per sphere (a cap's projection and
/// rotation and a truncated product at N = 4): 0.36 µs on spherical receivers, 0.57–0.63 µs on
/// the plane, at S = 16 and 64 in `configs/experiments/budget.toml` and `budget_plane.toml`
/// on the development VM.
pub const SPHERE_SECONDS: f64 = 5e-7;

/// The cost model's time of the quadrature combination: per direction and receiver, and per
/// ray–sphere test, fitted to `sphere_combine = "quadrature"` in `configs/experiments/
/// budget.toml` (S = 2 / 16 / 64: 0.06 / 0.17 / 0.60 s per frame of 1,200 receivers) on the
/// development VM.
pub const SPHERE_DIRECTION_SECONDS: f64 = 4.3e-9;
pub const SPHERE_TEST_SECONDS: f64 = 0.9e-9;

/// A sphere set's parameters. `internal_order`: the order M the caps are multiplied at before
/// truncating to the run's N (0: N itself, the plain order-N chain); `fit`: which spheres.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SetSpec {
    pub parts: usize,
    pub combine: Combine,
    pub internal_order: usize,
    pub fit: SphereFit,
}

impl SetSpec {
    pub(crate) fn parse(k: &Keys) -> Result<Self, KeyError> {
        Ok(Self {
            parts: super::parts(k.parts)?,
            combine: {
                let s = k.sphere_combine.unwrap_or("product");
                Combine::from_name(s).ok_or_else(|| {
                    KeyError::new(
                        "sphere_combine",
                        format!("{s:?} is not one of {:?}", Combine::NAMES),
                    )
                })?
            },
            internal_order: match k.sphere_order.unwrap_or(0) {
                0 => 0,
                m => KeyError::int("sphere_order", m, 1, MAX_SPHERE_ORDER)?,
            },
            fit: {
                let s = k.sphere_fit.unwrap_or("area");
                SphereFit::from_name(s).ok_or_else(|| {
                    KeyError::new(
                        "sphere_fit",
                        format!("{s:?} is not one of {:?}", SphereFit::NAMES),
                    )
                })?
            },
        })
    }

    /// The set the render settings describe (`render`'s: their parts, combination, internal
    /// order and fit).
    pub(crate) fn of_settings(rs: &RenderSettings) -> Self {
        Self {
            parts: rs.parts,
            combine: rs.sphere_combine,
            internal_order: rs.sphere_order,
            fit: rs.sphere_fit,
        }
    }
}

impl MethodSpec for SetSpec {
    fn reads(&self) -> Vec<&'static str> {
        match self.combine {
            Combine::Product => vec!["parts", "sphere_combine", "sphere_order", "sphere_fit"],
            _ => vec!["parts", "sphere_combine", "sphere_fit"],
        }
    }
    /// The internal order at or above N (0: N itself); SH exponentiation at orders up to
    /// `shscale_field::shexp_ol::MAX_SHEXP_ORDER`.
    fn check_order(&self, order: usize) -> Result<(), KeyError> {
        let m = self.internal_order;
        if m != 0 && m < order {
            return Err(KeyError::new(
                "sphere_order",
                format!(
                    "{m} is below the order {order}: give 0 (that order) or an order from {order} to {MAX_SPHERE_ORDER}"
                ),
            ));
        }
        if self.combine == Combine::Shexp {
            super::check_shexp_order("sphere_combine", order)?;
        }
        Ok(())
    }
    /// The quadrature's `2Q²` directions per receiver (cast at the spheres); 0 for the others.
    fn rays(&self, occluders: f64, receivers: f64) -> f64 {
        occluders
            * match self.combine {
                Combine::Quadrature => {
                    receivers * (2 * SPHERE_QUADRATURE_RES * SPHERE_QUADRATURE_RES) as f64
                }
                _ => 0.0,
            }
    }
    /// 32 bytes per sphere.
    fn memory_bytes(&self, _order: usize, occluders: f64, _k_count: usize) -> f64 {
        occluders * (self.parts as f64 * 32.0)
    }
    /// Per receiver: [`SPHERE_SECONDS`] per sphere for products (× `(M/4)⁵` at an internal order
    /// M above 4: a product's Gaunt entries, about `0.2·M⁵` — 194 at M = 4, 51,814 at 12,
    /// 222,376 at 16), the union's and SH exponentiation's own; the quadrature per direction
    /// ([`SPHERE_DIRECTION_SECONDS`]) and sphere test ([`SPHERE_TEST_SECONDS`]), its rays
    /// meeting spheres, not a mesh.
    fn seconds(&self, order: usize, rays: f64, receivers: f64, rays_per_second: f64) -> f64 {
        let parts = self.parts as f64;
        match self.combine {
            Combine::Quadrature => rays * (SPHERE_DIRECTION_SECONDS + parts * SPHERE_TEST_SECONDS),
            Combine::Union => receivers * (UNION_SECONDS + parts * UNION_SPHERE_SECONDS),
            Combine::Shexp => {
                receivers * (SHEXP_SECONDS * product_work(order) + parts * SHEXP_SPHERE_SECONDS)
            }
            Combine::Product => {
                let work = product_work(self.internal_order.max(order));
                rays / rays_per_second + receivers * parts * SPHERE_SECONDS * work
            }
        }
    }
    fn apply(&self, rs: &mut RenderSettings) {
        rs.parts = self.parts;
        rs.sphere_order = self.internal_order;
        rs.sphere_combine = self.combine;
        rs.sphere_fit = self.fit;
    }
    fn into_spec(self) -> Spec {
        Spec::SphereSet(self)
    }
}

/// What a sphere set's combination needs, built once before its frames (all at the run's order
/// N unless said): nothing more for the plain chain, the internal order's basis and Gaunt tensor
/// for products above N, the quadrature's directions, the union's rings, or SH
/// exponentiation's Gaunt tensor and log table. The one factory of them: `render` and the
/// budget kinds' frames both build their sets from it.
pub enum SetTables {
    /// Truncated products at N, near to far.
    Chain,
    /// Truncated products at the internal order M > N, truncated to N once.
    Internal(ShBasis<f64>, GauntTensor<f64>),
    Quadrature(QuadratureGrid),
    Union(RingGrid),
    Shexp(GauntTensor<f64>, ZonalLogTable),
}

/// One frame's sphere set as a field, with the rays a receiver casts (the quadrature's, at the
/// spheres) and the bytes the set holds.
pub struct SetField<'a> {
    pub field: Box<dyn VisibilityField + Sync + 'a>,
    pub rays_per_receiver: usize,
    pub bytes: usize,
}

impl SetTables {
    /// The tables of `set` at order N (`basis` is N's), its order domain checked first
    /// ([`SetSpec::check_order`]).
    pub fn new(set: &SetSpec, order: usize, basis: &ShBasis<f64>) -> Result<Self, Error> {
        set.check_order(order)
            .map_err(|e| Error::config(format!("{}: {}", e.key, e.message)))?;
        Ok(match set.combine {
            Combine::Product if set.internal_order > order => SetTables::Internal(
                ShBasis::<f64>::new(set.internal_order)?,
                GauntTensor::<f64>::new(set.internal_order)?,
            ),
            Combine::Product => SetTables::Chain,
            Combine::Quadrature => {
                SetTables::Quadrature(QuadratureGrid::new(basis, SPHERE_QUADRATURE_RES))
            }
            Combine::Union => SetTables::Union(RingGrid::new(basis, UNION_RINGS)),
            Combine::Shexp => {
                let gaunt = GauntTensor::<f64>::new(order)?;
                let table = ZonalLogTable::new(&gaunt, SHEXP_EPS);
                SetTables::Shexp(gaunt, table)
            }
        })
    }

    /// `spheres` as one field: `basis` is N's; `chain` the Gaunt tensor at N for the plain chain
    /// (`None`: the caller multiplies the spheres itself, and gets `None` back).
    pub fn field<'a>(
        &'a self,
        spheres: &'a [Sphere],
        basis: &'a ShBasis<f64>,
        chain: Option<&'a GauntTensor<f64>>,
    ) -> Option<SetField<'a>> {
        let (field, rays, bytes): (Box<dyn VisibilityField + Sync + 'a>, usize, usize) = match self
        {
            SetTables::Chain => {
                let set = SphereSetField::new(spheres, basis, chain?);
                let bytes = set.size_bytes();
                (Box::new(set), 0, bytes)
            }
            SetTables::Internal(b, g) => {
                let set = SphereSetField::new(spheres, b, g);
                let bytes = set.size_bytes();
                (Box::new(set), 0, bytes)
            }
            SetTables::Quadrature(g) => (
                Box::new(SphereSetQuadrature::new(spheres, g)),
                g.len(),
                spheres.len() * 32 + g.size_bytes(),
            ),
            SetTables::Union(r) => {
                let set = SphereSetUnion::new(spheres, r);
                let bytes = set.size_bytes() + r.size_bytes();
                (Box::new(set), 0, bytes)
            }
            SetTables::Shexp(g, t) => {
                let set = SphereSetShexp::new(spheres, (basis, g), t, Exp::Hyb);
                let bytes = set.size_bytes();
                (Box::new(set), 0, bytes)
            }
        };
        Some(SetField {
            field,
            rays_per_receiver: rays,
            bytes,
        })
    }
}

/// A sphere set's CPU render: a mesh partitioned as for sub-volumes (on the rest pose, per
/// triangle) and one sphere fitted per part on the posed mesh — or that pose's first inscribed
/// balls (`RenderSettings::sphere_fit`) — timed as `sphere_fit`; the analytic sphere is its own
/// set; shaded through an SH basis. No rays, no local lights.
pub(crate) const CPU: CpuForm = CpuForm {
    build: |i, stages| {
        Ok(Built {
            spheres: stages.time("sphere_fit", || spheres_of(i))?,
            ..Built::default()
        })
    },
    work: |w| {
        let spheres = w.occluders * w.rs.parts.max(1) as f64 * 32.0;
        (0.0, w.bytes(0.0, spheres))
    },
    local_lights: LocalLights::Refused,
    truth_sampler: false,
    basis: true,
    full_frequency: false,
    extrapolates: false,
};

/// The sphere set of every occluder ([`CPU`]).
fn spheres_of(i: &Inputs) -> Result<Vec<Sphere>, Error> {
    let (scene, rs) = (i.scene, i.rs);
    let mut out = Vec::new();
    for (o, split) in scene.occluders.iter().zip(partitioned(scene, rs.parts)?) {
        match split {
            Some((posed, labels)) => out.extend(
                (rs.sphere_fit.spheres(&posed, &labels, rs.parts))
                    .map_err(|e| Error::config(format!("{}: sphere_fit: {e}", scene.file)))?,
            ),
            None => out.push(o.build()?.bounding_sphere()),
        }
    }
    Ok(out)
}
