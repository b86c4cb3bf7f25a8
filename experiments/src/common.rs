//! What several kinds share: the cost model of computing two scaling matrices, writing a text
//! file into a figure's folder, and the inputs of the kinds that read a mesh or a scene.

use shscale_scene::Error;
use std::path::{Path, PathBuf};

/// The cost model's seconds for one scaling matrix at `order` by adaptive quadrature: a fixed
/// 20 µs plus 2.5 µs per structural non-zero (N(2N²+1)/3 of the N⁴ elements, SHS §2.2). Fitted
/// on the development VM (2 threads) to `shscale run configs/experiments/extremes.toml` (220
/// matrices at N = 4, 16, 32 over k from 1e-6 to 1e6: 4.9 s) and
/// `configs/experiments/sweep_1e4.toml` (2·10⁴ matrices at N = 2: 1.1 s of work); checked on every
/// shipped config by `shscale bench estimates`.
pub(crate) fn matrix_seconds(order: usize) -> f64 {
    let n = order as f64;
    let nonzeros = n * (2.0 * n * n + 1.0) / 3.0;
    2e-5 + 2.5e-6 * nonzeros
}

/// The cost of a run that computes the plain and the energy matrix of one τ at `order` (once:
/// these kinds do not time them).
pub(crate) fn two_matrices_cost(order: usize) -> (shscale_runner::Cost, shscale_runner::Cost) {
    let nn = (order * order) as f64;
    (
        shscale_runner::Cost::default(),
        shscale_runner::Cost {
            bytes: nn * nn * 8.0 * 4.0,
            once_seconds: 2.0 * matrix_seconds(order),
            drivers: format!("order = {order} → 2 matrices of {nn}² elements"),
            ..shscale_runner::Cost::default()
        },
    )
}

/// Write `text` to `out/name` atomically and return the path.
pub(crate) fn write_text(out: &Path, name: &str, text: &str) -> Result<PathBuf, Error> {
    let p = out.join(name);
    shscale_runner::write_atomic(&p, text)?;
    Ok(p)
}

/// The inputs of a kind that reads the mesh named by its `mesh` key
/// ([`shscale_runner::Kind::inputs`]).
pub(crate) fn mesh_inputs(
    mesh: &str,
) -> Result<Vec<shscale_runner::inputs::Input>, shscale_runner::KeyError> {
    Ok(shscale_scene::vocab::mesh_inputs("mesh", mesh))
}

/// The inputs of a kind that reads the scene file named by its `scene` key, relative to the
/// config's folder: the file, its meshes and its environment map.
pub(crate) fn scene_inputs(
    config_dir: &Path,
    scene: &str,
) -> Result<Vec<shscale_runner::inputs::Input>, shscale_runner::KeyError> {
    shscale_scene::scene::Scene::inputs("scene", &config_dir.join(scene))
        .map_err(|e| shscale_runner::KeyError::new("scene", e.to_string()))
}

/// The inscribed fit's work (cells × triangles, `shscale_geometry::inscribed::inscribable`) of
/// `mesh` in the orientation `orientation_seed` gives it (as `budget` orients it), checked at
/// plan time: a mesh with no inside, or one above the fit's bound, is refused naming
/// `sphere_fit` and the mesh. Once per mesh and seed per process (a sweep plans each run).
pub(crate) fn inscribed_work(
    mesh: &str,
    orientation_seed: u64,
) -> Result<f64, shscale_runner::KeyError> {
    type Memo = Vec<((String, u64), Result<f64, String>)>;
    static MEMO: std::sync::Mutex<Memo> = std::sync::Mutex::new(Vec::new());
    let key = (mesh.to_string(), orientation_seed);
    let known = (MEMO.lock().unwrap_or_else(|e| e.into_inner()))
        .iter()
        .find(|(k, _)| *k == key)
        .map(|(_, v)| v.clone());
    let work = match known {
        Some(w) => w,
        None => {
            let w = (|| {
                let mut m = shscale_scene::vocab::placed_mesh(mesh, glam::DVec3::ZERO, 1.0, false)
                    .map_err(|e| e.to_string())?;
                if orientation_seed != 0 {
                    let q = shscale_field::truth::SplitMix(orientation_seed).rotation();
                    m.rotate_about(m.bounding_sphere().center, q);
                }
                shscale_geometry::inscribed::inscribable(&m).map_err(|e| e.to_string())
            })();
            (MEMO.lock().unwrap_or_else(|e| e.into_inner())).push((key, w.clone()));
            w
        }
    };
    work.map_err(|e| {
        shscale_runner::KeyError::new(
            "sphere_fit",
            format!("\"inscribed\" on mesh \"{mesh}\": {e}"),
        )
    })
}
