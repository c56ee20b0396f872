"""Two-parameter curves through a labelled point: folds (`continue_folds`, PyCont's LP-C) and Hopf
points (`continue_hopf`, H-C2), every point refined on autocable's defining system
(`autocable.methods.continuation.curve_chart`) and checked with the exact Jacobian, codimension-2 points from
autocable's test functions compared with PyCont's labels."""
from __future__ import annotations

import math
import time
from typing import Sequence

import numpy as np

from autocable.codegen.pydstool import continuation_system
from autocable.errors import CacheError, ComputationError
from autocable.methods.continuation.events import _critical_pair, _fold_check, _hopf_check
from autocable.methods.continuation.chart import _build_branch, _Chart, _correct, _locate, _sign, _sign_changes, _tangent
from autocable.methods.continuation.problem import (ContinuationResult, ContinuationSettings, Progress,
                                                    StartError, _resolve)
from autocable.methods.continuation.curve_chart import _CURVES, _classify_curve_point, _curve_tests, _CurveChart
from autocable.methods.continuation.pycont_driver import _one_line, _pycont_curve, _Side
from autocable.results import EndPoint, SpecialPoint


#: PyDSTool generator behind LP-C/H-C2: "Dopri" compiles the scaled field once (cached by content hash).
_CURVE_GENERATOR = "Dopri"
#: PyCont's bordered test functions draw random borders from numpy's global generator: seeded
#: (and the caller's state restored) so that a curve is the same on every run.
_PYCONT_SEED = 1729


