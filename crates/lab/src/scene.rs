//! Scene files (TOML). Two stages (docs/ARCHITECTURE.md (habit 5)): [`RawScene`] mirrors the file exactly and rejects
//! unknown fields; [`Scene::load`] resolves it — validates every range and names the file, the
//! line and the field in every error.
//!
//! ```toml
//! order = 4                 # SH order N
//! alpha_deg = 45            # cone half-angle
//! layout = "latlong:12x20"  # base-sphere layout
//! hemisphere_res = 32       # H (H×H rays per sample; 2H² for ray-traced truth)
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

use crate::LabError;
use glam::DVec3;
use serde::Deserialize;
use shscale_field::Layout;
use std::path::{Path, PathBuf};

/// The file as written.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawScene {
    pub order: Option<usize>,
    pub alpha_deg: Option<f64>,
    pub layout: Option<String>,
    pub hemisphere_res: Option<usize>,
    pub k_count: Option<usize>,
    pub sampling_radius: Option<f64>,
    #[serde(default)]
    pub occluder: Vec<RawOccluder>,
    pub receiver: RawReceiver,
    pub light: RawLight,
    #[serde(default)]
    pub light_source: Vec<RawLightSource>,
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

/// A resolved scene.
#[derive(Clone, Debug)]
pub struct Scene {
    pub file: String,
    pub order: usize,
    pub alpha: f64,
    pub layout: Layout,
    pub hemisphere_res: usize,
    pub k_count: usize,
    pub sampling_radius: f64,
    pub occluders: Vec<OccluderSpec>,
    pub receiver_center: DVec3,
    pub receiver_size: [f64; 2],
    pub resolution: [usize; 2],
    pub light: LightSpec,
    pub light_sources: Vec<LightSourceSpec>,
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

/// Line of the first occurrence of `key =` (or the table header) in the text, for semantic errors.
fn line_of_key(text: &str, key: &str) -> usize {
    text.lines()
        .position(|l| {
            let t = l.trim_start();
            t.starts_with(&format!("{key} "))
                || t.starts_with(&format!("{key}="))
                || t.starts_with(&format!("[{key}]"))
                || t.starts_with(&format!("[[{key}]]"))
        })
        .map_or(0, |i| i + 1)
}

impl Scene {
    /// Read and resolve a scene file.
    pub fn load(path: &Path) -> Result<Self, LabError> {
        let text = std::fs::read_to_string(path).map_err(|e| LabError::Io {
            path: path.display().to_string(),
            reason: e.to_string(),
        })?;
        Self::parse(
            &path.display().to_string(),
            &text,
            path.parent().unwrap_or(Path::new(".")),
        )
    }

