//! Triangle meshes as flat arrays with fixed topology: positions (f64) and index triples.
//! Deformers rewrite `positions` only.

use crate::bsphere::Sphere;

use crate::error::GeometryError;
use glam::DVec3;
use std::collections::HashMap;

/// A triangle mesh.
#[derive(Clone, Debug, PartialEq)]
pub struct Mesh {
    /// Where it came from (file path, bundled name or shape description), for messages.
    pub name: String,
    pub positions: Vec<DVec3>,
    pub triangles: Vec<[u32; 3]>,
}

/// Non-fatal findings of [`Mesh::inspect`].
#[derive(Clone, Debug, PartialEq)]
pub struct MeshReport {
    pub vertices: usize,
    pub triangles: usize,
    pub bounding_sphere: Sphere,
    /// Every edge shared by exactly two faces with opposite orientation.
    pub watertight: bool,
    pub boundary_edges: usize,
    pub non_manifold_edges: usize,
    /// Triangles with zero area (kept; they never occlude).
    pub degenerate_triangles: usize,
    pub unreferenced_vertices: usize,
}

impl Mesh {
    /// The largest |coordinate| of a vertex: squared areas and squared distances (≤ 1e200) stay
    /// far from f64 overflow; ray tracing maps the mesh to its unit frame.
    pub const MAX_COORDINATE: f64 = 1e50;
    /// The smallest extent (largest side of the bounding box) of a mesh: squared areas (≥ 1e-200)
    /// stay far from f64 underflow.
    pub const MIN_EXTENT: f64 = 1e-50;
    /// The most triangles of a mesh (a 2.5 GB vertex and index budget).
    pub const MAX_TRIANGLES: usize = 50_000_000;

    /// Build and validate: at least one vertex and one triangle, finite coordinates within
    /// ±[`Mesh::MAX_COORDINATE`], an extent of at least [`Mesh::MIN_EXTENT`], at most
    /// [`Mesh::MAX_TRIANGLES`] triangles, indices in range. Zero-area triangles are an error (`allow_degenerate = false`) or counted by
    /// [`Mesh::inspect`] (`true`). Errors name `name` and the element.
    pub fn new(
        name: &str,
        positions: Vec<DVec3>,
        triangles: Vec<[u32; 3]>,
        allow_degenerate: bool,
    ) -> Result<Self, GeometryError> {
        if positions.is_empty() || triangles.is_empty() {
            return Err(GeometryError::Empty {
                file: name.into(),
                vertices: positions.len(),
                triangles: triangles.len(),
            });
        }
        Self::check_positions(name, &positions)?;
        if triangles.len() > Self::MAX_TRIANGLES {
            return Err(GeometryError::Domain {
                file: name.into(),
                reason: format!(
                    "{} triangles, more than the limit {}",
                    triangles.len(),
                    Self::MAX_TRIANGLES
                ),
            });
        }
        let n = positions.len() as u32;
        for (f, t) in triangles.iter().enumerate() {
            if let Some(&bad) = t.iter().find(|&&v| v >= n) {
                return Err(GeometryError::Invalid {
                    file: name.into(),
                    element: "face",
                    index: f,
                    reason: format!("vertex index {bad} out of range (mesh has {n} vertices)"),
                });
            }
        }
        let mesh = Self {
            name: name.into(),
            positions,
            triangles,
        };
        if !allow_degenerate {
            if let Some(f) = (0..mesh.triangles.len()).find(|&f| mesh.triangle_area(f) == 0.0) {
                return Err(GeometryError::Invalid {
                    file: name.into(),
                    element: "face",
                    index: f,
                    reason: format!("zero-area triangle {:?}", mesh.triangles[f]),
                });
            }
        }
        Ok(mesh)
    }

