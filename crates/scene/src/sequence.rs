//! Deforming sequences with every method of the vocabulary (`render --frames --method M`).
//!
//! The papers' extrapolation from a uniform sampling sphere has the real-time path
//! ([`crate::render::render_sequence`]: the BVH refitted, one BSV per frame, the receiver
//! cache). Every other method — the papers' full field, sub-volumes, sphere sets (fitted to each
//! frame's posed mesh), per-direction sampling radii, the truths — is rendered frame by frame
//! from the posed mesh with [`crate::render::render`]: the same code as a single image at
//! `pose_t = f / frames`, so a sequence's frame equals that image, and its stage times are that
//! render's (nothing is carried from frame to frame: no refit, no cache). With a reference, each
//! frame's `shade_rmse_rel` against the reference of the same pose is computed after the frame,
//! outside its times.

use crate::error::Error;
use crate::method::Method;
use crate::render::{render, render_sequence_each, FrameStats, RenderOutput};
use crate::scene::Scene;
use crate::settings::RenderSettings;
use shscale_field::bsv::RadialRule;

/// One frame of a sequence: its stage times (seconds, in execution order) and, with a
/// reference, its error.
#[derive(Clone, Debug)]
pub struct SequenceFrame {
    pub frame: usize,
    pub t: f64,
    pub stages: Vec<(String, f64)>,
    /// The sum of the stages.
    pub seconds: f64,
    /// `shade_rmse_rel` against the reference at the same pose.
    pub error: Option<f64>,
}

/// Whether a render with `rs` takes the cached real-time path: the papers' extrapolation
/// sampled on one sphere (uniform radial rule).
pub fn cached_path(rs: &RenderSettings) -> bool {
    rs.method == Method::Extrapolated && rs.radial == RadialRule::Uniform
}

/// The pixels as one flat list of channels.
pub fn flat(p: &[[f32; 3]]) -> Vec<f64> {
    p.iter().flat_map(|p| p.map(f64::from)).collect()
}

/// A reference to score images against (docs/conventions.md §6): a truth method rendered at any
/// pose of a scene, and the scene's unshadowed image (band-limited, no occluders), computed once
/// — `shade_rmse_rel(image, truth, unshadowed)`. Used by `render --reference` (one image or every
/// frame) and `bench --methods --errors`.
pub struct Reference {
    pub method: Method,
    /// The render settings of the scored renders with the reference's method.
    settings: RenderSettings,
    unshadowed: Vec<f64>,
}

impl Reference {
    /// The reference `method` for renders of `scene` with the settings `rs` (their order, truth
    /// resolution and every other parameter).
    pub fn new(scene: &Scene, rs: &RenderSettings, method: Method) -> Result<Self, Error> {
        let mut open = scene.clone();
        open.occluders.clear();
        Ok(Reference {
            method,
            settings: rs.with(method),
            unshadowed: flat(&render(&open, &rs.with(Method::RayTraced))?.pixels),
        })
    }

    /// The reference's image of `scene` at the deformers' time `t` (`None`: the scene's own
    /// `pose_t`).
    pub fn image(&self, scene: &Scene, t: Option<f64>) -> Result<RenderOutput, Error> {
        match t {
            None => render(scene, &self.settings),
            Some(t) => render(
                &Scene {
                    pose_t: Some(t),
                    ..scene.clone()
                },
                &self.settings,
            ),
        }
    }

    /// `shade_rmse_rel` of `pixels` against `truth` (flat, [`flat`]); `None` where the
    /// unshadowed image is black.
    pub fn error(&self, pixels: &[[f32; 3]], truth: &[f64]) -> Option<f64> {
        shscale_field::shading::shade_rmse_rel(&flat(pixels), truth, &self.unshadowed)
    }

    /// The error of `pixels` against the reference at `t`, rendered for it.
    fn error_at(&self, scene: &Scene, t: f64, pixels: &[[f32; 3]]) -> Result<f64, Error> {
        let truth = flat(&self.image(scene, Some(t))?.pixels);
        self.error(pixels, &truth)
            .ok_or_else(|| Error::config(format!("{}: the unshadowed image is black", scene.file)))
    }
}

/// What [`render_sequence_with`] calls after every frame (outside its times): the frame and its
/// pixels.
pub type EachFrame<'a> = dyn FnMut(&SequenceFrame, &[[f32; 3]]) + 'a;

/// `frames` poses `t = f / frames` of `scene` rendered with `rs`, each frame's stage times
/// and (with `reference`) its error; the image is the last frame's. `each` sees every frame
/// and its pixels as it is done (progress, errors against other references).
pub fn render_sequence_with(
    scene: &Scene,
    rs: &RenderSettings,
    frames: usize,
    reference: Option<Method>,
    each: &mut EachFrame,
) -> Result<(RenderOutput, Vec<SequenceFrame>), Error> {
    let frames = frames.max(1);
    let scorer = (reference.map(|r| Reference::new(scene, rs, r))).transpose()?;
    if cached_path(rs) {
        return cached(scene, rs, frames, scorer.as_ref(), each);
    }
    let mut out = Vec::with_capacity(frames);
    let mut last = None;
    for f in 0..frames {
        let t = f as f64 / frames as f64;
        let posed = Scene {
            pose_t: Some(t),
            ..scene.clone()
        };
        let img = render(&posed, rs)?;
        let error = match &scorer {
            Some(s) => Some(s.error_at(scene, t, &img.pixels)?),
            None => None,
        };
        let fr = SequenceFrame {
            frame: f,
            t,
            seconds: img.stages.iter().map(|s| s.1).sum(),
            stages: img.stages.clone(),
            error,
        };
        each(&fr, &img.pixels);
        out.push(fr);
        last = Some(img);
    }
    Ok((last.expect("at least one frame"), out))
}

/// The cached path's frames as [`SequenceFrame`]s (stages `deform`, `bvh_update`,
/// `bsv_sampling`, `shading`).
fn cached(
    scene: &Scene,
    rs: &RenderSettings,
    frames: usize,
    scorer: Option<&Reference>,
    each: &mut EachFrame,
) -> Result<(RenderOutput, Vec<SequenceFrame>), Error> {
    let mut out = Vec::with_capacity(frames);
    let (img, _) = render_sequence_each(scene, rs, frames, &mut |st: &FrameStats, pixels| {
        let error = match scorer {
            Some(s) => Some(s.error_at(scene, st.t, pixels)?),
            None => None,
        };
        let stages = named_stages(&[
            ("deform", st.deform_seconds),
            ("bvh_update", st.bvh_update_seconds),
            ("bsv_sampling", st.bsv_sampling_seconds),
            ("shading", st.shading_seconds),
        ]);
        let fr = SequenceFrame {
            frame: st.frame,
            t: st.t,
            seconds: stages.iter().map(|s| s.1).sum(),
            stages,
            error,
        };
        each(&fr, pixels);
        out.push(fr);
        Ok(())
    })?;
    Ok((img, out))
}

impl SequenceFrame {
    /// Frame `frame` at `t` with its `(stage, seconds)` (no error): its seconds their sum.
    pub(crate) fn of_stages(frame: usize, t: f64, stages: &[(&str, f64)]) -> Self {
        let stages = named_stages(stages);
        Self {
            frame,
            t,
            seconds: stages.iter().map(|s| s.1).sum(),
            stages,
            error: None,
        }
    }
}

/// A frame's stage times as [`SequenceFrame::stages`] holds them (names owned).
pub(crate) fn named_stages(stages: &[(&str, f64)]) -> Vec<(String, f64)> {
    (stages.iter()).map(|(n, v)| (n.to_string(), *v)).collect()
}
