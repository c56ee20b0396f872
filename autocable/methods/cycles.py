"""Periodic orbits from a Hopf point: PyCont's LC-C (AUTO collocation), Floquet multipliers from the
variational equations over one period (cross-checked with AUTO's), and LPC/PD/NS from multiplier
crossings (`continue_cycles`).

``engine="compiled"`` hands the run to `autocable.methods.compiled_cycles` (autocable's own
collocation on the C kernel); both engines build their records with `cycle_result`."""
from __future__ import annotations

import math
import time
import warnings

import numpy as np

from autocable.codegen import compat
from autocable.codegen.pydstool import continuation_system, pydstool_cache_dir
from autocable.methods.continuation_chart import _build_branch, _Chart
from autocable.methods.continuation_problem import ContinuationResult, ContinuationSettings, Progress, _resolve
from autocable.methods.pycont_driver import _one_line
from autocable.methods.system import System
from autocable.results import EndPoint, SpecialPoint, stability_measure


def _monodromy(system: System, x0, p, T: float, rtol: float, samples: int = 400):
    """Integrate x' = f, Phi' = J Phi over one period: (Phi(T), x(T), dense samples of x)."""
    from scipy.integrate import solve_ivp

    n = system.dimension

    def rhs(_t, z):
        x = z[:n]
        Phi = z[n:].reshape(n, n)
        return np.concatenate([system.f(x, p), (system.jac(x, p) @ Phi).ravel()])

    if T <= 0 or not np.any(np.asarray(x0) != 0) and not np.any(system.f(x0, p)):
        # A degenerate cycle (the Hopf point itself): the monodromy of an equilibrium is exp(J T).
        from scipy.linalg import expm
        x0 = np.asarray(x0, float)
        return expm(system.jac(x0, p) * T), x0.copy(), np.tile(x0, (samples + 1, 1))
    z0 = np.concatenate([np.asarray(x0, float), np.eye(n).ravel()])
    ts = np.linspace(0.0, T, samples + 1)
    sol = solve_ivp(rhs, (0.0, T), z0, method="DOP853", t_eval=ts, rtol=rtol,
                    atol=rtol * (np.max(np.abs(x0)) + 1e-300) * 1e-2)
    if sol.status < 0 or sol.y.shape[1] != len(ts):
        raise RuntimeError(sol.message)
    return sol.y[n:, -1].reshape(n, n), sol.y[:n, -1], sol.y[:n].T


def _crossing_distance(mults: np.ndarray, kind: str) -> float:
    """Signed distance to the unit circle of the non-trivial multiplier that crosses it at an
    LPC (real, through +1), PD (real, through -1) or NS (complex pair)."""
    rest = np.delete(mults, int(np.argmin(np.abs(mults - 1.0))))
    real = np.abs(rest.imag) < 1e-7
    if kind == "LPC":
        d = rest[real].real - 1.0
    elif kind == "PD":
        d = -rest[real].real - 1.0
    else:
        d = np.abs(rest[~real]) - 1.0
    return float(d[np.argmin(np.abs(d))]) if d.size else 1.0


def _genuine_crossing(kind: str, m0: np.ndarray, m1: np.ndarray) -> bool:
    """Whether a change of `_cycle_counts` between two cycles is a multiplier crossing the unit
    circle as ``kind`` says, rather than two multipliers meeting on the real axis and leaving it as
    a complex pair (or back). A PD changes the number of real multipliers below -1 by an odd number
    (a collision of two changes it by two). An NS moves a complex pair from inside the circle to
    outside (or back), with an argument above 1e-3 rad: at a fold of cycles the double multiplier
    +1 splits into 1 +- 1e-6 i, a 1:1 resonance, not a torus bifurcation. An LPC is taken as counted."""
    def parts(m):
        m = np.asarray(m, complex)
        r = np.delete(m, int(np.argmin(np.abs(m - 1.0))))
        real = np.abs(r.imag) <= 1e-7 * np.maximum(np.abs(r), 1.0)
        cplx = r[~real]
        return (int(np.sum(real & (r.real < -1))), int(np.sum(np.abs(cplx) > 1)), int(np.sum(np.abs(cplx) < 1)),
                cplx)

    n0, out0, in0, c0 = parts(m0)
    n1, out1, in1, c1 = parts(m1)
    if kind == "PD":
        return (n1 - n0) % 2 == 1
    if kind == "NS":
        moved = out1 - out0
        return (moved != 0 and moved % 2 == 0 and in1 - in0 == -moved and c0.size and c1.size
                and min(np.min(np.abs(np.angle(c0))), np.min(np.abs(np.angle(c1)))) > 1e-3)
    return True