def _analyse_curve(chart: _CurveChart, Ys: list[np.ndarray], settings: ContinuationSettings,
                   branch_name: str, pycont_special: Sequence, fixed: Sequence[int] = (),
                   bt_ends: Sequence[int] = (), lam_bounds=None):
    """Polish every point on autocable's defining system, check it independently (det J = 0 for a
    fold, a pair on the imaginary axis for a Hopf point), locate codimension-2 points by sign
    changes of `_curve_tests` and compare them with PyCont's labels. ``fixed`` are indices of
    points already located by autocable (the start, a BT end): not moved. An end on a range
    boundary (``lam_bounds``) is refined on that boundary. ``bt_ends`` are ends of
    a Hopf curve at a Bogdanov-Takens point (omega = 0 there: not checked for an imaginary pair)."""
    sysm = chart.system
    n = sysm.dimension
    fixed = set(fixed)
    polished, moved = [], 0
    for i, Y in enumerate(Ys):
        Y = np.asarray(Y, float)
        if i in fixed or len(Ys) < 2:
            polished.append(Y.copy())
            continue
        a, b = max(i - 1, 0), min(i + 1, len(Ys) - 1)
        t = Ys[b] - Ys[a]
        if lam_bounds is not None and i in (0, len(Ys) - 1):
            for col, (lo, hi) in zip((-2, -1), lam_bounds):
                if min(abs(Y[col] - lo), abs(Y[col] - hi)) <= 1e-12:
                    t = np.zeros_like(Y)
                    t[col] = 1.0          # keep the end on the boundary it was put on
        if not np.linalg.norm(t) > 0:
            polished.append(Y.copy())
            continue
        Yp, ok = _correct(chart.at(Y), Y, t / np.linalg.norm(t), settings.newton_tol, maxiter=8)
        if ok and np.linalg.norm(Yp - Y) <= 1e-6 * (1.0 + np.linalg.norm(Y)):
            polished.append(Yp)
        else:
            polished.append(Y.copy())
            moved += 1
    Ys = polished
    m = len(Ys)
    X = np.array([chart.to_phys(Y)[0] for Y in Ys]).reshape(m, n)
    P = np.array([chart.to_phys(Y)[1] for Y in Ys]).reshape(m, len(sysm.parameters))
    eig = np.zeros((m, n), dtype=complex)
    detJ, omega, check, stable = np.zeros(m), np.full(m, math.nan), np.zeros(m), np.zeros(m, bool)
    tests: dict[str, list[float]] = {}
    ref = None
    refs = []
    for i, Y in enumerate(Ys):
        J = sysm.jac(X[i], P[i])
        ev = np.linalg.eigvals(J)
        eig[i] = ev[np.lexsort((-ev.imag, -ev.real))]
        detJ[i] = np.linalg.det(J)
        if chart.kind == "fold":
            check[i] = _fold_check(J)
            rest = np.delete(ev, int(np.argmin(np.abs(ev))))
        else:
            _, w, check[i] = _hopf_check(ev, np.linalg.norm(J))
            omega[i] = w if w > 0 else math.nan
            rest = np.delete(ev, list(_critical_pair(ev)))
        stable[i] = bool(rest.size == 0 or np.max(rest.real) < 0)
        vals, vw = _curve_tests(chart, Y, ref)
        ref = vw
        refs.append(vw)
        for k, v in vals.items():
            tests.setdefault(k, [math.nan] * m)[i] = v
    failures = [i for i in range(m) if not check[i] <= settings.curve_check_tol and i not in bt_ends]
    # Codimension-2 points: sign changes of autocable's test functions, located on the curve.
    found, rejected = [], []
    for i in bt_ends:
        accepted, why, extra = _classify_curve_point(chart, "BT", Ys[i])
        if accepted:
            found.append((i, "BT", Ys[i], True, dict(extra, end_of_curve=True)))
        else:
            rejected.append(("BT", chart.values(Ys[i]), why))
    for kind in ("CP", "BT", "ZH", "GH", "DH"):
        if kind not in tests:
            continue
        for i in _sign_changes(tests[kind]):
            j = i + 1
            while j < m - 1 and _sign(tests[kind][j]) == 0:
                j += 1
            Ya, Yb = Ys[i], Ys[j]
            if kind == "GH" and not (math.isfinite(tests["GH"][i]) and math.isfinite(tests["GH"][j])):
                continue
            ref_i = refs[i]

            def tau(Y, kind=kind, ref_i=ref_i):
                return _curve_tests(chart, Y, ref_i)[0].get(kind, math.nan)
            Y, ok = _locate(chart.at(Ya), Ya, Yb, tau, settings.newton_tol)
            accepted, why, extra = _classify_curve_point(chart, kind, Y)
            if not accepted:
                rejected.append((kind, chart.values(Y), why))
                continue
            if kind == "CP":
                extra["normal_form_b"] = tau(Ya)
            if kind == "GH":
                extra["l1"] = 0.0
            if any(f[1] == kind and np.linalg.norm(f[2] - Y) <= 1e-6 * (1 + np.linalg.norm(Y)) for f in found):
                continue  # the same point twice (e.g. the BT that ends a Hopf curve)
            found.append((i, kind, Y, ok, extra))
    # At a BT point of a fold curve the w . v test and ZH's pair-sum test may both vanish: the BT wins.
    bts = [f[2] for f in found if f[1] == "BT"]
    found = [f for f in found if not (f[1] == "ZH" and any(np.linalg.norm(f[2] - b) <= 1e-6 * (1 + np.linalg.norm(b))
                                                            for b in bts))]
    pyc = [(t, np.asarray(Y, float)) for t, Y in pycont_special]
    used: set[int] = set()

    def near(i_seg: int, Y, Yp) -> bool:
        a, b = max(i_seg - 1, 0), min(i_seg + 2, m - 1)
        return np.linalg.norm(Y - Yp) <= max(np.linalg.norm(Ys[b] - Ys[a]), 10 * settings.test_tol)

    entries = []
    for i, kind, Y, ok, extra in found:
        match = next((k for k, (t, Yp) in enumerate(pyc) if k not in used and t == kind and near(i, Y, Yp)), None)
        if match is not None:
            used.add(match)
        msg = "" if ok else "refinement did not bracket a zero: location interpolated"
        if match is None:
            msg = (msg + "; " if msg else "") + "not in PyCont's list (PyCont missed it)"
        entries.append((i, kind, Y, ok, match is not None, "autocable", extra, msg))
    for k, (t, Yp) in enumerate(pyc):
        if k in used:
            continue
        i = int(np.argmin([np.linalg.norm(Y - Yp) for Y in Ys])) if Ys else 0
        ev_p = np.linalg.eigvals(chart.jac(Yp))
        entries.append((i, t, Yp, False, True, "pycont", {"eigenvalues": [complex(e) for e in ev_p]},
                        f"PyCont reports {t} here; autocable's test functions change sign nowhere near it "
                        f"(or its eigenvalues say otherwise): not confirmed"))
    p1, p2 = sysm.parameter_names[chart.k1], sysm.parameter_names[chart.k2]
    specials, counters = [], {}
    for i, kind, Y, ok, confirmed, origin, extra, msg in sorted(entries, key=lambda e: (e[0], e[1])):
        counters[kind] = counters.get(kind, 0) + 1
        x, p = chart.to_phys(Y)
        amps = sysm.amplitude_values(x)
        extra = dict(extra, parameter2=p2, value2=float(p[chart.k2]))
        specials.append(SpecialPoint(
            branch=branch_name, type=kind, label=f"{kind}{counters[kind]}", parameter=p1,
            value=float(p[chart.k1]), a1=float(amps[0]) if amps else math.nan,
            a2=float(amps[1]) if len(amps) > 1 else math.nan, state=tuple(x),
            parameters=sysm.parameter_dict(p), index=int(i), converged=bool(ok),
            confirmed_by_pycont=bool(confirmed), origin=origin, message=msg, extra=extra))
    info = {"check": "sigma_min(J)/sigma_max(J)" if chart.kind == "fold" else
                     "|Re lambda| / ||J||_F of the critical pair (inf: the pair is real)",
            "check_tol": settings.curve_check_tol,
            "check_max": float(max((check[i] for i in range(m) if i not in bt_ends), default=math.nan)),
            "check_failures": failures[:50], "check_failure_count": len(failures),
            "rejected_candidates": [[k, list(v), why] for k, v, why in rejected],
            "points_kept_unpolished": moved}
    cols = {"det_J": detJ, "omega": omega, "check_residual": check}
    return Ys, X, P, eig, stable, tuple(specials), info, cols


