"""Benchmarks: speed targets are measured here, never in timed tests.

``derive``: the derivation of eq. (21) cold (an empty cache folder) and cached, and the speed of the
compiled integration of eq. (21) against scipy's DOP853 with a Python right-hand side, at the same
tolerances, on the same equations, in one run (best of ``repeats`` after a warm-up).
"""
from __future__ import annotations

import os
import tempfile
import time

import numpy as np


def _best(fn, repeats: int) -> float:
    fn()                                   # warm-up: builds, imports, caches
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def bench_derive(model_path: str, repeats: int = 3, log=None) -> dict:
    from autocable.methods.integration import Ode21Integrator
    from autocable.model.derive import derive
    from autocable.spec import load_model

    say = log or (lambda s: None)
    spec = load_model(model_path)
    old = os.environ.get("AUTOCABLE_CACHE")
    with tempfile.TemporaryDirectory() as tmp:
        os.environ["AUTOCABLE_CACHE"] = tmp
        try:
            say("derivation, cold (empty cache) ...")
            t0 = time.perf_counter()
            d = derive(spec)
            cold = time.perf_counter() - t0
            cached = min(_timed(lambda: derive(spec)) for _ in range(repeats))
        finally:
            if old is None:
                os.environ.pop("AUTOCABLE_CACHE", None)
            else:
                os.environ["AUTOCABLE_CACHE"] = old
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
    return {
        "model": spec.name,
        "derivation_cold_s": cold, "derivation_cached_s": cached,
        "derivation_stages_s": d.timings,
        "integration": {"system": "eq. (21)", "t_end": t_end, "rtol": rtol, "atol": atol,
                        "U": pars["U"], "eta": pars["eta"], "Omega": pars["Omega"],
                        "compiled_dopri_s": t_c, "scipy_dop853_s": t_s, "speedup": t_s / t_c,
                        "compiled_build_s": compiled.build_seconds,
                        "max_relative_difference": diff},
        "targets": {"derivation_cold_s": 30.0, "derivation_cached_s": 0.5, "speedup": 50.0},
    }


def _timed(fn) -> float:
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def run_bench(what: str, model_path: str, repeats: int = 3, log=None) -> dict:
    if what == "derive":
        return bench_derive(model_path, repeats, log)
    raise ValueError(f"unknown benchmark {what!r}")