    /// Every coordinate finite and within ±[`Mesh::MAX_COORDINATE`], and an extent of at least
    /// [`Mesh::MIN_EXTENT`].
    fn check_positions(name: &str, positions: &[DVec3]) -> Result<(), GeometryError> {
        if let Some(i) = positions.iter().position(|p| !p.is_finite()) {
            return Err(GeometryError::Invalid {
                file: name.into(),
                element: "vertex",
                index: i,
                reason: format!("non-finite coordinate {:?}", positions[i]),
            });
        }
        if let Some(i) = positions
            .iter()
            .position(|p| p.abs().max_element() > Self::MAX_COORDINATE)
        {
            return Err(GeometryError::Invalid {
                file: name.into(),
                element: "vertex",
                index: i,
                reason: format!(
                    "coordinate {:?} is beyond ±{:e}, the supported range (rescale the mesh)",
                    positions[i],
                    Self::MAX_COORDINATE
                ),
            });
        }
        let (lo, hi) = positions.iter().fold(
            (DVec3::splat(f64::MAX), DVec3::splat(f64::MIN)),
            |(lo, hi), p| (lo.min(*p), hi.max(*p)),
        );
        let extent = (hi - lo).max_element();
        if extent < Self::MIN_EXTENT {
            return Err(GeometryError::Domain {
                file: name.into(),
                reason: format!(
                    "the mesh spans {extent:e}, below {:e}, the smallest supported size (rescale the mesh)",
                    Self::MIN_EXTENT
                ),
            });
        }
        Ok(())
    }

    /// Parse OBJ text. tobj's parse errors carry no line, so lines are pre-checked here: every
    /// `v` line needs three numbers and every `f` line three or more vertex references.
    pub fn from_obj_bytes(name: &str, bytes: &[u8]) -> Result<Self, GeometryError> {
        let text = std::str::from_utf8(bytes).map_err(|e| GeometryError::Parse {
            file: name.into(),
            line: bytes[..e.valid_up_to()]
                .iter()
                .filter(|b| **b == b'\n')
                .count()
                + 1,
            reason: format!("not UTF-8 text: {e}"),
        })?;
        // Every statement is checked here, so that errors carry their line (tobj's do not).
        let mut counts = ObjCounts::default();
        for (i, line) in text.lines().enumerate() {
            counts.check(line).map_err(|reason| GeometryError::Parse {
                file: name.into(),
                line: i + 1,
                reason,
            })?;
        }
        let opts = tobj::LoadOptions {
            triangulate: true,
            single_index: false,
            ..Default::default()
        };
        let (models, _) = tobj::load_obj_buf(&mut std::io::BufReader::new(bytes), &opts, |_| {
            Err(tobj::LoadError::OpenFileFailed)
        })
        .map_err(|e| GeometryError::Parse {
            file: name.into(),
            line: 0,
            reason: e.to_string(),
        })?;
        let mut positions = Vec::new();
        let mut triangles = Vec::new();
        for m in models {
            let base = positions.len() as u32;
            positions.extend(
                m.mesh
                    .positions
                    .chunks_exact(3)
                    .map(|p| DVec3::new(p[0], p[1], p[2])),
            );
            triangles.extend(
                m.mesh
                    .indices
                    .chunks_exact(3)
                    .map(|t| [t[0] + base, t[1] + base, t[2] + base]),
            );
        }
        Self::new(name, positions, triangles, false)
    }

    /// Area of triangle `f`.
    pub(crate) fn triangle_area(&self, f: usize) -> f64 {
        let [a, b, c] = self.corners(f);
        0.5 * (b - a).cross(c - a).length()
    }

    /// The three corners of triangle `f`.
    #[inline]
    pub fn corners(&self, f: usize) -> [DVec3; 3] {
        let t = self.triangles[f];
        [
            self.positions[t[0] as usize],
            self.positions[t[1] as usize],
            self.positions[t[2] as usize],
        ]
    }

    /// The minimal enclosing sphere of the vertices.
    pub fn bounding_sphere(&self) -> Sphere {
        crate::bsphere::min_enclosing_sphere(&self.positions)
    }

    /// Topology and validity findings.
    pub fn inspect(&self) -> MeshReport {
        let mut edges: HashMap<(u32, u32), (u32, u32)> = HashMap::new(); // (forward, backward) counts
        for t in &self.triangles {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                let e = edges.entry((a.min(b), a.max(b))).or_default();
                if a < b {
                    e.0 += 1;
                } else {
                    e.1 += 1;
                }
            }
        }
        let boundary = edges.values().filter(|(f, b)| f + b == 1).count();
        let non_manifold = edges
            .values()
            .filter(|(f, b)| f + b > 2 || (f + b == 2 && *f != 1))
            .count();
        let mut used = vec![false; self.positions.len()];
        self.triangles
            .iter()
            .flatten()
            .for_each(|&v| used[v as usize] = true);
        MeshReport {
            vertices: self.positions.len(),
            triangles: self.triangles.len(),
            bounding_sphere: self.bounding_sphere(),
            watertight: boundary == 0 && non_manifold == 0,
            boundary_edges: boundary,
            non_manifold_edges: non_manifold,
            degenerate_triangles: (0..self.triangles.len())
                .filter(|&f| self.triangle_area(f) == 0.0)
                .count(),
            unreferenced_vertices: used.iter().filter(|u| !**u).count(),
        }
    }

    /// Turn every vertex by the rotation `q` about `center` (`p ↦ center + q·(p − center)`):
    /// lengths and, about the bounding sphere's centre, the minimal bounding sphere are kept.
    pub fn rotate_about(&mut self, center: DVec3, q: glam::DQuat) {
        for p in &mut self.positions {
            *p = center + q * (*p - center);
        }
    }

    /// Uniformly scale and translate so the minimal bounding sphere becomes `target`.
    pub fn fit_to(&mut self, target: &Sphere) {
        let s = self.bounding_sphere();
        let f = target.radius / s.radius;
        for p in &mut self.positions {
            *p = target.center + (*p - s.center) * f;
        }
    }
}

