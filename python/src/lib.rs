//! The native part of the `shscale` Python package (PyO3, abi3): thin bindings over the
//! workspace's crates with the CLI's conventions (docs/conventions.md) — NumPy arrays in and out,
//! `ValueError` carrying the same messages as the CLI for bad input, the GIL released during long
//! calls, and no Rust panic crossing into Python (a panic becomes `RuntimeError`). The Python
//! layer (`shscale/__init__.py`) adds the pandas-facing `run` and `load_results`.

use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray1, PyArray2, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use shscale_experiments::probe::ProbeParams;
use shscale_field::{Frame, Layout};
use shscale_geometry::DVec3;
use shscale_scaling::{Eta, KTable, ScalingMatrix, TauFamily};
use std::panic::{catch_unwind, AssertUnwindSafe};

/// A bad-input error: `ValueError` with the message, prefixed by the parameter it concerns.
fn bad(param: &str, e: impl std::fmt::Display) -> PyErr {
    PyValueError::new_err(format!("{param}: {e}"))
}

/// Run `f`, turning a panic into `RuntimeError` (nothing unwinds into Python).
fn guard<T>(f: impl FnOnce() -> PyResult<T>) -> PyResult<T> {
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(r) => r,
        Err(p) => {
            let msg = p
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_else(|| "unknown panic".into());
            Err(PyRuntimeError::new_err(format!(
                "internal error (please report it): {msg}"
            )))
        }
    }
}

fn check_order(order: usize, max: usize) -> PyResult<()> {
    if order == 0 || order > max {
        return Err(bad("order", format!("{order} is outside 1..={max}")));
    }
    Ok(())
}

/// Rows of an `(P, 3)` array of finite numbers.
fn rows3(name: &str, a: &PyReadonlyArray2<f64>) -> PyResult<Vec<DVec3>> {
    let v = a.as_array();
    if v.ncols() != 3 {
        return Err(bad(
            name,
            format!("expected shape (P, 3), got {:?}", v.shape()),
        ));
    }
    v.rows()
        .into_iter()
        .enumerate()
        .map(|(i, r)| {
            let p = DVec3::new(r[0], r[1], r[2]);
            if p.is_finite() {
                Ok(p)
            } else {
                Err(bad(name, format!("row {i}: {p} is not finite")))
            }
        })
        .collect()
}

/// The most values `sh_eval` returns (8 bytes each): checked before anything is allocated (a
/// `(10⁵, 128²)` request once aborted the interpreter on a 13 GB allocation).
const MAX_SH_EVAL_VALUES: usize = 50_000_000;

/// The most work one `visibility` call does without `allow_large`, in basis-term evaluations
/// (points × rays per point × N²): the CLI's largest single query (`shscale visibility` at order
/// 128 and truth_res 1024: 4·1024² rays × 128²).
const MAX_QUERY_WORK: f64 = 4.0 * 1024.0 * 1024.0 * 128.0 * 128.0;

/// `(P, N²)` basis values at the directions `dirs` (rows, normalised first).
#[pyfunction]
fn sh_eval<'py>(
    py: Python<'py>,
    order: usize,
    dirs: PyReadonlyArray2<'py, f64>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    guard(|| {
        check_order(order, shscale_sh::MAX_ORDER)?;
        let rows = dirs.as_array().nrows();
        let values = rows.saturating_mul(order * order);
        if values > MAX_SH_EVAL_VALUES {
            return Err(bad(
                "dirs",
                format!("{rows} directions × {} basis functions = {values} values, more than the limit {MAX_SH_EVAL_VALUES} (400 MB); split the directions", order * order),
            ));
        }
        let d = rows3("dirs", &dirs)?;
        let basis = shscale_sh::ShBasis::<f64>::new(order).map_err(|e| bad("order", e))?;
        let nn = order * order;
        let mut out = vec![0.0; d.len() * nn];
        for (i, p) in d.iter().enumerate() {
            basis
                .eval_dir(p.to_array(), &mut out[i * nn..(i + 1) * nn])
                .map_err(|e| bad("dirs", format!("row {i}: {e}")))?;
        }
        Ok(Array2::from_shape_vec((d.len(), nn), out)
            .map_err(|e| bad("dirs", e))?
            .into_pyarray(py))
    })
}