    /// Resolve scene text; `file` names it in errors and `base` anchors relative paths.
    pub fn parse(file: &str, text: &str, base: &Path) -> Result<Self, LabError> {
        let raw: RawScene = toml::from_str(text).map_err(|e| crate::toml_error(file, text, &e))?;
        let err = |key: &str, msg: String| {
            LabError::Config(format!(
                "{file}:{}: {key}: {msg}",
                line_of_key(text, key.split('.').next_back().unwrap_or(key))
            ))
        };
        let order = raw.order.unwrap_or(4);
        if !(1..=16).contains(&order) {
            return Err(err("order", format!("{order} is outside 1..=16")));
        }
        let alpha_deg = raw.alpha_deg.unwrap_or(45.0);
        if !(alpha_deg > 0.0 && alpha_deg < 90.0) {
            return Err(err("alpha_deg", format!("{alpha_deg} is outside (0, 90)")));
        }
        let layout = Layout::parse(raw.layout.as_deref().unwrap_or("latlong:12x20"))
            .map_err(|e| err("layout", e.to_string()))?;
        let hemisphere_res = raw.hemisphere_res.unwrap_or(32);
        if !(1..=256).contains(&hemisphere_res) {
            return Err(err(
                "hemisphere_res",
                format!("{hemisphere_res} is outside 1..=256"),
            ));
        }
        let k_count = raw.k_count.unwrap_or(40);
        if k_count < 2 {
            return Err(err("k_count", format!("{k_count} must be ≥ 2")));
        }
        let sampling_radius = raw.sampling_radius.unwrap_or(1.0);
        if !(sampling_radius.is_finite() && sampling_radius >= 1.0) {
            return Err(err(
                "sampling_radius",
                format!("{sampling_radius} must be ≥ 1"),
            ));
        }
        let finite3 = |v: [f64; 3]| v.iter().all(|x| x.is_finite());
        let mut occluders = Vec::new();
        for (i, o) in raw.occluder.iter().enumerate() {
            if !finite3(o.center) {
                return Err(err(
                    "center",
                    format!("occluder {}: center {:?} is not finite", i + 1, o.center),
                ));
            }
            if !(o.radius.is_finite() && o.radius > 0.0) {
                return Err(err(
                    "radius",
                    format!("occluder {}: radius {} must be > 0", i + 1, o.radius),
                ));
            }
            let up_is_y = match o.up.as_deref().unwrap_or("y") {
                "y" => true,
                "z" => false,
                other => {
                    return Err(err(
                        "up",
                        format!("occluder {}: {other:?} is not \"y\" or \"z\"", i + 1),
                    ))
                }
            };
            use shscale_geometry::deform::DeformerKind as K;
            let deformer = match o.deformer.as_deref() {
                None => None,
                Some(name) => {
                    let (kind, default) = match name {
                        "flap" => (K::Flap, 0.8),
                        "bend" => (K::Bend, 1.2),
                        "twist" => (K::Twist, 0.25),
                        "morph" => (K::Morph, 0.5),
                        other => {
                            return Err(err(
                                "deformer",
                                format!(
                                    "occluder {}: {other:?} is not flap, bend, twist or morph",
                                    i + 1
                                ),
                            ))
                        }
                    };
                    if o.mesh == "sphere" {
                        return Err(err(
                            "deformer",
                            format!("occluder {}: the analytic sphere cannot deform", i + 1),
                        ));
                    }
                    let amount = o.amount.unwrap_or(default);
                    if !amount.is_finite() {
                        return Err(err(
                            "amount",
                            format!("occluder {}: {amount} is not finite", i + 1),
                        ));
                    }
                    Some((kind, amount))
                }
            };
            occluders.push(OccluderSpec {
                mesh: o.mesh.clone(),
                center: DVec3::from_array(o.center),
                radius: o.radius,
                up_is_y,
                deformer,
            });
        }
        let r = &raw.receiver;
        if !finite3(r.center) {
            return Err(err(
                "center",
                format!("receiver center {:?} is not finite", r.center),
            ));
        }
        if !(r.size.iter().all(|s| s.is_finite() && *s > 0.0)) {
            return Err(err(
                "size",
                format!("receiver size {:?} must be > 0", r.size),
            ));
        }
        if !(r.resolution.iter().all(|n| (2..=4096).contains(n))) {
            return Err(err(
                "resolution",
                format!(
                    "receiver resolution {:?} must be within 2..=4096",
                    r.resolution
                ),
            ));
        }
        let l = &raw.light;
        let nonneg = |key: &str, v: Option<f64>, default: f64| -> Result<f64, LabError> {
            let v = v.unwrap_or(default);
            if v.is_finite() && v >= 0.0 {
                Ok(v)
            } else {
                Err(err(key, format!("{v} must be finite and ≥ 0")))
            }
        };
        let light = match l.kind.as_str() {
            "sky" => {
                let sun_dir = DVec3::from_array(l.sun_dir.unwrap_or([0.3, 0.2, 1.0]));
                if !(sun_dir.is_finite() && sun_dir.length() > 0.0) {
                    return Err(err(
                        "sun_dir",
                        format!("{sun_dir} must be a non-zero vector"),
                    ));
                }
                let rad = l.sun_radius_deg.unwrap_or(5.0);
                if !(rad > 0.0 && rad <= 90.0) {
                    return Err(err("sun_radius_deg", format!("{rad} is outside (0, 90]")));
                }
                LightSpec::Sky {
                    ambient: nonneg("ambient", l.ambient, 0.3)?,
                    zenith: nonneg("zenith", l.zenith, 1.0)?,
                    sun: nonneg("sun", l.sun, 20.0)?,
                    sun_dir: sun_dir.normalize(),
                    sun_radius: rad.to_radians(),
                }
            }
            "exr" => {
                let p = l
                    .path
                    .as_deref()
                    .ok_or_else(|| err("path", "light kind \"exr\" needs path".into()))?;
                LightSpec::Exr {
                    path: base.join(p),
                    intensity: nonneg("intensity", l.intensity, 1.0)?,
                }
            }
            other => {
                return Err(err(
                    "kind",
                    format!("light kind {other:?} is not \"sky\" or \"exr\""),
                ))
            }
        };
        let mut light_sources = Vec::new();
        for (i, l) in raw.light_source.iter().enumerate() {
            let hinge = match l.kind.as_str() {
                "quad" => false,
                "hinge" => true,
                other => {
                    return Err(err(
                        "kind",
                        format!(
                            "light_source {}: {other:?} is not \"quad\" or \"hinge\"",
                            i + 1
                        ),
                    ))
                }
            };
            if !finite3(l.center) {
                return Err(err(
                    "center",
                    format!(
                        "light_source {}: center {:?} is not finite",
                        i + 1,
                        l.center
                    ),
                ));
            }
            let size = l.size.unwrap_or(1.0);
            if !(size.is_finite() && size > 0.0) {
                return Err(err(
                    "size",
                    format!("light_source {}: size {size} must be > 0", i + 1),
                ));
            }
            let hinge_deg = l.hinge_deg.unwrap_or(100.0);
            if !(hinge_deg > 0.0 && hinge_deg < 180.0) {
                return Err(err(
                    "hinge_deg",
                    format!("light_source {}: {hinge_deg} is outside (0, 180)", i + 1),
                ));
            }
            let intensity = l.intensity.unwrap_or(1.0);
            let radiance = l.radiance.unwrap_or([1.0, 1.0, 1.0]).map(|v| v * intensity);
            if radiance.iter().any(|v| !(v.is_finite() && *v >= 0.0)) {
                return Err(err(
                    "radiance",
                    format!(
                        "light_source {}: {radiance:?} must be finite and ≥ 0",
                        i + 1
                    ),
                ));
            }
            let energy = match l.eta.as_deref().unwrap_or("plain") {
                "plain" => false,
                "energy" => true,
                other => {
                    return Err(err(
                        "eta",
                        format!(
                            "light_source {}: {other:?} is not \"plain\" or \"energy\"",
                            i + 1
                        ),
                    ))
                }
            };
            light_sources.push(LightSourceSpec {
                hinge,
                center: DVec3::from_array(l.center),
                size,
                hinge_angle: hinge_deg.to_radians(),
                radiance,
                energy,
            });
        }
        Ok(Self {
            file: file.into(),
            order,
            alpha: alpha_deg.to_radians(),
            layout,
            hemisphere_res,
            k_count,
            sampling_radius,
            occluders,
            receiver_center: DVec3::from_array(r.center),
            receiver_size: r.size,
            resolution: r.resolution,
            light,
            light_sources,
        })
    }
}
