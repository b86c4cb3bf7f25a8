//! Sub-volumes of a mesh — the papers' own future work (TR §6, SHS §5): "partitioning a
//! deformable object into a small number of sub-volumes that are handled separately". The rule:
//! k-means (Lloyd's algorithm) on the triangles' centroids, seeded deterministically by
//! farthest-point sampling. The partition is per triangle, so a deforming mesh (fixed topology)
//! keeps it over its whole sequence: compute it once on the rest pose.

use crate::error::GeometryError;
use crate::mesh::Mesh;
use glam::DVec3;

/// The most parts of a partition.
pub const MAX_PARTS: usize = 64;

/// The most Lloyd iterations (the assignment usually stops changing within 20).
const MAX_ITERATIONS: usize = 100;

/// The part (0..parts) of every triangle of `mesh`: k-means on the triangle centroids. Seeds:
/// the centroid farthest from the mean centroid, then repeatedly the centroid farthest from
/// every seed so far (ties to the lower index); then Lloyd iterations (assign each centroid to
/// the nearest centre, ties to the lower part; move each centre to its centroids' mean) until
/// no assignment changes, at most 100. A part left empty takes the centroid farthest from its
/// own centre, so every part is non-empty. Deterministic. Domain: `1 ≤ parts ≤ min(64,
/// triangles)`.
pub fn kmeans_parts(mesh: &Mesh, parts: usize) -> Result<Vec<u32>, GeometryError> {
    let n = mesh.triangles.len();
    if parts == 0 || parts > MAX_PARTS || parts > n {
        return Err(GeometryError::Domain {
            file: mesh.name.clone(),
            reason: format!(
                "{parts} parts: give 1 to {} (at most {MAX_PARTS}, at most one per triangle; {n} triangles)",
                MAX_PARTS.min(n)
            ),
        });
    }
    let c: Vec<DVec3> = (0..n)
        .map(|f| {
            let [a, b, d] = mesh.corners(f);
            (a + b + d) / 3.0
        })
        .collect();
    let mean = c.iter().copied().sum::<DVec3>() / n as f64;
    let farthest = |from: &dyn Fn(DVec3) -> f64| -> usize {
        (0..n).fold(
            0,
            |best, i| if from(c[i]) > from(c[best]) { i } else { best },
        )
    };
    let mut centres = vec![c[farthest(&|p| (p - mean).length_squared())]];
    while centres.len() < parts {
        let seeds = centres.clone();
        let d = move |p: DVec3| {
            seeds
                .iter()
                .map(|s| (p - *s).length_squared())
                .fold(f64::INFINITY, f64::min)
        };
        centres.push(c[farthest(&d)]);
    }
    let nearest = |p: DVec3, centres: &[DVec3]| -> u32 {
        (0..centres.len()).fold(0, |best, k| {
            if (p - centres[k]).length_squared() < (p - centres[best]).length_squared() {
                k
            } else {
                best
            }
        }) as u32
    };
    let mut labels: Vec<u32> = c.iter().map(|p| nearest(*p, &centres)).collect();
    for _ in 0..MAX_ITERATIONS {
        // Centres: the means of their centroids; an empty part takes the centroid farthest from
        // its own centre (never the last of another part).
        let mut sum = vec![DVec3::ZERO; parts];
        let mut count = vec![0usize; parts];
        for (p, l) in c.iter().zip(&labels) {
            sum[*l as usize] += *p;
            count[*l as usize] += 1;
        }
        for k in 0..parts {
            if count[k] > 0 {
                centres[k] = sum[k] / count[k] as f64;
            }
        }
        fill_empty(&c, &mut labels, &mut centres, &mut count);
        let next: Vec<u32> = c.iter().map(|p| nearest(*p, &centres)).collect();
        // A reassignment may empty a part again: the next pass, or the repair after the loop,
        // fills it.
        if next == labels {
            break;
        }
        labels = next;
    }
    // The final assignment may leave a part empty only if the last pass did; repair once more.
    let mut count = vec![0usize; parts];
    labels.iter().for_each(|l| count[*l as usize] += 1);
    fill_empty(&c, &mut labels, &mut centres, &mut count);
    Ok(labels)
}

/// Give every empty part (count 0) the centroid farthest from its own centre among parts that
/// keep at least one (ties to the lower index); that centroid becomes the part's centre.
fn fill_empty(c: &[DVec3], labels: &mut [u32], centres: &mut [DVec3], count: &mut [usize]) {
    for k in 0..count.len() {
        if count[k] == 0 {
            let far = (0..c.len())
                .filter(|&i| count[labels[i] as usize] > 1)
                .max_by(|&a, &b| {
                    let da = (c[a] - centres[labels[a] as usize]).length_squared();
                    let db = (c[b] - centres[labels[b] as usize]).length_squared();
                    da.total_cmp(&db).then(b.cmp(&a))
                })
                .expect("parts ≤ triangles leaves a part with two or more");
            count[labels[far] as usize] -= 1;
            labels[far] = k as u32;
            count[k] = 1;
            centres[k] = c[far];
        }
    }
}