/// The N² coefficients of a spherical cap of half-angle `angle_deg` about +z.
#[pyfunction]
fn sh_cap<'py>(
    py: Python<'py>,
    order: usize,
    angle_deg: f64,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    guard(|| {
        check_order(order, shscale_sh::MAX_ORDER)?;
        if !(0.0..=180.0).contains(&angle_deg) {
            return Err(bad("angle_deg", format!("{angle_deg} is outside [0, 180]")));
        }
        let v =
            shscale_sh::cap_coeffs(order, angle_deg.to_radians()).map_err(|e| bad("order", e))?;
        Ok(v.into_pyarray(py))
    })
}

/// `coeffs` rotated by the ZYZ Euler angles (degrees).
#[pyfunction]
fn sh_rotate<'py>(
    py: Python<'py>,
    order: usize,
    coeffs: PyReadonlyArray1<'py, f64>,
    euler_zyz_deg: [f64; 3],
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    guard(|| {
        check_order(order, shscale_sh::MAX_ORDER)?;
        let c = coeffs.as_slice().map_err(|e| bad("coeffs", e))?.to_vec();
        if c.len() != order * order {
            return Err(bad(
                "coeffs",
                format!(
                    "order {order} needs {} coefficients, got {}",
                    order * order,
                    c.len()
                ),
            ));
        }
        if let Some(i) = c.iter().position(|v| !v.is_finite()) {
            return Err(bad("coeffs", format!("item {i} ({}) is not finite", c[i])));
        }
        if euler_zyz_deg.iter().any(|v| !v.is_finite()) {
            return Err(bad(
                "euler_zyz_deg",
                format!("{euler_zyz_deg:?}: expected 3 finite angles in degrees"),
            ));
        }
        let [a, b, g] = euler_zyz_deg.map(f64::to_radians);
        let rot = shscale_sh::ShRotation::new(order, &shscale_sh::euler_zyz(a, b, g))
            .map_err(|e| bad("order", e))?;
        let mut out = vec![0.0; c.len()];
        rot.apply(&c, &mut out).map_err(|e| bad("coeffs", e))?;
        Ok(out.into_pyarray(py))
    })
}

fn family(tau: &str, alpha_deg: f64) -> PyResult<TauFamily> {
    shscale_scene::vocab::tau_family(tau, alpha_deg).map_err(|e| bad(&e.key, e.message))
}

fn eta(energy: bool) -> Eta {
    if energy {
        Eta::Energy
    } else {
        Eta::Plain
    }
}

fn dense<'py>(py: Python<'py>, m: &ScalingMatrix<f64>) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let d = m.to_dense();
    let n = d.len();
    Ok(
        Array2::from_shape_vec((n, n), d.into_iter().flatten().collect())
            .map_err(|e| bad("order", e))?
            .into_pyarray(py),
    )
}

/// The dense `(N², N²)` scaling matrix `M_k` (`energy`: η = sin τ · τ′ for radiance).
#[pyfunction]
#[pyo3(signature = (order, tau="cone", alpha_deg=45.0, k=2.0, energy=false))]
fn scaling_matrix<'py>(
    py: Python<'py>,
    order: usize,
    tau: &str,
    alpha_deg: f64,
    k: f64,
    energy: bool,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    guard(|| {
        check_order(order, 32)?;
        let f = family(tau, alpha_deg)?;
        let t = f.at(k).map_err(|e| bad("k", e))?;
        let m = py
            .allow_threads(|| ScalingMatrix::compute(t.as_ref(), eta(energy), order))
            .map_err(|e| bad("order", e))?;
        dense(py, &m)
    })
}

/// A table of scaling matrices over a k range, interpolated on lookup.
#[pyclass(module = "shscale._native", frozen)]
struct KTableHandle(KTable);

