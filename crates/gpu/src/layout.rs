//! GPU data layouts, declared once: [`gpu_struct!`] defines the Rust `#[repr(C)]` Pod struct and
//! emits the matching WGSL `struct` text from the same field list, so a layout is never written
//! twice; each struct's size is asserted at compile time. Shaders are assembled as
//! `WGSL_STRUCTS + common.wgsl + kernel.wgsl` (all included at compile time).
//!
//! Field types are limited to ones whose Rust and WGSL layouts agree without implicit padding:
//! `[f32; 4]`/`vec4<f32>`, `[u32; 4]`/`vec4<u32>`, `f32`, `u32` — the sizes asserted below would
//! catch any slip.

use bytemuck::{Pod, Zeroable};

/// Declare a GPU struct in Rust and WGSL at once: `name { field: RustType => "wgsl type", … }`.
macro_rules! gpu_struct {
    ($(#[$doc:meta])* $name:ident [$size:expr] { $($(#[$fdoc:meta])* $f:ident : $rt:ty => $wt:literal),* $(,)? }) => {
        $(#[$doc])*
        #[repr(C)]
        #[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
        pub struct $name { $($(#[$fdoc])* pub $f: $rt),* }
        impl $name {
            /// The WGSL declaration of this struct.
            pub const WGSL: &'static str = concat!(
                "struct ", stringify!($name), " {\n",
                $("    ", stringify!($f), ": ", $wt, ",\n",)*
                "}\n"
            );
        }
        const _: () = assert!(std::mem::size_of::<$name>() == $size, "GPU layout size");
    };
}

gpu_struct! {
    /// A binary BVH node (obvhs `Bvh2Node` without its meta fields). Leaf: `count > 0`
    /// triangles from `first` in the reordered triangle buffer; inner: children `first`,
    /// `first + 1`.
    GpuNode [32] {
        min: [f32; 3] => "vec3<f32>",
        count: u32 => "u32",
        max: [f32; 3] => "vec3<f32>",
        first: u32 => "u32",
    }
}

gpu_struct! {
    /// A triangle's corners (`w` unused).
    GpuTri [48] {
        v0: [f32; 4] => "vec4<f32>",
        v1: [f32; 4] => "vec4<f32>",
        v2: [f32; 4] => "vec4<f32>",
    }
}

gpu_struct! {
    /// One base-sphere sample: position and local frame (z toward the entity centre), fixed for
    /// a sequence.
    GpuSample [64] {
        pos: [f32; 4] => "vec4<f32>",
        fx: [f32; 4] => "vec4<f32>",
        fy: [f32; 4] => "vec4<f32>",
        fz: [f32; 4] => "vec4<f32>",
    }
}

gpu_struct! {
    /// Kernel parameters shared by all stages (a uniform).
    GpuParams [32] {
        /// SH order N (≤ 8) and N².
        order: u32 => "u32",
        nn: u32 => "u32",
        /// Base-sphere samples and rays per sample (H²).
        samples: u32 => "u32",
        rays: u32 => "u32",
        /// Receivers and shaded channels (1 grey, 3 RGB).
        receivers: u32 => "u32",
        channels: u32 => "u32",
        /// Ray start offset `RAY_EPS · r` of this frame.
        tmin: f32 => "f32",
        pad: u32 => "u32",
    }
}

gpu_struct! {
    /// One receiver of the cached extrapolation (`ReceiverCache`): three sample indices and
    /// barycentric weights; `flag = 1` means beyond `k_max` with the constant irradiance
    /// `constant.xyz`.
    GpuReceiver [48] {
        idx: [u32; 3] => "vec3<u32>",
        flag: u32 => "u32",
        w: [f32; 4] => "vec4<f32>",
        constant: [f32; 4] => "vec4<f32>",
    }
}

gpu_struct! {
    /// Parameters of the receiver-cache kernel (a uniform).
    GpuCacheParams [48] {
        /// Sampling-sphere centre (xyz) and radius (w).
        center: [f32; 4] => "vec4<f32>",
        receivers: u32 => "u32",
        order: u32 => "u32",
        nn: u32 => "u32",
        channels: u32 => "u32",
        /// Tabulated k values and quadrature points.
        k_count: u32 => "u32",
        quad: u32 => "u32",
        /// 1: the table interpolates in ln k.
        log_k: u32 => "u32",
        pad: u32 => "u32",
    }
}

gpu_struct! {
    /// Parameters of the sphere-set shading kernel (a uniform).
    GpuSetParams [32] {
        receivers: u32 => "u32",
        /// SH order N (≤ 8) and N².
        order: u32 => "u32",
        nn: u32 => "u32",
        /// Spheres of the set (≤ 64) and entries of the order-N Gaunt tensor.
        spheres: u32 => "u32",
        entries: u32 => "u32",
        /// Shaded channels (1 grey, 3 RGB).
        channels: u32 => "u32",
        /// The union's z-rings (≤ 32; 0 for the product chain) and the fewest rings a panel
        /// takes.
        rings: u32 => "u32",
        panel_rings: u32 => "u32",
    }
}

gpu_struct! {
    /// Parameters of the sub-volumes kernel (a uniform).
    GpuPartsParams [48] {
        receivers: u32 => "u32",
        /// SH order N (≤ 8) and N².
        order: u32 => "u32",
        nn: u32 => "u32",
        /// Parts (≤ 16), base-sphere samples per part, Gaunt entries, quadrature points.
        parts: u32 => "u32",
        samples: u32 => "u32",
        entries: u32 => "u32",
        quad: u32 => "u32",
        /// Tabulated k values per part; 1: the tables interpolate in ln k.
        k_count: u32 => "u32",
        log_k: u32 => "u32",
        /// Shaded channels (1 grey, 3 RGB).
        channels: u32 => "u32",
        pad0: u32 => "u32",
        pad1: u32 => "u32",
    }
}

gpu_struct! {
    /// The frame's pose and the tree's sizes (`pose.wgsl`, a uniform).
    GpuPose [32] {
        /// 0 none, 1 bend, 2 twist, 3 morph, 4 flap.
        kind: u32 => "u32",
        vertices: u32 => "u32",
        /// Leaves and nodes of the tree.
        leaves: u32 => "u32",
        nodes: u32 => "u32",
        /// The frame's scalar (`Deformer::scalar`: bend κ, twist angle, morph weight, flap
        /// angle) and the deformer's constant (`Deformer::constant`: twist h, flap y0).
        scalar: f32 => "f32",
        constant: f32 => "f32",
        pad0: u32 => "u32",
        pad1: u32 => "u32",
    }
}

gpu_struct! {
    /// One level of inner nodes to refit (`pose.wgsl`, a uniform per level).
    GpuLevel [16] {
        start: u32 => "u32",
        count: u32 => "u32",
        pad0: u32 => "u32",
        pad1: u32 => "u32",
    }
}

/// The most spheres a sphere set's kernels sort and combine per receiver (and a device fit
/// writes in all).
pub const MAX_GPU_SPHERES: usize = 64;

gpu_struct! {
    /// One mesh's sphere fit (`fit.wgsl`, a uniform): its parts, the first of its spheres' slots
    /// in the set's sphere buffer, and the point the moments are taken about (the rest pose's
    /// bounding-sphere centre, for f32 precision).
    GpuFit [32] {
        parts: u32 => "u32",
        slot: u32 => "u32",
        pad0: u32 => "u32",
        pad1: u32 => "u32",
        origin: [f32; 4] => "vec4<f32>",
    }
}

/// Every struct's WGSL declaration, prepended to each shader.
pub(crate) fn wgsl_structs() -> String {
    [
        GpuNode::WGSL,
        GpuTri::WGSL,
        GpuSample::WGSL,
        GpuParams::WGSL,
        GpuReceiver::WGSL,
        GpuCacheParams::WGSL,
        GpuSetParams::WGSL,
        GpuPartsParams::WGSL,
        GpuPose::WGSL,
        GpuLevel::WGSL,
        GpuFit::WGSL,
    ]
    .concat()
}

/// Common WGSL (constants, ray–box and ray–triangle tests), included at compile time.
pub(crate) const COMMON_WGSL: &str = include_str!("common.wgsl");
/// SH evaluation in WGSL (needs a `knorm` binding in the kernel).
pub(crate) const SH_WGSL: &str = include_str!("sh.wgsl");

/// A complete shader: struct declarations, common code, then `parts` (e.g. SH code and a
/// kernel).
pub fn shader(parts: &[&str]) -> String {
    let mut s = wgsl_structs();
    s.push('\n');
    s.push_str(COMMON_WGSL);
    for p in parts {
        s.push('\n');
        s.push_str(p);
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wgsl_declarations_name_every_field() {
        assert!(GpuNode::WGSL.contains("min: vec3<f32>,"));
        assert!(GpuNode::WGSL.contains("first: u32,"));
        assert!(GpuParams::WGSL.starts_with("struct GpuParams {"));
        assert_eq!(GpuReceiver::WGSL.matches(':').count(), 4);
    }
}