def _continue_curve(kind: str, source: ContinuationResult, label: str | SpecialPoint, second_parameter: str,
                    bounds: tuple[float, float], settings: ContinuationSettings | None, name: str | None,
                    directions: str, progress: Progress | None) -> ContinuationResult:
    t0 = time.perf_counter()
    sp0, problem, base_settings = _resolve(source, label)
    settings = settings or base_settings
    want, ctype, _ = _CURVES[kind]
    if sp0.type != want:
        raise ValueError(f"{sp0.name} is a {sp0.type} point; a {kind} curve starts from a {want} point")
    if directions not in ("both", "forward", "backward"):
        raise ValueError(f"directions must be 'both', 'forward' or 'backward', got {directions!r}")
    sysm = problem.system
    p1, p2 = problem.parameter, str(second_parameter)
    if p2 not in sysm.parameter_names:
        raise ValueError(f"{p2!r} is not a parameter of {sysm.name!r} (it has {list(sysm.parameter_names)})")
    if p2 == p1:
        raise ValueError(f"the second parameter must differ from the first ({p1!r})")
    lo2, hi2 = (float(b) for b in bounds)
    if not (math.isfinite(lo2) and math.isfinite(hi2) and lo2 < hi2):
        raise ValueError(f"range of {p2} must be two finite numbers lo < hi, got {bounds}")
    name = name or f"{source.branch.name}_{sp0.label}_{kind}"
    base = sysm.parameter_vector(sp0.parameters)
    k1, k2 = sysm.parameter_names.index(p1), sysm.parameter_names.index(p2)
    for pn, k, (lo, hi) in ((p1, k1, problem.bounds), (p2, k2, (lo2, hi2))):
        if not lo <= base[k] <= hi:
            raise StartError(f"{sp0.name} has {pn} = {base[k]:g}, outside the range [{lo:g}, {hi:g}]")
    x0 = np.asarray(sp0.state, float)
    J0 = sysm.jac(x0, base)
    tscale = 1.0 / float(np.linalg.norm(J0)) if np.linalg.norm(J0) > 0 else 1.0
    chart = _CurveChart(sysm, kind, k1, k2, base, float(problem.state_scale), float(problem.span),
                        hi2 - lo2, tscale)
    Y0 = chart.to_chart(x0, base)
    e2 = np.zeros_like(Y0)
    e2[-1] = 1.0
    Y0c, ok = _correct(chart.at(Y0), Y0, e2, settings.newton_tol)
    if not ok:
        raise StartError(f"{sp0.name} could not be refined on the {kind} curve's defining system "
                         f"(Newton did not converge)")
    Y0 = Y0c
    t = _tangent(chart.DF(Y0))
    lead = -1 if abs(t[-1]) > 1e-12 else -2            # forward: increasing p2 (else p1)
    t = t if t[lead] >= 0 else -t
    lam_bounds = ((chart.lam(1, problem.bounds[0]), chart.lam(1, problem.bounds[1])),
                  (chart.lam(2, lo2), chart.lam(2, hi2)))
    try:
        cont = continuation_system(sysm._scaled_field_2p, _CURVE_GENERATOR,
                                   ics={v: float(y) for v, y in zip(sysm.variables, Y0[:-2])},
                                   pars=chart.pycont_pars())
    except CacheError:
        raise       # an unwritable or full cache: the command's one-line error, not a curve's end
    except Exception as exc:  # noqa: BLE001
        # no engine, no curve: a failed run, as for equilibria (`continue_equilibria`)
        raise ComputationError(f"{name}: PyCont could not be set up: {_one_line(exc)}") from None
    t_setup = time.perf_counter()
    wanted = {"both": ("forward", "backward"), "forward": ("forward",), "backward": ("backward",)}[directions]
    sides = {}
    rng_state = np.random.get_state()
    try:
        for side in wanted:
            if any(sd.reason == "closed" for sd in sides.values()):
                sides[side] = _Side([Y0], [], [None], "closed", "the curve is closed, traversed in the other direction")
                continue
            np.random.seed(_PYCONT_SEED)
            sgn = 1.0 if side == "forward" else -1.0
            sides[side] = _pycont_curve(cont, chart, settings, Y0, sgn * t, lam_bounds, name, side, progress)
    finally:
        np.random.set_state(rng_state)
    t1 = time.perf_counter()
    back = sides.get("backward", _Side([Y0], [], [None], "not_run", ""))
    fwd = sides.get("forward", _Side([Y0], [], [None], "not_run", ""))
    Ys = list(reversed(back.points[1:])) + fwd.points
    fixed = [len(back.points) - 1]                       # the start, refined above
    if back.reason == "neutral_saddle" and len(back.points) > 1:
        fixed.append(0)
    if fwd.reason == "neutral_saddle" and len(fwd.points) > 1:
        fixed.append(len(Ys) - 1)
    bt_ends = ([0] if back.reason == "neutral_saddle" and len(back.points) > 1 else []) \
        + ([len(Ys) - 1] if fwd.reason == "neutral_saddle" and len(fwd.points) > 1 else [])
    Ys, X, P, eig, stable, specials, info, cols = _analyse_curve(
        chart, Ys, settings, name, back.pycont_special + fwd.pycont_special, fixed, bt_ends, lam_bounds)
    start_index = len(back.points) - 1
    v1, v2 = chart.values(Ys[0]), chart.values(Ys[-1])
    where = "; the curve ends at ({}, {}) = ({:.8g}, {:.8g})"
    ends = (EndPoint("backward", back.reason, v1[0], len(back.points) - 1,
                     back.message + (where.format(p1, p2, *v1) if back.reason != "not_run" else "")),
            EndPoint("forward", fwd.reason, v2[0], len(fwd.points) - 1,
                     fwd.message + (where.format(p1, p2, *v2) if fwd.reason != "not_run" else "")))
    info = dict(info, start_index=start_index, started_from=sp0.name, second_parameter=p2,
                second_bounds=[lo2, hi2], state_scale=chart.xscale, time_scale=tscale, pycont_curve=ctype,
                pycont_restarts={k: getattr(sd, "restarts", 0) for k, sd in sides.items()})
    ch1 = _Chart(sysm, k1, base, chart.xscale, chart.s1)
    branch = _build_branch(name, "equilibrium", ch1, X, P, stable, eig, specials, ends, info,
                           extra_columns=cols).replace(kind=kind, parameter2=p2)
    t2 = time.perf_counter()
    return ContinuationResult(branch, problem.at(**{p1: float(base[k1])}), settings,
                              {"setup_s": t_setup - t0, "pycont_s": t1 - t_setup, "analysis_s": t2 - t1,
                               "points": len(Ys)})


