//! A sphere set's mesh posed and its spheres fitted on the device: the frame's deformer maps the
//! rest vertices (`pose.wgsl`'s `deform`, the kernel the papers' device-posed sequence uses), and
//! two passes of `fit.wgsl` fit one sphere per part by the host's area rule
//! (`shscale_geometry::partition::fit_spheres`, docs/math.md "Sphere sets") straight into the
//! set's sphere buffer — a frame uploads one 32-byte pose and reads nothing back. The parts are
//! the host's (k-means on the rest pose, kept for the sequence); their triangles are sorted by
//! part once, so each part is a contiguous range that one 256-wide workgroup sums.
//!
//! Valid domain: meshes with at most [`MAX_GPU_FIT_PARTS`] parts whose vertex and triangle
//! buffers fit the adapter's storage binding (refused by name otherwise); the sums are f32 over
//! a part's triangles (a strided sum per thread, then a tree): against the host's f64 fit of
//! its f64 pose the spheres' centres and radii differ by at most 1.4e-7 of the mesh's bounding
//! radius over four deformers, 1 to 16 parts and three times on lavapipe (`tests/fit.rs`, bound
//! 2e-6 r), and a part without area gets the host's empty sphere.

use crate::context::GpuContext;
use crate::error::GpuError;
use crate::layout::{shader, GpuFit, MAX_GPU_SPHERES};
use crate::pose::DeviceDeform;
use shscale_geometry::deform::Deformer;
use shscale_geometry::Mesh;

const FIT_WGSL: &str = include_str!("fit.wgsl");

/// The most parts one mesh's device fit takes (the set's sphere buffer holds
/// [`MAX_GPU_SPHERES`]).
pub const MAX_GPU_FIT_PARTS: usize = MAX_GPU_SPHERES;

/// The fit kernels' source.
pub(crate) fn fit_source() -> String {
    shader(&[FIT_WGSL])
}

/// One deforming mesh of a sphere set, posed and fitted on the device.
pub struct GpuSphereFit {
    deform: DeviceDeform,
    parts: usize,
    /// `fit_moments`, `fit_spheres`.
    fit_pipes: [wgpu::ComputePipeline; 2],
    fit_binds: [wgpu::BindGroup; 2],
}

impl GpuSphereFit {
    /// Set up `rest` (placed; every frame's pose has its topology) deformed by `deformer` (none:
    /// every frame is the rest pose), its triangles in parts `labels` (one per triangle, below
    /// `parts`), writing spheres `slot..slot + parts` of `spheres` (the set's sphere buffer,
    /// the sphere set's `spheres_buffer`).
    pub fn new(
        ctx: &GpuContext,
        rest: &Mesh,
        deformer: Option<&Deformer>,
        (labels, parts): (&[u32], usize),
        (spheres, slot): (&wgpu::Buffer, usize),
    ) -> Result<Self, GpuError> {
        check(ctx, rest, (labels, parts), slot)?;
        let deform = DeviceDeform::new(ctx, rest, deformer)?;
        let (part_tris, ranges) = by_part(rest, labels, parts);
        let o = rest.bounding_sphere().center;
        let fit = GpuFit {
            parts: parts as u32,
            slot: slot as u32,
            origin: [o.x as f32, o.y as f32, o.z as f32, 0.0],
            ..Default::default()
        };
        let fit_buf = ctx.uniform("fit", bytemuck::bytes_of(&fit));
        let tris_buf = ctx.storage_init("fit part triangles", bytemuck::cast_slice(&part_tris));
        let ranges_buf = ctx.storage_init("fit part ranges", bytemuck::cast_slice(&ranges));
        let moments = ctx.storage("fit moments", 32 * parts as u64);
        let src = fit_source();
        let fit_pipes = ["fit_moments", "fit_spheres"].map(|e| ctx.pipeline(e, &src, e));
        // Both passes read the same five buffers; the second also writes the spheres.
        let fit_binds = [0, 1].map(|i| {
            let mut res = vec![
                (0, whole(&fit_buf)),
                (1, whole(&deform.posed)),
                (2, whole(&tris_buf)),
                (3, whole(&ranges_buf)),
                (4, whole(&moments)),
            ];
            if i == 1 {
                res.push((5, whole(spheres)));
            }
            ctx.bind_at(&fit_pipes[i], &res)
        });
        Ok(Self {
            deform,
            parts,
            fit_pipes,
            fit_binds,
        })
    }

    /// The spheres this mesh writes.
    pub fn parts(&self) -> usize {
        self.parts
    }

    /// The host's half of frame time `t`: write the frame's pose (32 bytes).
    pub fn prepare(&mut self, ctx: &GpuContext, t: f64) {
        self.deform.write(ctx, t);
    }

    /// Record the deformation pass.
    pub(crate) fn record_deform(&self, pass: &mut wgpu::ComputePass<'_>) {
        self.deform.record(pass);
    }

    /// Record the fit: the parts' moments, then their spheres (one workgroup per part each).
    pub(crate) fn record_fit(&self, pass: &mut wgpu::ComputePass<'_>) {
        for (pipe, bind) in self.fit_pipes.iter().zip(&self.fit_binds) {
            pass.set_pipeline(pipe);
            pass.set_bind_group(0, bind, &[]);
            pass.dispatch_workgroups(self.parts as u32, 1, 1);
        }
    }

    /// The posed vertices of the last frame (tests).
    pub fn read_posed(&self, ctx: &GpuContext) -> Result<Vec<[f32; 4]>, GpuError> {
        self.deform.read_posed(ctx)
    }
}

/// `Ok` when [`GpuSphereFit::new`] can take its parts and slot, else the culprit named (the
/// pose's own checks are [`DeviceDeform::new`]'s).
fn check(
    ctx: &GpuContext,
    rest: &Mesh,
    (labels, parts): (&[u32], usize),
    slot: usize,
) -> Result<(), GpuError> {
    let nt = rest.triangles.len();
    if parts == 0 || parts > MAX_GPU_FIT_PARTS || slot + parts > MAX_GPU_FIT_PARTS {
        return Err(GpuError::Input(format!(
            "{parts} parts at slot {slot}: the device fit takes 1 to {MAX_GPU_FIT_PARTS} spheres in all"
        )));
    }
    if labels.len() != nt || labels.iter().any(|&l| l as usize >= parts) {
        return Err(GpuError::Input(format!(
            "{} part labels below {parts} for {nt} triangles",
            labels.len()
        )));
    }
    ctx.check_binding("the fit's triangles", 16 * nt as u64)
}

/// The triangles sorted by part (stable: each part keeps the mesh's order) as the kernels read
/// them, and each part's range of them (`first, end`; `0, 0` for a part without triangles).
fn by_part(mesh: &Mesh, labels: &[u32], parts: usize) -> (Vec<[u32; 4]>, Vec<[u32; 4]>) {
    let mut order: Vec<usize> = (0..labels.len()).collect();
    order.sort_by_key(|&f| labels[f]);
    let tris = (order.iter())
        .map(|&f| {
            let [a, b, c] = mesh.triangles[f];
            [a, b, c, 0]
        })
        .collect();
    let mut ranges = vec![[0u32; 4]; parts];
    for (i, &f) in order.iter().enumerate() {
        let r = &mut ranges[labels[f] as usize];
        if r[1] == 0 {
            r[0] = i as u32;
        }
        r[1] = i as u32 + 1;
    }
    (tris, ranges)
}

/// A whole buffer as a binding.
fn whole(b: &wgpu::Buffer) -> wgpu::BindingResource<'_> {
    b.as_entire_binding()
}
