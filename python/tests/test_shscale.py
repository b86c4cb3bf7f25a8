"""Tests of the Python package against the command line (the same numbers, the same error
messages), of its bad-input handling, of the GIL being released, and of a tiny run end to end."""

import json
import os
import subprocess
import threading
import time
from pathlib import Path

import numpy as np
import pytest

import shscale

ROOT = Path(__file__).resolve().parents[2]
BIN = Path(os.environ.get("SHSCALE_BIN", ROOT / "target" / "release" / "shscale"))


def cli(*args):
    """The CLI's JSON answer."""
    out = subprocess.run([str(BIN), *args], capture_output=True, text=True, check=True)
    return json.loads(out.stdout)


def cli_error(*args):
    """The CLI's one error line, without the `error: ` prefix and the flag's dashes."""
    out = subprocess.run([str(BIN), *args], capture_output=True, text=True)
    assert out.returncode == 2, out
    line = out.stderr.strip()
    assert line.startswith("error: ")
    return line[len("error: "):]


@pytest.fixture(scope="module", autouse=True)
def binary():
    if not BIN.exists():
        pytest.fail(f"{BIN}: build the CLI first (cargo build --release) or set SHSCALE_BIN")


def test_sh_eval_cap_rotate_equal_the_cli():
    d = [1.0, 2.0, -3.0]
    got = shscale.sh_eval(5, [d])[0]
    want = cli("sh", "eval", "--order", "5", "--dir", "1,2,-3")["values"]
    np.testing.assert_array_equal(got, want)
    # Several directions at once, each normalised: equal to one call per row.
    dirs = np.array([[0, 0, 1], [1, 1, 0], [0.3, -0.2, 0.9]])
    many = shscale.sh_eval(4, dirs)
    assert many.shape == (3, 16)
    for i, r in enumerate(dirs):
        np.testing.assert_array_equal(many[i], shscale.sh_eval(4, r)[0])
    np.testing.assert_array_equal(
        shscale.sh_cap(4, 30.0), cli("sh", "cap", "--order", "4", "--angle-deg", "30")["values"]
    )
    c = [1.0, 0.2, 0.5, -0.3]
    np.testing.assert_array_equal(
        shscale.sh_rotate(2, c, [10, 90, -20]),
        cli("sh", "rotate", "--order", "2", "--coeffs", "1,0.2,0.5,-0.3", "--euler-zyz-deg", "10,90,-20")["values"],
    )


def test_matrices_and_tables_equal_the_cli():
    m = shscale.scaling_matrix(4, "cone", 45.0, 2.0)
    assert m.shape == (16, 16)
    np.testing.assert_array_equal(
        m, cli("matrix", "--order", "4", "--tau", "cone", "--alpha-deg", "45", "--k", "2")["matrix"]
    )
    e = shscale.scaling_matrix(3, tau="midrange", k=0.5, energy=True)
    np.testing.assert_array_equal(
        e, cli("matrix", "--order", "3", "--tau", "midrange", "--k", "0.5", "--energy")["matrix"]
    )
    t = shscale.ktable(2, 0.5, 2.0, count=10)
    want = cli("matrix", "--order", "2", "--tau", "cone", "--alpha-deg", "45", "--table", "10", "--k-range", "0.5,2")
    assert t.size_bytes == want["size_bytes"]
    err, at = t.max_interp_error(3)
    assert (err, at) == (want["max_interp_error"], want["max_interp_error_k"])
    # At a node the table is the directly computed matrix.
    k = float(t.ks[3])
    np.testing.assert_allclose(t.lookup(k), shscale.scaling_matrix(2, k=k), rtol=0, atol=1e-15)
    print(f"k-table N = 2, K = 10: max interpolation error {err:.3e} at k = {at:.3f}")