#[pymethods]
impl KTableHandle {
    /// The interpolated `(N², N²)` matrix at `k`. Outside the table's range a `ValueError`,
    /// unless `clamp` (then the matrix at the nearer end, as the renderer uses it).
    #[pyo3(signature = (k, clamp=false))]
    fn lookup<'py>(
        &self,
        py: Python<'py>,
        k: f64,
        clamp: bool,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        guard(|| {
            let mut m = ScalingMatrix::identity(self.0.order()).map_err(|e| bad("order", e))?;
            let at = self.0.lookup(k, &mut m).map_err(|e| bad("k", e))?;
            if !clamp && at != shscale_scaling::KLookup::Interior {
                let ks = self.0.ks();
                return Err(bad(
                    "k",
                    format!(
                        "{k} is outside the table's range [{}, {}] (clamp=True takes the nearer end)",
                        ks[0],
                        ks[ks.len() - 1]
                    ),
                ));
            }
            dense(py, &m)
        })
    }
    /// The tabulated k values.
    #[getter]
    fn ks<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.0.ks().to_vec().into_pyarray(py)
    }
    #[getter]
    fn order(&self) -> usize {
        self.0.order()
    }
    #[getter]
    fn size_bytes(&self) -> usize {
        self.0.size_bytes()
    }
    /// The largest absolute interpolation error over the whole matrix, checked at
    /// `per_interval` points per interval against direct quadrature, and where: `(error, k)`.
    #[pyo3(signature = (per_interval=3))]
    fn max_interp_error(&self, py: Python<'_>, per_interval: usize) -> PyResult<(f64, f64)> {
        guard(|| {
            if !(1..=64).contains(&per_interval) {
                return Err(bad(
                    "per_interval",
                    format!("{per_interval} is outside 1..=64"),
                ));
            }
            py.allow_threads(|| self.0.max_interp_error(per_interval))
                .map_err(|e| bad("k", e))
        })
    }
}

/// Build a k-table (`shscale matrix --table`).
#[pyfunction]
#[pyo3(signature = (order, k_min, k_max, count=40, tau="cone", alpha_deg=45.0, energy=false, spacing="exp", interp="linear"))]
#[allow(clippy::too_many_arguments)]
fn ktable(
    py: Python<'_>,
    order: usize,
    k_min: f64,
    k_max: f64,
    count: usize,
    tau: &str,
    alpha_deg: f64,
    energy: bool,
    spacing: &str,
    interp: &str,
) -> PyResult<KTableHandle> {
    guard(|| {
        check_order(order, 32)?;
        let max = shscale_scene::vocab::MAX_K_COUNT;
        if !(2..=max).contains(&count) {
            return Err(bad("count", format!("{count} is outside 2..={max}")));
        }
        let f = family(tau, alpha_deg)?;
        let s = shscale_scene::vocab::parse_spacing(spacing).map_err(|m| bad("spacing", m))?;
        let i = shscale_scene::vocab::parse_interp(interp).map_err(|m| bad("interp", m))?;
        let t = py
            .allow_threads(|| KTable::build(f, eta(energy), order, count, k_min, k_max, s, i))
            .map_err(|e| bad("k_min/k_max", e))?;
        Ok(KTableHandle(t))
    })
}

use shscale_scene::vocab::MAX_VISIBILITY_RES;

