"""`autocable bench shooting` and `autocable bench sweep`: speed targets, measured here.

``shooting``: the steady response of eq. (21) by shooting (`methods.integration.shooting`) against
transient integration to the steady state (`Ode21Integrator.simulate`, the compiled DOP853, the
brute-force reference of the ladder) at the (U*, eta*) of Figs. 5-10 and 11 detunings each. Both
are timed per point (best of ``repeats`` after a warm-up) and checked against a tighter transient
reference (rtol 1e-12, steady to 1e-11): the speed-up is quoted at the accuracy both reach, with
each one's largest error. Target: shooting at least 20x faster per point (the median over the
points; the total time is reported too, and is set by the few modulated and diverging points that
both methods must integrate).

``sweep``: the throughput of `autocable sweep` (points per second of the task phase, after the
workers have loaded the model) with 1 and 2 LocalCluster workers, and the scaling 2 workers / 1
worker (target >= 1.7 on 2 cores), on a (U, eta, sigma) grid that mixes cheap and slow points.
Both record the machine's load average: on a shared machine the scaling says more about the other
jobs than about Dask.
"""
from __future__ import annotations

import contextlib
import gc
import math
import os
import tempfile
import time
from pathlib import Path

import numpy as np

#: (U*, eta*) of the bench: Figs. 5a, 5b, 6 (no wind) and 7-10 (wind), as `bench ame-vs-ode`.
CASES = ((0.0, 8.2e-5), (0.0, 4.1e-4), (0.0, 1.4e-3), (0.7, 4.1e-4), (1.3, 4.1e-4), (0.7, 1.4e-3),
         (1.3, 1.4e-3))
SIGMAS = tuple(np.round(np.linspace(-0.05, 0.05, 11), 12))


def _rel(a, b) -> float:
    if not (math.isfinite(a) and math.isfinite(b)):
        return 0.0 if (math.isfinite(a) == math.isfinite(b)) else math.inf
    return abs(a - b)


@contextlib.contextmanager
def _no_gc():
    """The garbage collector off while a block is timed, as `timeit` does: its passes fall at the
    same allocation counts in every repeat, so best-of-n would not filter them out, and a 3 ms
    pass charged to a 1 ms point says nothing about the method."""
    gc.collect()
    gc.disable()
    try:
        yield
    finally:
        gc.enable()