def continue_folds(source: ContinuationResult, fold: str | SpecialPoint, second_parameter: str,
                   bounds: tuple[float, float], settings: ContinuationSettings | None = None, *,
                   name: str | None = None, directions: str = "both",
                   progress: Progress | None = None) -> ContinuationResult:
    """The curve of folds through the fold ``fold`` (e.g. "LP1") of ``source``, in the plane of the
    source's parameter (over its range) and ``second_parameter`` (over ``bounds``): PyCont's LP-C.

    Returns a branch of kind "fold" (columns: both parameters, the state, a1, a2, det_J,
    check_residual; ``parameter2`` names the second parameter). Every point is refined on
    autocable's own defining system (f = 0 and a bordered test function of J) and checked: the
    ``check_residual`` sigma_min(J)/sigma_max(J) of the exact Jacobian must be <= ``curve_check_tol``
    (failures listed in ``info["check_failures"]``). Cusps (CP), Bogdanov-Takens (BT) and zero-Hopf
    (ZH) points come from autocable's test functions (`_curve_tests`), confirmed by the eigenvalues
    and compared with PyCont's labels (PyCont-only labels kept with ``origin="pycont"``).
    ``directions``: "both", "forward" (increasing second parameter at the start) or "backward".
    The curve stops at either range (itself: PyCont's 'B' stop crashes), at ``curve_max_points``
    per direction, or when PyCont fails (the points before the failure are kept)."""
    return _continue_curve("fold", source, fold, second_parameter, bounds, settings, name, directions, progress)