/// `(P, N²)` ray-traced visibility (1 = unoccluded) over the full sphere at each point: the
/// converged stratified truth (`quadrature = "stratified"`, `4T²` rays, as `shscale visibility`)
/// or the Gauss–Legendre rings (`"gauss"`, `2H²` rays).
#[pyfunction]
#[pyo3(signature = (mesh, points, order, hemisphere_res=32, frame="entity", quadrature="stratified", truth_res=shscale_field::truth::DEFAULT_TRUTH_RES, seed=shscale_field::truth::DEFAULT_TRUTH_SEED, allow_large=false))]
#[allow(clippy::too_many_arguments)]
fn visibility<'py>(
    py: Python<'py>,
    mesh: &str,
    points: PyReadonlyArray2<'py, f64>,
    order: usize,
    hemisphere_res: usize,
    frame: &str,
    quadrature: &str,
    truth_res: usize,
    seed: u64,
    allow_large: bool,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    guard(|| {
        check_order(order, shscale_sh::MAX_ORDER)?;
        if hemisphere_res == 0 || hemisphere_res > MAX_VISIBILITY_RES {
            return Err(bad(
                "hemisphere_res",
                format!("{hemisphere_res} is outside 1..={MAX_VISIBILITY_RES}"),
            ));
        }
        let frame = Frame::from_name(frame)
            .ok_or_else(|| bad("frame", format!("{frame:?} is not \"entity\" or \"local\"")))?;
        let pts = rows3("points", &points)?;
        let occ = shscale_scene::vocab::occluder(mesh).map_err(|e| bad("mesh", e))?;
        shscale_scene::vocab::check_query_points(occ.as_ref(), mesh, &pts, frame == Frame::Local)
            .map_err(|m| bad("points", m))?;
        let nn = order * order;
        let quadrature = shscale_scene::vocab::Quadrature::parse(quadrature)
            .map_err(|m| bad("quadrature", m))?;
        // The CLI's query (`shscale visibility`), set up once for every point.
        let query = shscale_scene::vocab::VisibilityQuery::new(
            quadrature,
            order,
            hemisphere_res,
            truth_res,
            seed,
        )
        .map_err(|e| match quadrature {
            shscale_scene::vocab::Quadrature::Gauss => bad("order", e),
            shscale_scene::vocab::Quadrature::Stratified => bad("truth_res", e),
        })?;
        let work = pts.len() as f64 * query.rays_per_point() as f64 * (order * order) as f64;
        if work > MAX_QUERY_WORK && !allow_large {
            return Err(bad(
                "points",
                format!(
                    "{} point(s) × {} rays × {} basis functions = {work:.2e} evaluations, more than the limit {MAX_QUERY_WORK:.2e} (the CLI's largest single query); fewer points, a lower order or truth_res, or allow_large=True",
                    pts.len(),
                    query.rays_per_point(),
                    order * order
                ),
            ));
        }
        let values: Vec<f64> = py.allow_threads(|| {
            pts.iter()
                .flat_map(|p| query.at(occ.as_ref(), *p, frame).coeffs)
                .collect()
        });
        Ok(Array2::from_shape_vec((pts.len(), nn), values)
            .map_err(|e| bad("points", e))?
            .into_pyarray(py))
    })
}

/// Mesh counts, minimal bounding sphere, watertightness and validation findings.
#[pyfunction]
fn inspect<'py>(py: Python<'py>, mesh: &str) -> PyResult<Bound<'py, PyDict>> {
    guard(|| {
        let d = PyDict::new(py);
        if mesh == "sphere" {
            d.set_item("mesh", "sphere (analytic unit sphere)")?;
            for k in [
                "vertices",
                "triangles",
                "boundary_edges",
                "non_manifold_edges",
                "degenerate_triangles",
                "unreferenced_vertices",
            ] {
                d.set_item(k, 0)?;
            }
            d.set_item("center", [0.0; 3])?;
            d.set_item("radius", 1.0)?;
            d.set_item("watertight", true)?;
            return Ok(d);
        }
        let m = shscale_scene::vocab::mesh(mesh).map_err(|e| bad("mesh", e))?;
        let r = py.allow_threads(|| m.inspect());
        d.set_item("mesh", mesh)?;
        d.set_item("vertices", r.vertices)?;
        d.set_item("triangles", r.triangles)?;
        d.set_item("center", r.bounding_sphere.center.to_array())?;
        d.set_item("radius", r.bounding_sphere.radius)?;
        d.set_item("watertight", r.watertight)?;
        d.set_item("boundary_edges", r.boundary_edges)?;
        d.set_item("non_manifold_edges", r.non_manifold_edges)?;
        d.set_item("degenerate_triangles", r.degenerate_triangles)?;
        d.set_item("unreferenced_vertices", r.unreferenced_vertices)?;
        Ok(d)
    })
}