/// The OBJ statements seen so far (vertices, texture coordinates, normals), against which each
/// new line is checked; an error is the reason, in words.
#[derive(Default)]
struct ObjCounts {
    v: usize,
    vt: usize,
    vn: usize,
}

impl ObjCounts {
    fn check(&mut self, line: &str) -> Result<(), String> {
        let mut it = line.split_whitespace();
        match it.next() {
            Some("v") => {
                check_obj_vertex(line, &it.collect::<Vec<_>>())?;
                self.v += 1;
            }
            Some("f") => self.check_face(line, &it.collect::<Vec<_>>())?,
            Some(kind @ ("vn" | "vt")) => {
                let need = if kind == "vn" { 3 } else { 1 };
                let nums: Vec<&str> = it.collect();
                if nums.len() < need
                    || (nums.iter()).any(|s| !s.parse::<f64>().is_ok_and(f64::is_finite))
                {
                    let what = if kind == "vn" { "normal" } else { "texture" };
                    return Err(format!("bad {what} line {line:?}"));
                }
                if kind == "vn" {
                    self.vn += 1;
                } else {
                    self.vt += 1;
                }
            }
            _ => {}
        }
        Ok(())
    }

    /// Three or more `v[/vt[/vn]]` references, each in range of those defined so far.
    fn check_face(&self, line: &str, refs: &[&str]) -> Result<(), String> {
        if refs.len() < 3 {
            return Err(format!("face with fewer than 3 vertices: {line:?}"));
        }
        let vcount = self.v;
        for r in refs {
            let mut parts = r.split('/');
            let idx = parts.next().unwrap_or("");
            match idx.parse::<i64>() {
                Ok(v) if v > 0 && (v as usize) <= vcount => {}
                Ok(v) if v < 0 && (v.unsigned_abs() as usize) <= vcount => {}
                _ => {
                    return Err(format!(
                        "vertex reference {r:?} out of range (1..={vcount} defined so far)"
                    ))
                }
            }
            // Texture and normal references: empty, or in range of those defined.
            for (what, count) in [("texture", self.vt), ("normal", self.vn)] {
                let Some(p) = parts.next().filter(|p| !p.is_empty()) else {
                    continue;
                };
                match p.parse::<i64>() {
                    Ok(v) if v != 0 && (v.unsigned_abs() as usize) <= count => {}
                    _ => {
                        return Err(format!(
                        "{what} reference {p:?} in {r:?} is not one of the {count} defined so far"
                    ))
                    }
                }
            }
            if parts.next().is_some() {
                return Err(format!("face vertex {r:?} has more than v/vt/vn"));
            }
        }
        Ok(())
    }
}

/// A `v` line: three finite numbers within ±[`Mesh::MAX_COORDINATE`].
fn check_obj_vertex(line: &str, nums: &[&str]) -> Result<(), String> {
    if nums.len() < 3 || nums[..3].iter().any(|s| s.parse::<f64>().is_err()) {
        return Err(format!("bad vertex line {line:?}"));
    }
    let xyz: Vec<f64> = nums[..3]
        .iter()
        .map(|s| s.parse::<f64>().unwrap())
        .collect();
    if let Some(bad) = xyz.iter().find(|v| !v.is_finite()) {
        return Err(format!("non-finite coordinate {bad}"));
    }
    if let Some(bad) = xyz.iter().find(|v| v.abs() > Mesh::MAX_COORDINATE) {
        return Err(format!(
            "coordinate {bad:e} is beyond ±{:e}, the supported range (rescale the mesh)",
            Mesh::MAX_COORDINATE
        ));
    }
    Ok(())
}
