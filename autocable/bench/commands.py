"""Benchmarks: speed targets are measured here, never in timed tests.

``ame-vs-ode``: the error map of the Multiple Scales AME (22)-(24) against direct integration of
eq. (21) at the (U, eta) of Figs. 5-10 over sigma in [-0.05, 0.05], and the AME derivation time
cold and cached (see `bench_ame_vs_ode`).

``derive``: the derivation of eq. (21) cold (an empty cache folder) and cached, and the speed of the
compiled integration of eq. (21) against scipy's DOP853 with a Python right-hand side, at the same
tolerances, on the same equations, in one run (best of ``repeats`` after a warm-up).
"""
from __future__ import annotations

import contextlib
import json
import math
import os
import tempfile
import time

import numpy as np

from autocable._paths import MODELS_DIR
from autocable.plotting.style import styled


@contextlib.contextmanager
def _empty_cache():
    """A cold start: the cache folder (``$AUTOCABLE_CACHE``) is an empty temporary one while the
    block runs, the caller's setting restored after it however the block ends."""
    old = os.environ.get("AUTOCABLE_CACHE")
    with tempfile.TemporaryDirectory() as tmp:
        os.environ["AUTOCABLE_CACHE"] = tmp
        try:
            yield tmp
        finally:
            if old is None:
                os.environ.pop("AUTOCABLE_CACHE", None)
            else:
                os.environ["AUTOCABLE_CACHE"] = old


def _best(fn, repeats: int) -> float:
    fn()                                   # warm-up: builds, imports, caches
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def bench_derive(model_path: str, repeats: int = 3, log=None) -> dict:
    from autocable.methods.integration.ode21 import Ode21Integrator
    from autocable.model.derive import derive
    from autocable.spec import load_model

    say = log or (lambda s: None)
    spec = load_model(model_path)
    with _empty_cache():
        say("derivation, cold (empty cache) ...")
        t0 = time.perf_counter()
        d = derive(spec)
        cold = time.perf_counter() - t0
        cached = min(_timed(lambda: derive(spec)) for _ in range(repeats))
    say(f"  cold {cold:.2f} s, cached {cached * 1e3:.1f} ms")

    pars = {"U": 0.7, "eta": 4.1e-4, "Omega": d.ode.omega1 + 0.01, "wind": 1.0, "Uinv": 1 / 0.7}
    y0, t_end, dt = (0.0, 1e-6, 0.0, 0.0), 2000.0, 0.1
    rtol, atol = 1e-9, 1e-12
    compiled = Ode21Integrator(d.ode, "dopri", rtol=rtol, atol=atol)
    reference = Ode21Integrator(d.ode, "scipy", rtol=rtol, atol=atol)
    say("compiled integration (Dopri) ...")
    t_c = _best(lambda: compiled.run(y0, 0.0, t_end, dt, pars), repeats)
    say(f"  {t_c * 1e3:.1f} ms (build {compiled.build_seconds:.2f} s)")
    say("scipy DOP853, Python right-hand side ...")
    t_s = _best(lambda: reference.run(y0, 0.0, t_end, dt, pars), max(1, repeats - 1))
    _, yc = compiled.run(y0, 0.0, t_end, dt, pars)
    _, ys = reference.run(y0, 0.0, t_end, dt, pars)
    diff = float(np.max(np.abs(yc - ys)) / np.max(np.abs(ys)))
    say(f"  {t_s:.2f} s: compiled is {t_s / t_c:.0f}x faster")
    # A second integrator on the same equations loads the cached build (no compiler run).
    t_load = _timed(lambda: Ode21Integrator(d.ode, "dopri", rtol=rtol, atol=atol))
    say(f"  cached build loaded in {t_load * 1e3:.0f} ms")
    # Above U_c the cubic model blows up in finite time: `simulate` must say so quickly.
    say("diverging response (U = 1.1, eta = 0) ...")
    diverged = Ode21Integrator(d.ode).simulate(1.1, 0.0, 0.0, (0.01, 0.0, 1e-6, 0.0), max_time=5000.0)
    say(f"  {diverged.message} in {diverged.wall_seconds:.2f} s")
    return {
        "model": spec.name,
        "derivation_cold_s": cold, "derivation_cached_s": cached,
        "derivation_stages_s": d.timings,
        "integration": {"system": "eq. (21)", "t_end": t_end, "rtol": rtol, "atol": atol,
                        "U": pars["U"], "eta": pars["eta"], "Omega": pars["Omega"],
                        "compiled_dopri_s": t_c, "scipy_dop853_s": t_s, "speedup": t_s / t_c,
                        "compiled_build_s": compiled.build_seconds,
                        "max_relative_difference": diff,
                        "cached_build_load_s": t_load},
        "divergence": {"U": 1.1, "max_time": 5000.0, "message": diverged.message,
                       "wall_s": diverged.wall_seconds},
        "targets": {"derivation_cold_s": 30.0, "derivation_cached_s": 0.5, "speedup": 50.0,
                    "cached_build_load_s": 1.0, "divergence_wall_s": 60.0},
    }


