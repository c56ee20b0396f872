"""Periodic orbits from a Hopf point: PyCont's LC-C (AUTO collocation), Floquet multipliers from the
variational equations over one period (cross-checked with AUTO's), and LPC/PD/NS from multiplier
crossings (`continue_cycles`).

``engine="compiled"`` hands the run to `autocable.methods.continuation.compiled_cycles` (autocable's own
collocation on the C kernel); both engines build their records with `cycle_result`."""
from __future__ import annotations

import math
import time
import warnings

import numpy as np

from autocable.codegen import compat
from autocable.codegen.pydstool import continuation_system, pydstool_cache_dir
from autocable.errors import CacheError
from autocable.methods.continuation.chart import _Chart
from autocable.methods.continuation.compiled_cycles import continue_cycles_compiled, continue_cycles_from_orbit
from autocable.methods.continuation.cycle_records import _sampled_extremes, cycle_result
from autocable.methods.continuation.events import _monodromy
from autocable.methods.continuation.settings import CYCLE_ENGINES
from autocable.methods.continuation.problem import ContinuationResult, ContinuationSettings, Progress, _resolve
from autocable.methods.continuation.pycont_driver import _one_line
from autocable.results import EndPoint, SpecialPoint

__all__ = ["continue_cycles", "continue_cycles_compiled", "continue_cycles_from_orbit", "CYCLE_ENGINES"]