def _cycle_counts(mults: np.ndarray) -> tuple[int, int, int]:
    """(real > 1, real < -1, complex outside) counts of the non-trivial multipliers."""
    if mults.size == 0 or not np.all(np.isfinite(mults)):
        return (-1, -1, -1)
    rest = np.delete(mults, int(np.argmin(np.abs(mults - 1.0))))
    tol = 1e-7
    real = np.abs(rest.imag) <= tol * np.maximum(np.abs(rest), 1.0)
    return (int(np.sum(real & (rest.real > 1))), int(np.sum(real & (rest.real < -1))),
            int(np.sum(~real & (np.abs(rest) > 1))))


#: The cycle engines: PyCont's LC-C (AUTO) or autocable's own collocation on the C kernel.
CYCLE_ENGINES = ("pycont", "compiled")


def continue_cycles(source: ContinuationResult, hopf: str | SpecialPoint,
                    settings: ContinuationSettings | None = None, *, name: str | None = None,
                    progress: Progress | None = None, engine: str = "pycont") -> ContinuationResult:
    """Periodic orbits born at the Hopf point ``hopf`` of ``source`` (PyCont LC-C, AUTO collocation
    with ``ntst`` intervals of ``ncol`` points), in the continued parameter's range.

    ``engine="compiled"``: the same records from autocable's own collocation on the C kernel
    (`autocable.methods.compiled_cycles`), no PyDSTool.

    Per cycle: the period, the min/max of every amplitude over the cycle (from a dense integration of
    one period started on AUTO's profile), the Floquet multipliers from the variational equations
    over that period (cross-checked with AUTO's: ``info["auto_multiplier_max_diff"]``), stability
    (every non-trivial multiplier inside the unit circle), and LPC/PD/NS from multiplier crossings.
    The branch ends at the range, at ``cycle_max_points``, when AUTO fails (NaNs) or when the period
    exceeds ``max_period_ratio`` times the Hopf period (a homoclinic approach, Sect. 5)."""
    if engine not in CYCLE_ENGINES:
        raise ValueError(f"engine must be one of {list(CYCLE_ENGINES)}, got {engine!r}")
    if engine == "compiled":
        from autocable.methods.compiled_cycles import continue_cycles_compiled
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


def _sampled_extremes(sysm: System, samples) -> tuple[tuple[float, float], tuple[float, float]]:
    """((a1_min, a2_min), (a1_max, a2_max)) over the sampled states of a cycle (NaN for a missing a2)."""
    amps = sysm.amplitude_values(samples)
    lo, hi = [math.nan, math.nan], [math.nan, math.nan]
    for k, a in enumerate(amps[:2]):
        a = np.asarray(a) * np.ones(len(samples))
        lo[k], hi[k] = float(np.min(a)), float(np.max(a))
    return (lo[0], lo[1]), (hi[0], hi[1])


