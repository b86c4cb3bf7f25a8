//! Spherical Delaunay triangulation of unit directions and barycentric interpolation on it.
//!
//! Construction (stereographic projection + spade): rotate so that sample 0 sits at the north
//! pole, project the other samples stereographically from the pole, `(x, y, z) ↦ (x, y)/(1 − z)`,
//! and triangulate them in the plane with spade. Stereographic projection maps circles on the
//! sphere to circles in the plane, so the planar Delaunay triangles are the spherical Delaunay
//! triangles not incident to the pole; those are the fan joining sample 0 to the planar convex
//! hull. Location: the triangle containing a query is searched among those incident to the
//! nearest sample first, then among all (exact fallback). Weights: the query written as
//! `α a + β b + γ c` (a 3×3 solve, i.e. gnomonic barycentric coordinates) normalised to sum 1.

use glam::{DMat3, DVec3};
use spade::{DelaunayTriangulation, Point2, Triangulation};

/// A triangulation of unit directions.
#[derive(Clone, Debug)]
pub struct SphericalTriangulation {
    dirs: Vec<DVec3>,
    tris: Vec<[u32; 3]>,
    /// Triangles incident to each vertex.
    incident: Vec<Vec<u32>>,
}

impl SphericalTriangulation {
    /// Triangulate `dirs` (unit, ≥ 4, not all on one great circle). Duplicate directions are
    /// rejected by spade's insertion (reported as an error string).
    pub fn new(dirs: &[DVec3]) -> Result<Self, String> {
        if dirs.len() < 4 {
            return Err(format!("need at least 4 directions, got {}", dirs.len()));
        }
        let pole = dirs[0];
        // Rotation taking `pole` to +z.
        let f = crate::frame::LocalFrame::from_z(pole);
        let mut t: DelaunayTriangulation<Point2<f64>> = DelaunayTriangulation::new();
        let mut handle_to_sample = Vec::new();
        for (i, d) in dirs.iter().enumerate().skip(1) {
            let l = f.to_local(*d);
            let den = 1.0 - l.z;
            if den <= 1e-12 {
                return Err(format!("direction {i} coincides with direction 0"));
            }
            let h = t
                .insert(Point2::new(l.x / den, l.y / den))
                .map_err(|e| format!("direction {i}: {e:?}"))?;
            if h.index() != handle_to_sample.len() {
                return Err(format!("direction {i} duplicates an earlier one"));
            }
            handle_to_sample.push(i as u32);
        }
        let mut tris: Vec<[u32; 3]> = t
            .inner_faces()
            .map(|face| face.vertices().map(|v| handle_to_sample[v.fix().index()]))
            .collect();
        for e in t.convex_hull() {
            let (a, b) = (
                handle_to_sample[e.from().fix().index()],
                handle_to_sample[e.to().fix().index()],
            );
            tris.push([0, a, b]);
        }
        let mut incident = vec![Vec::new(); dirs.len()];
        for (k, tri) in tris.iter().enumerate() {
            for &v in tri {
                incident[v as usize].push(k as u32);
            }
        }
        Ok(Self {
            dirs: dirs.to_vec(),
            tris,
            incident,
        })
    }

    /// The triangles (indices into the directions).
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.tris
    }

    /// Gnomonic barycentric weights of unit `q` in triangle `t`; all ≥ −tol if inside.
    fn weights(&self, t: [u32; 3], q: DVec3) -> Option<[f64; 3]> {
        let m = DMat3::from_cols(
            self.dirs[t[0] as usize],
            self.dirs[t[1] as usize],
            self.dirs[t[2] as usize],
        );
        let det = m.determinant();
        if det.abs() < 1e-300 {
            return None;
        }
        let w = m.inverse() * q;
        let s = w.x + w.y + w.z;
        if s <= 0.0 {
            return None; // the antipodal triangle
        }
        Some([w.x / s, w.y / s, w.z / s])
    }

    /// Interpolation weights `(vertex, weight)` for unit direction `q` (weights ≥ 0, sum 1).
    pub fn locate(&self, q: DVec3) -> [(u32, f64); 3] {
        const TOL: f64 = -1e-12;
        let nearest = (0..self.dirs.len())
            .max_by(|&a, &b| self.dirs[a].dot(q).total_cmp(&self.dirs[b].dot(q)))
            .unwrap();
        let candidates = self.incident[nearest]
            .iter()
            .map(|&k| k as usize)
            .chain(0..self.tris.len());
        let mut best: Option<([u32; 3], [f64; 3], f64)> = None;
        for k in candidates {
            let t = self.tris[k];
            if let Some(w) = self.weights(t, q) {
                let worst = w[0].min(w[1]).min(w[2]);
                if worst >= TOL {
                    best = Some((t, w, worst));
                    break;
                }
                if best.is_none_or(|b| worst > b.2) {
                    best = Some((t, w, worst));
                }
            }
        }
        let (t, w, _) = best.expect("a triangulation of the sphere contains every direction");
        let w = w.map(|x| x.max(0.0));
        let s = w[0] + w[1] + w[2];
        [(t[0], w[0] / s), (t[1], w[1] / s), (t[2], w[2] / s)]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use shscale_sh::DirectionSet;

    #[test]
    fn triangulation_covers_the_sphere_and_interpolates_linear_data_exactly_at_nodes() {
        let set = DirectionSet::fibonacci_sphere(200);
        let dirs: Vec<DVec3> = set.dirs.iter().map(|d| DVec3::from_array(*d)).collect();
        let t = SphericalTriangulation::new(&dirs).unwrap();
        // Euler: a triangulated sphere with V vertices has 2V − 4 triangles.
        assert_eq!(t.triangles().len(), 2 * dirs.len() - 4);
        // Total spherical area of the (flat) triangles approaches 4π from below.
        let area: f64 = t
            .triangles()
            .iter()
            .map(|tr| {
                let (a, b, c) = (
                    dirs[tr[0] as usize],
                    dirs[tr[1] as usize],
                    dirs[tr[2] as usize],
                );
                // Van Oosterom–Strackee solid angle.
                let num = a.dot(b.cross(c)).abs();
                let den = 1.0 + a.dot(b) + b.dot(c) + c.dot(a);
                2.0 * num.atan2(den)
            })
            .sum();
        assert!(
            (area - 4.0 * std::f64::consts::PI).abs() < 1e-9,
            "area {area}"
        );
        // At a node the weight is 1 on that node.
        for i in [0usize, 17, 199] {
            let w = t.locate(dirs[i]);
            let on = w
                .iter()
                .find(|(v, _)| *v as usize == i)
                .map(|x| x.1)
                .unwrap_or(0.0);
            assert!((on - 1.0).abs() < 1e-9, "node {i}: {w:?}");
        }
        // Any direction is located with non-negative weights summing to 1.
        for d in DirectionSet::gauss_sphere(9, 17).dirs {
            let w = t.locate(DVec3::from_array(d));
            assert!(w.iter().all(|x| x.1 >= 0.0));
            assert!((w.iter().map(|x| x.1).sum::<f64>() - 1.0).abs() < 1e-12);
        }
    }
}