def _timed(fn) -> float:
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def run_bench(what: str, model_path: str, repeats: int = 3, log=None, out=None) -> dict:
    if what == "derive":
        return bench_derive(model_path, repeats, log)
    if what == "ame-vs-ode":
        return bench_ame_vs_ode(model_path, repeats, log, out=out)
    if what == "auto":
        from autocable.bench.auto import bench_auto
        return bench_auto(model_path, repeats=repeats, log=log)
    if what == "figures":
        return bench_figures(log=log, out=out)
    if what == "bound-scenes":
        from autocable.bench.bound_scenes import bench_bound_scenes
        return bench_bound_scenes(model_path, log=log)
    if what == "ordering":
        from autocable.studies.ordering import bench_ordering, write
        result = bench_ordering(model_path, log=log)
        if out:
            result["files"] = [str(f) for f in write(result, out)]
        return result
    if what == "engines":
        from autocable.bench.engines import bench_engines
        return bench_engines(log=log)
    if what == "shooting":
        from autocable.bench.shooting import bench_shooting
        return bench_shooting(model_path, repeats=repeats, log=log)
    if what == "sweep":
        from autocable.bench.shooting import bench_sweep
        return bench_sweep(model_path, repeats=repeats, log=log)
    if what == "onset":
        return bench_onset(model_path, repeats, log)
    if what == "gallop":
        return bench_gallop(model_path, repeats, log)
    if what == "exact-load":
        from autocable.bench.exact_load import bench_exact_load
        return bench_exact_load(model_path, repeats, log)
    if what == "pairs":
        from autocable._paths import SAMPLE_MODEL
        # the target is set on the 190 m stay (five pairs below 3 Hz); --model picks another cable
        return bench_pairs(str(PAIRS_MODEL) if model_path == str(SAMPLE_MODEL) else model_path, repeats, log)
    if what == "calibration":
        from autocable.bench.calibration import bench_calibration
        return bench_calibration(model_path, log=log, out=out)
    if what == "continuation":
        from autocable.bench.continuation import bench_continuation
        return bench_continuation(model_path, repeats=repeats, cold=True, progress=log)
    raise ValueError(f"unknown benchmark {what!r}")


# -- onset: the damping curve of `autocable onset --damping` ----------------------------------------
def bench_onset(model_path: str, repeats: int = 3, log=None, n: int = 50) -> dict:
    """Wall time of the onset report and of a 50-point damping grid (U_cr against the damping ratio,
    `autocable onset --damping A:B:50` without the amplitude curves), warm: the derivation read from
    the cache (its cold time reported beside). Target: the grid under 2 s."""

    from autocable.model.derive import derive
    from autocable.studies.onset import damping_curve, design_damping, onset_report
    t0 = time.perf_counter()
    d = derive(model_path)
    first = time.perf_counter() - t0
    xi = d.ode.xi_s
    grid = np.linspace(0.25 * xi, 4 * xi, n)
    report = _best(lambda: onset_report(d), repeats)
    curve = _best(lambda: damping_curve(d, grid), repeats)
    U_design = 1.5 * d.spec.aero.critical_wind_speed_m_s
    design = _best(lambda: design_damping(d, U_design), repeats)
    result = {"model": model_path, "derive_s": first, "derivation_from_cache": d.from_cache,
              "onset_report_s": report, "damping_grid_points": n,
              "damping_grid": [float(grid[0]), float(grid[-1])], "damping_grid_s": curve,
              "design_damping_s": design, "design_wind_m_s": U_design, "target_damping_grid_s": 2.0,
              "meets_target": curve < 2.0}
    if log:
        log(f"onset report {report:.3g} s, {n}-point damping grid {curve:.3g} s (target 2 s), "
            f"design damping {design:.3g} s")
    return result


# -- pairs: `autocable onset --modes-below 3` -------------------------------------------------------
#: The cable of the pairs bench unless --model says otherwise, and its target.
PAIRS_MODEL = MODELS_DIR / "stay_190m.toml"
PAIRS_TARGET_S = 30.0


def bench_pairs(model_path: str, repeats: int = 3, log=None, below_hz: float = 3.0,
                design_wind_m_s: float = 25.0) -> dict:
    """Wall time of the table of `autocable onset --modes-below 3 --design-wind 25` (every mode pair
    below 3 Hz: derivation, onset, criticality, least damping), cold (an empty cache folder: every
    pair derived and calibrated) and warm (best of ``repeats``). Target: under 30 s."""
    from autocable.model.derive import derive
    from autocable.studies.onset import pairs_below

    def table():
        return pairs_below(derive(model_path), below_hz, design_wind_m_s)

    say = log or (lambda s: None)
    with _empty_cache():
        t0 = time.perf_counter()
        report = table()
        cold = time.perf_counter() - t0
    warm = _best(table, repeats)
    say(f"{len(report['pairs'])} pairs below {below_hz:g} Hz: cold {cold:.3g} s, warm {warm:.3g} s "
        f"(target {PAIRS_TARGET_S:g} s)")
    result = {"model": str(model_path), "below_Hz": below_hz, "design_wind_m_s": design_wind_m_s,
              "pairs": len(report["pairs"]), "cold_s": cold, "warm_s": warm, "target_s": PAIRS_TARGET_S,
              "meets_target": max(cold, warm) < PAIRS_TARGET_S,
              "onsets_U_m_s": [r["onset_U_m_s"] for r in report["pairs"]]}
    result["galloping"] = bench_pairs_galloping(model_path, below_hz, design_wind_m_s, log=log)
    result["meets_target"] = result["meets_target"] and result["galloping"]["cubic"]["meets_target"]
    return result


