//! Scene files (TOML). Two stages (docs/ARCHITECTURE.md (habit 5)): [`RawScene`] mirrors the file exactly and rejects
//! unknown fields; [`Scene::load`] resolves it — validates every range and names the file, the
//! line and the field in every error.
//!
//! ```toml
//! order = 4                 # SH order N
//! alpha_deg = 45            # cone half-angle
//! layout = "latlong:12x20"  # base-sphere layout
//! hemisphere_res = 32       # H (H×H rays per BSV sample)
//! truth_res = 32            # T of the truths (4T² stratified rays per receiver)
//! k_count = 40              # tabulated k values
//! sampling_radius = 1.0     # s ≥ 1
//!
//! [[occluder]]
//! mesh = "bunny"            # bundled name, .obj/.ply path, "sphere" (analytic), or a
//!                           # procedural shape: "bird", "egg", "sponge", "plane"
//! center = [0, 0, 1]        # where the bounding-sphere centre goes
//! radius = 1.0              # the bounding radius after scaling
//! up = "y"                  # the mesh's up axis ("y" or "z"); mapped to +z
//! deformer = "flap"         # optional: flap | bend | twist | morph, animated over the frames
//! amount = 0.8              #   its strength
//!
//! [receiver]
//! center = [0, 0, 0]        # plane z = center.z, normal +z
//! size = [4, 4]
//! resolution = [160, 160]
//!
//! [light]
//! kind = "sky"              # "sky" (closed form) or "exr" (lat-long map, top row = +z)
//! ambient = 0.3             # sky: a + b·max(0, z) + sun·[cap]
//! zenith = 1.0
//! sun = 20.0
//! sun_dir = [0.3, 0.2, 1]
//! sun_radius_deg = 5
//! # path = "envmaps/city.exr"  (exr; relative to the scene file)
//! # intensity = 1.0
//!
//! [[light_source]]          # optional local area lights, emitting toward −z
//! kind = "hinge"            # "quad" (one-sided square) or "hinge" (red + green panels)
//! center = [0, 0, 3]
//! size = 1.0
//! hinge_deg = 100
//! intensity = 5.0           # scales `radiance` (quad, default [1, 1, 1]) or red/green (hinge)
//! eta = "plain"             # source-radiance-field scaling: "plain" or "energy"
//! ```

use crate::error::Error;
use crate::settings::RenderSettings;
use crate::vocab::MAX_K_COUNT;
use glam::DVec3;
use serde::Deserialize;
use shscale_field::Layout;
use shscale_runner::check::{self, num, Ends};
use std::path::{Path, PathBuf};

/// The file as written.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawScene {
    pub order: Option<usize>,
    pub alpha_deg: Option<f64>,
    pub layout: Option<String>,
    pub hemisphere_res: Option<usize>,
    pub truth_res: Option<usize>,
    pub plausibility: Option<String>,
    pub k_count: Option<usize>,
    pub sampling_radius: Option<f64>,
    #[serde(default)]
    pub occluder: Vec<RawOccluder>,
    pub receiver: RawReceiver,
    pub light: RawLight,
    #[serde(default)]
    pub light_source: Vec<RawLightSource>,
    pub camera: Option<RawCamera>,
}