def bench_shooting(model_path: str, repeats: int = 3, log=None) -> dict:
    from autocable.methods.integration.ode21 import Ode21Integrator
    from autocable.methods.integration.shooting import ShootingSolver
    from autocable.model.derive import derive
    from autocable.spec import load_model

    say = log or (lambda s: None)
    d = derive(load_model(model_path))
    solver = ShootingSolver(d.ode)
    transient = Ode21Integrator(d.ode, engine="compiled")
    reference = Ode21Integrator(d.ode, engine="compiled", rtol=1e-12, atol=1e-15)
    solver.steady(0.0, 8.2e-5, 0.0)          # warm-up: builds/loads the compiled integrators
    transient.simulate(0.0, 8.2e-5, 0.0)
    rows, tot_s, tot_t = [], 0.0, 0.0
    for U, eta in CASES:
        # Each method runs a case's detunings as a block, the blocks alternating (shooting,
        # transient, shooting, ...) so that a change of the machine's load falls on both alike.
        # Timing point by point, each method right after the other, made each pay for the caches
        # the other had just filled (about 20 % for shooting, a sweep of one method does not).
        ts = {float(sg): [] for sg in SIGMAS}
        tt = {float(sg): [] for sg in SIGMAS}
        shot, trans = {}, {}
        for _ in range(max(repeats, 1)):
            with _no_gc():
                for sigma in ts:
                    t0 = time.perf_counter()
                    shot[sigma] = solver.steady(U, eta, sigma)
                    ts[sigma].append(time.perf_counter() - t0)
            with _no_gc():
                for sigma in tt:
                    t0 = time.perf_counter()
                    trans[sigma] = transient.simulate(U, eta, sigma)
                    tt[sigma].append(time.perf_counter() - t0)
        for sigma in ts:
            r, q = shot[sigma], trans[sigma]
            ref = reference.simulate(U, eta, sigma, steady_tol=1e-11)
            size = max(ref.a1, ref.a2) if math.isfinite(ref.a1) else 1.0
            ok_ref = ref.steady and ref.periodic
            err_s = max(_rel(r.a1, ref.a1), _rel(r.a2, ref.a2)) / size if ok_ref else None
            err_t = max(_rel(q.a1, ref.a1), _rel(q.a2, ref.a2)) / size if ok_ref else None
            row = {"U": U, "eta": eta, "sigma": sigma, "response": r.response,
                   "transient_periodic": bool(q.periodic), "transient_diverged": not math.isfinite(q.a1),
                   "shooting_ms": 1e3 * min(ts[sigma]), "transient_ms": 1e3 * min(tt[sigma]),
                   "speedup": min(tt[sigma]) / min(ts[sigma]), "shooting_rel_error": err_s,
                   "transient_rel_error": err_t, "fallback": r.fallback,
                   "transient_periods_before_shooting": r.transient_periods}
            rows.append(row)
            tot_s += min(ts[sigma])
            tot_t += min(tt[sigma])
            say(f"U={U:g} eta={eta:g} sigma={sigma:+.3f}: {r.response:14s} shooting {row['shooting_ms']:7.2f} ms, "
                f"transient {row['transient_ms']:7.2f} ms ({row['speedup']:.1f}x); errors "
                f"{err_s if err_s is None else f'{err_s:.1e}'} / {err_t if err_t is None else f'{err_t:.1e}'}")
    per_case = []
    for U, eta in CASES:
        sub = [r for r in rows if r["U"] == U and r["eta"] == eta]
        s_ms = sum(r["shooting_ms"] for r in sub)
        t_ms = sum(r["transient_ms"] for r in sub)
        per_case.append({"U": U, "eta": eta, "shooting_ms_per_point": s_ms / len(sub),
                         "transient_ms_per_point": t_ms / len(sub), "speedup": t_ms / s_ms,
                         "responses": sorted({r["response"] for r in sub})})
    neighbour = _neighbour_sweeps(model_path, repeats, say)
    errs_s = [r["shooting_rel_error"] for r in rows if r["shooting_rel_error"] is not None]
    errs_t = [r["transient_rel_error"] for r in rows if r["transient_rel_error"] is not None]
    periodic = [r for r in rows if r["shooting_rel_error"] is not None]
    return {"benchmark": "shooting", "points": len(rows), "repeats": repeats,
            "load_average_1min_at_end": os.getloadavg()[0], "cpus": os.cpu_count(),
            "shooting_total_s": tot_s, "transient_total_s": tot_t, "speedup_total": tot_t / tot_s,
            "speedup_period1_points": (sum(r["transient_ms"] for r in periodic)
                                       / max(sum(r["shooting_ms"] for r in periodic), 1e-12)),
            "speedup_median": float(np.median([r["speedup"] for r in rows])),
            "max_rel_error_shooting": max(errs_s, default=None),
            "max_rel_error_transient": max(errs_t, default=None),
            "accuracy_note": "errors of a1, a2 relative to max(a1, a2) against transient integration at "
                             "rtol 1e-12, steady to 1e-11, on the points where that reference is period-1",
            "class_mismatches": [r for r in rows if (r["response"] == "diverged") != r["transient_diverged"]],
            "speedup_median_period1_points": float(np.median([r["speedup"] for r in periodic] or [math.nan])),
            "target": "speedup_median >= 20 (per point, at equal or better accuracy); speedup_total is "
                      "dominated by the modulated and diverging points, where both integrate",
            "per_case": per_case,
            "neighbour_sweeps": neighbour,
            "neighbour_speedup_total": (sum(c["transient_s"] for c in neighbour)
                                        / sum(c["shooting_s"] for c in neighbour)),
            "rows": rows}


def _neighbour_sweeps(model_path: str, repeats: int, say) -> list:
    """Each case swept up in sigma, every point started from its neighbour's response: shooting
    (Newton from the neighbour's orbit, `sweep` with ``follow``) against the transient sweep of
    the overlays (`methods.integration.sweeps`, integration from the neighbour's end state); the
    same responses (largest difference reported) and the time of each (best of ``repeats``)."""
    from autocable.methods.integration.ode21 import DEFAULT_Q0, Ode21Integrator
    from autocable.methods.integration.sweeps import sweep
    from autocable.spec import load_model
    from autocable.studies.sweep import model_context, carry_from, compute_point
    model = load_model(model_path)
    model_context(model, "shooting")
    transient = Ode21Integrator(model_context(model, "shooting")[0].ode, engine="compiled")
    out = []
    for U, eta in CASES:
        best_s = best_t = math.inf
        for _ in range(max(repeats, 1)):
            t0 = time.perf_counter()
            recs, carried = [], None
            for sigma in SIGMAS:
                rec = compute_point(model, "shooting", U, eta, float(sigma), DEFAULT_Q0, 60000.0, carried)
                recs.append(rec)
                carried = carry_from(rec)
            best_s = min(best_s, time.perf_counter() - t0)
            t0 = time.perf_counter()
            ref = sweep(transient, "sigma", [float(v) for v in SIGMAS], {"U": U, "eta": eta}, directions=("up",))
            best_t = min(best_t, time.perf_counter() - t0)
        diffs = []
        for rec, p in zip(recs, ref):
            if rec["a1"] is not None and math.isfinite(p.a1) and p.periodic:
                diffs.append(max(abs(rec["a1"] - p.a1), abs(rec["a2"] - p.a2)) / max(p.a1, p.a2))
        row = {"U": U, "eta": eta, "shooting_s": best_s, "transient_s": best_t, "speedup": best_t / best_s,
               "max_rel_difference_period1": max(diffs, default=None), "compared_points": len(diffs),
               "responses": sorted({r["response"] for r in recs})}
        out.append(row)
        say(f"neighbour sweep U={U:g} eta={eta:g}: shooting {1e3 * best_s / len(SIGMAS):.2f} ms/point, "
            f"transient {1e3 * best_t / len(SIGMAS):.2f} ms/point ({row['speedup']:.1f}x), max difference "
            f"{row['max_rel_difference_period1']}")
    return out


