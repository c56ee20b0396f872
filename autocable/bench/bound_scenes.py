"""``autocable bench bound-scenes``: the scene time of one candidate in the calibration's bound stage.

The bound stage (`autocable.paper.bound`) runs a candidate's wind scenes (`bound.ORDER`) without
their figures, as executor tasks that each run the scene in a child forked from a warmed worker
(`autocable.paper.figures.scene_task`), with the runs and tables that decide no statement able to
lower a bound dropped from the scene copies: the orbit-started runs (`bound.orbit_runs`), the
eq. (21) overlay of a scene whose ``boxes`` statement is never used to prune
(`bound.NOT_USED_TO_PRUNE`: Fig. 3's) and Fig. 11's eq. (21) series (`bound.IF_NO_ODE21`: autocable's
own checks), as on the sample's targets file; the other overlays are deferred (`bound.DEFERRED`) and
run only for a candidate its branches do not stop, so the scenes' first runs, measured here, have
none. This bench does the same
for one model (the sample by default), one scene at a time from this process: per scene the wall
time, the child's CPU time (less sensitive to other load on a shared machine than wall time) and
the scene's own stages (run.json); the sum of the scenes' ``total_s`` is what the stage reports as
its scene time (`bound.scene_seconds`).
"""
from __future__ import annotations

import json
import os
import resource
import tempfile
import time
from pathlib import Path


def _cpu_children() -> float:
    ru = resource.getrusage(resource.RUSAGE_CHILDREN)
    return ru.ru_utime + ru.ru_stime


def _warm() -> None:
    """What a scene imports, loaded here once: the forked scenes start with it (the stage's workers
    are warmed the same way)."""
    import autocable.methods.continuation  # noqa: F401
    import autocable.methods.integration.ode21  # noqa: F401
    import autocable.model.ame_cache  # noqa: F401
    import autocable.model.derive  # noqa: F401
    import autocable.scene.runner  # noqa: F401
    import autocable.studies.advise  # noqa: F401
    from autocable.codegen.compat import import_pydstool
    import_pydstool()


def bench_bound_scenes(model_path: str, log=None, runs: str | None = None) -> dict:
    """Run the bound stage's scenes of ``model_path`` as the stage runs them (module docstring);
    returns the per-scene and summed wall, CPU and scene seconds, with what was dropped."""
    from autocable.paper import bound
    from autocable.paper.figures import default_runs_dir, scene_task
    from autocable.paper.report import stage_seconds

    say = log or (lambda s: None)
    runs_dir = Path(runs) if runs else default_runs_dir()
    model = Path(model_path).resolve()
    _warm()
    scenes, dropped = {}, []
    load = os.getloadavg()[0]
    t_all = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        (tmp / "runs").mkdir()
        for name in bound.ORDER:
            dst = tmp / "runs" / f"{name}.toml"
            # every overlay off: Fig. 3's is never run, the others are deferred until their boxes
            # can change the outcome, which most candidates never reach; Fig. 11's eq. (21) series
            # decides only autocable's own checks
            dropped += bound.scene_copy(runs_dir / f"{name}.toml", dst, model, drop_orbits=True,
                                        drop_overlay=True, drop_ode21=True)
            out = tmp / "out" / name
            cpu0 = _cpu_children()
            status, error, _, wall = scene_task(str(dst), str(out), None, None, False)
            cpu = _cpu_children() - cpu0
            try:
                stages = stage_seconds(json.loads((out / "run.json").read_text()).get("provenance", {})
                                       .get("stages") or {})
            except (OSError, ValueError):
                stages = {}
            scenes[name] = {"status": status, "error": error, "wall_s": wall, "cpu_s": cpu, **stages}
            say(f"{name}: {wall:.2f} s wall, {cpu:.2f} s CPU ({status})")
        scene_s = bound.scene_seconds(tmp / "out", bound.ORDER)
    totals = {k: sum(s.get(k, 0.0) for s in scenes.values())
              for k in ("wall_s", "cpu_s", "derive", "build", "continue", "integrate", "write", "other", "total")}
    return {"what": "the bound stage's wind scenes of one candidate, first runs (no figures; orbit-started "
                    "runs, the overlays and Fig. 11's eq. (21) series dropped, as for the sample's targets)",
            "model": str(model), "scenes": list(bound.ORDER), "dropped": dropped,
            "blas_threads": {v: os.environ.get(v) for v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS")},
            "load_average_before": load, "wall_s": time.perf_counter() - t_all,
            "scene_seconds": scene_s, "summed": totals, "per_scene": scenes}
