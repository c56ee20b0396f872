"""What autocable says about a branch of equilibria, whichever engine made its points (Sect. 5's
stability and special points): the state polished by Newton, stability from the eigenvalues at
every point, LP/BP/H located by the test functions of `events` and refined on the branch, l1 at H,
and the comparison with PyCont's own list. Shared by the PyCont front (`equilibria`) and the
compiled engine (`compiled_equilibria`), so both report through the same code."""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any, Mapping, Sequence

import numpy as np

from autocable.methods.continuation.events import _hopf_test, first_lyapunov
from autocable.methods.continuation.chart import (_Chart, _locate,
                                                  _oriented_tangents, _sign, _sign_changes, _tangent)
from autocable.methods.continuation.problem import (ContinuationSettings,
                                                    EquilibriumProblem, StartError)
from autocable.methods.continuation.system import System
from autocable.results import SpecialPoint


def equilibrium_near(system: System, x0, p, *, tol: float = 1e-12, scale: float = 1.0,
                     maxiter: int = 50) -> tuple[np.ndarray, bool, float]:
    """Newton at fixed parameters from ``x0``: (x, converged, max|f|). The step criterion is relative
    to |x| + ``scale`` (so the trivial solution x = 0 converges too)."""
    x = np.array(x0, dtype=float)
    p = np.asarray(p, float)
    converged = False
    for _ in range(maxiter):
        fx = system.f(x, p)
        try:
            step = np.linalg.solve(system.jac(x, p), fx)
        except np.linalg.LinAlgError:
            break
        x = x - step
        if not np.all(np.isfinite(x)):
            return np.array(x0, float), False, math.inf
        if np.linalg.norm(step) <= tol * (np.linalg.norm(x) + scale):
            converged = True
            break
    res = float(np.max(np.abs(system.f(x, p)))) if x.size else 0.0
    return x, converged, res


@dataclass(frozen=True)
class _Analysis:
    Ys: tuple
    x: np.ndarray
    p: np.ndarray
    eigen: np.ndarray
    stable: np.ndarray
    special: tuple
    info: dict


