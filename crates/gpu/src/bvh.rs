//! A binary BVH flattened for the GPU: obvhs builds a `Bvh2` over the mesh's triangles on the
//! host; nodes are copied to [`GpuNode`] and triangles reordered so that a leaf's `first` indexes
//! the triangle buffer directly (no primitive-index indirection on the GPU). Per frame the tree is
//! either rebuilt or refit, as the deformer prescribes (`DeformerKind::preferred_update`); a refit
//! keeps the node count, so the GPU buffers are written in place.

use crate::error::GpuError;
use crate::layout::{GpuNode, GpuTri};
use obvhs::bvh2::builder::build_bvh2_from_tris;
use obvhs::bvh2::Bvh2;
use obvhs::triangle::Triangle;
use obvhs::BvhBuildParams;
use shscale_geometry::ray::UpdateStrategy;
use shscale_geometry::Mesh;
use std::time::Duration;

/// Deepest tree the GPU traversal stack holds (the WGSL `STACK` constant).
pub const MAX_GPU_BVH_DEPTH: usize = 64;

/// What a device needs to refit a [`FlatBvh`] in place ([`FlatBvh::schedule`], `pose.wgsl`).
#[derive(Clone, Debug, Default)]
pub struct RefitSchedule {
    /// Per triangle slot of the flattened tree: its three mesh vertex indices and a pad.
    pub tri_verts: Vec<[u32; 4]>,
    /// The leaves' node indices.
    pub leaves: Vec<u32>,
    /// The inner nodes' indices grouped by level, deepest level first.
    pub inner: Vec<u32>,
    /// Each level's `(start, count)` in `inner`, deepest first.
    pub levels: Vec<(u32, u32)>,
}

/// Host side of the GPU BVH of one deforming mesh.
pub struct FlatBvh {
    strategy: UpdateStrategy,
    /// The tree's relative box area after its last build (`UpdateStrategy::Adaptive`).
    built_area: f64,
    tris: Vec<Triangle>,
    bvh: Bvh2,
    /// Flattened nodes and reordered triangles, ready to upload.
    pub nodes: Vec<GpuNode>,
    pub gpu_tris: Vec<GpuTri>,
}

/// The summed surface area of every node's box over the root's (as
/// `shscale_geometry::wide::WideBvh::relative_area`, for the binary tree).
fn relative_area(b: &Bvh2) -> f64 {
    let root = b.nodes.first().map_or(0.0, |n| n.aabb.half_area() as f64);
    if root.is_nan() || root <= 0.0 {
        return 1.0;
    }
    b.nodes
        .iter()
        .map(|n| n.aabb.half_area() as f64)
        .sum::<f64>()
        / root
}

fn triangles(mesh: &Mesh) -> Vec<Triangle> {
    (0..mesh.triangles.len())
        .map(|f| {
            let [a, b, c] = mesh.corners(f);
            Triangle {
                v0: a.as_vec3().into(),
                v1: b.as_vec3().into(),
                v2: c.as_vec3().into(),
            }
        })
        .collect()
}

impl FlatBvh {
    /// Build for `mesh`; errors on an empty mesh or a tree deeper than the GPU stack.
    pub fn build(mesh: &Mesh, strategy: UpdateStrategy) -> Result<Self, GpuError> {
        if mesh.triangles.is_empty() {
            return Err(GpuError::Input("mesh has no triangles".into()));
        }
        let tris = triangles(mesh);
        let bvh = Self::make(&tris);
        let mut out = Self {
            strategy,
            built_area: relative_area(&bvh),
            tris,
            bvh,
            nodes: Vec::new(),
            gpu_tris: Vec::new(),
        };
        out.flatten()?;
        Ok(out)
    }

    fn make(tris: &[Triangle]) -> Bvh2 {
        let mut t = Duration::default();
        let mut b = build_bvh2_from_tris(tris, BvhBuildParams::fast_build(), &mut t);
        b.init_primitives_to_nodes_if_uninit();
        b
    }

