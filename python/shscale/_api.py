"""The implementation of the ``shscale`` package; the public names are re-exported by
``shscale/__init__.py`` (this module's helpers and imports stay out of the package's namespace)."""


from __future__ import annotations

import math
import os
import warnings
from typing import Any, Mapping, Optional, Sequence

import numpy as np

from . import _native



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
    scalars and ``rows``, a pandas DataFrame with one row per radius (NaN where a metric is
    undefined; counts as integers): every column of the CLI's rows, as ``run()`` returns rows.
    ``radii`` defaults to the papers' Fig. 5 radii (0.5, 0.7, 0.9, 1.3, 2 × the bounding
    radius)."""
    import pandas as pd

    out = _native.probe(
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
    out["rows"] = pd.DataFrame(out["rows"])
    return out


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
        # A TOML basic string: backslash and quote escaped, and every control character (a
        # newline in a title, legal TOML when escaped) as its \\uXXXX escape.
        out = []
        for c in v:
            if c == "\\":
                out.append("\\\\")
            elif c == '"':
                out.append('\\"')
            elif ord(c) < 0x20 or ord(c) == 0x7F:
                out.append(f"\\u{ord(c):04X}")
            else:
                out.append(c)
        return '"' + "".join(out) + '"'
    if isinstance(v, (list, tuple, np.ndarray)):
        return "[" + ", ".join(_toml(x) for x in v) + "]"
    raise ValueError(f"{v!r}: not a value a config can hold (bool, number, string or list)")


def _key_arg(what: str, k: Any) -> str:
    if not isinstance(k, str):
        raise TypeError(f"{what}: keys are strings (dotted for nested keys), got {k!r}")
    return k


def _bare(k: str) -> str:
    """A TOML key: bare when it can be, quoted otherwise."""
    if k and all(c.isascii() and (c.isalnum() or c in "_-") for c in k):
        return k
    return _toml(k)


def _toml_table(d: Mapping, path: tuple = ()) -> str:
    """A dict config as TOML text: plain keys first, then tables (``[a.b]``) and arrays of
    tables (``[[sweep]]``, ``[[occluder]]``), nested as deep as the dict."""
    lines, tables, arrays = [], [], []
    for k, v in d.items():
        if not isinstance(k, str):
            raise TypeError(f"config: keys are strings, got {k!r}")
        if isinstance(v, Mapping):
            tables.append((k, v))
        elif isinstance(v, (list, tuple)) and v and all(isinstance(x, Mapping) for x in v):
            arrays.append((k, v))
        else:
            lines.append(f"{_bare(k)} = {_toml(v)}")
    out = "\n".join(lines) + ("\n" if lines else "")
    for k, v in tables:
        name = ".".join(_bare(p) for p in path + (k,))
        out += f"\n[{name}]\n" + _toml_table(v, path + (k,))
    for k, vs in arrays:
        name = ".".join(_bare(p) for p in path + (k,))
        for v in vs:
            out += f"\n[[{name}]]\n" + _toml_table(v, path + (k,))
    return out


def run(
    config: str | os.PathLike | Mapping[str, Any],
    overrides: Mapping[str, Any] | None = None,
    sweep: Mapping[str, Sequence[Any]] | None = None,
    name: str | None = None,
    out_dir: str | os.PathLike = "results",
    allow_large: bool = False,
):
    """Run an experiment config through the runner (``shscale run``): resumable, every run's
    rows in ``<out_dir>/<experiment>/<name>/runs.csv``. ``config`` is a path, a TOML string, or
    a dict of the same keys (``{"experiment": "probe", "sweep": {"alpha_deg": [30, 60]}}``);
    relative paths in a string or dict config are relative to the working directory. ``overrides`` are ``--set`` (dotted keys
    for nested tables), ``sweep`` adds or replaces sweep axes (``--sweep``). Returns
    ``(rows, results_dir)``: the rows as a pandas DataFrame and the directory."""
    # Mesa's software Vulkan device (the runner's GPU timing) complains on stderr without it.
    if "XDG_RUNTIME_DIR" not in os.environ:
        import tempfile

        os.environ["XDG_RUNTIME_DIR"] = tempfile.mkdtemp(prefix="shscale-xdg-")
    sets = [f"{_key_arg('overrides', k)}={_toml(v)}" for k, v in (overrides or {}).items()]
    sweeps = []
    for k, vs in (sweep or {}).items():
        if isinstance(vs, (str, bytes, Mapping)) or not isinstance(vs, (list, tuple, np.ndarray)):
            raise ValueError(
                f"sweep: {k}: {vs!r} is not a list of values (a sweep axis is a list: give [{vs!r}])"
            )
        sweeps.append(f"{_key_arg('sweep', k)}={','.join(_toml(x) for x in vs)}")
    text = None
    if isinstance(config, Mapping):
        text, label = _toml_table(config), "<dict config>"
    elif isinstance(config, str) and not os.path.exists(config) and "=" in config:
        text, label = config, "<TOML text config>"
    elif isinstance(config, (str, os.PathLike)):
        label = os.fspath(config)
    else:
        raise TypeError(
            f"config: expected a path, a TOML string or a dict, got {type(config).__name__}"
        )
    directory, notes = _native.run_config(
        label, sets, sweeps, name, os.fspath(out_dir), bool(allow_large), text
    )
    for n in notes:
        warnings.warn(n, stacklevel=2)
    return load_results(directory), directory


def load_results(directory: str | os.PathLike):
    """The rows of a results directory (its ``runs.csv``) as a pandas DataFrame, typed by the
    ``runs.schema.json`` beside it: ``run_id`` and every string column stay strings, integers
    are nullable ``Int64``, booleans ``bool``, list parameters (``0.5;0.7;2``) lists of floats.
    ``DataFrame.attrs`` holds ``units`` (column → unit), ``schema`` (the columns' entries),
    ``code`` (this module's numerical fingerprint) and ``notes``: rows that are stale (computed
    by another numerical code), of several codes (mixed) or timed on a busy machine, in the
    words of ``shscale report`` — each also given as a ``UserWarning``. Without a schema (rows of
    an older version) every cell is read as text and nothing is converted."""
    import json
    import stat

    import pandas as pd

    directory = os.fspath(directory)
    path = os.path.join(directory, "runs.csv")
    try:
        # lstat: a FIFO, a device or a link is never opened (a FIFO would block forever).
        st = os.lstat(path)
    except FileNotFoundError:
        raise ValueError(f"{path}: no runs.csv (run an experiment into this directory first)") from None
    except OSError as e:
        raise ValueError(f"{path}: {e.strerror}") from None
    if not stat.S_ISREG(st.st_mode):
        raise ValueError(f"{path}: not a regular file (a FIFO, a device, a link or a folder); nothing read")
    schema_path = os.path.join(directory, "runs.schema.json")
    schema = None
    if os.path.isfile(schema_path) and not os.path.islink(schema_path):
        with open(schema_path, encoding="utf-8") as f:
            try:
                schema = json.load(f)
            except json.JSONDecodeError as e:
                raise ValueError(f"{schema_path}: not JSON ({e})") from None
    # Every cell as text first: no column is guessed (a run id of digits stays a string).
    df = pd.read_csv(path, dtype=str, keep_default_na=False)
    columns = (schema or {}).get("columns", [])
    by_name = {c["name"]: c for c in columns}
    missing = [c for c in by_name if c not in df.columns]
    if schema is not None and missing:
        raise ValueError(
            f"{path}: lacks the column(s) {', '.join(missing[:5])} that {schema_path} names"
        )
    for name, c in by_name.items():
        ty = c.get("type", "string").rstrip("?")
        col = df[name]
        try:
            if ty == "integer":
                df[name] = pd.to_numeric(col.where(col != "")).astype("Int64")
            elif ty == "float":
                df[name] = pd.to_numeric(col.where(col != "")).astype(float)
            elif ty == "bool":
                bad = set(col) - {"true", "false"}
                if bad:
                    raise ValueError(f"not true or false: {sorted(bad)[:3]}")
                df[name] = col == "true"
            elif ty == "list":
                df[name] = [
                    [float(x) for x in v.split(";")] if v.strip() else [] for v in col
                ]
        except (ValueError, TypeError) as e:
            raise ValueError(f"{path}: column {name!r} ({ty}): {e}") from None
    df.attrs["units"] = {n: c.get("unit", "") for n, c in by_name.items() if c.get("unit")}
    df.attrs["schema"] = columns
    df.attrs["code"] = _native.code_fingerprint()
    has_times = any(c.get("role") == "time" for c in columns)
    codes = list(df["code"].astype(str)) if "code" in df.columns else None
    busy = (
        ["true" if bool(x) else "false" for x in df["contended"]] if "contended" in df.columns else None
    )
    notes = list(_native.row_notes(codes, busy, has_times))
    df.attrs["notes"] = notes
    for n in notes:
        warnings.warn(f"{path}: {n}", stacklevel=2)
    return df


def plot(
    directory: str | os.PathLike,
    metric: str,
    x: str,
    series: Sequence[str] | str = (),
    facet: str | None = None,
    where: Mapping[str, Any] | None = None,
    log_y: bool | None = None,
    log_x: bool = False,
) -> list[str]:
    """Plot ``metric`` against ``x`` from a results directory (``shscale plot``): one series
    per combination of the ``series`` columns (default: the other varying parameters, faceted by
    the probe radius when that would make more than 8 series), one panel per value of ``facet``,
    rows kept where every ``where`` column equals its value; a ``*_mean`` metric with ``*_p25`` /
    ``*_p75`` columns gets its interquartile band. ``log_y``: ``None`` decides by the data. A
    line through rows that differ in a parameter at one x is refused (``ValueError`` naming it).
    Returns the PNG and SVG paths."""
    if isinstance(series, str):
        series = [series]
    filters = [(str(k), _toml(v).strip('"')) for k, v in (where or {}).items()]
    return list(
        _native.plot(
            os.fspath(directory),
            str(metric),
            str(x),
            [str(s) for s in series],
            None if facet is None else str(facet),
            filters,
            None if log_y is None else bool(log_y),
            bool(log_x),
        )
    )


def kinds() -> list:
    """The experiment kinds of the runner."""
    return list(_native.kinds())