def _analyse_equilibria(chart: _Chart, Ys: list[np.ndarray], settings: ContinuationSettings,
                        branch_name: str, pycont_special: Sequence | None, pycont_stab: Sequence,
                        skip: Sequence[int] = (), precomputed: Mapping[str, Any] | None = None) -> _Analysis:
    """``pycont_special=None``: no PyCont run (the compiled engine), nothing to compare with.
    ``precomputed``: points already polished, with ``X``, ``P``, ``eigen``, ``stable``, ``T``,
    ``hopf``, ``bdet`` per point (the compiled engine's arrays); only the special points are located here."""
    sysm = chart.system
    n = sysm.dimension
    polished, moved = [], 0
    for Y in (Ys if precomputed is None else ()):
        x, p = chart.to_phys(Y)
        xp, ok, _ = equilibrium_near(sysm, x, p, tol=settings.newton_tol, scale=chart.xscale, maxiter=8)
        # Keep the point PyCont gave when Newton at fixed parameter wanders (next to a fold).
        if ok and np.linalg.norm(xp - x) <= 1e-6 * (np.linalg.norm(x) + chart.xscale):
            polished.append(chart.to_chart(xp, chart.value(Y[-1])))
        else:
            polished.append(np.asarray(Y, float).copy())
            moved += 1
    if precomputed is not None:
        # The compiled engine's rows of one float array: nothing to convert.
        Ys = list(Ys)
        X, P = precomputed["X"], precomputed["P"]
        eig, stable, T, hopf = (np.asarray(precomputed[k]) for k in ("eigen", "stable", "T", "hopf"))
    else:
        Ys = polished
        X = np.array([chart.to_phys(Y)[0] for Y in Ys])
        P = np.array([chart.to_phys(Y)[1] for Y in Ys])
        eig = np.zeros((len(Ys), n), dtype=complex)
        hopf = np.zeros(len(Ys))
        for i in range(len(Ys)):
            J = sysm.jac(X[i], P[i])
            ev = np.linalg.eigvals(J)
            eig[i] = ev[np.lexsort((-ev.imag, -ev.real))]
            hopf[i] = _hopf_test(J)
        stable = np.max(eig.real, axis=1) < 0 if n else np.ones(len(Ys), bool)
        T = _oriented_tangents(chart, Ys) if len(Ys) > 1 else np.zeros((len(Ys), n + 1))
    vp = T[:, -1]
    # The branch-point test function det([J_x, J_p; v]) changes sign at simple BPs, not at folds.
    bdet = np.array([np.linalg.det(np.vstack([chart.DF(Y), t])) for Y, t in zip(Ys, T)]) \
        if len(Ys) > 1 and precomputed is None else np.zeros(len(Ys))
    if precomputed is not None and len(Ys) > 1:
        bdet = np.asarray(precomputed["bdet"], float)
    tests = {"LP": vp, "BP": bdet, "H": hopf}
    skip = set(skip)
    candidates = []
    if "LP" in settings.locate or "BP" in settings.locate:
        candidates += [("LP", i) for i in _sign_changes(vp)]
        candidates += [("BP", i) for i in _sign_changes(bdet)]
    if "H" in settings.locate and n >= 2:
        candidates += [("H", i) for i in _sign_changes(hopf)]
    # A pitchfork's new branch turns in the parameter at the BP it passes through: its vp zero is
    # that BP, not a fold.
    bp_segments = {i for t, i in candidates if t == "BP"}
    candidates = [(t, i) for t, i in candidates if not (t == "LP" and i in bp_segments)]
    found = []
    neutral, rejected = [], []
    for kind, i in sorted(candidates, key=lambda c: c[1]):
        j = i + 1
        while j < len(Ys) - 1 and _sign(tests[kind][j]) == 0:
            j += 1
        if i in skip or j in skip:
            continue
        Ya, Yb = Ys[i], Ys[j]
        ref = Yb - Ya
        if kind == "LP":
            def tau(Y, ref=ref):
                v = _tangent(chart.DF(Y))
                return float(v[-1] if v @ ref >= 0 else -v[-1])
        elif kind == "BP":
            def tau(Y, ref=ref):
                return float(np.linalg.det(np.vstack([chart.DF(Y), ref / np.linalg.norm(ref)])))
        else:
            def tau(Y):
                x, p = chart.to_phys(Y)
                return _hopf_test(sysm.jac(x, p))
        # A chart that locates the same test functions itself (the compiled engine's, in C).
        located = getattr(chart, "locate_test", None)
        Y, ok = located(kind, Ya, Yb, settings.newton_tol) if located is not None else \
            _locate(chart, Ya, Yb, tau, settings.newton_tol)
        sv = None
        if kind == "BP":
            # The rank test below on the located point is also `_sharpen_branch_point`'s test for
            # a point that needs no sharpening: one SVD for both.
            sv = np.linalg.svd(chart.DF(Y), compute_uv=False)
            if not (ok and sv[-1] <= 1e-7 * sv[0]):
                Y, ok = _sharpen_branch_point(chart, Y, ok, float(np.linalg.norm(ref)), settings.newton_tol)
                sv = None
        x, p = chart.to_phys(Y)
        J = chart.jac(x, p)
        ev = np.linalg.eigvals(J)
        extra: dict[str, Any] = {"eigenvalues": [complex(e) for e in ev]}
        message = ""
        if kind in ("LP", "BP"):
            # Fold or branch point is decided by the rank of [J_x, J_p]: full at a fold, deficient at
            # a BP (where a pitchfork's new branch also turns in the parameter: vp changes sign there).
            if sv is None:
                sv = np.linalg.svd(chart.DF(Y), compute_uv=False)
            deficient = sv[-1] <= 1e-7 * sv[0]
            if kind == "BP" and not deficient:
                rejected.append(("BP", chart.value(Y[-1])))
                continue
            kind = "BP" if deficient else "LP"
            # [J_x, J_p] = 0 exactly at a pitchfork of a field odd in the state on its trivial
            # branch (Fig. 3's galloping onset, a = 0): rank 0, not 0/0
            extra["rank_test"] = float(sv[-1] / sv[0]) if sv[0] > 0 else (0.0 if sv[0] == 0 else math.nan)
        if kind == "H":
            # Which pair sums to ~0: a complex pair is a Hopf point, a real pair a neutral saddle.
            best, pair = math.inf, None
            for a in range(n):
                for b in range(a + 1, n):
                    s_ = abs(ev[a] + ev[b])
                    if s_ < best:
                        best, pair = s_, (ev[a], ev[b])
            scale_ev = max(np.max(np.abs(ev)), 1e-300)
            if pair is None or abs(pair[0].imag) <= 1e-8 * scale_ev:
                neutral.append(chart.value(Y[-1]))
                continue
            try:
                l1, w = first_lyapunov(sysm, x, p)
                extra.update(l1=l1, omega=w, period=2 * math.pi / w,
                             criticality="supercritical" if l1 < 0 else "subcritical")
            except (np.linalg.LinAlgError, ValueError) as exc:
                extra.update(omega=abs(pair[0].imag), period=2 * math.pi / abs(pair[0].imag))
                message = f"l1 not computed: {exc}"
        if kind == "LP":
            extra["tangent"] = [float(v) for v in _tangent(chart.DF(Y))]
        elif kind == "BP":
            # At a BP the kernel is 2-D: the old branch's direction is the chord across it.
            extra["tangent"] = [float(v) for v in ref / np.linalg.norm(ref)]
        if any(f[0] == kind and np.linalg.norm(f[2] - Y) <= 1e-6 * (1 + np.linalg.norm(Y)) for f in found):
            continue  # the same point seen by two test functions
        if not ok:
            message = (message + "; " if message else "") + "refinement did not bracket a zero: location interpolated"
        found.append((kind, i, Y, ok, extra, message))
    # A pitchfork's new branch turns in the parameter at the BP it crosses; when the vp zero and
    # the BP fall in neighbouring segments the LP found there is that BP again.
    bps = [(f[1], f[2]) for f in found if f[0] == "BP"]
    merged = [f for f in found if f[0] == "LP" and any(abs(f[1] - i) <= 2 or np.linalg.norm(f[2] - b) <= 1e-3
                                                      for i, b in bps)]
    found = [f for f in found if not any(f is m for m in merged)]
    # PyCont's list against ours.
    specials = []
    counters: dict[str, int] = {}
    pyc = [(t, np.asarray(Y, float)) for t, Y in (pycont_special or ())]
    used = set()

    def near(i_seg: int, Y, Yp) -> bool:
        a, b = max(i_seg - 1, 0), min(i_seg + 2, len(Ys) - 1)
        scale_ = max(np.linalg.norm(Ys[b] - Ys[a]), 10 * settings.test_tol)
        return np.linalg.norm(Y - Yp) <= scale_

    entries = []
    for kind, i, Y, ok, extra, message in found:
        match = None
        for m, (t, Yp) in enumerate(pyc):
            if m not in used and t == kind and near(i, Y, Yp):
                match = m
                break
        if match is not None:
            used.add(match)
        entries.append((i, kind, Y, ok, None if pycont_special is None else match is not None, "autocable",
                        extra, message if match is not None or pycont_special is None else
                        (message + "; " if message else "") + "not in PyCont's list (PyCont missed it)"))
    for m, (t, Yp) in enumerate(pyc):
        if m in used:
            continue
        i = int(np.argmin([np.linalg.norm(Y - Yp) for Y in Ys]))
        entries.append((i, t, Yp, False, True, "pycont", {},
                        f"PyCont reports {t} here; autocable's test functions change sign nowhere "
                        f"near it: not confirmed (PyCont's point may be spurious)"))
    for i, kind, Y, ok, confirmed, origin, extra, message in sorted(entries, key=lambda e: (e[0], e[1])):
        counters[kind] = counters.get(kind, 0) + 1
        x, p = chart.to_phys(Y)
        amps = sysm.amplitude_values(x)
        specials.append(SpecialPoint(
            branch=branch_name, type=kind, label=f"{kind}{counters[kind]}",
            parameter=sysm.parameter_names[chart.k], value=chart.value(Y[-1]),
            a1=float(amps[0]) if amps else math.nan, a2=float(amps[1]) if len(amps) > 1 else math.nan,
            state=tuple(x), parameters=sysm.parameter_dict(p), index=int(i), converged=bool(ok),
            confirmed_by_pycont=None if confirmed is None else bool(confirmed), origin=origin, message=message,
            extra=extra))
    checked = [i for i, s in enumerate(pycont_stab) if s is not None]
    disagree = [i for i in checked if (pycont_stab[i] == "S") != bool(stable[i])]
    info = {"pycont_stability_disagreements": len(disagree),
            "pycont_stability_disagreement_points": disagree[:50],
            "pycont_stability_checked": len(checked),
            "neutral_saddles": neutral, "rejected_candidates": rejected,
            "lp_merged_into_bp": [chart.value(f[2][-1]) for f in merged], "points_kept_unpolished": moved}
    return _Analysis(tuple(Ys), X, P, eig, stable, tuple(specials), info)


