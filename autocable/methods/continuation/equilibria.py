"""Equilibria: Newton at fixed parameters (`equilibrium_near`), settling by integration (`settle`),
EP-C continuation (`continue_equilibria`), branch switching at a BP (`switch_branch`), and the
analysis of a branch: polishing, stability from the eigenvalues, LP/BP/H located by autocable's
test functions and compared with PyCont's list."""
from __future__ import annotations

import math
import time
from dataclasses import replace
from typing import Mapping

import numpy as np

from autocable.methods.continuation.chart import (_build_branch, _Chart, _correct, _tangent)
from autocable.methods.continuation.compiled_equilibria import continue_equilibria_compiled, switch_branch_compiled
from autocable.methods.continuation.equilibrium_analysis import _analyse_equilibria, _relabel, _start_on_chart, equilibrium_near
from autocable.methods.continuation.settings import ENGINES
from autocable.methods.continuation.problem import (ContinuationResult, ContinuationSettings,
                                                    EquilibriumProblem, Progress, StartError, _resolve)
from autocable.methods.continuation.pycont_driver import _contclass, _pycont_equilibria, _Side
from autocable.methods.continuation.system import System
from autocable.results import EndPoint, SpecialPoint


#: The largest modal amplitude a start may have or an integration may reach: a_k is the peak
#: displacement over the cable length, and the cubic model holds only far below it.
AMPLITUDE_LIMIT = 1.0


def settle(system: System, values: Mapping[str, float], x0, *, scale: float = 1.0,
           chunks: int = 40, patience: int = 4, rtol: float = 1e-9, engine: str = "pycont",
           seconds: float = 60.0, evaluations: int = 2_000_000) -> np.ndarray:
    """The stable equilibrium reached by integrating x' = f(x; p) from ``x0``, refined by Newton.

    Integrates (scipy LSODA with the exact Jacobian) in chunks of 25 / (mean damping rate) until the
    Newton step from the current state is below 1e-6 of |x| + ``scale`` and every eigenvalue has a
    negative real part. Raises `StartError` when the orbit leaves a ball of 1e6 (|x0| + ``scale``),
    when the Newton step has not halved for ``patience`` chunks in a row (the orbit is going round
    a cycle, or creeping along a family of equilibria), or after ``chunks`` chunks.

    ``engine = "compiled"`` evaluates f and J in the system's C kernel (the same functions, tested
    equal to the sympy ones), otherwise they are the numpy ones.

    Budget: ``seconds`` of wall time and ``evaluations`` of f (`ContinuationSettings.settle_seconds`,
    ``settle_evaluations``); spending either raises `BudgetExceeded`. A start or a state with an
    amplitude beyond `AMPLITUDE_LIMIT` raises `StartError`."""
    from scipy.integrate import solve_ivp

    from autocable.methods.continuation.settings import Budget

    if _engine(engine) == "compiled":
        from autocable.codegen.ckernel import compiled_kernel
        rhs = compiled_kernel(system)
    else:
        rhs = system
    p = system.parameter_vector(values)
    y = np.array(x0, dtype=float)
    start = np.round(np.asarray(x0, float), 12).tolist()
    if not np.all(np.isfinite(y)) or max(system.amplitude_values(y), default=0.0) > AMPLITUDE_LIMIT:
        raise StartError(f"the start {start} has an amplitude beyond {AMPLITUDE_LIMIT:g} (a_k is the "
                         "peak displacement over the cable length); start from amplitudes of the "
                         "response, e.g. 5e-3")
    rate = abs(np.trace(system.jac(y, p))) / max(system.dimension, 1)
    if not rate > 0:
        rate = 1.0
    chunk = 25.0 / rate
    bound = 1e6 * (np.linalg.norm(y) + scale)
    t, best, stale = 0.0, math.inf, 0
    budget = Budget(f"integrating the AME from {start} to a steady state", seconds, evaluations,
                    "raise settle_seconds or settle_evaluations in the run's steps, or start from other "
                    "amplitudes")

    def f(_t, z):
        budget.spent += 1        # counted here, checked per step in `grown`: an exception raised
        return rhs.f(z, p)       # inside LSODA's Fortran callback would print a C-level traceback

    def grown(tt, z):
        # stops the integration where the orbit leaves the model's range (a_k <= AMPLITUDE_LIMIT)
        # or the ball of `bound`, instead of following a blow-up to its end; and at the budget
        budget.check(at=f"(t = {tt:.6g})")
        return min(bound - float(np.linalg.norm(z)),
                   AMPLITUDE_LIMIT - max(system.amplitude_values(z), default=0.0))
    grown.terminal = True

    for _ in range(int(chunks)):
        sol = solve_ivp(f, (t, t + chunk), y, method="LSODA", events=grown,
                        jac=lambda _t, z: rhs.jac(z, p), rtol=rtol, atol=rtol * scale * 1e-3)
        if sol.status < 0 or not np.all(np.isfinite(sol.y)):
            raise StartError(f"integrating from {start} failed at t = {t:g}: {sol.message}")
        y, t = sol.y[:, -1].copy(), float(sol.t[-1])
        if sol.status == 1 or np.linalg.norm(y) > bound:
            raise StartError(f"integrating from {start}: the orbit diverges "
                             f"(|x| = {np.linalg.norm(y):.3g} at t = {t:g}); start elsewhere")
        J = system.jac(y, p)
        try:
            step = float(np.linalg.norm(np.linalg.solve(J, system.f(y, p))))
        except np.linalg.LinAlgError:
            step = math.inf
        if np.max(np.linalg.eigvals(J).real) < 0 and step <= 1e-6 * (np.linalg.norm(y) + scale):
            x, ok, res = equilibrium_near(system, y, p, scale=scale)
            if ok:
                return x
        if step < 0.5 * best:
            best, stale = step, 0
        else:
            stale += 1
            if stale >= patience:
                break
    a = system.amplitude_values(y)
    raise StartError(f"integrating from {start} did not settle on an equilibrium by "
                     f"t = {t:.6g} (amplitudes now {', '.join(f'{v:.4g}' for v in a)}): the motion may "
                     f"be periodic; start from other amplitudes or from a labelled point")