def continue_cycles(source: ContinuationResult, hopf: str | SpecialPoint,
                    settings: ContinuationSettings | None = None, *, name: str | None = None,
                    progress: Progress | None = None, engine: str = "pycont") -> ContinuationResult:
    """Periodic orbits born at the Hopf point ``hopf`` of ``source`` (PyCont LC-C, AUTO collocation
    with ``ntst`` intervals of ``ncol`` points), in the continued parameter's range.

    ``engine="compiled"``: the same records from autocable's own collocation on the C kernel
    (`autocable.methods.continuation.compiled_cycles`), no PyDSTool.

    Per cycle: the period, the min/max of every amplitude over the cycle (from a dense integration of
    one period started on AUTO's profile), the Floquet multipliers from the variational equations
    over that period (cross-checked with AUTO's: ``info["auto_multiplier_max_diff"]``), stability
    (every non-trivial multiplier inside the unit circle), and LPC/PD/NS from multiplier crossings.
    The branch ends at the range, at ``cycle_max_points``, when AUTO fails (NaNs) or when the period
    exceeds ``max_period_ratio`` times the Hopf period (a homoclinic approach, Sect. 5)."""
    if engine not in CYCLE_ENGINES:
        raise ValueError(f"engine must be one of {list(CYCLE_ENGINES)}, got {engine!r}")
    if engine == "compiled":
        return continue_cycles_compiled(source, hopf, settings, name=name, progress=progress)
    hp, problem, base_settings = _resolve(source, hopf)
    settings = settings or base_settings
    if hp.type != "H":
        raise ValueError(f"{hp.name} is a {hp.type} point, not a Hopf point")
    name = name or f"{source.branch.name}_{hp.label}_cycles"
    sysm = problem.system
    t0 = time.perf_counter()
    chart = _Chart(sysm, sysm.parameter_names.index(problem.parameter),
                   sysm.parameter_vector(hp.parameters), problem.state_scale, problem.span)
    YH = chart.to_chart(hp.state, hp.value)
    T_H = float(hp.extra.get("period", math.nan))
    dst = compat.import_pydstool()
    vf = sysm.scaled_field()
    reason, message = "max_points", ""
    pts = []
    try:
        cont = continuation_system(vf, "Dopri", ics=chart.point_dict(YH), pars=chart.pycont_pars(0.0), auto=True)
        with compat.pydstool_session(f"continuing cycles from {hp.name}", pydstool_cache_dir()), \
                warnings.catch_warnings():
            warnings.simplefilter("ignore")
            cont.newCurve(dst.args(
                name="LC", type="LC-C", initpoint=chart.point_dict(YH), freepars=["lam"],
                StepSize=settings.cycle_step, MinStepSize=settings.min_step,
                MaxStepSize=settings.cycle_max_step, MaxNumPoints=settings.cycle_max_points,
                NumIntervals=settings.ntst, NumCollocation=settings.ncol, NumSPOut=1,
                SolutionMeasures=["max", "min"], SaveEigen=True, LocBifPoints=["LPC", "PD", "NS"],
                verbosity=0, FuncTol=settings.tol, VarTol=settings.tol, TestTol=settings.test_tol))
            cont["LC"].forward()
        pts = list(cont["LC"].sol)
    except CacheError:
        raise       # an unwritable or full cache: the command's one-line error, not a branch's end
    except Exception as exc:  # noqa: BLE001
        reason, message = "error", f"AUTO's cycle continuation failed: {_one_line(exc)}"
    t1 = time.perf_counter()
    lo, hi = chart.lam(problem.bounds[0]), chart.lam(problem.bounds[1])
    rows, auto_labels = [], []
    for i, pt in enumerate(pts):
        lam, T = float(pt["lam"]), float(pt["_T"])
        cyc = next((v["cycle"] for v in pt.labels.values() if isinstance(v, dict) and "cycle" in v), None)
        if "MX" in pt.labels or not (math.isfinite(lam) and math.isfinite(T)):
            reason, message = "no_convergence", "AUTO stopped with NaNs (MX point)"
            break
        if not lo - 1e-12 <= lam <= hi + 1e-12:
            reason, message = "range", f"{problem.parameter} left the range"
            break
        if math.isfinite(T_H) and T > settings.max_period_ratio * T_H:
            reason = "period_blowup"
            message = (f"the period reached {T:.4g} (> {settings.max_period_ratio:g} x the Hopf period "
                       f"{T_H:.4g}) at {problem.parameter} = {chart.value(lam):.6g}: a homoclinic orbit "
                       f"is near; lower cycle_max_step to approach it more closely")
            break
        auto_ev = None
        lc = pt.labels.get("LC", {})
        if isinstance(lc, dict) and "data" in lc and "evals" in lc["data"]:
            auto_ev = np.asarray(lc["data"].evals, dtype=complex)
        for t in ("LPC", "PD", "NS"):
            if t in pt.labels:
                auto_labels.append((t, len(rows)))
        rows.append((lam, T, cyc, auto_ev))
        if progress and i % 10 == 0:
            progress(f"{name}: {problem.parameter} = {chart.value(lam):.6g}, period {T:.4g}, {len(rows)} cycles")
    n = sysm.dimension
    X, P, periods, mults, amin, amax = [], [], [], [], [], []
    auto_diff, closure = [], []
    for lam, T, cyc, auto_ev in rows:
        p = chart.p(lam)
        if cyc is not None:
            prof = np.column_stack([np.asarray(cyc[v], float) for v in sysm.variables]) * chart.xscale
        else:
            prof = np.array([chart.to_phys(YH)[0]])
        x0 = prof[0]
        try:
            Phi, xT, dense = _monodromy(sysm, x0, p, T, settings.floquet_rtol)
            mu = np.linalg.eigvals(Phi)
            size = np.max(np.ptp(prof, axis=0)) if len(prof) > 1 else 0.0
            err = float(np.linalg.norm(xT - x0) / max(size, 1e-300 + chart.xscale * 1e-12))
            samples = np.vstack([dense, prof]) if err < 1e-3 else prof
        except (RuntimeError, ValueError, np.linalg.LinAlgError):
            mu = auto_ev if auto_ev is not None else np.full(n, np.nan + 0j)
            err, samples = math.inf, prof
        closure.append(err)
        mu = mu[np.argsort(-np.abs(mu))]
        if auto_ev is not None and auto_ev.size == mu.size and np.all(np.isfinite(auto_ev)):
            a = np.sort_complex(auto_ev)
            b = np.sort_complex(mu)
            auto_diff.append(float(np.max(np.abs(a - b))))
        lo_, hi_ = _sampled_extremes(sysm, samples)
        amin.append(lo_)
        amax.append(hi_)
        periods.append(T)
        X.append(x0)
        P.append(p)
        mults.append(mu)
    if rows and reason == "max_points" and len(rows) < settings.cycle_max_points:
        reason, message = "no_convergence", "AUTO stopped before the point budget (see AUTO's limits)"
    side = EndPoint("forward", reason, chart.value(rows[-1][0]) if rows else hp.value, len(rows), message)
    info = {"from": hp.name, "hopf_period": T_H, "closure_error_max": max(closure) if closure else None,
            "auto_multiplier_max_diff": max(auto_diff) if auto_diff else None, "ntst": settings.ntst,
            "ncol": settings.ncol}
    return cycle_result(name, problem, settings, chart, X, P, periods, mults, amin, amax, auto_labels, side,
                        info, {"auto_s": t1 - t0, "analysis_s": time.perf_counter() - t1, "points": len(rows)},
                        t_analysis=t1)

