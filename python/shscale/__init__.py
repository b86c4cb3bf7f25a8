"""shscale from Python: spherical harmonics scaling and shadow fields for deformable objects.

NumPy arrays in and out, with the conventions of the ``shscale`` command line (real SH, index
``l² + l + m``, docs/conventions.md). Bad input raises ``ValueError`` with the message the CLI
prints; long calls release the GIL.

>>> import shscale
>>> shscale.sh_eval(2, [[0, 0, 1]]).shape
(1, 4)
"""

from __future__ import annotations

import math
import os
import warnings
from typing import Any, Mapping, Optional, Sequence

import numpy as np

from . import _native

__version__ = _native.__version__

__all__ = [
    "sh_eval",
    "sh_cap",
    "sh_rotate",
    "scaling_matrix",
    "ktable",
    "visibility",
    "inspect",
    "probe",
    "run",
    "load_results",
    "kinds",
]


def _real(name: str, a: Any) -> np.ndarray:
    """``a`` as a float64 array: integers and reals are taken; complex values are refused
    (their imaginary parts would be dropped), as are objects, strings and booleans."""
    raw = np.asarray(a)
    if raw.dtype.kind == "c":
        raise ValueError(f"{name}: complex values are not accepted (their imaginary parts would be dropped)")
    if raw.dtype.kind not in "iuf":
        raise TypeError(f"{name}: expected real numbers, got an array of dtype {raw.dtype}")
    return raw.astype(np.float64, copy=False)


def _rows3(name: str, a: Any) -> np.ndarray:
    arr = _real(name, a)
    if arr.ndim == 1:
        arr = arr.reshape(1, -1)
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise ValueError(f"{name}: expected shape (P, 3) or (3,), got {np.shape(a)}")
    return np.ascontiguousarray(arr)


def _count(name: str, v: Any) -> int:
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)):
        raise ValueError(f"{name}: {v!r} is not a whole number")
    if v < 0:
        raise ValueError(f"{name}: {v} is negative: a whole number ≥ 0 is expected")
    if v >= 2**63:
        raise ValueError(f"{name}: {v} is too large (at most 2**63 - 1)")
    return int(v)


def sh_eval(order: int, dirs: Any) -> np.ndarray:
    """The N² real SH basis values at each direction (rows of ``dirs``, normalised first):
    shape ``(P, N²)``."""
    return _native.sh_eval(_count("order", order), _rows3("dirs", dirs))


def sh_cap(order: int, angle_deg: float) -> np.ndarray:
    """The N² coefficients of the indicator of a cap of half-angle ``angle_deg`` about +z."""
    return _native.sh_cap(_count("order", order), float(angle_deg))


def sh_rotate(order: int, coeffs: Any, euler_zyz_deg: Sequence[float]) -> np.ndarray:
    """``coeffs`` (N²) rotated by the ZYZ Euler angles (degrees)."""
    c = np.ascontiguousarray(_real("coeffs", coeffs).ravel())
    e = [float(x) for x in euler_zyz_deg]
    if len(e) != 3:
        raise ValueError(f"euler_zyz_deg: expected 3 angles, got {len(e)}")
    return _native.sh_rotate(_count("order", order), c, e)


def scaling_matrix(
    order: int,
    tau: str = "cone",
    alpha_deg: float = 45.0,
    k: float = 2.0,
    energy: bool = False,
) -> np.ndarray:
    """The dense ``(N², N²)`` scaling matrix M_k: cone τ (k = d/r > 0, half-angle α) or
    mid-range τ (k = d/R in (−1, 1)); ``energy`` for radiance (η = sin τ · τ′)."""
    return _native.scaling_matrix(
        _count("order", order), tau, float(alpha_deg), float(k), bool(energy)
    )


def ktable(
    order: int,
    k_min: float,
    k_max: float,
    count: int = 40,
    tau: str = "cone",
    alpha_deg: float = 45.0,
    energy: bool = False,
    spacing: str = "exp",
    interp: str = "linear",
):
    """A table of ``count`` scaling matrices over [k_min, k_max] (``spacing``: exp, uniform,
    chebyshev; ``interp``: linear, cubic in ln k). ``.lookup(k)`` gives the interpolated
    matrix, ``.ks`` the nodes, ``.max_interp_error()`` the measured error."""
    return _native.ktable(
        _count("order", order),
        float(k_min),
        float(k_max),
        _count("count", count),
        tau,
        float(alpha_deg),
        bool(energy),
        spacing,
        interp,
    )