/// Extrapolated vs ray-traced visibility at probe radii (`shscale probe`): a dict with the run's
/// scalars and `rows`, a dict of NumPy arrays (one entry per column, one element per radius;
/// undefined metrics are NaN).
#[pyfunction]
#[pyo3(signature = (mesh, order, alpha_deg, layout="latlong:12x20", hemisphere_res=32, sampling_radius=1.0, radii=None, k_count=40, on_surface_eps=1e-3, allow_large=false))]
#[allow(clippy::too_many_arguments)]
fn probe<'py>(
    py: Python<'py>,
    mesh: &str,
    order: usize,
    alpha_deg: f64,
    layout: &str,
    hemisphere_res: usize,
    sampling_radius: f64,
    radii: Option<Vec<f64>>,
    k_count: usize,
    on_surface_eps: f64,
    allow_large: bool,
) -> PyResult<Bound<'py, PyDict>> {
    guard(|| {
        // The probe kind's parameters, bounds and cost model (as `shscale probe`).
        let params = ProbeParams {
            mesh: mesh.into(),
            order,
            alpha_deg,
            layout: layout.into(),
            hemisphere_res,
            sampling_radius,
            k_count,
            on_surface_eps,
            radii: radii.unwrap_or_else(|| shscale_field::probe::DEFAULT_RADII.to_vec()),
            ..ProbeParams::default()
        };
        let spec = params.checked_spec(allow_large).map_err(|e| {
            if e.key.is_empty() {
                PyValueError::new_err(e.message)
            } else {
                bad(&e.key, e.message)
            }
        })?;
        let occ = shscale_scene::vocab::occluder(mesh).map_err(|e| bad("mesh", e))?;
        let analytic = (mesh == "sphere").then(|| shscale_geometry::AnalyticSphere::unit().sphere);
        let res = py
            .allow_threads(|| {
                shscale_experiments::probe::driver::probe(occ.as_ref(), analytic, &spec)
            })
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        let d = PyDict::new(py);
        d.set_item("mesh", mesh)?;
        d.set_item("order", order)?;
        d.set_item("alpha_deg", alpha_deg)?;
        d.set_item(
            "layout",
            Layout::parse(layout).map(|l| l.name()).unwrap_or_default(),
        )?;
        d.set_item("hemisphere_res", hemisphere_res)?;
        d.set_item("sampling_radius", sampling_radius)?;
        d.set_item("k_count", k_count)?;
        d.set_item("k_min", res.k_min)?;
        d.set_item("k_max", res.k_max)?;
        d.set_item("samples", res.samples)?;
        d.set_item("on_surface_samples", res.on_surface_samples)?;
        d.set_item("bsv_rays", res.bsv_rays)?;
        d.set_item("bsv_sampling_seconds", res.bsv_sampling_seconds)?;
        d.set_item("table_build_seconds", res.table_build_seconds)?;
        let rows = probe_columns(py, &res.rows)?;
        d.set_item("rows", rows)?;
        Ok(d)
    })
}

/// The probe's rows as columns, one NumPy array per field of the row struct (through serde, in
/// its field order: the same columns as `shscale probe`), undefined metrics as NaN.
fn probe_columns<'py>(
    py: Python<'py>,
    rows: &[shscale_experiments::probe::ProbeRow],
) -> PyResult<Bound<'py, PyDict>> {
    let out = PyDict::new(py);
    let values = serde_json::to_value(rows).map_err(|e| PyValueError::new_err(e.to_string()))?;
    let list = values.as_array().map(Vec::as_slice).unwrap_or_default();
    let keys: Vec<String> = list
        .first()
        .and_then(|r| r.as_object())
        .map(|o| o.keys().cloned().collect())
        .unwrap_or_default();
    for k in keys {
        // Counts stay integers (every value an integer); other columns are reals, NaN where
        // a metric is undefined.
        if list.iter().all(|r| r[&k].is_i64()) {
            let col: Vec<i64> = list.iter().map(|r| r[&k].as_i64().unwrap_or(0)).collect();
            out.set_item(k, col.into_pyarray(py))?;
        } else {
            let col: Vec<f64> = list
                .iter()
                .map(|r| r[&k].as_f64().unwrap_or(f64::NAN))
                .collect();
            out.set_item(k, col.into_pyarray(py))?;
        }
    }
    Ok(out)
}

