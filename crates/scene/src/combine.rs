//! How several occluders' visibilities become one — the choice a sphere set (and, for products
//! and SH exponentiation, sub-volumes) makes: its own module so that the scene's settings
//! (`Scene::sphere_combine`) and the method vocabulary (`method.rs`) both name it without
//! importing each other.

/// How a sphere set combines its spheres.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Combine {
    /// Truncated SH products near to far, as every multi-occluder method here.
    Product,
    /// The set's joint visibility projected by a quadrature at every receiver (no truncated
    /// products; its rays, cast at the spheres, are counted).
    Quadrature,
    /// The union of the caps projected exactly in φ and by Gauss–Legendre rings in z (their
    /// count `method::UNION_RINGS`; `shscale_field::union`): the quadrature's quantity without
    /// rays.
    Union,
    /// SH exponentiation (Ren et al. 2006, `shscale_field::shexp_ol`): the blockers' product-
    /// algebra logs summed and exponentiated by HYB, at orders up to
    /// `shscale_field::shexp_ol::MAX_SHEXP_ORDER`.
    Shexp,
}

impl Combine {
    /// The names `sphere_combine` takes.
    pub const NAMES: [&'static str; 4] = ["product", "quadrature", "union", "shexp"];

    /// The name configs and flags give it.
    pub fn name(self) -> &'static str {
        match self {
            Self::Product => "product",
            Self::Quadrature => "quadrature",
            Self::Union => "union",
            Self::Shexp => "shexp",
        }
    }

    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "product" => Some(Self::Product),
            "quadrature" => Some(Self::Quadrature),
            "union" => Some(Self::Union),
            "shexp" => Some(Self::Shexp),
            _ => None,
        }
    }
}