def bench_pairs_galloping(model_path: str, below_hz: float = 3.0, design_wind_m_s: float = 25.0,
                          log=None) -> dict:
    """The whole table of `onset --modes-below 3 --design-wind 25`, galloping columns included
    (`autocable.studies.pairs_galloping`: every pair's galloping study and global least damping),
    in process, on the cubic load (the acceptance target: under 30 s) and, where the model's curves
    are bounded by a blend (the ``.blended`` files, docs/aero-curves.md), on the exact load as
    `--load exact` runs it (minutes: reported, no target). Each once, after the linear table has
    filled the derivation cache; the compiled continuation systems are loaded from the cache
    where an earlier run built them (a cold cache adds their C builds: about 40 s per pair on the
    exact load). Wall and CPU time both: on a shared machine the wall time moves with the load."""
    from dataclasses import replace

    from autocable.model.curves import curves_from_spec
    from autocable.model.derive import derive
    from autocable.model.onset import U_MAX_DEFAULT
    from autocable.spec import load_model
    from autocable.studies.pairs_galloping import pairs_with_galloping

    say = log or (lambda s: None)
    spec = load_model(model_path)
    loads = ["cubic"] + (["exact"] if curves_from_spec(spec.aero).kind == "blend" else [])
    out = {}
    for load in loads:
        d = derive(replace(spec, aero=replace(spec.aero, load=load)))
        say(f"galloping table on the {load} load ...")
        t0, c0 = time.perf_counter(), time.process_time()
        report = pairs_with_galloping(d, below_hz, design_wind_m_s, U_MAX_DEFAULT, log=log)
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
        rows = report["pairs"]
        out[load] = {"wall_s": wall, "cpu_s": cpu, "pairs": len(rows),
                     "least_damping_global": [r.get("least_damping_global") for r in rows],
                     "lowest_galloping_U_m_s": [r.get("lowest_galloping_U_m_s") for r in rows],
                     "lowest_galloping_U_bound": [r.get("lowest_galloping_U_bound") for r in rows]}
        if load == "cubic":
            out[load].update(target_s=PAIRS_TARGET_S, meets_target=wall < PAIRS_TARGET_S)
        say(f"  {len(rows)} pairs: {wall:.3g} s wall, {cpu:.3g} s CPU"
            + (f" (target {PAIRS_TARGET_S:g} s)" if load == "cubic" else ""))
    return out


# -- gallop: the galloping cycles of `autocable gallop` ---------------------------------------------------
def bench_gallop(model_path: str, repeats: int = 3, log=None) -> dict:
    """Wall time of `autocable gallop` on one cable (the study with a design wind of 1.5 U_c and the
    direct-integration check, as the command runs it), cold (an empty cache folder: the derivation
    and the compiled integrators built) and warm (best of ``repeats``, the builds loaded from the
    cache in a fresh `CycleContinuation`). Target: under 10 s."""
    from autocable.model.derive import derive
    from autocable.studies.gallop import gallop_study

    say = log or (lambda s: None)
    with _empty_cache():
        say("derivation and gallop study, cold (empty cache) ...")
        t0 = time.perf_counter()
        d = derive(model_path)
        derive_cold = time.perf_counter() - t0
        U_design = 1.5 * d.spec.aero.critical_wind_speed_m_s
        t0 = time.perf_counter()
        study = gallop_study(d, U_design)
        cold = time.perf_counter() - t0
        say(f"  derivation {derive_cold:.2f} s, gallop {cold:.2f} s")
        warm = _best(lambda: gallop_study(d, U_design), repeats)
        t0 = time.perf_counter()
        gallop_study(d, U_design, checks=False)
        no_check = time.perf_counter() - t0
    branches = [h for c in study["cases"] for h in c["hopf_points"]]
    result = {"model": model_path, "mode_pair": d.mode_pair, "design_wind_m_s": U_design,
              "derive_cold_s": derive_cold, "gallop_cold_s": cold, "gallop_warm_s": warm,
              "gallop_warm_without_check_s": no_check, "check_cold_s": sum(
                  r[k]["seconds"] for r in study["check"] for k in ("from_cycle", "from_large_start")),
              "build_cold_s": sum(c["build_seconds"] for c in study["cases"]),
              "continuation_cold_s": sum(h["seconds"] for h in branches),
              "cycles": sum(h["points"] for h in branches),
              "lowest_galloping_U_m_s": study["lowest_galloping_U_m_s"], "target_s": 10.0,
              "meets_target": cold + derive_cold < 10.0 and warm < 10.0}
    say(f"  warm {warm:.2f} s ({no_check:.2f} s without the direct-integration check), {result['cycles']} cycles "
        "(target 10 s)")
    return result


