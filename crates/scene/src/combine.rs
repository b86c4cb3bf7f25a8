//! How several occluders' visibilities become one — the choice a sphere set (and, for products
//! and SH exponentiation, sub-volumes) makes: its own module so that the scene's settings
//! (`Scene::sphere_combine`) and the method vocabulary (`method/`) both name it without
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

shscale_names::names!(Combine {
    Product = "product",
    Quadrature = "quadrature",
    Union = "union",
    Shexp = "shexp",
});

/// Which spheres a sphere set takes for a mesh.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SphereFit {
    /// One sphere per k-means part, by the part's area-weighted centroid and RMS spread
    /// (`shscale_geometry::partition::fit_spheres`): cheap, refitted every frame.
    #[default]
    Area,
    /// The greedy cover of the mesh's interior by inscribed balls
    /// (`shscale_geometry::inscribed`): every ball inside the solid, the sets nested in their
    /// count, so the exact union's full-frequency error cannot rise with S; a one-off fit of
    /// each pose (cached per pose), not a per-frame one.
    Inscribed,
}

shscale_names::names!(SphereFit { Area = "area", Inscribed = "inscribed" });

impl SphereFit {
    /// `parts` spheres for `mesh`: one per part of `labels` (area), or the first `parts` of the
    /// mesh's inscribed balls (fewer where they cover its interior sooner).
    pub fn spheres(
        self,
        mesh: &shscale_geometry::Mesh,
        labels: &[u32],
        parts: usize,
    ) -> Result<Vec<shscale_geometry::Sphere>, shscale_geometry::GeometryError> {
        match self {
            Self::Area => Ok(shscale_geometry::partition::fit_spheres(
                mesh, labels, parts,
            )),
            Self::Inscribed => Ok(shscale_geometry::inscribed::inscribed_set(mesh, parts)?.0),
        }
    }
}