def _engine(engine: str) -> str:
    if engine not in ENGINES:
        raise ValueError(f"engine must be one of {list(ENGINES)}, got {engine!r}")
    return engine


def continue_equilibria(problem: EquilibriumProblem, settings: ContinuationSettings = ContinuationSettings(),
                        start=None, *, name: str = "EQ", directions: str = "both",
                        progress: Progress | None = None, engine: str = "pycont") -> ContinuationResult:
    """EP-C of ``problem`` from ``start`` (a state vector, default the zero state), both directions.

    ``start`` is refined by Newton at the start parameter value; a start that does not converge
    raises `StartError`. ``directions`` is ``"both"``, ``"forward"`` (increasing parameter) or
    ``"backward"``. The branch runs from the backward end through the start to the forward end.
    ``engine``: ``"pycont"`` (PyCont's EP-C) or ``"compiled"`` (autocable's C kernel,
    `autocable.methods.continuation.compiled_equilibria`; the same analysis and records).
    """
    if _engine(engine) == "compiled":
        return continue_equilibria_compiled(problem, settings, start, name=name, directions=directions,
                                            progress=progress)
    t0 = time.perf_counter()
    sysm = problem.system
    chart = _Chart.of(problem)
    Y0, v0 = _start_on_chart(problem, settings, start, chart, sysm)
    sides = {}
    wanted = {"both": ("forward", "backward"), "forward": ("forward",), "backward": ("backward",)}[directions]
    cont = _contclass(chart, Y0, name)
    t_setup = time.perf_counter()
    for side in wanted:
        if any(sd.reason == "closed" for sd in sides.values()):
            # The other direction went all the way round: this one would retrace it.
            sides[side] = _Side([Y0], [], [None], "closed", "the branch is a closed curve, "
                                                            "traversed in the other direction")
            continue
        d = v0 if side == "forward" else -v0
        sides[side] = _pycont_equilibria(cont, chart, problem, settings, Y0, d, name, side, progress)
    t1 = time.perf_counter()
    back = sides.get("backward", _Side([Y0], [], [None], "not_run", ""))
    fwd = sides.get("forward", _Side([Y0], [], [None], "not_run", ""))
    Ys = list(reversed(back.points[1:])) + fwd.points
    stab = list(reversed(back.pycont_stab[1:])) + fwd.pycont_stab
    an = _analyse_equilibria(chart, Ys, settings, name, back.pycont_special + fwd.pycont_special, stab)
    an = _with_unlocated(an, back.unlocated + fwd.unlocated, problem.parameter)
    ends = (EndPoint("backward", back.reason, chart.value(Ys[0][-1]), len(back.points) - 1, back.message),
            EndPoint("forward", fwd.reason, chart.value(Ys[-1][-1]), len(fwd.points) - 1, fwd.message))
    info = dict(an.info, start_index=len(back.points) - 1, state_scale=chart.xscale)
    if back.unlocated or fwd.unlocated:
        # special points PyCont detected and failed to locate; autocable's test functions did
        info["pycont_unlocated"] = back.unlocated + fwd.unlocated
    branch = _build_branch(name, "equilibrium", chart, an.x, an.p, an.stable, an.eigen, an.special, ends, info)
    t2 = time.perf_counter()
    return ContinuationResult(branch, problem, settings,
                              {"setup_s": t_setup - t0, "pycont_s": t1 - t_setup, "analysis_s": t2 - t1,
                               "points": len(Ys)})