def _sharpen_branch_point(chart: _Chart, Y: np.ndarray, ok: bool, reach: float, tol: float,
                          maxiter: int = 20) -> tuple[np.ndarray, bool]:
    """A branch point located by `_locate` made exact, when it is not yet rank-deficient to 1e-7
    or `_locate` did not bracket it (``ok`` False).

    Next to a BP both branches cross the chord's normal hyperplane, so the corrections of
    `_locate` are ill-conditioned there and its zero of det [DF; chord] can land ~1e-6 off the BP
    (or on the other branch), depending on how close a computed point falls to it. Newton on the
    regular defining system of a simple BP (Govaerts, Numerical Methods for Bifurcations, Sect.
    6.2; MATCONT's EP-curve BP locator): F(Y) + beta psi = 0, DF(Y)^T psi = 0, psi.psi = 1, in
    (Y, beta, psi), with the derivative of DF^T psi by central differences of DF. The refined
    point is used when Newton converges within ``reach`` (the bracket's length) of the located
    point with sigma_min/sigma_max of DF below 1e-7; otherwise the located point is kept."""
    DF = chart.DF(Y)
    sv = np.linalg.svd(DF, compute_uv=False)
    if ok and sv[-1] <= 1e-7 * sv[0]:
        return Y, ok
    U_ = np.linalg.svd(DF)[0]
    n = DF.shape[0]
    psi = U_[:, -1].copy()
    Z = np.concatenate([Y, [0.0], psi])
    h = 1e-6
    for _ in range(maxiter):
        Yz, beta, psi = Z[:n + 1], Z[n + 1], Z[n + 2:]
        DF = chart.DF(Yz)
        G = np.concatenate([chart.F(Yz) + beta * psi, DF.T @ psi, [psi @ psi - 1.0]])
        A = np.zeros((2 * n + 2, 2 * n + 2))
        A[:n, :n + 1] = DF
        A[:n, n + 1] = psi
        A[:n, n + 2:] = beta * np.eye(n)
        for k in range(n + 1):
            e = np.zeros(n + 1)
            e[k] = h
            A[n:2 * n + 1, k] = (chart.DF(Yz + e) - chart.DF(Yz - e)).T @ psi / (2 * h)
        A[n:2 * n + 1, n + 2:] = DF.T
        A[2 * n + 1, n + 2:] = 2 * psi
        try:
            step = np.linalg.solve(A, G)
        except np.linalg.LinAlgError:
            return Y, ok
        Z = Z - step
        if not np.all(np.isfinite(Z)):
            return Y, ok
        if np.linalg.norm(step[:n + 1]) <= tol * (1.0 + np.linalg.norm(Z[:n + 1])):
            Yr = Z[:n + 1]
            sv = np.linalg.svd(chart.DF(Yr), compute_uv=False)
            if np.linalg.norm(Yr - Y) <= reach and sv[-1] <= 1e-7 * sv[0]:
                return Yr, True
            return Y, ok
    return Y, ok