/// Run an experiment config through the runner (`shscale run`): `set` and `sweep` are the
/// `--set key=value` and `--sweep key=v1,v2` overrides. `config` is a file's path, or, with
/// `text`, the label of that config text (a dict or TOML string from Python; its relative paths
/// are relative to the working directory). Returns `(results_dir, warnings)`.
#[pyfunction]
#[pyo3(signature = (config, set=vec![], sweep=vec![], name=None, out_dir="results", allow_large=false, text=None))]
#[allow(clippy::too_many_arguments)]
fn run_config(
    py: Python<'_>,
    config: &str,
    set: Vec<String>,
    sweep: Vec<String>,
    name: Option<String>,
    out_dir: &str,
    allow_large: bool,
    text: Option<String>,
) -> PyResult<(String, Vec<String>)> {
    guard(|| {
        let registry = shscale_experiments::registry();
        let ov = shscale_runner::config::Overrides { set, sweep, name };
        let plan = match &text {
            // The plan's default name is "python" (a label like "<dict config>" is no name).
            Some(t) => shscale_runner::Plan::parse(config, "python", t, &ov, &registry),
            None => shscale_runner::Plan::load(std::path::Path::new(config), &ov, &registry),
        }
        .map_err(|e| PyValueError::new_err(e.to_string()))?;
        plan.check_limits(allow_large)
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        let out = std::path::PathBuf::from(out_dir);
        // The plan runs on a thread of its own while this one, every 100 ms, takes the GIL to
        // let Python's signal handlers run: Ctrl-C (KeyboardInterrupt) stops the plan between
        // runs — within one run's time — keeping every finished run, and is raised again here
        // once the finished runs are committed.
        let stop = std::sync::atomic::AtomicBool::new(false);
        let mut signal: Option<PyErr> = None;
        let result = py.allow_threads(|| {
            std::thread::scope(|scope| {
                let worker = scope.spawn(|| run_and_report(&plan, &out, &stop));
                while !worker.is_finished() {
                    std::thread::sleep(std::time::Duration::from_millis(100));
                    if signal.is_none() {
                        if let Err(e) = Python::with_gil(|py| py.check_signals()) {
                            stop.store(true, std::sync::atomic::Ordering::Release);
                            signal = Some(e);
                        }
                    }
                }
                worker.join().unwrap_or_else(|_| {
                    Err(shscale_scene::Error::config(
                        "the plan's thread panicked".into(),
                    ))
                })
            })
        });
        if let Some(e) = signal {
            // Say what was kept and how to go on, then raise what Python asked for.
            let how = match &result {
                Err(r) => r.to_string(),
                Ok(_) => "every run had finished".to_string(),
            };
            Python::with_gil(|py| {
                let msg = format!("shscale.run: {how}; the same call resumes");
                let _ = py
                    .import("sys")
                    .and_then(|sys| sys.getattr("stderr")?.call_method1("write", (msg + "\n",)));
            });
            return Err(e);
        }
        let (dir, warnings) = result.map_err(|e| PyValueError::new_err(e.to_string()))?;
        Ok((dir.display().to_string(), warnings))
    })
}

/// `plan` run into `out` until `stop` is set, then reported: its results folder and the
/// runner's warnings.
fn run_and_report(
    plan: &shscale_runner::Plan,
    out: &std::path::Path,
    stop: &std::sync::atomic::AtomicBool,
) -> Result<(std::path::PathBuf, Vec<String>), shscale_scene::Error> {
    let warnings = std::sync::Mutex::new(Vec::new());
    let s = shscale_runner::run_plan_until(
        plan,
        out,
        None,
        &|ev| {
            if let shscale_runner::RunEvent::Warn(w) = ev {
                (warnings.lock().unwrap_or_else(|e| e.into_inner())).push(w.to_string());
            }
        },
        stop,
    )?;
    shscale_runner::report(plan.kind, &s.dir)?;
    Ok((s.dir, warnings.into_inner().unwrap_or_default()))
}

