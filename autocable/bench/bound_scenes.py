"""``autocable bench bound-scenes``: the scene time of one candidate in the calibration's bound stage.

The bound stage (`autocable.paper.bound`) runs a candidate's wind scenes (`bound.ORDER`) one at a
time without their figures, its orbit-started runs dropped (`bound.orbit_runs`: they decide no
statement that lowers a bound), each scene in its own process forked from a parent that preloaded
the imports. This bench does the same for one model (the sample by default): it copies the scene
files with the model's path, drops those runs, runs each scene in a forked child and records per
scene the wall time, the child's CPU time (less sensitive to other load on a shared machine than
wall time) and the scene's own stages (run.json). The sum of the scenes' ``total_s`` is what the
bound stage reports as its scene time (`bound.scene_seconds`).
"""
from __future__ import annotations

import json
import multiprocessing
import os
import resource
import tempfile
import time
from pathlib import Path


def _child(scene_path: str, out: str) -> None:
    from autocable.scene.runner import load_scene, run_scene
    from autocable.studies.advise import choose_ame
    run_scene(load_scene(scene_path), out, plot=False, choose_ame=choose_ame)


def _cpu_children() -> float:
    ru = resource.getrusage(resource.RUSAGE_CHILDREN)
    return ru.ru_utime + ru.ru_stime


def bench_bound_scenes(model_path: str, log=None, runs: str | None = None) -> dict:
    """Run the bound stage's scenes of ``model_path`` as the stage runs them (module docstring);
    returns the per-scene and summed wall, CPU and scene seconds, with the dropped runs."""
    from autocable.paper import bound
    from autocable.paper.candidates import _drop_run
    from autocable.paper.figures import _preload, default_runs_dir
    from autocable.paper.report import stage_seconds

    say = log or (lambda s: None)
    runs_dir = Path(runs) if runs else default_runs_dir()
    model = Path(model_path).resolve()
    fork = "fork" in multiprocessing.get_all_start_methods()
    ctx = multiprocessing.get_context("fork" if fork else "spawn")
    if fork:
        _preload()
    scenes, dropped = {}, []
    load = os.getloadavg()[0]
    t_all = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        (tmp / "runs").mkdir()
        for name in bound.ORDER:
            src = runs_dir / f"{name}.toml"
            dst = tmp / "runs" / f"{name}.toml"
            text = src.read_text()
            dst.write_text(text.replace('model = "../models/luongo_zulli_2012.toml"', f'model = "{model}"'))
            for k in reversed(bound.orbit_runs(dst)):
                if _drop_run(dst, k):
                    dropped.append(f"{name}: run[{k}]")
            out = tmp / "out" / name
            cpu0, t0 = _cpu_children(), time.perf_counter()
            proc = ctx.Process(target=_child, args=(str(dst), str(out)))
            proc.start()
            proc.join()
            wall, cpu = time.perf_counter() - t0, _cpu_children() - cpu0
            try:
                run = json.loads((out / "run.json").read_text())
                stages = stage_seconds(run.get("provenance", {}).get("stages") or {})
                status = run.get("status", "?")
            except (OSError, ValueError):
                stages, status = {}, "failed"
            scenes[name] = {"status": status if proc.exitcode == 0 else f"exit {proc.exitcode}",
                            "wall_s": wall, "cpu_s": cpu, **stages}
            say(f"{name}: {wall:.2f} s wall, {cpu:.2f} s CPU ({status})")
        scene_s = bound.scene_seconds(tmp / "out", bound.ORDER)
    totals = {k: sum(s.get(k, 0.0) for s in scenes.values())
              for k in ("wall_s", "cpu_s", "derive", "build", "continue", "integrate", "write", "other", "total")}
    return {"what": "the bound stage's wind scenes of one candidate (plot=False, orbit-started runs dropped)",
            "model": str(model), "scenes": list(bound.ORDER), "dropped_runs": dropped,
            "load_average_before": load, "wall_s": time.perf_counter() - t_all,
            "scene_seconds": scene_s, "summed": totals, "per_scene": scenes}
