#!/usr/bin/env python3
"""The real-time issue's GPU targets against what `scripts/device-check` measured.

Usage: scripts/device-targets.py OUT   (the folder device-check wrote: table1.json, methods.json)

Prints Markdown: per Table 1 scene the papers' method's best GPU path against 1,000 FPS and
against the same machine's CPU frame (≥ 5×), and each sphere-set row's best GPU path against
5,000 FPS. Every figure is read from the JSON; nothing is assumed. Exit 2 naming the file (and
the row and key) when one is missing, not a regular file, or holds a row that is not
device-check's; text from the rows is escaped for its Markdown cell.
"""
import json
import math
import os
import stat
import sys
from pathlib import Path

PAPERS_FPS, SETS_FPS, GPU_OVER_CPU = 1000.0, 5000.0, 5.0


def fail(message):
    print(f"device-targets: {message}", file=sys.stderr)
    sys.exit(2)


def is_number(x):
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


def load(path):
    """The rows of one of device-check's JSON files, each checked: a regular file (a FIFO would
    block the read forever), a list of objects whose `scene`, `path` and `device` are non-empty
    strings, `fps` and `frame_ms` finite numbers > 0, `method` (where present) a string and
    `error_mean` a number or null. Anything else exits 2 naming the file, the row and the key."""
    try:
        st = os.stat(path)
    except OSError as e:
        fail(f"{path}: {e.strerror}")
    if not stat.S_ISREG(st.st_mode):
        fail(f"{path}: not a regular file (a FIFO, a device or a folder); nothing read")
    try:
        rows = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as e:
        fail(f"{path}: {e}")
    if not isinstance(rows, list):
        fail(f"{path}: not a list of bench rows (scene, path, device, fps, frame_ms)")
    for i, r in enumerate(rows):
        where = f"{path}: row {i}"
        if not isinstance(r, dict):
            fail(f"{where}: not an object")
        for k in ("scene", "path", "device"):
            if not isinstance(r.get(k), str) or not r[k]:
                fail(f"{where}: {k!r} is {r.get(k)!r}, not a non-empty string")
        for k in ("fps", "frame_ms"):
            if not is_number(r.get(k)) or r[k] <= 0:
                fail(f"{where}: {k!r} is {r.get(k)!r}, not a finite number > 0")
        if "method" in r and not isinstance(r["method"], str):
            fail(f"{where}: 'method' is {r['method']!r}, not a string")
        if r.get("error_mean") is not None and not is_number(r["error_mean"]):
            fail(f"{where}: 'error_mean' is {r['error_mean']!r}, not a number or null")
    return rows


def cell(text):
    """Text from the rows as one Markdown table cell: `|` escaped, `<`, `>` and `&` as
    entities, line breaks as spaces — a scene named `x | <script>` stays text in its cell."""
    t = str(text).replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")
    return t.replace("|", "\\|").replace("\r", " ").replace("\n", " ")


def verdict(ok):
    return "met" if ok else "**not met**"


def main():
    if len(sys.argv) != 2:
        fail("usage: scripts/device-targets.py OUT (the folder scripts/device-check wrote)")
    out = Path(sys.argv[1])
    table1 = load(out / "table1.json")
    methods = load(out / "methods.json")
    devices = sorted({r["device"] for r in table1 if r["path"] != "cpu"})
    print(f"GPU: {cell(', '.join(devices)) or 'none (no GPU rows)'}\n")
    print("| scene | best GPU path | GPU FPS | ≥ 1,000 FPS | CPU frame (ms) | GPU frame (ms) | GPU / CPU speed | ≥ 5× |")
    print("|---|---|---:|---|---:|---:|---:|---|")
    for scene in sorted({r["scene"] for r in table1}):
        rows = [r for r in table1 if r["scene"] == scene]
        cpu = [r for r in rows if r["path"] == "cpu"]
        gpu = [r for r in rows if r["path"] != "cpu"]
        if not gpu:
            print(f"| {cell(scene)} | — | — | no GPU row | — | — | — | — |")
            continue
        best = min(gpu, key=lambda r: r["frame_ms"])
        if cpu:
            speed = cpu[0]["frame_ms"] / best["frame_ms"]
            c = f"{cpu[0]['frame_ms']:.3f} | {best['frame_ms']:.3f} | {speed:.2f}× | {verdict(speed >= GPU_OVER_CPU)}"
        else:
            c = f"— | {best['frame_ms']:.3f} | — | no CPU row"
        print(f"| {cell(scene)} | {cell(best['path'])} | {best['fps']:.0f} | {verdict(best['fps'] >= PAPERS_FPS)} | {c} |")
    print("\n| scene | sphere set | best GPU path | GPU FPS | ≥ 5,000 FPS | error vs band-limited truth |")
    print("|---|---|---|---:|---|---:|")
    for r in methods:
        if not str(r.get("method", "")).startswith("sphere_set") or not r["path"].startswith("gpu"):
            continue
        same = [x for x in methods if x["scene"] == r["scene"] and x.get("method") == r["method"] and x["path"].startswith("gpu")]
        if r is not min(same, key=lambda x: x["frame_ms"]):
            continue
        err = r.get("error_mean")
        err = "—" if err is None else f"{err:.4f}"
        print(f"| {cell(r['scene'])} | {cell(r['method'])} | {cell(r['path'])} | {r['fps']:.0f} | {verdict(r['fps'] >= SETS_FPS)} | {err} |")


if __name__ == "__main__":
    main()