/// The sub-meshes of a partition: part k holds the triangles labelled k, in their order, with
/// only the vertices they use (renumbered in order of first use). `labels` has one entry per
/// triangle, each below `parts`.
pub fn split(mesh: &Mesh, labels: &[u32], parts: usize) -> Vec<Mesh> {
    let mut out: Vec<Mesh> = (0..parts)
        .map(|k| Mesh {
            name: format!("{} (part {k} of {parts})", mesh.name),
            positions: Vec::new(),
            triangles: Vec::new(),
        })
        .collect();
    let mut remap: Vec<Vec<u32>> = vec![vec![u32::MAX; mesh.positions.len()]; parts];
    for (t, l) in mesh.triangles.iter().zip(labels) {
        let (m, r) = (&mut out[*l as usize], &mut remap[*l as usize]);
        let tri = t.map(|v| {
            if r[v as usize] == u32::MAX {
                r[v as usize] = m.positions.len() as u32;
                m.positions.push(mesh.positions[v as usize]);
            }
            r[v as usize]
        });
        m.triangles.push(tri);
    }
    out
}

/// A sphere set of the mesh (the occluder model of Ren et al. 2006, here fitted by a stated
/// rule, not their optimisation): one sphere per part of `labels`. For part k, with area
/// weights `A` (each triangle's area over its three corners):
///
/// - `g`: the area-weighted mean of the part's triangle centroids;
/// - `ρ`: the area-weighted RMS distance of the part's triangle corners from `g`;
/// - `m = Σ A n / Σ A`: the mean unit normal, `|m|` ∈ [0, 1] (0 for a closed surface, 1 for a
///   flat patch);
/// - centre `g + ρ|m|·u`, `u = ±m/|m|` turned toward the whole mesh's area centroid (`−m/|m|`
///   when the part is the whole mesh), radius `ρ`.
///
/// So a closed part is its own best-fit sphere about its centroid (a tessellated sphere of
/// radius R: exactly R), and a flat patch gets the sphere tangent to it at its centroid, on the
/// mesh's inner side, as wide as the patch — a heuristic of this project, measured against the
/// truth in the `budget` kinds. A part with zero area gets radius 0. Cost: one pass over the
/// triangles, per frame (the labels are per triangle, fixed over a sequence).
pub fn fit_spheres(mesh: &Mesh, labels: &[u32], parts: usize) -> Vec<crate::Sphere> {
    let mut area = vec![0.0; parts];
    let mut g = vec![DVec3::ZERO; parts];
    let mut m = vec![DVec3::ZERO; parts];
    let (mut total, mut whole) = (0.0, DVec3::ZERO);
    let mut areas = Vec::with_capacity(labels.len());
    for (f, l) in labels.iter().enumerate() {
        let [a, b, c] = mesh.corners(f);
        let cross = (b - a).cross(c - a);
        let ar = 0.5 * cross.length();
        areas.push(ar);
        let k = *l as usize;
        area[k] += ar;
        g[k] += ar * (a + b + c) / 3.0;
        m[k] += 0.5 * cross;
        total += ar;
        whole += ar * (a + b + c) / 3.0;
    }
    let whole = if total > 0.0 {
        whole / total
    } else {
        DVec3::ZERO
    };
    for k in 0..parts {
        if area[k] > 0.0 {
            g[k] /= area[k];
            m[k] /= area[k];
        }
    }
    let mut spread = vec![0.0; parts];
    for (f, l) in labels.iter().enumerate() {
        let k = *l as usize;
        let ar = areas[f];
        spread[k] += (mesh.corners(f).iter())
            .map(|p| ar / 3.0 * (*p - g[k]).length_squared())
            .sum::<f64>();
    }
    (0..parts)
        .map(|k| {
            if area[k] <= 0.0 {
                return crate::Sphere {
                    center: g[k],
                    radius: 0.0,
                };
            }
            let rho = (spread[k] / area[k]).sqrt();
            let len = m[k].length();
            let mut u = if len > 0.0 { m[k] / len } else { DVec3::ZERO };
            let toward = whole - g[k];
            if u.dot(toward) < 0.0 || (toward.length_squared() == 0.0) {
                u = -u;
            }
            crate::Sphere {
                center: g[k] + rho * len * u,
                radius: rho,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shapes::uv_sphere;

    #[test]
    fn sphere_fit_of_a_closed_sphere_is_itself_and_of_a_flat_patch_is_tangent() {
        // One tessellated sphere (corners on the radius): the sphere itself.
        let s = uv_sphere(1.5, 24, 32);
        let labels = vec![0; s.triangles.len()];
        let f = fit_spheres(&s, &labels, 1)[0];
        println!("uv sphere: centre {:?}, radius {}", f.center, f.radius);
        assert!(f.center.length() < 1e-12 && (f.radius - 1.5).abs() < 1e-12);
        // Two spheres as one mesh split in two: each part's fit is that sphere.
        let m = two_spheres();
        let labels = kmeans_parts(&m, 2).unwrap();
        let fits = fit_spheres(&m, &labels, 2);
        for want in [DVec3::ZERO, DVec3::new(6.0, 0.0, 0.0)] {
            assert!(
                fits.iter()
                    .any(|f| (f.center - want).length() < 1e-9 && (f.radius - 1.0).abs() < 1e-9),
                "{fits:?}"
            );
        }
        // A flat square of side 2 in z = 0 facing +z with its mesh's centroid below it (a
        // second part far under it): the sphere is tangent at the patch centroid, on the
        // inner side, its radius the corners' area-weighted RMS distance (√2: every corner of
        // the two triangles is a corner of the square).
        let mut sq = crate::shapes::plane(2.0, 2.0, 1, 1);
        let below = uv_sphere(0.1, 6, 8);
        let off = sq.positions.len() as u32;
        let n_sq = sq.triangles.len();
        sq.positions.extend(
            below
                .positions
                .iter()
                .map(|p| *p + DVec3::new(0.0, 0.0, -5.0)),
        );
        sq.triangles
            .extend(below.triangles.iter().map(|t| t.map(|v| v + off)));
        let labels: Vec<u32> = (0..sq.triangles.len())
            .map(|i| u32::from(i >= n_sq))
            .collect();
        let f = fit_spheres(&sq, &labels, 2)[0];
        let rho = ((0..n_sq)
            .map(|t| {
                sq.triangle_area(t) / 3.0
                    * sq.corners(t)
                        .iter()
                        .map(|p| p.length_squared())
                        .sum::<f64>()
            })
            .sum::<f64>()
            / 4.0)
            .sqrt();
        println!(
            "flat patch: centre {:?}, radius {} (want {rho})",
            f.center, f.radius
        );
        assert!((f.radius - rho).abs() < 1e-12);
        assert!((f.center - DVec3::new(0.0, 0.0, -rho)).length() < 1e-12);
        // A part of zero area (a degenerate triangle) gets radius 0: it occludes nothing.
        let flat = Mesh {
            name: "degenerate".into(),
            positions: vec![DVec3::ZERO, DVec3::X, 2.0 * DVec3::X],
            triangles: vec![[0, 1, 2]],
        };
        assert_eq!(fit_spheres(&flat, &[0], 1)[0].radius, 0.0);
    }

    /// Two unit spheres 6 apart as one mesh.
    fn two_spheres() -> Mesh {
        let a = uv_sphere(1.0, 12, 16);
        let mut m = a.clone();
        let off = a.positions.len() as u32;
        m.positions
            .extend(a.positions.iter().map(|p| *p + DVec3::new(6.0, 0.0, 0.0)));
        m.triangles
            .extend(a.triangles.iter().map(|t| t.map(|v| v + off)));
        m
    }

    #[test]
    fn two_separated_spheres_split_into_the_two_spheres() {
        let m = two_spheres();
        let half = m.triangles.len() / 2;
        let labels = kmeans_parts(&m, 2).unwrap();
        // Every triangle of the first sphere in one part, every one of the second in the other.
        assert!(labels[..half].iter().all(|l| *l == labels[0]));
        assert!(labels[half..].iter().all(|l| *l == labels[half]));
        assert_ne!(labels[0], labels[half]);
        let parts = split(&m, &labels, 2);
        for p in &parts {
            assert_eq!(p.triangles.len(), half);
            let s = crate::min_enclosing_sphere(&p.positions);
            println!("part sphere: centre {:?}, radius {}", s.center, s.radius);
            assert!((s.radius - 1.0).abs() < 1e-9, "{}", s.radius);
        }
        // One part: everything; deterministic.
        assert!(kmeans_parts(&m, 1).unwrap().iter().all(|l| *l == 0));
        assert_eq!(kmeans_parts(&m, 8).unwrap(), kmeans_parts(&m, 8).unwrap());
    }

    #[test]
    fn every_part_is_non_empty_and_the_domain_is_checked() {
        let m = uv_sphere(1.0, 6, 8);
        let n = m.triangles.len();
        for parts in [1, 2, 3, 7, 16, n.min(MAX_PARTS)] {
            let labels = kmeans_parts(&m, parts).unwrap();
            let mut count = vec![0; parts];
            labels.iter().for_each(|l| count[*l as usize] += 1);
            assert!(count.iter().all(|c| *c > 0), "{parts}: {count:?}");
            let total: usize = split(&m, &labels, parts)
                .iter()
                .map(|p| p.triangles.len())
                .sum();
            assert_eq!(total, n);
        }
        for bad in [0, MAX_PARTS + 1, n + 1] {
            let e = kmeans_parts(&m, bad).unwrap_err().to_string();
            assert!(e.contains(&format!("{bad} parts")), "{e}");
        }
    }
}