/// `[camera]`: a perspective view for `shscale render --camera` (+z up).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawCamera {
    pub position: [f64; 3],
    pub look_at: [f64; 3],
    pub fov_deg: Option<f64>,
    pub resolution: Option<[usize; 2]>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawLightSource {
    /// "quad" (one-sided square) or "hinge" (the papers' red/green hinged light).
    pub kind: String,
    pub center: [f64; 3],
    pub size: Option<f64>,
    pub hinge_deg: Option<f64>,
    /// Linear RGB radiance of a quad; the hinge is red and green scaled by `intensity`.
    pub radiance: Option<[f64; 3]>,
    pub intensity: Option<f64>,
    /// "plain" (default; radiance is invariant along rays) or "energy" (the papers' prescription).
    pub eta: Option<String>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawOccluder {
    pub mesh: String,
    pub center: [f64; 3],
    pub radius: f64,
    pub up: Option<String>,
    /// "flap" (bird), "bend" / "twist" (sponge, plane, any mesh), "morph" (egg → sphere).
    pub deformer: Option<String>,
    /// Strength: flap amplitude (rad, default 0.8), bend curvature (default 1.2), twist turns
    /// (default 0.25), morph egg parameter (default 0.5).
    pub amount: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawReceiver {
    pub center: [f64; 3],
    pub size: [f64; 2],
    pub resolution: [usize; 2],
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawLight {
    pub kind: String,
    pub ambient: Option<f64>,
    pub zenith: Option<f64>,
    pub sun: Option<f64>,
    pub sun_dir: Option<[f64; 3]>,
    pub sun_radius_deg: Option<f64>,
    pub path: Option<String>,
    pub intensity: Option<f64>,
}

/// An occluder as resolved.
#[derive(Clone, Debug)]
pub struct OccluderSpec {
    pub mesh: String,
    pub center: DVec3,
    pub radius: f64,
    pub up_is_y: bool,
    pub deformer: Option<(shscale_geometry::deform::DeformerKind, f64)>,
    /// A turn of the placed mesh about its bounding sphere's centre (`None`: as placed), set by
    /// studies that vary the occluder's orientation (the `budget_plane` kind's
    /// `placement_seed`); scene files do not set it. Frames rendered one at a time
    /// ([`crate::render::render`] at a `pose_t`) deform the occluder in its own frame and turn
    /// it after ([`crate::frame::posed`]); the sequence engines (`render_sequence`, the GPU
    /// path) read scene files only, which set no turn.
    pub turn: Option<glam::DQuat>,
}

impl OccluderSpec {
    /// The occluder's mesh at rest: [`crate::vocab::placed_mesh`], then its turn about the
    /// centre. The analytic sphere has none (an error from `placed_mesh`).
    pub fn placed(&self) -> Result<shscale_geometry::Mesh, Error> {
        let mut m = crate::vocab::placed_mesh(&self.mesh, self.center, self.radius, self.up_is_y)?;
        if let Some(q) = self.turn {
            m.rotate_about(m.bounding_sphere().center, q);
        }
        Ok(m)
    }

    /// The occluder at rest: the analytic sphere, or the BVH of [`OccluderSpec::placed`].
    pub fn build(&self) -> Result<Box<dyn shscale_geometry::Occluder>, Error> {
        if self.mesh == "sphere" {
            let sphere = shscale_geometry::Sphere {
                center: self.center,
                radius: self.radius,
            };
            return Ok(Box::new(shscale_geometry::AnalyticSphere { sphere }));
        }
        Ok(Box::new(shscale_geometry::MeshBvh::build(
            &self.placed()?,
            shscale_geometry::ray::UpdateStrategy::Rebuild,
        )))
    }
}

/// The light as resolved.
#[derive(Clone, Debug)]
pub enum LightSpec {
    Sky {
        ambient: f64,
        zenith: f64,
        sun: f64,
        sun_dir: DVec3,
        sun_radius: f64,
    },
    Exr {
        path: PathBuf,
        intensity: f64,
    },
}

/// A resolved scene: what is there to be seen — its occluders (and their pose), the receiver
/// plane, the light, the local light sources and the camera. How it is rendered (the method
/// and every parameter a method reads) is a [`crate::settings::RenderSettings`], which the scene
/// file's top-level keys give defaults for ([`Scene::load`] returns both).
#[derive(Clone, Debug)]
pub struct Scene {
    pub file: String,
    pub occluders: Vec<OccluderSpec>,
    pub receiver_center: DVec3,
    pub receiver_size: [f64; 2],
    pub resolution: [usize; 2],
    pub light: LightSpec,
    pub light_sources: Vec<LightSourceSpec>,
    /// The `[camera]` table, if any (`render --camera` uses a default view otherwise).
    pub camera: Option<Camera>,
    /// The deformers' time t ∈ [0, 1) at which [`crate::render::render`] poses the occluders, set
    /// by experiments (no scene-file key); `None`: the rest pose.
    pub pose_t: Option<f64>,
}

/// A local area light, emitting downward (toward −z) from `center`.
#[derive(Clone, Debug)]
pub struct LightSourceSpec {
    pub hinge: bool,
    pub center: DVec3,
    pub size: f64,
    pub hinge_angle: f64,
    pub radiance: [f64; 3],
    pub energy: bool,
}

/// Every key of a scene file: (key path, type, default, meaning and range) — the config
/// reference; a test checks the list against the schema (`RawScene` and its tables).
pub const SCENE_KEYS: &[(&str, &str, &str, &str)] = &[
    ("order", "integer", "4", "SH order N, 1..=16"),
    ("alpha_deg", "number", "45", "cone half-angle α, degrees, (0, 90)"),
    ("layout", "string", "`latlong:12x20`", "base-sphere layout, at most 10⁶ samples"),
    ("hemisphere_res", "integer", "32", "H: H² rays per BSV sample, 1..=256"),
    ("truth_res", "integer", "32", "T of the ray-traced truths: 4T² stratified rays per receiver (band-limited, per occluder; full-frequency, plus the sun's cap), with their own error estimate, 1..=256"),
    ("plausibility", "string", "`none`", "the extrapolation's plausibility mitigation: `none` or `clamp` (visibility clamped to [0, 1] and 1 outside the bounding cone, re-projected)"),
    ("k_count", "integer", "40", "k-table entries, 2..=10000"),
    ("sampling_radius", "number", "1", "sampling sphere in bounding radii, [1, 1000]"),
    ("occluder[i].mesh", "string", "(required)", "`sphere`, a procedural shape, a bundled mesh or a path (relative to the scene file)"),
    ("occluder[i].center", "3 numbers", "(required)", "where the bounding-sphere centre goes, each within ±1e6"),
    ("occluder[i].radius", "number", "(required)", "the bounding radius after scaling, [1e-6, 1e6]"),
    ("occluder[i].up", "string", "`y`", "the mesh's up axis, `y` or `z`, mapped to +z"),
    ("occluder[i].deformer", "string", "—", "`flap`, `bend`, `twist` or `morph`, animated over the frames (not for `sphere`)"),
    ("occluder[i].amount", "number", "the deformer's own", "deformer strength, [−10, 10]"),
    ("receiver.center", "3 numbers", "(required)", "centre of the receiver plane (normal +z), each within ±1e6"),
    ("receiver.size", "2 numbers", "(required)", "extent in x and y, each [1e-6, 1e6]"),
    ("receiver.resolution", "2 integers", "(required)", "receivers along x and y, 2..=4096 each"),
    ("light.kind", "string", "(required)", "`sky` (closed form) or `exr` (lat-long map, top row +z)"),
    ("light.ambient", "number", "0.3", "sky: constant term, [0, 1e12]"),
    ("light.zenith", "number", "1", "sky: max(0, z) term, [0, 1e12]"),
    ("light.sun", "number", "20", "sky: sun strength, [0, 1e12]"),
    ("light.sun_dir", "3 numbers", "`[0.3, 0.2, 1]`", "sky: sun direction, not all 0"),
    ("light.sun_radius_deg", "number", "5", "sky: sun angular radius, degrees, (0, 90]"),
    ("light.path", "string", "(required for `exr`)", "the EXR map, relative to the scene file; pixels finite and ≥ 0 (ringing to −1e-3 × max clamped)"),
    ("light.intensity", "number", "1", "exr: scale of the map, [0, 1e12], intensity × max ≤ 1e12"),
    ("light_source[i].kind", "string", "(required)", "`quad` (one-sided square) or `hinge` (red and green panels), emitting toward −z"),
    ("light_source[i].center", "3 numbers", "(required)", "centre, each within ±1e6"),
    ("light_source[i].size", "number", "1", "side, [1e-6, 1e6]"),
    ("light_source[i].hinge_deg", "number", "100", "hinge: angle between the panels, degrees, (0, 180)"),
    ("light_source[i].radiance", "3 numbers", "`[1, 1, 1]`", "quad: RGB radiance, each [0, 1e12]"),
    ("light_source[i].intensity", "number", "1", "scales the radiance, [0, 1e12], product ≤ 1e12"),
    ("light_source[i].eta", "string", "`plain`", "source-radiance-field scaling: `plain` or `energy`"),
    ("camera.position", "3 numbers", "(required in `[camera]`)", "`render --camera`: the eye, each within ±1e6 (+z up); without `[camera]` a default view of the receiver plane"),
    ("camera.look_at", "3 numbers", "(required in `[camera]`)", "the point the camera looks at, not the position"),
    ("camera.fov_deg", "number", "40", "vertical field of view, degrees, [1, 170]"),
    ("camera.resolution", "2 integers", "`[480, 320]`", "image width and height, 2..=4096 each"),
];

/// The largest |coordinate| (and size) of anything placed in a scene: occluder centres and
/// radii, the receiver plane, light sources (docs/limits.md).
pub const MAX_SCENE_COORDINATE: f64 = 1e6;
/// The smallest occluder radius, receiver size and light-source size.
pub(crate) const MIN_SCENE_SIZE: f64 = 1e-6;
/// The largest radiance-like value (sky terms, intensities, light-source radiance): irradiance
/// sums stay far from f32 overflow in the images.
pub(crate) const MAX_RADIANCE: f64 = 1e12;
/// The most occluders (and light sources) of a scene.
pub(crate) const MAX_OCCLUDERS: usize = 64;

/// A perspective camera; +z is up.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub position: DVec3,
    pub look_at: DVec3,
    /// Vertical field of view, degrees.
    pub fov_deg: f64,
    pub resolution: [usize; 2],
}

impl Camera {
    /// The default view of a scene: from the −y side, above the receiver plane, at its centre.
    pub fn default_for(scene: &Scene) -> Self {
        let c = scene.receiver_center;
        let s = scene.receiver_size[0].max(scene.receiver_size[1]);
        Self {
            position: c + DVec3::new(0.0, -1.25 * s, 0.9 * s),
            look_at: c + DVec3::new(0.0, 0.0, 0.1 * s),
            fov_deg: 40.0,
            resolution: [480, 320],
        }
    }
}

impl Scene {
    /// Every input a run reading the scene file at `path` reads
    /// ([`shscale_runner::Kind::inputs`], named by the parameter `key`): the file, its
    /// occluders' meshes ([`crate::vocab::mesh_inputs`]) and its environment map. The scene is
    /// parsed (an error names it); parsed scenes are kept by path, size and modification time,
    /// so a plan of many runs parses each once.
    pub fn inputs(key: &str, path: &Path) -> Result<Vec<shscale_runner::inputs::Input>, Error> {
        use shscale_runner::inputs::Input;
        type Key = (PathBuf, u64, Option<std::time::SystemTime>);
        static KNOWN: std::sync::Mutex<Vec<(Key, Vec<Input>)>> = std::sync::Mutex::new(Vec::new());
        let m = std::fs::metadata(path).ok();
        let k: Key = (
            path.to_path_buf(),
            m.as_ref().map_or(0, |m| m.len()),
            m.and_then(|m| m.modified().ok()),
        );
        if let Some(found) = (KNOWN.lock().unwrap_or_else(|e| e.into_inner()).iter())
            .find(|(x, _)| *x == k)
            .map(|(_, v)| v.clone())
        {
            return Ok(found);
        }
        let (scene, _) = Self::load(path)?;
        let mut out = vec![Input::File {
            key: key.into(),
            path: path.to_path_buf(),
        }];
        for o in &scene.occluders {
            out.extend(crate::vocab::mesh_inputs(key, &o.mesh));
        }
        if let LightSpec::Exr { path, .. } = &scene.light {
            out.push(Input::File {
                key: key.into(),
                path: path.clone(),
            });
        }
        let mut known = KNOWN.lock().unwrap_or_else(|e| e.into_inner());
        if known.len() >= 16 {
            known.remove(0);
        }
        known.push((k, out.clone()));
        Ok(out)
    }

    /// Read and resolve a scene file: the scene and the render settings its top-level keys
    /// give (the method [`crate::method::Method::Extrapolated`] until a caller sets another).
    pub fn load(path: &Path) -> Result<(Self, RenderSettings), Error> {
        let text = shscale_files::input::read_regular_string(path)?;
        Self::parse(
            &path.display().to_string(),
            &text,
            path.parent().unwrap_or(Path::new(".")),
        )
    }

    /// Resolve scene text; `file` names it in errors and `base` anchors relative paths.
    pub fn parse(file: &str, text: &str, base: &Path) -> Result<(Self, RenderSettings), Error> {
        let raw: RawScene = toml::from_str(text).map_err(|e| {
            Error::config(shscale_runner::config::toml_error(file, text, &e).to_string())
        })?;
        let c = Checker {
            source: shscale_runner::config::Source::new(file, text),
        };
        let s = c.sampling(&raw)?;
        if raw.occluder.len() > MAX_OCCLUDERS {
            return Err(c.err(
                "occluder",
                format!(
                    "{} occluders, more than the limit {MAX_OCCLUDERS}",
                    raw.occluder.len()
                ),
            ));
        }
        let occluders = (raw.occluder.iter().enumerate())
            .map(|(i, o)| c.occluder(i, o, base))
            .collect::<Result<_, _>>()?;
        let r = &raw.receiver;
        let receiver_center = c.receiver(r)?;
        let light = c.light(&raw.light, base)?;
        if raw.light_source.len() > MAX_OCCLUDERS {
            return Err(c.err(
                "light_source",
                format!(
                    "{} light sources, more than the limit {MAX_OCCLUDERS}",
                    raw.light_source.len()
                ),
            ));
        }
        let light_sources = (raw.light_source.iter().enumerate())
            .map(|(i, l)| c.light_source(i, l))
            .collect::<Result<_, _>>()?;
        let camera = raw.camera.as_ref().map(|r| c.camera(r)).transpose()?;
        let scene = Self {
            camera,
            file: file.into(),
            occluders,
            receiver_center,
            receiver_size: r.size,
            resolution: r.resolution,
            light,
            light_sources,
            pose_t: None,
        };
        Ok((scene, s))
    }
}

/// Checks the values of one scene file: every error names the file, the key as a path
/// (`occluder[1].radius`) and the key's own line (toml_edit spans; the table's line when the key
/// is absent, a default). Ranges through [`shscale_runner::check`], so the message states the
/// range tested (docs/limits.md).
struct Checker {
    source: shscale_runner::config::Source,
}

impl Checker {
    fn err(&self, key: &str, message: String) -> Error {
        let e = shscale_runner::config::ConfigError {
            place: self.source.place_of_key(key),
            key: key.into(),
            message,
        };
        Error::Runner(shscale_runner::Error::Place(e))
    }

    /// `v` within `lo..=hi` (integers).
    fn int(&self, key: &str, v: usize, lo: usize, hi: usize) -> Result<usize, Error> {
        check::int(v, lo, hi).map_err(|m| self.err(key, m))
    }

    /// `v` finite and within the interval.
    fn real(&self, key: &str, v: f64, lo: f64, hi: f64, ends: Ends) -> Result<f64, Error> {
        check::real(v, lo, hi, ends).map_err(|m| self.err(key, m))
    }

    /// `v` finite and within `[lo, hi]`.
    fn within(&self, key: &str, v: f64, lo: f64, hi: f64) -> Result<f64, Error> {
        self.real(key, v, lo, hi, Ends::Closed)
    }

    /// A point: every coordinate finite and within ±[`MAX_SCENE_COORDINATE`].
    fn coords(&self, key: &str, v: [f64; 3]) -> Result<DVec3, Error> {
        if v.iter()
            .all(|x| x.is_finite() && x.abs() <= MAX_SCENE_COORDINATE)
        {
            return Ok(DVec3::from_array(v));
        }
        Err(self.err(
            key,
            format!(
                "[{}, {}, {}] must be finite, each within ±{MAX_SCENE_COORDINATE:e}",
                num(v[0]),
                num(v[1]),
                num(v[2])
            ),
        ))
    }

    /// A word that must be one of `choices` (its value), named in the message as `expected`.
    fn choice<T: Copy>(
        &self,
        key: &str,
        word: &str,
        choices: &[(&str, T)],
        expected: &str,
    ) -> Result<T, Error> {
        (choices.iter().find(|(w, _)| *w == word).map(|(_, v)| *v))
            .ok_or_else(|| self.err(key, format!("{word:?} is not {expected}")))
    }

    /// The render settings the file's top-level keys give, each checked; a key left out keeps
    /// [`RenderSettings::default`]'s value (docs/config.md).
    fn sampling(&self, raw: &RawScene) -> Result<RenderSettings, Error> {
        let d = RenderSettings::default();
        let layout = match raw.layout.as_deref() {
            Some(l) => Layout::parse(l).map_err(|e| self.err("layout", e.to_string()))?,
            None => d.layout,
        };
        let plausibility = match raw.plausibility.as_deref() {
            Some(p) => (shscale_field::extrapolate::Plausibility::parse(p))
                .map_err(|m| self.err("plausibility", m))?,
            None => d.plausibility,
        };
        let int = |key: &str, v: Option<usize>, dv: usize, (lo, hi): (usize, usize)| {
            self.int(key, v.unwrap_or(dv), lo, hi)
        };
        // In the order the keys were always checked (the first bad key is the one named).
        Ok(RenderSettings {
            order: int("order", raw.order, d.order, (1, 16))?,
            alpha: match raw.alpha_deg {
                Some(a) => (crate::vocab::AlphaDeg::new(a))
                    .map_err(|m| self.err("alpha_deg", m))?
                    .radians(),
                None => d.alpha,
            },
            layout,
            hemisphere_res: int(
                "hemisphere_res",
                raw.hemisphere_res,
                d.hemisphere_res,
                (1, 256),
            )?,
            truth_res: int("truth_res", raw.truth_res, d.truth_res, (1, 256))?,
            plausibility,
            k_count: int("k_count", raw.k_count, d.k_count, (2, MAX_K_COUNT))?,
            sampling_radius: self.within(
                "sampling_radius",
                raw.sampling_radius.unwrap_or(d.sampling_radius),
                1.0,
                1e3,
            )?,
            ..d
        })
    }

    /// Occluder `i`; a mesh path (not a built-in name) relative to `base`, the scene file's folder.
    fn occluder(&self, i: usize, o: &RawOccluder, base: &Path) -> Result<OccluderSpec, Error> {
        let key = |k: &str| format!("occluder[{i}].{k}");
        let center = self.coords(&key("center"), o.center)?;
        self.within(
            &key("radius"),
            o.radius,
            MIN_SCENE_SIZE,
            MAX_SCENE_COORDINATE,
        )?;
        let up = o.up.as_deref().unwrap_or("y");
        let up_is_y = self.choice(
            &key("up"),
            up,
            &[("y", true), ("z", false)],
            "\"y\" or \"z\"",
        )?;
        use shscale_geometry::deform::DeformerKind as K;
        let deformer = match o.deformer.as_deref() {
            None => None,
            Some(name) => {
                let kinds = [
                    ("flap", (K::Flap, 0.8)),
                    ("bend", (K::Bend, 1.2)),
                    ("twist", (K::Twist, 0.25)),
                    ("morph", (K::Morph, 0.5)),
                ];
                let expected = "flap, bend, twist or morph";
                let (kind, default) = self.choice(&key("deformer"), name, &kinds, expected)?;
                if o.mesh == "sphere" {
                    return Err(
                        self.err(&key("deformer"), "the analytic sphere cannot deform".into())
                    );
                }
                let amount =
                    self.within(&key("amount"), o.amount.unwrap_or(default), -10.0, 10.0)?;
                Some((kind, amount))
            }
        };
        let mesh = if crate::vocab::builtin_mesh(&o.mesh) || Path::new(&o.mesh).is_absolute() {
            o.mesh.clone()
        } else {
            base.join(&o.mesh).display().to_string()
        };
        Ok(OccluderSpec {
            mesh,
            center,
            radius: o.radius,
            up_is_y,
            deformer,
            turn: None,
        })
    }

    /// The receiver plane's centre, its size and resolution checked.
    fn receiver(&self, r: &RawReceiver) -> Result<DVec3, Error> {
        let center = self.coords("receiver.center", r.center)?;
        for (j, v) in r.size.iter().enumerate() {
            let key = format!("receiver.size[{j}]");
            self.within(&key, *v, MIN_SCENE_SIZE, MAX_SCENE_COORDINATE)?;
        }
        if !(r.resolution.iter().all(|n| (2..=4096).contains(n))) {
            return Err(self.err(
                "receiver.resolution",
                format!("{:?} must be within 2..=4096 each", r.resolution),
            ));
        }
        Ok(center)
    }

    fn light(&self, l: &RawLight, base: &Path) -> Result<LightSpec, Error> {
        let nonneg = |key: &str, v: Option<f64>, default: f64| {
            self.within(
                &format!("light.{key}"),
                v.unwrap_or(default),
                0.0,
                MAX_RADIANCE,
            )
        };
        match l.kind.as_str() {
            "sky" => {
                let sun_dir = DVec3::from_array(l.sun_dir.unwrap_or([0.3, 0.2, 1.0]));
                if !(sun_dir.is_finite() && sun_dir.length() > 0.0) {
                    return Err(self.err(
                        "light.sun_dir",
                        format!("{sun_dir} must be a non-zero vector"),
                    ));
                }
                let rad = l.sun_radius_deg.unwrap_or(5.0);
                let rad = self.real("light.sun_radius_deg", rad, 0.0, 90.0, Ends::OpenClosed)?;
                Ok(LightSpec::Sky {
                    ambient: nonneg("ambient", l.ambient, 0.3)?,
                    zenith: nonneg("zenith", l.zenith, 1.0)?,
                    sun: nonneg("sun", l.sun, 20.0)?,
                    sun_dir: sun_dir.normalize(),
                    sun_radius: rad.to_radians(),
                })
            }
            "exr" => {
                let p = (l.path.as_deref()).ok_or_else(|| {
                    self.err("light.path", "light kind \"exr\" needs path".into())
                })?;
                Ok(LightSpec::Exr {
                    path: base.join(p),
                    intensity: nonneg("intensity", l.intensity, 1.0)?,
                })
            }
            other => Err(self.err("light.kind", format!("{other:?} is not \"sky\" or \"exr\""))),
        }
    }

    fn light_source(&self, i: usize, l: &RawLightSource) -> Result<LightSourceSpec, Error> {
        let key = |k: &str| format!("light_source[{i}].{k}");
        let kinds = [("quad", false), ("hinge", true)];
        let hinge = self.choice(&key("kind"), &l.kind, &kinds, "\"quad\" or \"hinge\"")?;
        let center = self.coords(&key("center"), l.center)?;
        let size = l.size.unwrap_or(1.0);
        let size = self.within(&key("size"), size, MIN_SCENE_SIZE, MAX_SCENE_COORDINATE)?;
        let hinge_deg = l.hinge_deg.unwrap_or(100.0);
        let hinge_deg = self.real(&key("hinge_deg"), hinge_deg, 0.0, 180.0, Ends::Open)?;
        let intensity = l.intensity.unwrap_or(1.0);
        let intensity = self.within(&key("intensity"), intensity, 0.0, MAX_RADIANCE)?;
        let base = l.radiance.unwrap_or([1.0, 1.0, 1.0]);
        for (j, v) in base.iter().enumerate() {
            self.within(
                &format!("light_source[{i}].radiance[{j}]"),
                *v,
                0.0,
                MAX_RADIANCE,
            )?;
        }
        let radiance = base.map(|v| v * intensity);
        if radiance.iter().any(|v| *v > MAX_RADIANCE) {
            return Err(self.err(
                &key("intensity"),
                format!(
                    "intensity {} × radiance {base:?} exceeds {MAX_RADIANCE:e}",
                    num(intensity)
                ),
            ));
        }
        let etas = [("plain", false), ("energy", true)];
        let eta = l.eta.as_deref().unwrap_or("plain");
        let energy = self.choice(&key("eta"), eta, &etas, "\"plain\" or \"energy\"")?;
        Ok(LightSourceSpec {
            hinge,
            center,
            size,
            hinge_angle: hinge_deg.to_radians(),
            radiance,
            energy,
        })
    }

    fn camera(&self, c: &RawCamera) -> Result<Camera, Error> {
        let position = self.coords("camera.position", c.position)?;
        let look_at = self.coords("camera.look_at", c.look_at)?;
        if (look_at - position).length() == 0.0 {
            return Err(self.err("camera.look_at", "must differ from camera.position".into()));
        }
        let fov_deg = self.within("camera.fov_deg", c.fov_deg.unwrap_or(40.0), 1.0, 170.0)?;
        let resolution = c.resolution.unwrap_or([480, 320]);
        if !resolution.iter().all(|n| (2..=4096).contains(n)) {
            return Err(self.err(
                "camera.resolution",
                format!("{resolution:?} must be within 2..=4096 each"),
            ));
        }
        Ok(Camera {
            position,
            look_at,
            fov_deg,
            resolution,
        })
    }
}
