//! What the scene crate's sequence and GPU parity tests share: their scenes.

use shscale_scene::scene::Scene;
use shscale_scene::settings::RenderSettings;
use std::path::Path;

pub fn scene(occluders: &str) -> (Scene, RenderSettings) {
    let text = format!(
        r#"
order = 4
layout = "fib:60"
hemisphere_res = 12
{occluders}
[receiver]
center = [0, 0, 0]
size = [5, 5]
resolution = [20, 20]

[light]
kind = "sky"
"#
    );
    Scene::parse("test.toml", &text, Path::new(".")).unwrap()
}

/// The scene of the GPU sphere-set parity tests: a flapping bird of 4 spheres and three static
/// analytic spheres, one cutting the receiver plane (receivers inside it see nothing) and one
/// 10⁴ radii away (a cap of 1e-4 rad).
pub fn sphere_set_scene() -> (Scene, RenderSettings) {
    let (s, mut rs) = scene(
        "[[occluder]]\nmesh = \"bird\"\ncenter = [0, 0, 1.4]\nradius = 1.0\ndeformer = \"flap\"\n\n[[occluder]]\nmesh = \"sphere\"\ncenter = [1.5, 0.5, 0.9]\nradius = 0.4\n\n[[occluder]]\nmesh = \"sphere\"\ncenter = [-1.5, -1.5, 0.1]\nradius = 0.6\n\n[[occluder]]\nmesh = \"sphere\"\ncenter = [0, 0, 3000]\nradius = 0.3\n",
    );
    rs.parts = 4;
    (s, rs)
}
