//! Every method's GPU form behind one dispatch: which GPU sequence renders a scene's method
//! ([`gpu_form`], with the reason where its keys have none) and, for the per-frame forms, the
//! sequence itself with every frame as a [`SequenceFrame`] ([`render_gpu_frames`]) — the one
//! place `render --frames --gpu`, `bench --methods … --gpu` and `budget_plane`'s device axis
//! choose a GPU path.

use crate::error::Error;
use crate::method::Method;
use crate::render::RenderOutput;
use crate::scene::Scene;
use crate::sequence::SequenceFrame;
use crate::settings::RenderSettings;
use shscale_field::bsv::RadialRule;
use shscale_gpu::GpuContext;

/// The GPU sequence a method runs on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GpuForm {
    /// The papers' extrapolation from one sampling sphere: the real-time sequence
    /// ([`crate::gpu_path`]), its sampling sphere enclosing every pose, no per-frame image.
    Sequence,
    /// The extrapolation from clearance radii ([`crate::gpu_radial`]).
    Radial,
    /// Sub-volumes ([`crate::gpu_parts`]).
    SubVolumes,
    /// The full field ([`crate::gpu_field`]).
    FullField,
    /// Sphere sets by the chain, the union or SH exponentiation ([`crate::gpu_sets`]).
    SphereSet,
    /// The band-limited ray-traced reference ([`crate::gpu_truth`]).
    RayTraced,
}

impl GpuForm {
    /// How the form is named in a sequence's title.
    pub fn name(self) -> &'static str {
        match self {
            Self::Sequence => "extrapolation",
            Self::Radial => "per-direction radii",
            Self::SubVolumes => "sub-volumes",
            Self::FullField => "full-field",
            Self::SphereSet => "sphere-set",
            Self::RayTraced => "ray-traced",
        }
    }
}

/// The GPU form of `scene` rendered with `rs`: `Ok(None)` where its method has none at all (the
/// full-frequency reference, the extrapolation with the occlusion rule or the plausibility clamp),
/// an error naming the culprit where it has one but the keys are outside it.
pub fn gpu_form(scene: &Scene, rs: &RenderSettings) -> Result<Option<GpuForm>, Error> {
    let form = match rs.method {
        Method::SphereSet => GpuForm::SphereSet,
        Method::FullField => GpuForm::FullField,
        Method::SubVolumes => GpuForm::SubVolumes,
        Method::RayTraced => GpuForm::RayTraced,
        Method::Extrapolated if matches!(rs.radial, RadialRule::Clearance { .. }) => {
            GpuForm::Radial
        }
        Method::Extrapolated if crate::sequence::cached_path(rs) => GpuForm::Sequence,
        _ => return Ok(None),
    };
    match form {
        GpuForm::Sequence => crate::gpu_path::check(scene, rs)?,
        GpuForm::Radial => crate::gpu_radial::check(scene, rs)?,
        GpuForm::SubVolumes => crate::gpu_parts::check(scene, rs)?,
        GpuForm::FullField => crate::gpu_field::check(scene, rs)?,
        GpuForm::SphereSet => crate::gpu_sets::check(scene, rs)?,
        GpuForm::RayTraced => crate::gpu_truth::check(scene, rs)?,
    }
    Ok(Some(form))
}

impl GpuForm {
    /// The method keys (the vocabulary's names, `method::Spec::reads`) whose values this GPU
    /// form carries out: every other key its method reads must keep the kind's default on the
    /// GPU path ([`unhonoured`]), so that no GPU time is recorded for a computation other than
    /// the CPU's. Values a form takes only in part (a sphere set's combinations, its internal
    /// order, sub-volumes' part count) are checked by the form's own `check`.
    pub(crate) fn honours(self) -> &'static [&'static str] {
        match self {
            Self::Sequence => &[
                "layout",
                "hemisphere_res",
                "alpha_deg",
                "sampling_radius",
                "k_count",
            ],
            Self::Radial => &[
                "layout",
                "hemisphere_res",
                "alpha_deg",
                "sampling_radius",
                "k_count",
                "radial",
                "radial_delta",
            ],
            Self::SubVolumes => &[
                "layout",
                "hemisphere_res",
                "alpha_deg",
                "sampling_radius",
                "k_count",
                "parts",
            ],
            Self::FullField => crate::method::FULL_FIELD_KEYS,
            Self::SphereSet => &["parts", "sphere_combine", "sphere_order", "sphere_fit"],
            Self::RayTraced => &["rt_res"],
        }
    }
}

/// The first method key `form` does not carry out whose value is not the kind's default: of
/// `read` (the keys the run's method reads), `cells` the run's `(key, value)` and `defaults`
/// the kind's. `None` when the GPU form computes what the CPU does.
pub fn unhonoured<'a>(
    form: GpuForm,
    read: &[&str],
    cells: &'a [(&'static str, String)],
    defaults: &'a [(&'static str, String)],
) -> Option<(&'static str, &'a str, &'a str)> {
    let default = |k: &str| {
        defaults
            .iter()
            .find(|(d, _)| *d == k)
            .map(|(_, v)| v.as_str())
    };
    (cells.iter())
        .filter(|(k, _)| read.contains(k) && !form.honours().contains(k))
        .find_map(|(k, v)| match default(k) {
            Some(d) if d != v => Some((*k, v.as_str(), d)),
            _ => None,
        })
}