def test_visibility_inspect_probe_equal_the_cli():
    v = shscale.visibility("sphere", [[0, 0, 2], [0.5, 1.5, 0.2]], 4, hemisphere_res=16, quadrature="gauss")
    s = shscale.visibility("sphere", [[0, 0, 2], [0.5, 1.5, 0.2]], 4, truth_res=32)
    assert v.shape == (2, 16) and s.shape == (2, 16)
    for i, p in enumerate(["0,0,2", "0.5,1.5,0.2"]):
        want = cli("visibility", "--mesh", "sphere", "--point", p, "--order", "4", "--hemisphere-res", "16", "--quadrature", "gauss")
        np.testing.assert_array_equal(v[i], want["values"])
        want = cli("visibility", "--mesh", "sphere", "--point", p, "--order", "4", "--truth-res", "32")
        assert want["quadrature"] == "stratified" and want["rays"] == 4 * 32 * 32
        np.testing.assert_array_equal(s[i], want["values"])
    info = shscale.inspect("bunny")
    want = cli("inspect", "bunny")
    assert info["vertices"] == want["vertices"] and info["triangles"] == want["triangles"]
    assert info["radius"] == want["bounding_sphere"]["radius"]
    assert list(info["center"]) == want["bounding_sphere"]["center"]
    p = shscale.probe("bird", 3, 45.0, layout="fib:40", hemisphere_res=8, radii=[0.7, 1.3], k_count=8)
    want = cli("probe", "--mesh", "bird", "--order", "3", "--alpha-deg", "45", "--layout", "fib:40",
               "--hemisphere-res", "8", "--radii", "0.7,1.3", "--k-count", "8")
    assert p["samples"] == want["samples"] and p["k_min"] == want["k_min"]
    # Rows as run() gives them: a DataFrame, counts as integers.
    import pandas as pd

    assert isinstance(p["rows"], pd.DataFrame) and len(p["rows"]) == 2
    assert p["rows"]["probes"].dtype.kind == "i" and p["rows"]["radius"].dtype.kind == "f"
    # Every column of the CLI's rows (the probe's one row struct through serde, the CSV's too),
    # the CLI's device columns aside.
    cli_cols = [c for c in want["rows"][0] if c not in ("device", "threads")]
    assert list(p["rows"]) == cli_cols
    # Times (and their spreads) differ run to run; the GPU's device name is text.
    numeric = [c for c in cli_cols if not c.endswith(("_seconds", "_spread")) and c != "gpu_device"]
    assert (p["rows"]["gpu_device"] == "").all() or p["rows"]["gpu_device"].isna().all()
    for col in numeric:
        got = p["rows"][col]
        ref = np.array([np.nan if r[col] is None else r[col] for r in want["rows"]], dtype=float)
        np.testing.assert_array_equal(got, ref, err_msg=col)


@pytest.mark.parametrize(
    "call, flags",
    [
        (lambda: shscale.scaling_matrix(4, alpha_deg=95.0), ["matrix", "--order", "4", "--tau", "cone", "--alpha-deg", "95", "--k", "2"]),
        (lambda: shscale.probe("sphere", 4, 45.0, layout="fib:1000000000"), ["probe", "--mesh", "sphere", "--order", "4", "--alpha-deg", "45", "--layout", "fib:1000000000"]),
        (lambda: shscale.probe("sphere", 4, 45.0, radii=[-1.0]), ["probe", "--mesh", "sphere", "--order", "4", "--alpha-deg", "45", "--radii", "-1"]),
        (lambda: shscale.probe("sphere", 4, 45.0, k_count=1_000_000_000), ["probe", "--mesh", "sphere", "--order", "4", "--alpha-deg", "45", "--k-count", "1000000000"]),
        (lambda: shscale.probe("bunny", 4, 45.0, layout="fib:1000000", hemisphere_res=256), ["probe", "--mesh", "bunny", "--order", "4", "--alpha-deg", "45", "--layout", "fib:1000000", "--hemisphere-res", "256"]),
        (lambda: shscale.probe("moon", 4, 45.0), ["probe", "--mesh", "moon", "--order", "4", "--alpha-deg", "45"]),
    ],
)
def test_errors_carry_the_cli_message(call, flags):
    """The same words as the CLI: the Python message is the CLI's, with the key for the flag."""
    with pytest.raises(ValueError) as e:
        call()
    want = cli_error(*flags)
    # The CLI names the flag (`--radii:`), Python the parameter (`radii:`).
    want = want.split(": ", 1)[1] if want.startswith("--") else want
    assert want in str(e.value), (str(e.value), want)