SWEEP_BENCH = """
title = "bench sweep"
model = "{model}"
method = "shooting"
[grid]
U = [0.0, 0.7]
eta = [8.2e-5, 4.1e-4, 1.4e-3]
sigma = {{ from = -0.05, to = 0.05, num = {num} }}
"""


def bench_sweep(model_path: str, repeats: int = 3, log=None, num: int = 61) -> dict:
    from autocable.scene.sweep_schema import load_sweep
    from autocable.studies.sweep import run_sweep

    say = log or (lambda s: None)
    out = {"benchmark": "sweep", "grid": "U in {0, 0.7} x eta in {8.2e-5, 4.1e-4, 1.4e-3} x "
                                         f"{num} sigma in [-0.05, 0.05], method shooting", "runs": []}
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "bench.toml"
        path.write_text(SWEEP_BENCH.format(model=Path(model_path).resolve(), num=num))
        spec = load_sweep(path)
        out["points"] = spec.size
        rates = {}
        out["load_average_1min_at_start"] = os.getloadavg()[0]
        out["cpus"] = os.cpu_count()
        for k in range(max(repeats, 1)):
            # interleaved (serial, 1, 2, serial, 1, 2, ...) so that a change of the machine's load
            # during the bench affects every setting alike; the best of the repeats counts
            for workers in (0, 1, 2):
                t0 = time.perf_counter()
                summary = run_sweep(spec, Path(tmp) / f"w{workers}-{k}", workers=workers)
                wall = time.perf_counter() - t0
                where = summary["where"]
                rate = where["compute_points_per_second"]
                run = {"workers": workers if workers else "serial (no Dask)", "wall_seconds": wall,
                       "startup_seconds": where["startup_seconds"], "compute_seconds": where["compute_seconds"],
                       "points_per_second": rate, "chunk": where.get("chunk"),
                       "cpu_seconds": where["cpu_seconds"],
                       "client_cpu_seconds": where.get("client_cpu_seconds", 0.0),
                       "cores_obtained": where["cpu_seconds"] / where["compute_seconds"],
                       # the workers' and the client's/scheduler's CPU together
                       "points_per_cpu_second": summary["computed"] / (where["cpu_seconds"]
                                                                       + where.get("client_cpu_seconds", 0.0)),
                       "responses": summary["responses"]}
                out["runs"].append(run)
                say(f"sweep bench: workers={run['workers']}: {rate:.1f} points/s "
                    f"(compute {run['compute_seconds']:.2f} s on {run['cores_obtained']:.2f} cores' worth of "
                    f"CPU, startup {run['startup_seconds']:.2f} s)")
                rates[workers] = max(rates.get(workers, 0.0), rate)
        out["load_average_1min_at_end"] = os.getloadavg()[0]
        out["points_per_second"] = {"serial": rates[0], "1 worker": rates[1], "2 workers": rates[2]}
        out["scaling_2_over_1"] = rates[2] / rates[1]
        # what the workers got from the machine: CPU seconds per wall second of the task phase
        best_runs = {}
        for r in out["runs"]:
            seen = best_runs.get(str(r["workers"]))
            if seen is None or r["points_per_second"] >= seen["points_per_second"]:
                best_runs[str(r["workers"])] = r
        out["cores_obtained"] = {k: r["cores_obtained"] for k, r in best_runs.items()}
        # throughput per CPU second: equal for 1 and 2 workers when Dask costs nothing extra
        per_cpu = {}
        for r in out["runs"]:
            if r["points_per_cpu_second"]:
                per_cpu[str(r["workers"])] = max(per_cpu.get(str(r["workers"]), 0.0), r["points_per_cpu_second"])
        out["points_per_cpu_second"] = per_cpu
        out["efficiency_2_workers"] = rates[2] / (2 * rates[1])
        # the scaling the machine would show with both cores free: 2 x the per-CPU-second ratio
        if per_cpu.get("1") and per_cpu.get("2"):
            out["cpu_normalised_efficiency_2_over_1"] = per_cpu["2"] / per_cpu["1"]
        out["target"] = "scaling_2_over_1 >= 1.7 on 2 cores"
    return out