# -- ame-vs-ode: the Multiple Scales AME (22)-(24) against direct integration of eq. (21) -------------
#: (U*, eta*) of the error map: Figs. 5a, 5b, 6 (no wind) and 7-10 (wind), Sect. 5.
AME_VS_ODE_CASES = ((0.0, 8.2e-5), (0.0, 4.1e-4), (0.0, 1.4e-3),
                    (0.7, 4.1e-4), (1.3, 4.1e-4), (0.7, 1.4e-3), (1.3, 1.4e-3))
_STATUS_SHORT = {"same-branch": "same", "different-branch": "diff. branch",
                 "no-ame-branch": "no AME branch", "quasi-periodic-21": "(21) quasi-periodic",
                 "ame-not-equilibrium": "AME not equilibrium", "diverged-both": "both diverge",
                 "diverged-21": "(21) diverges", "diverged-ame": "AME diverges"}


def _ame_timings(d, repeats: int) -> dict:
    """AME derivation cold (empty cache folder) and cached (JSON read), as `bench_derive` does."""
    from autocable.model.ame_cache import derive_ame

    with _empty_cache():
        t0 = time.perf_counter()
        cold = derive_ame(d)
        cold_s = time.perf_counter() - t0
        cached_s = min(_timed(lambda: derive_ame(d)) for _ in range(max(1, repeats)))
        again = derive_ame(d)
        hit = again.from_cache and again.ame == cold.ame
    t0 = time.perf_counter()
    back = type(cold.ame).from_dict(json.loads(json.dumps(cold.ame.to_dict())))
    back.cartesian_rhs()
    reload_s = time.perf_counter() - t0
    return {"ame_derivation_cold_s": cold_s, "ame_derivation_cached_s": cached_s,
            "ame_json_reload_s": reload_s,
            "targets": {"ame_derivation_cold_s": 60.0, "ame_derivation_cached_s": 0.5,
                        "ame_json_reload_s": 0.5},
            "cache_round_trip_equal": hit,
            "engine_seconds": cold.ame.provenance.get("derivation_seconds"),
            "complex_rows": len(cold.ame.complex_rows), "cartesian_rows": len(cold.ame.cartesian_rows)}


def _row(c) -> dict:
    o, a = c.ode, c.ame

    def num(x):
        return None if x is None or not math.isfinite(x) else float(x)

    return {"sigma": c.sigma, "status": c.status,
            "a1_ode21": num(o.a1) if o else None, "a2_ode21": num(o.a2) if o else None,
            "ode21_periodic": bool(o.periodic) if o else None,
            "ode21_t_end": float(o.t_end) if o else None, "ode21_error": c.ode_error,
            "a1_ame": num(a.a1), "a2_ame": num(a.a2), "ame_equilibrium": a.periodic,
            "ame_stable": a.equilibrium.stable if a.equilibrium else None, "ame_t_end": a.t_end,
            "rel_a1": num(c.rel_a1), "rel_a2": num(c.rel_a2),
            "a1_ame_nearest": num(c.nearest.amplitudes[0]) if c.nearest and c.nearest.converged else None,
            "a2_ame_nearest": num(c.nearest.amplitudes[1]) if c.nearest and c.nearest.converged else None,
            "nearest_stable": c.nearest.stable if c.nearest and c.nearest.converged else None,
            "rel_a1_nearest": num(c.rel_a1_nearest)}