/// `frames` poses of `scene` rendered on the GPU by `form`, every frame handed to `each` as a
/// [`SequenceFrame`] with its pixels; the last frame's image. [`GpuForm::Sequence`] keeps no
/// per-frame image: it is [`crate::gpu_path::render_sequence_gpu_with`]'s, and refused here.
pub fn render_gpu_frames(
    scene: &Scene,
    rs: &RenderSettings,
    form: GpuForm,
    frames: usize,
    ctx: &GpuContext,
    each: &mut dyn FnMut(&SequenceFrame, &[[f32; 3]]),
) -> Result<RenderOutput, Error> {
    render_gpu_frames_posed(scene, rs, form, frames, ctx, false, each)
}

/// Whether `form` with the settings `rs` can pose its frames on the device (`render --device-pose`,
/// `bench --device-pose`): the papers' sequence ([`crate::gpu_path`]) and sphere sets with the
/// area fit ([`crate::gpu_sets::SetPose::Device`]); the other forms pose on the host.
pub fn poses_on_device(rs: &RenderSettings, form: GpuForm) -> bool {
    match form {
        GpuForm::Sequence => true,
        GpuForm::SphereSet => rs.sphere_fit == crate::combine::SphereFit::Area,
        _ => false,
    }
}

/// [`render_gpu_frames`], posed on the device where `device_pose` (sphere sets with the area fit
/// only: the other per-frame forms refuse it by name).
pub fn render_gpu_frames_posed(
    scene: &Scene,
    rs: &RenderSettings,
    form: GpuForm,
    frames: usize,
    ctx: &GpuContext,
    device_pose: bool,
    each: &mut dyn FnMut(&SequenceFrame, &[[f32; 3]]),
) -> Result<RenderOutput, Error> {
    if device_pose && !poses_on_device(rs, form) {
        return Err(Error::config(format!(
            "{}: --device-pose: the {} GPU frames are posed on the host (the device poses the papers' sequence and sphere sets with sphere_fit = \"area\")",
            scene.file,
            form.name()
        )));
    }
    let out = match form {
        GpuForm::Sequence => {
            return Err(Error::config(format!(
                "{}: the papers' GPU sequence keeps no per-frame image",
                scene.file
            )))
        }
        GpuForm::Radial => {
            crate::gpu_radial::render_sequence_radial_gpu(scene, rs, frames, ctx, &mut |f, px| {
                each(&f.as_sequence_frame(), px)
            })?
            .0
        }
        GpuForm::SubVolumes => {
            crate::gpu_parts::render_sequence_sub_volumes_gpu(
                scene,
                rs,
                frames,
                ctx,
                &mut |f, px| each(&f.as_sequence_frame(), px),
            )?
            .0
        }
        GpuForm::FullField => {
            crate::gpu_field::render_sequence_full_field_gpu(
                scene,
                rs,
                frames,
                ctx,
                &mut |f, px| each(&f.as_sequence_frame(), px),
            )?
            .0
        }
        GpuForm::SphereSet => {
            use crate::gpu_sets::{render_sequence_sphere_set_gpu_posed, SetPose};
            let pose = if device_pose {
                SetPose::Device
            } else {
                SetPose::Host
            };
            render_sequence_sphere_set_gpu_posed(scene, rs, frames, ctx, pose, &mut |f, px| {
                each(&f.as_sequence_frame(), px)
            })?
            .0
        }
        GpuForm::RayTraced => {
            crate::gpu_truth::render_sequence_ray_traced_gpu(
                scene,
                rs,
                frames,
                ctx,
                &mut |f, px| each(&f.as_sequence_frame(), px),
            )?
            .0
        }
    };
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The vocabulary's rule: a key the method reads, that the form does not carry out, at a
    /// value other than the default, is named; the same key at its default, a key the form
    /// carries out, and a key the method does not read are not.
    #[test]
    fn a_key_the_form_does_not_carry_out_is_named() {
        let cells = vec![
            ("plausibility", "clamp".to_string()),
            ("alpha_deg", "30".to_string()),
            ("shells", "4".to_string()),
        ];
        let defaults = vec![
            ("plausibility", "none".to_string()),
            ("alpha_deg", "45".to_string()),
            ("shells", "16".to_string()),
        ];
        let read = ["plausibility", "alpha_deg"];
        assert_eq!(
            unhonoured(GpuForm::Sequence, &read, &cells, &defaults),
            Some(("plausibility", "clamp", "none"))
        );
        assert_eq!(
            unhonoured(GpuForm::Sequence, &read, &defaults, &defaults),
            None
        );
        assert_eq!(
            unhonoured(GpuForm::Sequence, &["alpha_deg"], &cells, &defaults),
            None
        );
        // `shells` is not read by the extrapolation; the full field carries it out.
        assert_eq!(
            unhonoured(GpuForm::FullField, &["shells"], &cells, &defaults),
            None
        );
        assert_eq!(
            unhonoured(GpuForm::SphereSet, &["shells"], &cells, &defaults),
            Some(("shells", "4", "16"))
        );
    }
}
