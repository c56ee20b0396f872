"""Benchmark of the continuation: per-point EP-C cost on the sample AME and the total time of a
Fig. 6-sized scene, warm and cold (`bench_continuation`, run by ``autocable bench``), for the
PyCont engine and the compiled one (`time_compiled`)."""
from __future__ import annotations

import math
import time

from autocable.methods.continuation.problem import ContinuationSettings, EquilibriumProblem, Progress
from autocable.methods.continuation.equilibria import continue_equilibria, switch_branch
from autocable.methods.continuation.system import auto_state_scale as _auto_scale, ame_system


def bench_continuation(model: str = "models/luongo_zulli_2012.toml", *, repeats: int = 3,
                       cold: bool = True, progress: Progress | None = None) -> dict:
    """Per-point EP-C cost on the sample AME and the total time of a Fig. 6-sized scene.

    Warm: in this process, after one untimed run (builds loaded). Cold (``cold=True``): the same
    scene in a fresh process with an empty cache folder (derivation, AME, both compiled libraries
    built from scratch). Returns plain numbers (seconds)."""
    import os
    import subprocess
    import sys
    import tempfile

    from autocable.model.ame_cache import derive_ame
    from autocable.model.derive import derive

    def say(msg):
        if progress:
            progress(msg)

    t0 = time.perf_counter()
    ame = derive_ame(derive(model)).ame
    system = ame_system(ame, "2dof", wind=False)
    t_model = time.perf_counter() - t0
    problem = EquilibriumProblem(system, "sigma", {"sigma": -0.05, "U": 0.0, "eta": 1.4e-3},
                                 (-0.05, 0.05), state_scale=_auto_scale(system, {"sigma": 0.0, "U": 0.0, "eta": 1.4e-3}))
    settings = ContinuationSettings()
    say("bench: EP-C on the sample AME (warm-up)")
    continue_equilibria(problem, settings, name="I", directions="forward")
    per_point, totals = [], []
    for _ in range(repeats):
        r = continue_equilibria(problem, settings, name="I", directions="forward")
        per_point.append(r.timings["pycont_s"] / max(r.timings["points"] - 1, 1))
        analysis = r.timings["analysis_s"] / max(r.timings["points"], 1)
    for _ in range(max(1, repeats - 1)):
        t = time.perf_counter()
        r = continue_equilibria(problem, settings, name="I")
        for bp in r.branch.of_type("BP"):
            switch_branch(r, bp.label)
        totals.append(time.perf_counter() - t)
    say("bench: the same with the compiled engine")
    comp = time_compiled(problem, settings, repeats=max(10, repeats))
    totals_c = []
    for _ in range(max(3, repeats)):
        t = time.perf_counter()
        rc = continue_equilibria(problem, settings, name="I", engine="compiled")
        for bp in rc.branch.of_type("BP"):
            switch_branch(rc, bp.label, engine="compiled")
        totals_c.append(time.perf_counter() - t)
    out = {"compiled_seconds_per_point": comp["seconds_per_point"],
           "compiled_cpu_seconds_per_point": comp["cpu_seconds_per_point"],
           "compiled_kernel_seconds_per_point": comp["kernel_seconds_per_point"],
           "compiled_points": comp["points"], "fig6_scene_warm_compiled_s": min(totals_c),
           "ep_c_seconds_per_point": min(per_point), "analysis_seconds_per_point": analysis,
           "setup_seconds_per_branch": r.timings.get("setup_s"),
           "points": int(r.timings["points"]), "fig6_scene_warm_s": min(totals),
           "model_and_ame_s": t_model, "branch_points": len(r.branch.of_type("BP"))}
    if cold:
        say("bench: Fig. 6-sized scene, cold cache (fresh process, builds from scratch)")
        code = ("import time,sys; t=time.perf_counter();"
                "from autocable.bench.continuation import _bench_scene;"
                f"_bench_scene({model!r}); print(time.perf_counter()-t)")
        with tempfile.TemporaryDirectory(prefix="autocable-bench-") as tmp:
            env = {**os.environ, "AUTOCABLE_CACHE": tmp}
            t = time.perf_counter()
            done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
            out["fig6_scene_cold_s"] = time.perf_counter() - t if done.returncode == 0 else math.nan
            if done.returncode != 0:
                out["cold_error"] = done.stderr.strip().splitlines()[-1:] or ["failed"]
    return out


def _bench_scene(model: str) -> None:
    from autocable.model.ame_cache import derive_ame
    from autocable.model.derive import derive

    ame = derive_ame(derive(model)).ame
    system = ame_system(ame, "2dof", wind=False)
    vals = {"sigma": -0.05, "U": 0.0, "eta": 1.4e-3}
    problem = EquilibriumProblem(system, "sigma", vals, (-0.05, 0.05),
                                 state_scale=_auto_scale(system, {**vals, "sigma": 0.0}))
    r = continue_equilibria(problem, ContinuationSettings(), name="I")
    for bp in r.branch.of_type("BP"):
        switch_branch(r, bp.label)


def time_compiled(problem: EquilibriumProblem, settings: ContinuationSettings, start=None, *,
                  repeats: int = 20, directions: str = "forward") -> dict:
    """Cost of `continue_equilibria(..., engine="compiled")` per point: the whole call (Newton at
    the start, the C loop with its test functions and Routh counts, numpy's eigenvalues of every
    point, location of the special points by `_locate`, l1 at Hopf points, the `Branch` record),
    best of ``repeats`` after a warm-up (which loads or builds the kernel), over the steps
    (points - 1, as AUTO's per-point cost is over its steps). Wall (perf_counter) and CPU
    (process_time) seconds; the C loop's share (``kernel_s``) beside them. Returns plain numbers
    and the best run's result."""
    def run():
        return continue_equilibria(problem, settings, start, name="I", directions=directions,
                                   engine="compiled")

    run()
    walls, cpus, best = [], [], None
    for _ in range(max(1, int(repeats))):
        w, c = time.perf_counter(), time.process_time()
        r = run()
        walls.append(time.perf_counter() - w)
        cpus.append(time.process_time() - c)
        if best is None or walls[-1] <= min(walls):
            best = r
    steps = max(int(best.timings["points"]) - 1, 1)
    return {"points": int(best.timings["points"]), "seconds_per_point": min(walls) / steps,
            "cpu_seconds_per_point": min(cpus) / steps,
            "median_seconds_per_point": float(sorted(walls)[len(walls) // 2]) / steps,
            "kernel_seconds_per_point": best.timings["kernel_s"] / steps,
            "analysis_seconds_per_point": best.timings["analysis_s"] / steps,
            "setup_seconds": best.timings["setup_s"], "repeats": len(walls), "result": best}