def test_bad_values_raise_value_error():
    for call in [
        lambda: shscale.sh_eval(0, [[0, 0, 1]]),
        lambda: shscale.sh_eval(4, [[0, 0, 0]]),
        lambda: shscale.sh_eval(4, [[np.nan, 0, 1]]),
        lambda: shscale.sh_eval(4, [[0, 1]]),
        lambda: shscale.sh_eval(-1, [[0, 0, 1]]),
        lambda: shscale.sh_eval(2.5, [[0, 0, 1]]),
        lambda: shscale.sh_cap(4, np.inf),
        lambda: shscale.sh_rotate(2, [1, 0, 0], [0, 0, 0]),
        lambda: shscale.sh_rotate(2, [1, 0, 0, np.nan], [0, 0, 0]),
        lambda: shscale.scaling_matrix(4, tau="laser"),
        lambda: shscale.scaling_matrix(4, k=-1.0),
        lambda: shscale.scaling_matrix(40),
        lambda: shscale.ktable(4, 2.0, 0.5),
        lambda: shscale.ktable(4, 0.5, 2.0, count=1),
        lambda: shscale.ktable(4, 0.5, 2.0, spacing="random"),
        lambda: shscale.ktable(4, 0.5, 2.0).lookup(100.0),
        lambda: shscale.ktable(4, 0.5, 2.0).lookup(np.nan, clamp=True),
        lambda: shscale.visibility("sphere", [[1e308, 0, 0]], 4),
        lambda: shscale.visibility("sphere", [[0, 0, 2]], 4, frame="world"),
        lambda: shscale.visibility("sphere", [[0, 0, 2]], 4, hemisphere_res=100000),
        lambda: shscale.visibility("sphere", [[0, 0, 2]], 4, quadrature="simpson"),
        lambda: shscale.visibility("sphere", [[0, 0, 2]], 4, truth_res=0),
        lambda: shscale.inspect("/nonexistent.ply"),
        lambda: shscale.run("/nonexistent.toml"),
        lambda: shscale.load_results("/nonexistent"),
    ]:
        with pytest.raises(ValueError) as e:
            call()
        assert str(e.value), "an empty message"


def test_hostile_calls_raise_and_never_crash_the_interpreter(tmp_path):
    # Each once aborted, crashed or silently misread; now a ValueError/TypeError naming the
    # argument, raised before any large allocation or work.
    deep = ".".join(["a"] * 30000)
    cfg = tmp_path / "c.toml"
    cfg.write_text('experiment = "sparsity"\norder = 2\n')
    for call, exc, needle in [
        (lambda: shscale.sh_eval(128, np.zeros((100000, 3)) + [0, 0, 1]), ValueError, "more than the limit"),
        (lambda: shscale.sh_eval(2**64, [[0, 0, 1]]), ValueError, "too large"),
        (lambda: shscale.sh_eval(2, np.array([[0, 0, 1 + 1j]])), ValueError, "complex"),
        (lambda: shscale.sh_eval(2, np.array([[0, 0, "z"]])), TypeError, "dtype"),
        (lambda: shscale.sh_eval(2, np.array([[0, 0, None]], dtype=object)), TypeError, "dtype"),
        (lambda: shscale.sh_rotate(2, np.array([1, 0, 0, 1j]), [0, 0, 0]), ValueError, "complex"),
        (
            lambda: shscale.visibility("sphere", np.zeros((10000, 3)) + [0, 0, 2], 128, truth_res=1024),
            ValueError,
            "allow_large",
        ),
        (lambda: shscale.run(cfg, overrides={deep: 1}, out_dir=tmp_path), ValueError, "256"),
        (lambda: shscale.run(cfg, overrides={"order[abc]": 1}, out_dir=tmp_path), ValueError, "[abc]"),
    ]:
        with pytest.raises(exc) as e:
            call()
        assert needle in str(e.value), str(e.value)[:300]
    # A runs.csv that is a FIFO blocked load_results forever; now refused without opening it.
    fifo_dir = tmp_path / "fifo"
    fifo_dir.mkdir()
    os.mkfifo(fifo_dir / "runs.csv")
    with pytest.raises(ValueError) as e:
        shscale.load_results(fifo_dir)
    assert "not a regular file" in str(e.value), str(e.value)
    # Non-contiguous and integer inputs are taken as they are.
    d = np.array([[0, 0, 1, 9], [1, 0, 0, 9]], dtype=np.int64)[:, :3]
    assert np.allclose(shscale.sh_eval(2, d), shscale.sh_eval(2, [[0.0, 0, 1], [1, 0, 0]]))