def _with_unlocated(an, unlocated: list, parameter: str):
    """The analysis with the message of each special point PyCont detected but failed to locate
    (`pycont_driver._unlocated_special_point`) saying so, instead of "PyCont missed it"."""
    if not unlocated:
        return an
    special = []
    for sp in an.special:
        for u in unlocated:
            lo, hi = sorted(u[parameter])
            if sp.type == u["type"] and sp.origin == "autocable" and not sp.confirmed_by_pycont \
                    and lo <= sp.value <= hi:
                sp = replace(sp, message=f"PyCont detected this {sp.type} between {parameter} = {lo:.6g} "
                                         f"and {hi:.6g} but could not locate it (its location did not "
                                         f"converge); located by autocable's test functions")
                break
        special.append(sp)
    return replace(an, special=tuple(special))


def switch_branch(source: ContinuationResult, bp: str | SpecialPoint,
                  settings: ContinuationSettings | None = None, *, name: str | None = None,
                  progress: Progress | None = None, engine: str = "pycont") -> ContinuationResult:
    """The branch crossing ``source`` at its branch point ``bp``, continued on both sides of it.
    ``engine`` as in `continue_equilibria`.

    At a BP the kernel of [J_x, J_p] is two-dimensional: it holds the old branch's tangent and the
    new one's. The start points are the BP shifted by +-h along the kernel vector orthogonal to the
    old tangent, corrected onto the new branch (Newton on the hyperplane through them, which is
    parallel to the old branch and so cannot fall back on it); each side is then continued away
    from the BP, and the two are joined through the BP."""
    if _engine(engine) == "compiled":
        return switch_branch_compiled(source, bp, settings, name=name, progress=progress)
    bp, problem, base_settings = _resolve(source, bp)
    settings = settings or base_settings
    if bp.type != "BP":
        raise ValueError(f"{bp.name} is a {bp.type} point, not a branch point")
    name = name or f"{source.branch.name}_{bp.label}"
    t0 = time.perf_counter()
    sysm = problem.system
    chart = _Chart(sysm, sysm.parameter_names.index(problem.parameter),
                   sysm.parameter_vector(bp.parameters), problem.state_scale, problem.span)
    Yb = chart.to_chart(bp.state, bp.value)
    _, s, vt = np.linalg.svd(chart.DF(Yb))
    kernel = vt[-2:]
    old = np.asarray(bp.extra.get("tangent", kernel[0]), float)
    old = kernel.T @ (kernel @ old)
    old /= np.linalg.norm(old)
    w = kernel[0] - (kernel[0] @ old) * old
    if np.linalg.norm(w) < 1e-8:
        w = kernel[1] - (kernel[1] @ old) * old
    w /= np.linalg.norm(w)
    sides = {}
    cont = _contclass(chart, Yb, name)
    t_setup = time.perf_counter()
    for sign, side in ((1, "+"), (-1, "-")):
        if any(sd.reason == "closed" for sd in sides.values()):
            sides[side] = _Side([Yb], [], [None], "closed", "the new branch is a closed curve through "
                                                            f"{bp.name}, traversed from the other side")
            continue
        target = Yb + sign * settings.switch_step * w
        Ys, ok = _correct(chart, target, w, settings.newton_tol)
        if not ok or np.linalg.norm(Ys - Yb) > 10 * settings.switch_step:
            sides[side] = _Side([Yb], [], [None], "no_convergence",
                                f"no branch found at distance {settings.switch_step:g} from {bp.name}: "
                                f"try another switch_step")
            continue
        v = _tangent(chart.DF(Ys))
        v = v if v @ (Ys - Yb) >= 0 else -v
        lo, hi = chart.lam(problem.bounds[0]), chart.lam(problem.bounds[1])
        if not lo <= Ys[-1] <= hi:
            sides[side] = _Side([Yb], [], [None], "range", "the new branch leaves the range at once")
            continue
        sd = _pycont_equilibria(cont, chart, problem, settings, Ys, v, name, "plus" if sign > 0 else "minus",
                                progress)
        sd.points.insert(0, Yb.copy())
        sd.pycont_stab.insert(0, None)
        sides[side] = sd
    t1 = time.perf_counter()
    minus, plus = sides["-"], sides["+"]
    Ys = list(reversed(minus.points[1:])) + plus.points
    stab = list(reversed(minus.pycont_stab[1:])) + plus.pycont_stab
    ib = len(minus.points) - 1
    # The junction is the BP itself: the parameter turns there on a pitchfork's new branch, which is
    # not a fold; it is recorded as the branch point below.
    an = _analyse_equilibria(chart, Ys, settings, name, minus.pycont_special + plus.pycont_special, stab,
                             skip=(ib,))
    junction = SpecialPoint(
        branch=name, type="BP", label="BP0", parameter=bp.parameter, value=bp.value, a1=bp.a1, a2=bp.a2,
        state=bp.state, parameters=bp.parameters, index=ib, converged=bp.converged,
        confirmed_by_pycont=None, origin="autocable", message=f"the branch point {bp.name} this branch was switched from",
        extra={"switched_from": bp.name})
    junction_Y = Yb
    # The junction BP may be seen again by the test functions (and by PyCont): it is BP0.
    others = tuple(s_ for s_ in an.special if not (
        s_.type in ("BP", "LP")
        and np.linalg.norm(chart.to_chart(s_.state, s_.value) - junction_Y) <= 0.5 * settings.switch_step))
    an = replace(an, special=_relabel(tuple(sorted((junction,) + others, key=lambda s_: s_.index))))
    an = _with_unlocated(an, minus.unlocated + plus.unlocated, problem.parameter)
    ends = (EndPoint("-", minus.reason, chart.value(Ys[0][-1]), len(minus.points) - 1, minus.message),
            EndPoint("+", plus.reason, chart.value(Ys[-1][-1]), len(plus.points) - 1, plus.message))
    info = dict(an.info, switched_from=bp.name, bp_index=ib, state_scale=chart.xscale)
    if minus.unlocated or plus.unlocated:
        info["pycont_unlocated"] = minus.unlocated + plus.unlocated
    branch = _build_branch(name, "equilibrium", chart, an.x, an.p, an.stable, an.eigen, an.special, ends, info)
    prob = problem.at(**{problem.parameter: bp.value})
    return ContinuationResult(branch, prob, settings,
                              {"setup_s": t_setup - t0, "pycont_s": t1 - t_setup,
                               "analysis_s": time.perf_counter() - t1, "points": len(Ys)})