/// `shscale plot` on a results directory: the files written (PNG and SVG).
#[pyfunction]
#[pyo3(signature = (directory, metric, x, series=vec![], facet=None, filters=vec![], log_y=None, log_x=false))]
#[allow(clippy::too_many_arguments)]
fn plot(
    py: Python<'_>,
    directory: &str,
    metric: &str,
    x: &str,
    series: Vec<String>,
    facet: Option<String>,
    filters: Vec<(String, String)>,
    log_y: Option<bool>,
    log_x: bool,
) -> PyResult<Vec<String>> {
    guard(|| {
        let dir = std::path::Path::new(directory);
        let err = |e: shscale_scene::Error| PyValueError::new_err(e.to_string());
        let kind = shscale_experiments::kind_of_dir(dir).map_err(err)?;
        let t = shscale_runner::records::Results::read(&dir.join("runs.csv"))
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        let keys = shscale_runner::kind::row_keys(kind);
        let spec = shscale_present::column_plot::PlotSpec {
            metric,
            x,
            series: &series,
            facet: facet.as_deref(),
            filters: &filters,
            log_y,
            log_x,
            stem: None,
            title: None,
        };
        let files = py
            .allow_threads(|| shscale_present::column_plot::plot_column(dir, &t, &keys, &spec))
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        Ok(files.iter().map(|f| f.display().to_string()).collect())
    })
}

/// The numerical fingerprint of the Rust code this module was built from (rows whose `code`
/// differs are stale).
#[pyfunction]
fn code_fingerprint() -> &'static str {
    shscale_runner::manifest::CODE_FINGERPRINT
}

/// What the `code` and `contended` cells of a table say (stale, mixed, timed on a busy
/// machine), in the words of `shscale report` and `merge`.
#[pyfunction]
#[pyo3(signature = (codes, contended, has_times))]
fn row_notes(
    codes: Option<Vec<String>>,
    contended: Option<Vec<String>>,
    has_times: bool,
) -> Vec<String> {
    let rows = codes
        .as_ref()
        .map(Vec::len)
        .or(contended.as_ref().map(Vec::len))
        .unwrap_or(0);
    shscale_runner::manifest::row_notes_of(
        codes.as_ref().map(|v| v.iter().map(String::as_str)),
        contended.as_ref().map(|v| v.iter().map(String::as_str)),
        rows,
        has_times,
    )
}

/// The experiment kinds of the runner, by name.
#[pyfunction]
fn kinds<'py>(py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
    PyList::new(py, shscale_experiments::registry().iter().map(|k| k.name()))
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_function(wrap_pyfunction!(sh_eval, m)?)?;
    m.add_function(wrap_pyfunction!(sh_cap, m)?)?;
    m.add_function(wrap_pyfunction!(sh_rotate, m)?)?;
    m.add_function(wrap_pyfunction!(scaling_matrix, m)?)?;
    m.add_function(wrap_pyfunction!(ktable, m)?)?;
    m.add_class::<KTableHandle>()?;
    m.add_function(wrap_pyfunction!(visibility, m)?)?;
    m.add_function(wrap_pyfunction!(inspect, m)?)?;
    m.add_function(wrap_pyfunction!(probe, m)?)?;
    m.add_function(wrap_pyfunction!(run_config, m)?)?;
    m.add_function(wrap_pyfunction!(kinds, m)?)?;
    m.add_function(wrap_pyfunction!(plot, m)?)?;
    m.add_function(wrap_pyfunction!(code_fingerprint, m)?)?;
    m.add_function(wrap_pyfunction!(row_notes, m)?)?;
    Ok(())
}