#: The equilibrium engines: PyCont's EP-C, or autocable's compiled C kernel.
def _relabel(points: Sequence[SpecialPoint]) -> tuple[SpecialPoint, ...]:
    """Number the labels of each type in branch order (BP0, the switching junction, keeps its name)."""
    counters: dict[str, int] = {}
    out = []
    for s_ in points:
        if s_.label.endswith("0") and s_.label[:-1] == s_.type:
            out.append(s_)
            continue
        counters[s_.type] = counters.get(s_.type, 0) + 1
        out.append(replace(s_, label=f"{s_.type}{counters[s_.type]}"))
    return tuple(out)


def _start_on_chart(problem: EquilibriumProblem, settings: ContinuationSettings, start, chart,
                    fields, newton=None, tangent=None) -> tuple[np.ndarray, np.ndarray]:
    """The start state corrected by Newton at the run's start value, on ``chart``, and the unit
    tangent there, oriented towards increasing parameter. ``fields`` gives f and jac: the
    `System` (PyCont engine) or the compiled kernel; ``newton`` (x0, p, tol=, scale=) -> (x,
    converged, residual) replaces `equilibrium_near` on ``fields`` and ``tangent`` (Y) -> the unit
    tangent with a positive parameter component (or None) the SVD, when given (the compiled
    engine's C versions of both)."""
    sysm = problem.system
    x0 = np.zeros(sysm.dimension) if start is None else np.asarray(start, float)
    if x0.shape != (sysm.dimension,):
        raise StartError(f"start state must have {sysm.dimension} entries {sysm.variables}, got {x0.shape}")
    x, ok, res = (newton or (lambda *a, **k: equilibrium_near(fields, *a, **k)))(
        x0, chart.p(0.0), tol=settings.newton_tol, scale=chart.xscale)
    if not ok:
        raise StartError(f"Newton from the start state did not converge to an equilibrium at "
                         f"{problem.parameter} = {chart.value(0.0):g} (residual {res:.3g}); start by "
                         f"integration or from a labelled point")
    Y0 = chart.to_chart(x, chart.value(0.0))
    v0 = tangent(Y0) if tangent is not None else None
    if v0 is not None and v0[-1] > 1e-12:
        return Y0, v0
    v0 = _tangent(chart.DF(Y0))
    if abs(v0[-1]) > 1e-12:
        v0 = v0 * np.sign(v0[-1])
    return Y0, v0


