"""`autocable bench calibration`: the calibration's parallel stages on the executor, measured.

Two parts, each `autocable calibrate` in a subprocess on the sample model and its targets file,
into fresh folders, with a compile cache (``AUTOCABLE_CACHE``) of the bench's own that starts empty:
a real calibration meets every candidate model for the first time, so its derivation and compiled
code are part of what the bound costs; one warm-up screen point builds the model-independent
integrators before anything is timed.

* **screen scaling**: a space of `SCREEN_POINTS` (readings, beta) points, screen only (``full =
  0``), once with 1 worker and once with 2; the screen's wall time (``screen_s`` of
  calibration.json), its points per minute and the speed-up from 1 to 2 workers.
* **bound on 20 candidate models**: a space whose screen gives at least 20 candidate models
  (`BOUND_SPACE`), one of them fully evaluated (the bound needs the no-wind scenes once), the rest
  bounded against the targets file's goal; the bound stage's wall time (calibration.json) and its
  scene time (the summed ``scene_s`` of bound.csv: each scene's own recorded time).

The command line is the one both older and newer versions accept (``--jobs`` is the older name of
``--workers``), so that the same bench measures a checkout before and after a change
(``PYTHONPATH=<checkout>``).
"""
from __future__ import annotations

import csv
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Callable

__all__ = ["bench_calibration", "space_text", "SCREEN_SPACE", "BOUND_SPACE"]

def space_text(yaw_deg, twist_ends=("natural",), full: int = 0) -> str:
    """A search-space file for the sample's mirrored reading: reference axes, diameter, one air
    density, the paper's ordering, Theta0 by the sample's rule, at the given yaws."""
    return (f"twist_ends = {list(twist_ends)!r}\n"
            'load_axes = ["reference"]\nangle_convention = ["mirrored"]\nload_length = ["diameter"]\n'
            'air_density_kg_m3 = [1.25]\nordering = ["paper"]\n'
            f"yaw_deg = {[float(y) for y in yaw_deg]!r}\n"
            'rivulet_angle_deg = ["calibrate"]\n'
            f"full = {int(full)}\n").replace("'", '"')


SCREEN_POINTS = 8
SCREEN_SPACE = space_text([-10.0, -5.0, 0.0, 5.0], ("natural", "restrained"))
BOUND_SPACE = space_text([-30.0, -25.0, -20.0, -15.0, -10.0, -5.0, 0.0, 5.0, 10.0, 15.0], full=1)


def _calibrate(model: Path, targets: Path, space: Path, out: Path, workers: int, bound: bool, env: dict) -> dict:
    cmd = [sys.executable, "-m", "autocable.cli", "calibrate", str(model), str(targets), "--space", str(space),
           "--out", str(out), "--jobs", str(workers), "--quiet"] + (["--bound"] if bound else [])
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, env=env)
    wall = time.perf_counter() - t0
    try:
        stats = json.loads((out / "calibration.json").read_text())
    except (OSError, ValueError):
        stats = {}
    return {"exit_status": proc.returncode, "wall_s": wall, "stats": stats,
            "stderr_tail": proc.stderr.strip().splitlines()[-5:]}


def bench_calibration(model_path: str, log: Callable[[str], None] | None = None, out=None) -> dict:
    """The screen's scaling from 1 to 2 workers and the bound stage on 20 candidate models
    (module docstring); the calibrations run in a temporary folder (``out`` is unused: the
    command writes the JSON there)."""
    say = log or (lambda s: None)
    model = Path(model_path).resolve()
    targets = model.with_suffix("").with_suffix(".targets.toml")
    result = {"what": "autocable calibrate: screen scaling and the bound stage", "cpu_count": os.cpu_count(),
              "load_average_before": os.getloadavg()[0]}
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        env = dict(os.environ, AUTOCABLE_CACHE=str(root / "cache"))
        (root / "screen.search.toml").write_text(SCREEN_SPACE)
        (root / "bound.search.toml").write_text(BOUND_SPACE)
        # one warm-up screen point, so that neither timed pass builds the integrators
        warm = root / "warm.search.toml"
        warm.write_text(space_text([20.0]))
        _calibrate(model, targets, warm, root / "warm", 1, False, env)
        screen = {}
        for n in (1, 2):
            say(f"screen of {SCREEN_POINTS} points on {n} worker(s) ...")
            r = _calibrate(model, targets, root / "screen.search.toml", root / f"screen_{n}", n, False, env)
            s = r["stats"]
            screen[n] = {"exit_status": r["exit_status"], "wall_s": r["wall_s"], "screen_s": s.get("screen_s"),
                         "points": s.get("computed"),
                         "points_per_min": (60 * s["computed"] / s["screen_s"]) if s.get("screen_s") else None}
            say(f"  screen {s.get('screen_s', float('nan')):.1f} s, command {r['wall_s']:.1f} s")
        speedup = (screen[1]["screen_s"] / screen[2]["screen_s"]
                   if screen[1]["screen_s"] and screen[2]["screen_s"] else None)
        result["screen"] = {"points": SCREEN_POINTS, "by_workers": screen, "speedup_1_to_2": speedup}
        say("bound stage on the candidate models of a 10-point space, 2 workers ...")
        r = _calibrate(model, targets, root / "bound.search.toml", root / "bound", 2, True, env)
        b = (r["stats"] or {}).get("bound") or {}
        rows = []
        try:
            with open(root / "bound" / "bound.csv", newline="") as fh:
                rows = [x for x in csv.DictReader(fh) if x.get("status") != "fully evaluated"]
        except OSError:
            pass
        scene_s = sum(float(x.get("scene_s") or 0.0) for x in rows)
        result["bound"] = {"exit_status": r["exit_status"], "command_wall_s": r["wall_s"],
                           "models": b.get("models"), "bounded_here": len(rows), "wall_s": b.get("wall_s"),
                           "scene_s": scene_s, "scenes": sum(len((x.get("scenes_run") or "").split()) for x in rows),
                           "by_status": b.get("by_status"), "highest_bound": b.get("highest_bound"),
                           "stderr_tail": r["stderr_tail"]}
        say(f"  {len(rows)} models bounded: stage {b.get('wall_s') or float('nan'):.1f} s wall, scene time {scene_s:.1f} s")
    return result