def cycle_result(name: str, problem, settings: ContinuationSettings, chart: _Chart, X, P, periods, mults,
                 amin, amax, auto_labels, side: EndPoint | tuple[EndPoint, ...], info: dict, timings: dict,
                 t_analysis: float | None = None, first_is_hopf: bool = True) -> ContinuationResult:
    """The cycle branch record from per-cycle data (both engines): x(0), the parameter vector, the
    period, the Floquet multipliers and the amplitude extremes of every cycle (the first one is the
    Hopf point, a degenerate cycle); stability (every non-trivial multiplier inside the unit circle)
    and LPC/PD/NS from multiplier crossings, located by linear interpolation between two cycles.

    ``auto_labels``: AUTO's (type, index) list to compare with (PyCont engine), or None (compiled
    engine: ``confirmed_by_pycont`` stays None). ``timings["analysis_s"]`` is measured from
    ``t_analysis`` when given. ``side``: the branch's end, or its ends (a branch continued both ways
    from a given orbit, ``first_is_hopf=False``)."""
    sysm = chart.system
    n = sysm.dimension
    cols = {c: [] for c in ("period", "a1_min", "a1_max", "a2_min", "a2_max")}
    stable = []
    mults = [np.asarray(m_, complex) for m_ in mults]
    for T, lo_, hi_, mu in zip(periods, amin, amax, mults):
        for k in (0, 1):
            cols[f"a{k + 1}_min"].append(float(lo_[k]))
            cols[f"a{k + 1}_max"].append(float(hi_[k]))
        cols["period"].append(float(T))
        m = stability_measure("cycle", mu)
        stable.append(bool(math.isfinite(m) and m < 1.0))
    auto_list = list(auto_labels or ())
    # Bifurcations of cycles from multiplier crossings, compared with AUTO's labels.
    specials = []
    counts = [_cycle_counts(m) for m in mults]
    counters: dict[str, int] = {}
    used = set()
    for i in range(len(X) - 1):
        c0, c1 = counts[i], counts[i + 1]
        if -1 in c0 or -1 in c1 or (i == 0 and first_is_hopf):
            continue  # the first point is the Hopf point itself (a degenerate cycle)
        for slot, kind in enumerate(("LPC", "PD", "NS")):
            if c0[slot] == c1[slot] or not _genuine_crossing(kind, mults[i], mults[i + 1]):
                continue
            match = next((m for m, (t, j) in enumerate(auto_list)
                          if m not in used and t == kind and abs(j - (i + 0.5)) <= 2), None)
            if match is not None:
                used.add(match)
            counters[kind] = counters.get(kind, 0) + 1
            # Linear interpolation in the distance of the crossing multiplier to the unit circle.
            d0, d1 = _crossing_distance(mults[i], kind), _crossing_distance(mults[i + 1], kind)
            s = d0 / (d0 - d1) if d0 != d1 else 0.5
            s = min(max(s, 0.0), 1.0)
            x = (1 - s) * X[i] + s * X[i + 1]
            p = (1 - s) * P[i] + s * P[i + 1]
            amps = [(1 - s) * cols[f"a{k}_max"][i] + s * cols[f"a{k}_max"][i + 1] for k in (1, 2)]
            if auto_labels is None:
                confirmed, note = None, ""
            else:
                confirmed = match is not None
                note = "" if match is not None else "; not in AUTO's list (AUTO missed it)"
            specials.append(SpecialPoint(
                branch=name, type=kind, label=f"{kind}{counters[kind]}", parameter=problem.parameter,
                value=float(p[chart.k]), a1=amps[0], a2=amps[1], state=tuple(x),
                parameters=sysm.parameter_dict(p), index=i, converged=False,
                confirmed_by_pycont=confirmed, origin="autocable",
                message="located by linear interpolation of the crossing multiplier between two cycles" + note,
                extra={"period": (1 - s) * cols["period"][i] + s * cols["period"][i + 1],
                       "multipliers": [complex(z) for z in mults[i + 1]]}))
    for m, (t, j) in enumerate(auto_list):
        if m in used or j >= len(X):
            continue
        counters[t] = counters.get(t, 0) + 1
        specials.append(SpecialPoint(
            branch=name, type=t, label=f"{t}{counters[t]}", parameter=problem.parameter,
            value=float(P[j][chart.k]), a1=cols["a1_max"][j], a2=cols["a2_max"][j], state=tuple(X[j]),
            parameters=sysm.parameter_dict(P[j]), index=j, converged=False, confirmed_by_pycont=True,
            origin="pycont", message=f"AUTO reports {t} here; autocable's multipliers show no crossing"))
    specials.sort(key=lambda s_: s_.index)
    X = np.array(X, float).reshape(len(X), n)
    P = np.array(P, float).reshape(len(X), len(sysm.parameters))
    ev = np.array(mults, dtype=complex).reshape(len(X), n) if mults else np.zeros((0, n), complex)
    branch = _build_branch(name, "cycle", chart, X, P, np.array(stable, bool), ev, tuple(specials),
                           side if isinstance(side, tuple) else (side,),
                           info, extra_columns=cols)
    # For cycles the a1, a2 columns hold the maxima over the cycle (the plotted upper envelope).
    table = dict(branch.table)
    for k in (1, 2):
        if f"a{k}" in table:
            table[f"a{k}"] = np.asarray(cols[f"a{k}_max"], float)
    branch = branch.replace(table=table)
    timings = dict(timings)
    if t_analysis is not None:
        timings["analysis_s"] = time.perf_counter() - t_analysis
    return ContinuationResult(branch, problem, settings, timings)