def visibility(
    mesh: str,
    points: Any,
    order: int,
    hemisphere_res: int = 32,
    frame: str = "entity",
    quadrature: str = "stratified",
    truth_res: int = 128,
    seed: int = 0x5EED7207,
    allow_large: bool = False,
) -> np.ndarray:
    """Ray-traced visibility (1 = unoccluded) over the full sphere at each point, projected to
    order N: shape ``(P, N²)``. ``mesh``: ``sphere``, a procedural shape (bird, egg, sponge,
    plane), a bundled mesh or an .obj/.ply path; ``frame``: entity or local. ``quadrature``:
    ``stratified`` (the converged truth, 4·truth_res² rays per point, as ``shscale visibility``)
    or ``gauss`` (the method's rings, 2·hemisphere_res² rays). A call doing more than the CLI's
    largest single query (points × rays × N² > 4·1024²·128²) raises ``ValueError`` unless
    ``allow_large``."""
    return _native.visibility(
        str(mesh),
        _rows3("points", points),
        _count("order", order),
        _count("hemisphere_res", hemisphere_res),
        frame,
        str(quadrature),
        _count("truth_res", truth_res),
        _count("seed", seed),
        bool(allow_large),
    )


def inspect(mesh: str) -> dict:
    """Mesh counts, minimal bounding sphere, watertightness and validation findings."""
    return _native.inspect(str(mesh))


def probe(
    mesh: str,
    order: int,
    alpha_deg: float,
    layout: str = "latlong:12x20",
    hemisphere_res: int = 32,
    sampling_radius: float = 1.0,
    radii: Optional[Sequence[float]] = None,
    k_count: int = 40,
    on_surface_eps: float = 1e-3,
    allow_large: bool = False,
) -> dict:
    """Extrapolated vs ray-traced visibility at probe radii (``shscale probe``): the run's
    scalars and ``rows``, a dict of arrays with one element per radius (NaN where a metric is
    undefined): every column of the CLI's rows. ``radii`` defaults to the papers' Fig. 5 radii
    (0.5, 0.7, 0.9, 1.3, 2 × the bounding radius)."""
    return _native.probe(
        str(mesh),
        _count("order", order),
        float(alpha_deg),
        layout,
        _count("hemisphere_res", hemisphere_res),
        float(sampling_radius),
        None if radii is None else [float(r) for r in radii],
        _count("k_count", k_count),
        float(on_surface_eps),
        bool(allow_large),
    )


def _toml(v: Any) -> str:
    """A Python value as a TOML value (the form ``--set key=value`` takes)."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        f = float(v)
        if math.isnan(f):
            return "nan"
        if math.isinf(f):
            return "inf" if f > 0 else "-inf"
        return repr(f)
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, (list, tuple, np.ndarray)):
        return "[" + ", ".join(_toml(x) for x in v) + "]"
    raise ValueError(f"{v!r}: not a value a config can hold (bool, number, string or list)")


def run(
    config: str | os.PathLike,
    overrides: Mapping[str, Any] | None = None,
    sweep: Mapping[str, Sequence[Any]] | None = None,
    name: str | None = None,
    out_dir: str | os.PathLike = "results",
    allow_large: bool = False,
):
    """Run an experiment config through the runner (``shscale run``): resumable, every run's
    rows in ``<out_dir>/<experiment>/<name>/runs.csv``. ``overrides`` are ``--set`` (dotted keys
    for nested tables), ``sweep`` adds or replaces sweep axes (``--sweep``). Returns
    ``(rows, results_dir)``: the rows as a pandas DataFrame and the directory."""
    # Mesa's software Vulkan device (the runner's GPU timing) complains on stderr without it.
    if "XDG_RUNTIME_DIR" not in os.environ:
        import tempfile

        os.environ["XDG_RUNTIME_DIR"] = tempfile.mkdtemp(prefix="shscale-xdg-")
    sets = [f"{k}={_toml(v)}" for k, v in (overrides or {}).items()]
    sweeps = [f"{k}={','.join(_toml(x) for x in vs)}" for k, vs in (sweep or {}).items()]
    directory, notes = _native.run_config(
        os.fspath(config), sets, sweeps, name, os.fspath(out_dir), bool(allow_large)
    )
    for n in notes:
        warnings.warn(n, stacklevel=2)
    return load_results(directory), directory


def load_results(directory: str | os.PathLike):
    """The rows of a results directory (its ``runs.csv``) as a pandas DataFrame."""
    import pandas as pd

    path = os.path.join(os.fspath(directory), "runs.csv")
    if not os.path.exists(path):
        raise ValueError(f"{path}: no runs.csv (run an experiment into this directory first)")
    return pd.read_csv(path, keep_default_na=True)


def kinds() -> list:
    """The experiment kinds of the runner."""
    return list(_native.kinds())