def bench_ame_vs_ode(model_path: str, repeats: int = 3, log=None, out=None, n_sigma: int = 21) -> dict:
    """Relative error map |a1_AME - a1_(21)| / a1_(21) over sigma in [-0.05, 0.05] at the (U, eta)
    of Figs. 5-10, both integrated from the same start (rest, q2 = 1e-6); see `compare_with_ode21`
    for what each status means. With ``out``: ame_vs_ode21.md and ame_vs_ode21.png there."""
    from autocable.methods.integration.ame import AmeIntegrator, compare_with_ode21
    from autocable.methods.integration.ode21 import Ode21Integrator
    from autocable.model.ame_cache import derive_ame
    from autocable.model.derive import derive

    say = log or (lambda s: None)
    t_start = time.perf_counter()
    d = derive(model_path)
    say("AME derivation, cold and cached ...")
    timings = _ame_timings(d, repeats)
    say(f"  cold {timings['ame_derivation_cold_s']:.3f} s, "
        f"cached {timings['ame_derivation_cached_s'] * 1e3:.1f} ms")
    ame = derive_ame(d).ame
    ame_int = AmeIntegrator(ame)
    # One compiled eq. (21) generator per process (see integration.py).
    ode_int = Ode21Integrator(d.ode)
    sigmas = np.linspace(-0.05, 0.05, n_sigma)
    cases = []
    for U, eta in AME_VS_ODE_CASES:
        rows = []
        t0 = time.perf_counter()
        for i, s in enumerate(sigmas):
            c = compare_with_ode21(ame_int, ode_int, U, eta, float(s))
            rows.append(_row(c))
            say(f"  U = {U:g}, eta = {eta:g}: sigma {s:+.3f} ({i + 1}/{len(sigmas)}) "
                f"{_STATUS_SHORT[c.status]:<20} rel a1 {c.rel_a1:.2e}")
        same = [r["rel_a1"] for r in rows if r["status"] == "same-branch" and r["rel_a1"] is not None]
        counts = {k: sum(r["status"] == k for r in rows) for k in _STATUS_SHORT}
        cases.append({"U": U, "eta": eta, "k11_eta": _k11(d.ode) * eta, "rows": rows,
                      "max_rel_a1_same_branch": max(same) if same else None,
                      "median_rel_a1_same_branch": float(np.median(same)) if same else None,
                      "status_counts": {k: v for k, v in counts.items() if v},
                      "wall_s": time.perf_counter() - t0})
        say(f"  done in {time.perf_counter() - t0:.1f} s; max rel a1 (same branch) "
            f"{cases[-1]['max_rel_a1_same_branch']}")
    result = {"model": d.spec.name, "ode_hash": d.ode.content_hash(),
              "galloping": _galloping(d.ode), "eta_scaling": _eta_scaling(cases),
              "amplitude_convention": "a_k peak modal amplitude: half peak-to-peak of q_k over the "
                                      "last 20 forcing periods for eq. (21), sqrt(r_k^2 + s_k^2) at "
                                      "an AME equilibrium",
              "start": "rest with q2 = 1e-6 (AME: r2 = 1e-6 by the first-order relation)",
              "sigma": [float(s) for s in sigmas], "timings": timings, "cases": cases,
              "statuses": _status_notes(), "wall_s": time.perf_counter() - t_start}
    if out is not None:
        from pathlib import Path
        from autocable._store import atomic_write_text
        folder = Path(out)
        folder.mkdir(parents=True, exist_ok=True)
        say("plot ...")
        _plot_ame_vs_ode(result, folder / "ame_vs_ode21.png")
        atomic_write_text(folder / "ame_vs_ode21.md", _markdown_ame_vs_ode(result, "ame_vs_ode21.png"))
        result["written"] = [str(folder / "ame_vs_ode21.md"), str(folder / "ame_vs_ode21.png")]
    return result


def _k11(ode) -> float:
    """|k11| of Gamma_{1,2} (eta f q1): |k11| eta / omega1^2 is the stiffness modulation the
    ordering (eta = O(eps), k11 = O(1)) treats as small."""
    hits = ode.find(1, (1, 0, 0, 0), (1, 0, 0))
    return abs(float(hits[0].coefficient)) if hits else math.nan


def _galloping(ode) -> dict:
    """The 1-dof galloping data of eq. (21) (Gamma_{1,1}, Gamma_{1,15}) and what their signs imply."""
    z11 = ode.find(1, (0, 0, 1, 0), u_power=1)
    z8 = ode.find(1, (0, 0, 3, 0), u_power=-1)
    if not (z11 and z8):
        return {}
    z11, z8 = z11[0].coefficient, z8[0].coefficient
    return {"zeta11": z11, "zeta8": z8, "2 xi_s omega1": 2 * ode.xi_s * ode.omega1,
            "threshold_U": -2 * ode.xi_s * ode.omega1 / z11,
            "kind": "subcritical (unstable branch below the threshold, no bounded galloping above)"
                    if z8 < 0 else "supercritical (stable branch above the threshold)"}


def _eta_scaling(cases) -> list:
    """Observed exponent of the relative a1 error in eta between the no-wind cases, per sigma."""
    nowind = [c for c in cases if c["U"] == 0.0]
    out = []
    if not nowind:
        return out
    for i, sigma in enumerate(r["sigma"] for r in nowind[0]["rows"]):
        if abs(abs(sigma) - 0.05) > 1e-12:
            continue
        pts = [(c["eta"], c["rows"][i]["rel_a1"]) for c in nowind
               if c["rows"][i]["status"] == "same-branch" and c["rows"][i]["rel_a1"]]
        for (e1, r1), (e2, r2) in zip(pts, pts[1:]):
            out.append({"sigma": sigma, "eta": [e1, e2], "rel_a1": [r1, r2],
                        "exponent": math.log(r2 / r1) / math.log(e2 / e1)})
    return out


def _status_notes() -> dict:
    from autocable.methods.integration.ame import STATUSES
    return dict(STATUSES)


def _fmt_e(x, digits=3) -> str:
    return "—" if x is None else f"{x:.{digits}e}"


