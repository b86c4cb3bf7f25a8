#!/usr/bin/env python3
"""The real-time issue's GPU targets against what `scripts/device-check` measured.

Usage: scripts/device-targets.py OUT   (the folder device-check wrote: table1.json, methods.json)

Prints Markdown: per Table 1 scene the papers' method's best GPU path against 1,000 FPS and
against the same machine's CPU frame (≥ 5×), and each sphere-set row's best GPU path against
5,000 FPS. Every figure is read from the JSON; nothing is assumed. Exit 2 naming the file when
one is missing or not device-check's.
"""
import json
import sys
from pathlib import Path

PAPERS_FPS, SETS_FPS, GPU_OVER_CPU = 1000.0, 5000.0, 5.0


def fail(message):
    print(f"device-targets: {message}", file=sys.stderr)
    sys.exit(2)


def load(path):
    try:
        rows = json.loads(path.read_text())
    except (OSError, ValueError) as e:
        fail(f"{path}: {e}")
    keys = ("scene", "path", "fps", "frame_ms")
    if not isinstance(rows, list) or not all(
        isinstance(r, dict) and all(k in r for k in keys) for r in rows
    ):
        fail(f"{path}: not a list of bench rows (scene, path, fps, frame_ms)")
    return rows


def verdict(ok):
    return "met" if ok else "**not met**"


def main():
    if len(sys.argv) != 2:
        fail("usage: scripts/device-targets.py OUT (the folder scripts/device-check wrote)")
    out = Path(sys.argv[1])
    table1 = load(out / "table1.json")
    methods = load(out / "methods.json")
    devices = sorted({r["device"] for r in table1 if r["path"] != "cpu"})
    print(f"GPU: {', '.join(devices) or 'none (no GPU rows)'}\n")
    print("| scene | best GPU path | GPU FPS | ≥ 1,000 FPS | CPU frame (ms) | GPU frame (ms) | GPU / CPU speed | ≥ 5× |")
    print("|---|---|---:|---|---:|---:|---:|---|")
    for scene in sorted({r["scene"] for r in table1}):
        rows = [r for r in table1 if r["scene"] == scene]
        cpu = [r for r in rows if r["path"] == "cpu"]
        gpu = [r for r in rows if r["path"] != "cpu"]
        if not gpu:
            print(f"| {scene} | — | — | no GPU row | — | — | — | — |")
            continue
        best = min(gpu, key=lambda r: r["frame_ms"])
        if cpu:
            speed = cpu[0]["frame_ms"] / best["frame_ms"]
            c = f"{cpu[0]['frame_ms']:.3f} | {best['frame_ms']:.3f} | {speed:.2f}× | {verdict(speed >= GPU_OVER_CPU)}"
        else:
            c = f"— | {best['frame_ms']:.3f} | — | no CPU row"
        print(f"| {scene} | {best['path']} | {best['fps']:.0f} | {verdict(best['fps'] >= PAPERS_FPS)} | {c} |")
    print("\n| scene | sphere set | best GPU path | GPU FPS | ≥ 5,000 FPS | error vs band-limited truth |")
    print("|---|---|---|---:|---|---:|")
    for r in methods:
        if not str(r.get("method", "")).startswith("sphere_set") or not r["path"].startswith("gpu"):
            continue
        same = [x for x in methods if x["scene"] == r["scene"] and x["method"] == r["method"] and x["path"].startswith("gpu")]
        if r is not min(same, key=lambda x: x["frame_ms"]):
            continue
        err = r.get("error_mean")
        err = "—" if err is None else f"{err:.4f}"
        print(f"| {r['scene']} | {r['method']} | {r['path']} | {r['fps']:.0f} | {verdict(r['fps'] >= SETS_FPS)} | {err} |")


if __name__ == "__main__":
    main()
