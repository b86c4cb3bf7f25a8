//! Self-shadowing receivers: the object's own vertices as receivers (docs/conventions.md §4; SHS §3.1 "ratios
//! k < 1 expand the original visibility function"). A vertex lies inside the bounding sphere, so
//! its visibility is extrapolated with `k = |v − c|/(s r) < 1` (expansion); shading uses the
//! area-weighted vertex normal. Truth: rays from the vertex (offset rule of the geometry crate),
//! band-limited like every other truth here.

use crate::evaluator::VisibilityField;
use crate::shading::{EnvLight, Shader};
use glam::DVec3;
use rayon::prelude::*;
use shscale_geometry::Mesh;

/// Area-weighted unit vertex normals (zero-length sums give +z).
pub fn vertex_normals(mesh: &Mesh) -> Vec<DVec3> {
    let mut n = vec![DVec3::ZERO; mesh.positions.len()];
    for f in 0..mesh.triangles.len() {
        let [a, b, c] = mesh.corners(f);
        let fnorm = (b - a).cross(c - a); // length = 2 × area
        for &v in &mesh.triangles[f] {
            n[v as usize] += fnorm;
        }
    }
    n.into_iter()
        .map(|v| v.try_normalize().unwrap_or(DVec3::Z))
        .collect()
}

/// Irradiance (channel 0) at every vertex of `mesh` with visibility from `field`, each vertex
/// nudged `offset` along its normal (receivers exactly on the surface would see their own facet).
pub fn shade_vertices(
    mesh: &Mesh,
    field: &dyn VisibilityField,
    light: &EnvLight,
    shader: &Shader,
    offset: f64,
) -> Vec<f64> {
    let normals = vertex_normals(mesh);
    let nn = light.rgb[0].len();
    mesh.positions
        .par_iter()
        .zip(&normals)
        .map(|(p, n)| {
            let mut v = vec![0.0; nn];
            field.eval(*p + offset * *n, &mut v);
            Shader::shade(&shader.transfer(light, *n), &v)[0]
        })
        .collect()
}