def continue_hopf(source: ContinuationResult, hopf: str | SpecialPoint, second_parameter: str,
                  bounds: tuple[float, float], settings: ContinuationSettings | None = None, *,
                  name: str | None = None, directions: str = "both",
                  progress: Progress | None = None) -> ContinuationResult:
    """The curve of Hopf points through ``hopf`` (e.g. "H1") of ``source`` in the plane of the
    source's parameter and ``second_parameter``: PyCont's H-C2 (J^2 + omega^2 I singular).

    A branch of kind "hopf" (columns as `continue_folds`, plus the frequency ``omega``). Checked at
    every point: a pair of eigenvalues of the exact Jacobian on the imaginary axis,
    |Re lambda| / ||J||_F <= ``curve_check_tol``. Where the pair turns real (a Bogdanov-Takens
    point, beyond which H-C2 follows neutral saddles) the curve ends with reason "neutral_saddle"
    at the located BT point. Generalized Hopf (GH: l1 = 0, Kuznetsov's l1 from exact derivatives),
    zero-Hopf (ZH: det J = 0) and, for n >= 4, double Hopf (DH) points come from autocable's test
    functions, compared with PyCont's labels."""
    return _continue_curve("hopf", source, hopf, second_parameter, bounds, settings, name, directions, progress)