def _markdown_ame_vs_ode(result: dict, png: str) -> str:
    t = result["timings"]
    lines = [
        "# AME (22)-(24) against direct integration of eq. (21)",
        "",
        "Generated by `autocable bench ame-vs-ode --out docs` (do not edit by hand).",
        f"Model `{result['model']}` (eq. 21 hash `{result['ode_hash']}`). Both methods start from the "
        f"same state: {result['start']}. Amplitudes: {result['amplitude_convention']}. "
        "The AME is integrated to its steady state (LSODA, analytic Jacobian) and its equilibrium "
        "refined by Newton; eq. (21) is integrated (compiled DOP853) until its amplitudes are steady.",
        "",
        f"AME derivation: cold {t['ame_derivation_cold_s']:.3f} s, cached "
        f"{t['ame_derivation_cached_s'] * 1e3:.1f} ms ({t['complex_rows']} complex rows, "
        f"{t['cartesian_rows']} Cartesian rows). Bench wall time {result['wall_s']:.0f} s.",
        "",
        f"![relative error map]({png})",
        "",
        "## Summary",
        "",
        "| U* | eta* | \\|k11\\| eta | max rel. error a1 (same branch) | median | statuses |",
        "|---|---|---|---|---|---|",
    ]
    for c in result["cases"]:
        st = ", ".join(f"{_STATUS_SHORT[k]}: {v}" for k, v in c["status_counts"].items())
        lines.append(f"| {c['U']:g} | {c['eta']:g} | {c['k11_eta']:.3f} | "
                     f"{_fmt_e(c['max_rel_a1_same_branch'], 2)} | "
                     f"{_fmt_e(c['median_rel_a1_same_branch'], 2)} | {st} |")
    lines += ["", "## Reading the map", ""]
    sc = result.get("eta_scaling", [])
    if sc:
        lines.append("- **Order in eta.** At fixed sigma the relative a1 error grows as eta^p between the "
                     "no-wind cases: " + "; ".join(
                         f"sigma = {x['sigma']:+.2f}, eta {x['eta'][0]:g} -> {x['eta'][1]:g}: "
                         f"{x['rel_a1'][0]:.2e} -> {x['rel_a1'][1]:.2e}, p = {x['exponent']:.2f}"
                         for x in sc)
                     + ". The ordering predicts p = 2 (tests/test_ame_vs_ode21.py derives it): the "
                       "exact-Omega AME reproduces the linear forced response exactly and misses "
                       "O(eta^2) x O(sigma, xi_s) corrections, so the error grows with |sigma|.")
    nowind = [c for c in result["cases"] if c["U"] == 0.0]
    if nowind:
        big = nowind[-1]
        fail = [r["sigma"] for r in big["rows"] if r["status"] in ("no-ame-branch", "different-branch")]
        lines.append("- **Expansion parameter.** The parametric stiffness modulation |k11| eta / omega1^2 "
                     "(Gamma_{1,2}), taken O(eps) by the ordering, is "
                     + ", ".join(f"{c['k11_eta']:.2f}" for c in nowind)
                     + " at eta = " + ", ".join(f"{c['eta']:g}" for c in nowind) + ". "
                     f"At eta = {big['eta']:g} the same-branch error reaches "
                     f"{_fmt_e(big['max_rel_a1_same_branch'], 2)}"
                     + (f", and at sigma in [{min(fail):+.3f}, {max(fail):+.3f}] the AME from the same "
                        "start lands on another branch or has no equilibrium near eq. (21)'s response "
                        "(MSM fails there)" if fail else "") + ".")
    g = result.get("galloping", {})
    if g:
        div = [f"U = {c['U']:g}, eta = {c['eta']:g}: " + (
            "every sigma" if all(r["status"].startswith("diverged") for r in c["rows"]) else
            ", ".join(f"{r['sigma']:+.3f}" for r in c["rows"] if r["status"].startswith("diverged")))
            for c in result["cases"] if any(r["status"].startswith("diverged") for r in c["rows"])]
        lines.append(f"- **Wind.** zeta8 = {g['zeta8']:.4g} (Gamma_{{1,15}} = zeta8/U), threshold "
                     f"U = {g['threshold_U']:.6g}: galloping is {g['kind']}. "
                     + (("With the cubic truncation nothing bounds a motion that passes the "
                         "unstable galloping cycle; " if g["zeta8"] < 0 else "")
                        + "eq. (21)'s integration stops with a collapsing step (finite-time blow-up). "
                        "Divergence at " + "; ".join(div) + "." if div else "No divergence."))
    lines.append("- **a2.** Where a2 is tiny (1e-10 to 1e-8) the AME and eq. (21) differ in a2: eq. (21)'s "
                 "half peak-to-peak of q2 contains non-resonant harmonics (e.g. the xi01 eta^2 f'^2 "
                 "forcing) that the first-order AME amplitude does not.")
    lines += ["", "Statuses:", ""]
    lines += [f"- **{_STATUS_SHORT[k]}** (`{k}`): {v}" for k, v in result["statuses"].items()]
    for c in result["cases"]:
        lines += ["", f"## U* = {c['U']:g}, eta* = {c['eta']:g}", "",
                  "| sigma | a1 (21) | a1 AME | rel. err a1 | a2 (21) | a2 AME | status "
                  "| a1 nearest AME eq. | rel. err | note |",
                  "|---|---|---|---|---|---|---|---|---|---|"]
        for r in c["rows"]:
            note = ""
            if r["status"] in ("diverged-21", "diverged-both") and r["ode21_error"]:
                note = "(21): " + r["ode21_error"][-70:].replace("|", "/")
            if r["status"] in ("diverged-ame", "diverged-both"):
                note += f" AME diverged at t = {r['ame_t_end']:.0f}"
            if r["nearest_stable"] is False:
                note += " nearest AME equilibrium unstable"
            lines.append(f"| {r['sigma']:+.3f} | {_fmt_e(r['a1_ode21'])} | {_fmt_e(r['a1_ame'])} | "
                         f"{_fmt_e(r['rel_a1'], 2)} | {_fmt_e(r['a2_ode21'], 2)} | "
                         f"{_fmt_e(r['a2_ame'], 2)} | "
                         f"{_STATUS_SHORT[r['status']]} | {_fmt_e(r['a1_ame_nearest'])} | "
                         f"{_fmt_e(r['rel_a1_nearest'], 2)} | {note.strip()} |")
    return "\n".join(lines) + "\n"