    /// Follow a deformation of the same mesh (same topology).
    pub fn update(&mut self, mesh: &Mesh) -> Result<(), GpuError> {
        self.same_topology(mesh)?;
        self.tris = triangles(mesh);
        match self.strategy {
            UpdateStrategy::Rebuild => self.bvh = Self::make(&self.tris),
            UpdateStrategy::Refit | UpdateStrategy::Adaptive => {
                let b = &mut self.bvh;
                for n in 0..b.nodes.len() {
                    let node = b.nodes[n];
                    if node.is_leaf() {
                        let first = node.first_index as usize;
                        let mut aabb = self.tris[b.primitive_indices[first] as usize].aabb();
                        for k in first..first + node.prim_count as usize {
                            aabb = aabb.union(&self.tris[b.primitive_indices[k] as usize].aabb());
                        }
                        b.nodes[n].set_aabb(aabb);
                    }
                }
                b.refit_all();
                if self.strategy == UpdateStrategy::Adaptive
                    && shscale_geometry::ray::rebuild_due(relative_area(&self.bvh), self.built_area)
                {
                    self.bvh = Self::make(&self.tris);
                    self.built_area = relative_area(&self.bvh);
                }
            }
        }
        self.flatten()
    }

    /// Build the tree again for `mesh` (same topology), whatever the strategy.
    pub fn rebuild(&mut self, mesh: &Mesh) -> Result<(), GpuError> {
        self.same_topology(mesh)?;
        self.tris = triangles(mesh);
        self.bvh = Self::make(&self.tris);
        self.built_area = relative_area(&self.bvh);
        self.flatten()
    }

    /// `Ok` when `mesh` has the triangle count this tree was built for.
    fn same_topology(&self, mesh: &Mesh) -> Result<(), GpuError> {
        if mesh.triangles.len() != self.tris.len() {
            return Err(GpuError::Input(format!(
                "topology changed: {} triangles, the BVH has {}",
                mesh.triangles.len(),
                self.tris.len()
            )));
        }
        Ok(())
    }

    /// The tree's relative box area after its last build (the reference of the rebuild rule,
    /// `shscale_geometry::ray::rebuild_due`).
    pub fn built_area(&self) -> f64 {
        self.built_area
    }

    /// The tree's relative box area now.
    pub fn relative_area(&self) -> f64 {
        relative_area(&self.bvh)
    }

    /// What a device needs to refit this tree in place for a new pose of `mesh` (the mesh this
    /// tree was built for, any pose): each triangle slot's vertex indices, the leaves, and the
    /// inner nodes level by level, deepest first — a level's nodes have their children refitted
    /// by the levels before it.
    pub fn schedule(&self, mesh: &Mesh) -> Result<RefitSchedule, GpuError> {
        self.same_topology(mesh)?;
        let tri_verts = (self.bvh.primitive_indices.iter())
            .map(|&p| {
                let [a, b, c] = mesh.triangles[p as usize];
                [a, b, c, 0]
            })
            .collect();
        let mut leaves = Vec::new();
        let mut by_depth: Vec<Vec<u32>> = Vec::new();
        let mut stack = vec![(0u32, 0usize)];
        while let Some((n, depth)) = stack.pop() {
            let node = &self.nodes[n as usize];
            if node.count > 0 {
                leaves.push(n);
            } else {
                if by_depth.len() <= depth {
                    by_depth.resize(depth + 1, Vec::new());
                }
                by_depth[depth].push(n);
                stack.push((node.first, depth + 1));
                stack.push((node.first + 1, depth + 1));
            }
        }
        let (mut inner, mut levels) = (Vec::new(), Vec::new());
        for level in by_depth.iter().rev() {
            levels.push((inner.len() as u32, level.len() as u32));
            inner.extend_from_slice(level);
        }
        Ok(RefitSchedule {
            tri_verts,
            leaves,
            inner,
            levels,
        })
    }

    fn flatten(&mut self) -> Result<(), GpuError> {
        let depth = self.bvh.depth(0);
        if depth >= MAX_GPU_BVH_DEPTH {
            return Err(GpuError::Input(format!(
                "BVH depth {depth} exceeds the GPU traversal stack ({MAX_GPU_BVH_DEPTH})"
            )));
        }
        self.nodes.clear();
        self.nodes.extend(self.bvh.nodes.iter().map(|n| GpuNode {
            min: n.aabb.min.to_array(),
            count: n.prim_count,
            max: n.aabb.max.to_array(),
            first: n.first_index,
        }));
        self.gpu_tris.clear();
        let v4 = |v: glam::Vec3A| [v.x, v.y, v.z, 0.0];
        self.gpu_tris
            .extend(self.bvh.primitive_indices.iter().map(|&p| {
                let t = &self.tris[p as usize];
                GpuTri {
                    v0: v4(t.v0),
                    v1: v4(t.v1),
                    v2: v4(t.v2),
                }
            }));
        Ok(())
    }