def test_long_calls_release_the_gil():
    """While a ray-traced visibility call runs, Python keeps running in another thread."""
    points = np.column_stack([np.zeros(200), np.zeros(200), np.linspace(1.2, 3.0, 200) * 7 + 4.7])
    ticks = []
    done = threading.Event()

    def count():
        while not done.is_set():
            ticks.append(time.perf_counter())
            time.sleep(0.001)

    t = threading.Thread(target=count)
    t.start()
    t0 = time.perf_counter()
    shscale.visibility("bunny", points, 4, hemisphere_res=128)
    t1 = time.perf_counter()
    done.set()
    t.join()
    during = [x for x in ticks if t0 < x < t1]
    print(f"visibility took {t1 - t0:.3f} s; the other thread ticked {len(during)} times meanwhile")
    assert t1 - t0 > 0.1, "too short to tell"
    # Holding the GIL would allow at most a tick or two (the interpreter's switch interval).
    assert len(during) >= 10


def test_tiny_run_end_to_end(tmp_path):
    cfg = tmp_path / "tiny.toml"
    cfg.write_text(
        'experiment = "probe"\nmesh = "sphere"\norder = 2\nlayout = "fib:10"\nhemisphere_res = 2\n'
        'k_count = 4\nradii = [2.0]\nparallel_runs = false\n[sweep]\nalpha_deg = [30, 60]\n'
    )
    out = tmp_path / "results"
    rows, directory = shscale.run(cfg, out_dir=out)
    assert Path(directory) == out / "probe" / "tiny"
    assert len(rows) == 2 and sorted(rows["alpha_deg"]) == [30.0, 60.0]
    for col in ["run_id", "occ_rel_l2_mean", "k_count", "git_revision"]:
        assert col in rows.columns, col
    # Resume: nothing new; overrides add runs in their own columns; load_results reads it back.
    again, _ = shscale.run(cfg, out_dir=out)
    assert list(again["run_id"]) == list(rows["run_id"])
    more, _ = shscale.run(cfg, overrides={"order": 3}, sweep={"alpha_deg": [45]}, out_dir=out)
    assert len(more) == 3 and sorted(set(more["order"])) == [2, 3]
    assert len(shscale.load_results(directory)) == 3
    # The same CSV as the CLI would read: the command line agrees on the row count.
    with pytest.raises(ValueError) as e:
        shscale.run(cfg, overrides={"order": 0}, out_dir=out)
    assert "--set order=0" in str(e.value) and "1..=16" in str(e.value)
    assert len(shscale.load_results(directory)) == 3, "a refused run wrote rows"


def test_plot_facets_filters_and_refuses_zigzags(tmp_path):
    """``plot`` as ``shscale plot``: a panel per radius, a filter to one radius, and a line through
    rows of different radii refused naming the radius."""
    cfg = {
        "experiment": "probe", "mesh": "sphere", "order": 2, "layout": "fib:12",
        "hemisphere_res": 2, "k_count": 4, "radii": [1.5, 2.0], "parallel_runs": False,
        "sweep": {"alpha_deg": [20, 40, 60]},
    }
    _, directory = shscale.run(cfg, name="p", out_dir=tmp_path)
    files = shscale.plot(directory, "occ_rel_l2_mean", "alpha_deg", facet="radius")
    assert [Path(f).name for f in files] == [
        "plot_occ_rel_l2_mean_vs_alpha_deg_by_radius.png",
        "plot_occ_rel_l2_mean_vs_alpha_deg_by_radius.svg",
    ]
    assert all(Path(f).stat().st_size > 1000 for f in files)
    svg = Path(files[1]).read_text()
    assert svg.count("probe radius ρ = ") == 2 and "interquartile" in svg
    one = shscale.plot(directory, "occ_rel_l2_mean", "alpha_deg", series="order", where={"radius": 1.5})
    assert Path(one[0]).name == "plot_occ_rel_l2_mean_vs_alpha_deg_series_order_where_radius-1.5.png"
    with pytest.raises(ValueError, match='differ in "radius"'):
        shscale.plot(directory, "occ_rel_l2_mean", "alpha_deg", series="order")
    with pytest.raises(ValueError, match='"nosuch" is not a column'):
        shscale.plot(directory, "nosuch", "alpha_deg")
    with pytest.raises(ValueError, match="no manifest.toml"):
        shscale.plot(tmp_path, "occ_rel_l2_mean", "alpha_deg")