@styled()      # the package's one look (autocable.plotting.style)
def _plot_ame_vs_ode(result: dict, path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    markers = {"same-branch": "o", "different-branch": "s", "no-ame-branch": "X",
               "quasi-periodic-21": "^", "ame-not-equilibrium": "v"}
    cases = result["cases"]
    fig, axes = plt.subplots(3, 3, figsize=(15, 12), constrained_layout=True)
    ax_err = (axes[0, 0], axes[0, 1])
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for i, c in enumerate(cases):
        ax = ax_err[0] if c["U"] == 0 else ax_err[1]
        col = colors[i % len(colors)]
        xs = [r["sigma"] for r in c["rows"] if r["rel_a1"]]
        ys = [r["rel_a1"] for r in c["rows"] if r["rel_a1"]]
        if xs:
            ax.plot(xs, ys, "-", color=col, lw=0.8, label=f"U={c['U']:g}, eta={c['eta']:g}")
        for r in c["rows"]:
            if r["rel_a1"]:
                m = markers.get(r["status"], "o")
                ax.plot(r["sigma"], r["rel_a1"], m, color=col, ms=5,
                        mfc=col if r["status"] == "same-branch" else "none")
    for ax, title in zip(ax_err, ("no wind: |a1 AME - a1 (21)| / a1 (21)", "with wind")):
        ax.set_yscale("log")
        ax.set_xlabel("sigma")
        ax.set_title(title, fontsize=10)
        ax.axhline(0.02, color="k", ls=":", lw=0.8)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    legend = axes[0, 2]
    legend.axis("off")
    for j, (k, m) in enumerate(markers.items()):
        legend.plot([], [], m, color="k", mfc="k" if k == "same-branch" else "none", label=_STATUS_SHORT[k])
    legend.plot([], [], "x", color="r", label="(21) diverges (blow-up of the cubic model)")
    legend.plot([], [], "+", color="b", label="AME diverges")
    legend.legend(loc="center", fontsize=9, title="markers (filled: same branch; dotted line: 2 %)")
    for ax, c in zip(list(axes[1]) + list(axes[2]), cases):
        s = [r["sigma"] for r in c["rows"]]
        for key, style, lab in (("a1_ode21", "ko", "a1 (21)"), ("a1_ame", "C0.-", "a1 AME"),
                                ("a2_ode21", "ks", "a2 (21)"), ("a2_ame", "C3.--", "a2 AME")):
            v = [r[key] if r[key] is not None else np.nan for r in c["rows"]]
            kw = {"mfc": "none", "ms": 5} if "ode21" in key else {"ms": 3}
            ax.plot(s, v, style, label=lab, **kw)
        for r in c["rows"]:
            if r["status"] in ("diverged-21", "diverged-both"):
                ax.plot(r["sigma"], 0, "rx", transform=ax.get_xaxis_transform(), clip_on=False)
            if r["status"] in ("diverged-ame", "diverged-both"):
                ax.plot(r["sigma"], 0.04, "b+", transform=ax.get_xaxis_transform(), clip_on=False)
        if all(r["status"] == "diverged-both" for r in c["rows"]):
            ax.text(0.5, 0.5, "no bounded response:\nboth eq. (21) and the AME diverge\nat every sigma",
                    transform=ax.transAxes, ha="center", va="center", fontsize=10)
        ax.set_title(f"U={c['U']:g}, eta={c['eta']:g} (|k11| eta = {c['k11_eta']:.2f})", fontsize=10)
        ax.set_xlabel("sigma")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7)
    for ax in list(axes[1])[len(cases):] + list(axes[2])[max(0, len(cases) - 3):]:
        if not ax.has_data():
            ax.axis("off")
    fig.suptitle("Multiple Scales AME (22)-(24) vs direct integration of eq. (21), same start", fontsize=12)
    fig.savefig(path, dpi=110)
    plt.close(fig)


# -- figures: wall time of `autocable figures`: cold, warm, recomputed -------------------------------------
#: The speed targets for all figure scenes on the 2-core machine (those of the one-executor round;
#: the earlier ones were 60 s cold and 15 s warm).
FIGURES_TARGETS = {"cold_s": 30.0, "warm_s": 6.0}