    /// Any-hit query on the host, through the flattened arrays exactly as the GPU walks them
    /// (the reference for the traversal shader and a check that flattening kept the tree).
    #[cfg(test)]
    pub(crate) fn occluded_flat(&self, o: [f32; 3], d: [f32; 3], tmin: f32) -> bool {
        let (o, d) = (glam::Vec3::from(o), glam::Vec3::from(d));
        let inv = d.recip();
        let hit_box = |n: &GpuNode| {
            let t0 = (glam::Vec3::from(n.min) - o) * inv;
            let t1 = (glam::Vec3::from(n.max) - o) * inv;
            let near = t0.min(t1).max_element().max(tmin);
            let far = t0.max(t1).min_element();
            near <= far
        };
        let mut stack = vec![0u32];
        while let Some(i) = stack.pop() {
            let n = &self.nodes[i as usize];
            if !hit_box(n) {
                continue;
            }
            if n.count > 0 {
                for t in &self.gpu_tris[n.first as usize..(n.first + n.count) as usize] {
                    let tri = Triangle {
                        v0: glam::Vec3::from_slice(&t.v0[..3]).into(),
                        v1: glam::Vec3::from_slice(&t.v1[..3]).into(),
                        v2: glam::Vec3::from_slice(&t.v2[..3]).into(),
                    };
                    let ray = obvhs::ray::Ray::new(o.into(), d.into(), tmin, f32::MAX);
                    if tri.intersect(&ray).is_finite() {
                        return true;
                    }
                }
            } else {
                stack.push(n.first);
                stack.push(n.first + 1);
            }
        }
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;
    use shscale_geometry::{shapes, MeshBvh, Occluder};

    /// Oracle: the 8-wide tree of `MeshBvh` (another tree, another traversal) on 4000 rays
    /// through and around a bent box; the flattened tree must answer identically, before and
    /// after a refit and a rebuild.
    #[test]
    fn flattened_tree_answers_as_the_cpu_bvh() {
        let mut mesh = shapes::box_block(DVec3::new(1.0, 0.5, 0.3), 12);
        for strategy in [
            UpdateStrategy::Refit,
            UpdateStrategy::Rebuild,
            UpdateStrategy::Adaptive,
        ] {
            let mut flat = FlatBvh::build(&mesh, strategy).unwrap();
            for pass in 0..3 {
                let cpu = MeshBvh::build(&mesh, UpdateStrategy::Rebuild);
                let mut mismatches = 0;
                let n = 4000;
                for i in 0..n {
                    let a = i as f64 * 2.399963;
                    let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
                    let s = (1.0 - z * z).sqrt();
                    let o = DVec3::new(2.0 * s * a.cos(), 2.0 * s * a.sin(), 2.0 * z);
                    let target = DVec3::new(
                        0.7 * (a * 3.1).sin(),
                        0.4 * (a * 1.7).cos(),
                        0.2 * (a * 0.3).sin(),
                    );
                    let d = (target - o).normalize();
                    let want = cpu.occluded(o, d, 1e-4, f64::INFINITY);
                    let got =
                        flat.occluded_flat(o.as_vec3().to_array(), d.as_vec3().to_array(), 1e-4);
                    mismatches += usize::from(want != got);
                }
                println!("{strategy:?} pass {pass}: {mismatches} / {n} rays differ");
                assert_eq!(mismatches, 0, "{strategy:?} pass {pass}");
                // Deform (a bend, then a quarter turn of twist, which makes `Adaptive`
                // rebuild) and follow.
                let rest = mesh.clone();
                if pass == 0 {
                    shscale_geometry::deform::bend(&rest, &mut mesh, 0.8, 0.5);
                } else {
                    shscale_geometry::deform::twist(&rest, &mut mesh, 0.25, 0.5);
                }
                let built_before = flat.built_area;
                flat.update(&mesh).unwrap();
                if strategy == UpdateStrategy::Adaptive && pass == 1 {
                    // `built_area` changes only when the tree is built again.
                    assert!(
                        flat.built_area != built_before,
                        "the twist should have triggered a rebuild"
                    );
                }
            }
        }
    }

    #[test]
    fn empty_and_changed_meshes_are_rejected() {
        let mut m = shapes::box_block(DVec3::ONE, 2);
        let mut flat = FlatBvh::build(&m, UpdateStrategy::Refit).unwrap();
        m.triangles.pop();
        let e = flat.update(&m).err().unwrap().to_string();
        assert!(e.contains("topology changed"), "{e}");
        m.triangles.clear();
        assert!(FlatBvh::build(&m, UpdateStrategy::Refit).is_err());
    }
}