def test_notebook_runs(tmp_path):
    """examples/quickstart.ipynb executes top to bottom."""
    nbformat = pytest.importorskip("nbformat")
    nbclient = pytest.importorskip("nbclient")
    nb = nbformat.read(ROOT / "examples" / "quickstart.ipynb", as_version=4)
    client = nbclient.NotebookClient(nb, timeout=300, kernel_name="python3", resources={"metadata": {"path": str(tmp_path)}})
    client.execute()
    outputs = [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", [])]
    assert not [o for o in outputs if o.get("output_type") == "error"]
    text = "".join(o.get("text", "") for o in outputs if o.get("output_type") == "stream")
    assert "44 structural" in text, text


def test_run_takes_a_path_a_toml_string_or_a_dict(tmp_path):
    text = 'experiment = "sparsity"\norder = 2\n\n[sweep]\nk = [1.5, 2.0]\n'
    cfg = tmp_path / "s.toml"
    cfg.write_text(text)
    by_path, _ = shscale.run(cfg, out_dir=tmp_path / "a")
    by_text, _ = shscale.run(text, out_dir=tmp_path / "b")
    by_dict, d = shscale.run(
        {"experiment": "sparsity", "order": 2, "sweep": {"k": [1.5, 2.0]}},
        out_dir=tmp_path / "c",
    )
    cols = ["run_id", "k", "eta", "nonzeros", "max_abs"]
    for other in (by_text, by_dict):
        assert other[cols].equals(by_path[cols])
    assert d.endswith("python"), d
    # Nested tables and arrays of tables: [[sweep]] blocks.
    blocks, _ = shscale.run(
        {"experiment": "sparsity", "order": 2, "sweep": [{"k": [1.5]}, {"k": [3.0]}]},
        out_dir=tmp_path / "e",
    )
    assert sorted(set(blocks["k"])) == [1.5, 3.0]
    # A title with a newline, a tab and an ESC is legal TOML once escaped: it runs, and the
    # manifest keeps it.
    title = "two\nlines\tand \x1b escape"
    _, t = shscale.run(
        {"experiment": "sparsity", "order": 2, "title": title, "k": 2.0},
        out_dir=tmp_path / "t",
    )
    tomllib = pytest.importorskip("tomllib")

    manifest = tomllib.loads((Path(t) / "manifest.toml").read_text())
    assert tomllib.loads(manifest["versions"][-1]["config_text"])["title"] == title
    for call, exc, needle in [
        (lambda: shscale.run(cfg, sweep={"k": 4}, out_dir=tmp_path / "f"), ValueError, "not a list"),
        (lambda: shscale.run(cfg, sweep={"k": "4"}, out_dir=tmp_path / "f"), ValueError, "not a list"),
        (lambda: shscale.run(cfg, overrides={1: 2}, out_dir=tmp_path / "f"), TypeError, "keys"),
        (lambda: shscale.run(42, out_dir=tmp_path / "f"), TypeError, "a path, a TOML string or a dict"),
        (lambda: shscale.run({"experiment": "nosuch"}, out_dir=tmp_path / "f"), ValueError, "nosuch"),
    ]:
        with pytest.raises(exc) as e:
            call()
        assert needle in str(e.value), str(e.value)


def test_the_namespace_is_the_api():
    public = {n for n in dir(shscale) if not n.startswith("_")}
    assert public == set(shscale.__all__) - {"__version__"}, public ^ set(shscale.__all__)
    for leaked in ["np", "os", "math", "warnings", "Any", "Mapping"]:
        assert not hasattr(shscale, leaked), leaked


def test_load_results_applies_the_schema_and_names_stale_rows(tmp_path):
    """``load_results`` types the columns by ``runs.schema.json`` (``run_id`` a string, list
    parameters lists, booleans, nullable integers), puts the units in ``attrs``, and names rows of
    another numerical code as stale — a warning and ``attrs["notes"]`` — as ``shscale report``
    does."""
    import csv
    import warnings

    cfg = tmp_path / "tiny.toml"
    cfg.write_text(
        'experiment = "probe"\nmesh = "sphere"\norder = 2\nlayout = "fib:10"\nhemisphere_res = 2\n'
        'k_count = 4\nradii = [2.0, 3.0]\nparallel_runs = false\n[sweep]\nalpha_deg = [30, 60]\n'
    )
    rows, directory = shscale.run(cfg, out_dir=tmp_path / "results")
    df = shscale.load_results(directory)
    assert df["run_id"].map(type).eq(str).all()
    assert all(v == [2.0, 3.0] for v in df["radii"]), df["radii"]
    assert df["contended"].dtype == bool
    assert str(df["order"].dtype) == "Int64"
    assert df.attrs["units"]["alpha_deg"] == "degree"
    assert df.attrs["code"] == df["code"].iloc[0]
    assert not any("stale" in n for n in df.attrs["notes"]), df.attrs["notes"]
    # Every row as another numerical code wrote it: stale, said so.
    path = Path(directory) / "runs.csv"
    with open(path, newline="") as f:
        table = list(csv.reader(f))
    at = table[0].index("code")
    for r in table[1:]:
        r[at] = "0123456789abcdef"
    with open(path, "w", newline="") as f:
        csv.writer(f, lineterminator="\n").writerows(table)
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        stale = shscale.load_results(directory)
    said = [str(x.message) for x in w]
    assert any("stale: all 4 rows were computed by numerical code 0123456789abcdef" in s for s in said), said
    assert any("stale" in n for n in stale.attrs["notes"])
    # A column the schema names but the file lacks is an error naming it.
    for r in table:
        del r[at]
    with open(path, "w", newline="") as f:
        csv.writer(f, lineterminator="\n").writerows(table)
    with pytest.raises(ValueError) as e:
        shscale.load_results(directory)
    assert "code" in str(e.value) and "runs.schema.json" in str(e.value)


def test_ctrl_c_stops_a_run_between_runs_and_keeps_the_finished_ones(tmp_path):
    """SIGINT during ``shscale.run()`` raises KeyboardInterrupt within about one run's time
    (it once waited for the whole plan, then discarded the rows), the finished runs stay in
    runs.csv, stderr says the same call resumes, and that call then finishes the rest."""
    import signal
    import sys

    cfg = tmp_path / "slow.toml"
    cfg.write_text(
        'experiment = "probe"\nmesh = "bunny"\nlayout = "latlong:12x20"\nhemisphere_res = 32\n'
        "truth_res = 48\nparallel_runs = false\n[sweep]\n"
        "alpha_deg = [10.0, 20.0, 30.0, 40.0, 50.0, 60.0, 70.0, 80.0]\n"
    )
    out = tmp_path / "out"
    script = (
        "import shscale, sys\n"
        "try:\n"
        f"    shscale.run({str(cfg)!r}, out_dir={str(out)!r})\n"
        "    print('finished')\n"
        "except KeyboardInterrupt:\n"
        "    print('interrupted')\n"
    )
    child = subprocess.Popen(
        [sys.executable, "-c", script], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    csv = out / "probe" / "slow" / "runs.csv"
    t0 = time.monotonic()
    while not (csv.exists() and len(csv.read_text().splitlines()) > 1):
        assert time.monotonic() - t0 < 120, "no run finished in 120 s"
        assert child.poll() is None, child.communicate()
        time.sleep(0.02)
    child.send_signal(signal.SIGINT)
    t1 = time.monotonic()
    stdout, stderr = child.communicate(timeout=120)
    waited = time.monotonic() - t1
    print(f"stopped {waited:.2f} s after SIGINT; stderr: {stderr.strip()}")
    assert stdout.strip() == "interrupted", (stdout, stderr)
    assert "the same call resumes" in stderr, stderr
    kept = {line.split(",")[0] for line in csv.read_text().splitlines()[1:]}
    assert 1 <= len(kept) < 8, kept
    # One run takes well under 10 s here; the whole plan several times that.
    assert waited < 10, waited
    df, _ = shscale.run(str(cfg), out_dir=str(out))
    assert df["run_id"].nunique() == 8