def _figures_pass(out_dir: str, env: dict, runs: str | None, jobs: int | None, only: list[str],
                  extra: tuple[str, ...] = ()) -> dict:
    import resource
    import subprocess
    import sys
    from pathlib import Path

    from autocable.paper.report import FIGURE_STAGES, load_scene_data, stage_seconds
    cmd = [sys.executable, "-m", "autocable.cli", "figures", "--out", out_dir, "--quiet", "--only", ",".join(only)]
    if runs:
        cmd += ["--runs", runs]
    if jobs:
        cmd += ["--workers", str(jobs)]
    cmd += list(extra)
    load = os.getloadavg()[0]
    ru0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    ru1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    # CPU time of the command and its scene processes: less sensitive to other load than wall time
    cpu = (ru1.ru_utime - ru0.ru_utime) + (ru1.ru_stime - ru0.ru_stime)
    scenes, totals = {}, {k: 0.0 for k in (*FIGURE_STAGES, "total")}
    for folder in sorted(p for p in Path(out_dir).iterdir() if p.is_dir()):
        d = load_scene_data(folder)
        if not d.ok:
            scenes[folder.name] = {"status": d.status, "error": d.error}
            continue
        if (d.run or {}).get("reused"):
            # copied from the cache (autocable.paper.reuse): its stage clocks are the earlier run's
            scenes[folder.name] = {"status": "ok", "reused": True}
            continue
        st = stage_seconds(((d.run or {}).get("provenance") or {}).get("stages") or {})
        scenes[folder.name] = {"status": "ok", **st}
        for k in totals:
            totals[k] += st[k]
    shares = {k: (totals[k] / totals["total"] if totals["total"] > 0 else math.nan) for k in FIGURE_STAGES}
    return {"wall_s": wall, "cpu_s": cpu, "load_average_before": load, "exit_status": proc.returncode,
            "argv_extra": list(extra), "scenes_reused": sum(1 for v in scenes.values() if v.get("reused")),
            "stderr_tail": proc.stderr.strip().splitlines()[-5:],
            "scenes": scenes, "stage_seconds_summed_over_scenes": totals, "stage_shares": shares}


def _stages() -> tuple:
    from autocable.paper.report import FIGURE_STAGES
    return tuple(FIGURE_STAGES)


def bench_figures(log=None, runs: str | None = None, jobs: int | None = None, out=None) -> dict:
    """Wall time of `autocable figures` (every scene) in a subprocess, three passes on one fresh
    AUTOCABLE_CACHE: **cold** (the cache empty), **warm** (the same command again: every scene's
    stored results reused, `autocable.paper.reuse`) and **recomputed** (``--recompute``: every
    scene computed again on the warm cache of derivations and builds). Each pass records its
    stages' share of the scenes' summed wall time (`autocable.paper.report.stage_seconds`; reused
    scenes have none), and per scene what the cold pass took more than the recomputed one
    (``cold_minus_warm``: the one-time derivations and builds). Scenes run in parallel, so the
    summed stage time exceeds the wall time by up to the number of processes. With ``out``, the
    recomputed pass's figures, data and report.md are kept in ``out/figures``."""
    from autocable.paper.figures import default_runs_dir, discover
    say = log or (lambda s: None)
    # one list for all passes: scene files added meanwhile must not make them incomparable
    only = [p.stem for p in discover(runs or default_runs_dir())]
    say(f"scenes: {', '.join(only)}")
    with tempfile.TemporaryDirectory() as tmp:
        env = dict(os.environ, AUTOCABLE_CACHE=os.path.join(tmp, "cache"))
        say("autocable figures, cold (empty cache) ...")
        cold = _figures_pass(os.path.join(tmp, "cold"), env, runs, jobs, only)
        say(f"  {cold['wall_s']:.1f} s (exit status {cold['exit_status']})")
        say("autocable figures, warm (the stored results reused) ...")
        warm = _figures_pass(os.path.join(tmp, "warm"), env, runs, jobs, only)
        say(f"  {warm['wall_s']:.1f} s (exit status {warm['exit_status']}, {warm['scenes_reused']} scenes reused)")
        say("autocable figures --recompute, warm (every scene computed again) ...")
        again_dir = os.path.join(str(out), "figures") if out else os.path.join(tmp, "again")
        again = _figures_pass(again_dir, env, runs, jobs, only, ("--recompute",))
        say(f"  {again['wall_s']:.1f} s (exit status {again['exit_status']})")
    # what a cold cache adds, per scene and stage: the one-time derivations and builds
    cold_extra = {name: {k: cold["scenes"][name][k] - again["scenes"][name][k] for k in (*_stages(), "total")}
                  for name in only if cold["scenes"].get(name, {}).get("status") == "ok"
                  and again["scenes"].get(name, {}).get("status") == "ok"}
    return {"what": "autocable figures, every runs/fig*.toml scene", "scenes": only, "cpu_count": os.cpu_count(),
            "jobs": jobs or os.cpu_count(), "cold": cold, "warm": warm, "recomputed": again,
            "cold_minus_warm": cold_extra,
            "targets": FIGURES_TARGETS,
            "targets_met": {"cold": cold["wall_s"] <= FIGURES_TARGETS["cold_s"] and cold["exit_status"] == 0,
                            "warm": warm["wall_s"] <= FIGURES_TARGETS["warm_s"] and warm["exit_status"] == 0}}
