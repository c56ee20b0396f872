"""Two-parameter curves of symmetry-breaking pitchforks (branch points, BP) of a Z2-symmetric system:
`continue_branch_points`, autocable's own pseudo-arclength continuation of a reduced defining system.

Why reduced. At U = 0 the AME (24) is equivariant under (r2, s2) -> -(r2, s2) (eq. (21) without
wind is symmetric in q2), so a2 = 0 is invariant and the Jacobian there is block-diagonal,
J = diag(J_in, J_out) (in-plane rows r1, s1; out-of-plane rows r2, s2). A pitchfork on the
mono-modal branch (where the bi-modal branches of Fig. 6 are born) is where J_out is singular. Its
curve in two parameters (p1, p2) solves

    f_in(x_in, 0; p1, p2) = 0,      g(x_in; p1, p2) = 0,

g the bordered test function of J_out (Govaerts, Numerical Methods for Bifurcations, Sect. 3.4):
n_in + 1 equations in n_in + 2 unknowns, regular at a simple symmetry-breaking pitchfork (the
generic BP-C of a non-symmetric system is singular there). With wind the aerodynamic rows break the
symmetry (f_out(x_in, 0) != 0): the pitchforks unfold into folds, BP curves do not exist and
`continue_branch_points` says so.

Every point is corrected by Newton on that system and checked independently on the full system:
``check_residual`` = sigma_min(J_out) / sigma_max(J) of the exact Jacobian at (x_in, 0), and
||f|| of the full field. Codimension-2 points along the curve come from sign changes of
test functions located by Brent on the curve (`chart._locate`): ``BT`` where J_out has a double
zero eigenvalue (trace J_out = 0: a curve of out-of-plane Hopf points ends there) and ``LP`` where
the BP curve crosses the fold curve of the mono-modal branch (det J_in = 0; it then meets a fold of
`continue_folds`). Both are checked by the eigenvalues of the full Jacobian."""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace

import numpy as np

from autocable.methods.continuation.chart import _build_branch, _Chart, _correct, _locate, _sign_changes, _tangent
from autocable.methods.continuation.problem import (ContinuationResult, ContinuationSettings, Progress,
                                                    StartError, _resolve)
from autocable.methods.continuation.system import System
from autocable.results import EndPoint, SpecialPoint

__all__ = ["continue_branch_points", "z2_split", "SymmetryError"]


class SymmetryError(ValueError):
    """The system has no Z2 symmetry that makes a branch point generic in two parameters."""


def z2_split(system: System, values=None, *, tol: float = 1e-10, trials: int = 4,
             seed: int = 7) -> tuple[tuple[int, ...], tuple[int, ...]]:
    """(in-plane, out-of-plane) variable indices of the symmetry x_out -> -x_out, the out-of-plane
    variables being those of every amplitude but the first (r2, s2 of the AME). Checked numerically,
    f(R x) = R f(x) at random points: raises `SymmetryError` if the system is not equivariant."""
    amps = system.amplitudes
    first = {system.variables.index(v) for v in amps[0][1]} if amps else set()
    inner = tuple(i for i in range(system.dimension) if i in first)
    outer = tuple(i for i in range(system.dimension) if i not in first)
    if not inner or not outer:
        raise SymmetryError(f"{system.name}: needs two groups of variables (one amplitude in-plane, "
                            f"the others out-of-plane), has {list(system.variables)}")
    rng = np.random.default_rng(seed)
    base = system.parameter_vector(values)
    R = np.ones(system.dimension)
    R[list(outer)] = -1.0
    for _ in range(trials):
        x = rng.normal(size=system.dimension) * 1e-2
        p = base * (1 + 0.1 * rng.normal(size=base.size)) + 1e-3 * rng.normal(size=base.size)
        fx = system.f(x, p)
        err = np.linalg.norm(system.f(R * x, p) - R * fx)
        if not err <= tol * (1.0 + np.linalg.norm(fx)):
            raise SymmetryError(f"{system.name} is not symmetric under {[system.variables[i] for i in outer]} -> "
                                f"minus themselves (||f(Rx) - R f(x)|| = {err:.2g}): its pitchforks unfold "
                                f"into folds (with wind the aerodynamic rows break the symmetry); continue "
                                f"the folds instead")
    return inner, outer


@dataclass(frozen=True, eq=False)
class _BPChart:
    """Y = (x_in / xscale, lam1, lam2), p[k1] = base[k1] + s1 lam1, p[k2] = base[k2] + s2 lam2,
    time scaled by ``tscale``. F = (tscale f_in / xscale, g), g the bordered test function of
    M = tscale J_out with borders fixed by `at`: the shapes `_correct` and `_locate` expect."""

    system: System
    inner: tuple
    outer: tuple
    k1: int
    k2: int
    base: np.ndarray
    xscale: float
    s1: float
    s2: float
    tscale: float
    border: tuple | None = None

    def p(self, Y) -> np.ndarray:
        p = self.base.copy()
        p[self.k1] += self.s1 * Y[-2]
        p[self.k2] += self.s2 * Y[-1]
        return p

    def to_phys(self, Y) -> tuple[np.ndarray, np.ndarray]:
        Y = np.asarray(Y, float)
        x = np.zeros(self.system.dimension)
        x[list(self.inner)] = Y[:-2] * self.xscale
        return x, self.p(Y)

    def to_chart(self, x, p) -> np.ndarray:
        x = np.asarray(x, float)
        return np.concatenate([x[list(self.inner)] / self.xscale,
                               [(p[self.k1] - self.base[self.k1]) / self.s1,
                                (p[self.k2] - self.base[self.k2]) / self.s2]])

    def values(self, Y) -> tuple[float, float]:
        p = self.p(np.asarray(Y, float))
        return float(p[self.k1]), float(p[self.k2])

    def lam(self, which: int, value: float) -> float:
        k, s = (self.k1, self.s1) if which == 1 else (self.k2, self.s2)
        return (float(value) - self.base[k]) / s

    def blocks(self, Y) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        J = self.system.jac(*self.to_phys(Y))
        return J, J[np.ix_(self.inner, self.inner)], J[np.ix_(self.outer, self.outer)]

    def at(self, Y) -> "_BPChart":
        U, _, Vt = np.linalg.svd(self.tscale * self.blocks(Y)[2])
        return replace(self, border=(U[:, -1].copy(), Vt[-1].copy()))

    def g(self, Y) -> float:
        M = self.tscale * self.blocks(Y)[2]
        b, c = self.border
        m = M.shape[0]
        A = np.zeros((m + 1, m + 1))
        A[:m, :m], A[:m, m], A[m, :m] = M, b, c
        rhs = np.zeros(m + 1)
        rhs[m] = 1.0
        return float(np.linalg.solve(A, rhs)[m])

    def F(self, Y) -> np.ndarray:
        if self.border is None:
            return self.at(Y).F(Y)
        x, p = self.to_phys(Y)
        f = self.system.f(x, p)[list(self.inner)]
        return np.append(self.tscale * f / self.xscale, self.g(Y))

    def DF(self, Y) -> np.ndarray:
        Y = np.asarray(Y, float)
        if self.border is None:
            return self.at(Y).DF(Y)
        x, p = self.to_phys(Y)
        J, Jp = self.system.jac(x, p), self.system.jac_p(x, p)
        inn = list(self.inner)
        top = np.column_stack([self.tscale * J[np.ix_(inn, inn)],
                               self.tscale * Jp[inn, self.k1] * self.s1 / self.xscale,
                               self.tscale * Jp[inn, self.k2] * self.s2 / self.xscale])
        # g's gradient by central differences: g is a smooth function of a small bordered solve.
        h = 1e-6
        grad = np.zeros(Y.size)
        for j in range(Y.size):
            e = np.zeros(Y.size)
            e[j] = h
            grad[j] = (self.g(Y + e) - self.g(Y - e)) / (2 * h)
        return np.vstack([top, grad])


def _tests(chart: _BPChart, Y) -> dict[str, float]:
    """Codimension-2 test functions on a BP curve: BT = trace J_out (with det J_out = 0 a double
    zero), LP = det J_in (the mono-modal branch folds here too)."""
    _, Jin, Jout = chart.blocks(Y)
    return {"BT": float(np.trace(Jout)), "LP": float(np.linalg.det(Jin))}


def _march(chart: _BPChart, Y0, t0, settings: ContinuationSettings, lam_bounds, max_points: int,
           progress: Progress | None, side: str):
    """Pseudo-arclength continuation of the BP curve from Y0 along t0 (Keller; step halved on a
    failed or sharply turning corrector, grown by 1.3 after a good one). Stops on a range boundary
    (the last point put on it), closing on the start, the point budget, or a step collapse.
    Returns (points, reason, message)."""
    pts, Y, t = [np.asarray(Y0, float)], np.asarray(Y0, float), np.asarray(t0, float)
    h = settings.curve_step
    tol = settings.newton_tol
    while True:
        if len(pts) > max_points:
            return pts, "max_points", f"{max_points} points on the {side} side"
        if h < settings.min_step:
            return pts, "step_collapse", f"the step fell below {settings.min_step:g} at ({chart.values(Y)[0]:.8g}, " \
                                         f"{chart.values(Y)[1]:.8g})"
        Yp = Y + h * t
        Yn, ok = _correct(chart.at(Y), Yp, t, tol)
        if ok:
            tn = _tangent(chart.at(Yn).DF(Yn))
            tn = tn if tn @ t >= 0 else -tn
        if not ok or tn @ t < 0.95 or np.linalg.norm(Yn - Y) > 2 * h:
            h /= 2
            continue
        out = [(col, b) for col, (lo, hi) in zip((-2, -1), lam_bounds) for b in (lo, hi)
               if (Yn[col] - b) * (Y[col] - b) < 0 or Yn[col] == b]
        if out:
            col, b = out[0]
            s = (b - Y[col]) / (Yn[col] - Y[col])
            guess = Y + s * (Yn - Y)
            guess[col] = b
            e = np.zeros_like(Y)
            e[col] = 1.0
            Yb, okb = _correct(chart.at(guess), guess, e, tol)
            pts.append(Yb if okb else guess)
            return pts, "range", "reached the range boundary"
        pts.append(Yn)
        if len(pts) > 4 and np.linalg.norm(Yn - pts[0]) < 0.5 * h:
            return pts, "closed", "the curve closed on its start"
        if progress and len(pts) % 50 == 0:
            progress(f"    BP curve, {side}: {len(pts)} points")
        Y, t = Yn, tn
        h = min(1.3 * h, settings.curve_max_step)


def continue_branch_points(source: ContinuationResult, label: str | SpecialPoint, second_parameter: str,
                           bounds: tuple[float, float], settings: ContinuationSettings | None = None, *,
                           name: str | None = None, directions: str = "both",
                           progress: Progress | None = None) -> ContinuationResult:
    """The curve of symmetry-breaking pitchforks through the branch point ``label`` (e.g. "BP1") of
    a mono-modal branch of ``source`` (a2 = 0), in the plane of the source's parameter (over its
    range) and ``second_parameter`` (over ``bounds``): the pitchforks where the bi-modal branches of
    Fig. 6 are born, as the support amplitude or the detuning moves.

    Returns a branch of kind "branch_point" (columns: both parameters, the state with a2 = 0, a1,
    det_J, check_residual = sigma_min(J_out)/sigma_max(J), which must be <= ``curve_check_tol`` at
    every point (failures in ``info["check_failures"]``)), with BT and LP codimension-2 points
    (module docstring). Raises `SymmetryError` for a system without the Z2 symmetry (the wind AME)
    and `StartError` if the start is not on a2 = 0 or cannot be refined on the defining system."""
    t0 = time.perf_counter()
    sp0, problem, base_settings = _resolve(source, label)
    settings = settings or base_settings
    if sp0.type != "BP":
        raise ValueError(f"{sp0.name} is a {sp0.type} point; a branch-point curve starts from a BP point")
    if directions not in ("both", "forward", "backward"):
        raise ValueError(f"directions must be 'both', 'forward' or 'backward', got {directions!r}")
    sysm = problem.system
    p1, p2 = problem.parameter, str(second_parameter)
    if p2 not in sysm.parameter_names or p2 == p1:
        raise ValueError(f"the second parameter must be a parameter of {sysm.name!r} other than {p1!r}, got {p2!r}")
    lo2, hi2 = (float(b) for b in bounds)
    if not (math.isfinite(lo2) and math.isfinite(hi2) and lo2 < hi2):
        raise ValueError(f"range of {p2} must be two finite numbers lo < hi, got {bounds}")
    inner, outer = z2_split(sysm, sp0.parameters)
    base = sysm.parameter_vector(sp0.parameters)
    k1, k2 = sysm.parameter_names.index(p1), sysm.parameter_names.index(p2)
    for pn, k, (lo, hi) in ((p1, k1, problem.bounds), (p2, k2, (lo2, hi2))):
        if not lo <= base[k] <= hi:
            raise StartError(f"{sp0.name} has {pn} = {base[k]:g}, outside the range [{lo:g}, {hi:g}]")
    x0 = np.asarray(sp0.state, float)
    scale_x = max(float(problem.state_scale), 1e-300)
    if np.max(np.abs(x0[list(outer)])) > 1e-8 * scale_x:
        raise StartError(f"{sp0.name} is not on the invariant plane a2 = 0 (out-of-plane state "
                         f"{x0[list(outer)].tolist()}): not a symmetry-breaking pitchfork")
    name = name or f"{source.branch.name}_{sp0.label}_BP"
    J0 = sysm.jac(x0, base)
    tscale = 1.0 / float(np.linalg.norm(J0)) if np.linalg.norm(J0) > 0 else 1.0
    chart = _BPChart(sysm, inner, outer, k1, k2, base, scale_x, float(problem.span), hi2 - lo2, tscale)
    Y0 = chart.to_chart(x0, base)
    e2 = np.zeros_like(Y0)
    e2[-1] = 1.0
    Y0, ok = _correct(chart.at(Y0), Y0, e2, settings.newton_tol)
    if not ok:
        raise StartError(f"{sp0.name} could not be refined on the branch-point curve's defining system")
    t = _tangent(chart.at(Y0).DF(Y0))
    lead = -1 if abs(t[-1]) > 1e-12 else -2
    t = t if t[lead] >= 0 else -t
    lam_bounds = ((chart.lam(1, problem.bounds[0]), chart.lam(1, problem.bounds[1])),
                  (chart.lam(2, lo2), chart.lam(2, hi2)))
    sides = {}
    for side in {"both": ("forward", "backward"), "forward": ("forward",), "backward": ("backward",)}[directions]:
        if any(r == "closed" for _, r, _ in sides.values()):
            sides[side] = ([Y0], "closed", "the curve is closed, traversed in the other direction")
            continue
        sgn = 1.0 if side == "forward" else -1.0
        sides[side] = _march(chart, Y0, sgn * t, settings, lam_bounds, settings.curve_max_points, progress, side)
    back = sides.get("backward", ([Y0], "not_run", ""))
    fwd = sides.get("forward", ([Y0], "not_run", ""))
    Ys = list(reversed(back[0][1:])) + fwd[0]
    start_index = len(back[0]) - 1
    t1 = time.perf_counter()
    m = len(Ys)
    n = sysm.dimension
    X = np.zeros((m, n))
    P = np.zeros((m, len(sysm.parameter_names)))
    eig = np.zeros((m, n), dtype=complex)
    detJ, check, resid, stable = np.zeros(m), np.zeros(m), np.zeros(m), np.zeros(m, bool)
    tests = {"BT": [], "LP": []}
    for i, Y in enumerate(Ys):
        X[i], P[i] = chart.to_phys(Y)
        J, Jin, Jout = chart.blocks(Y)
        ev = np.linalg.eigvals(J)
        eig[i] = ev[np.lexsort((-ev.imag, -ev.real))]
        detJ[i] = np.linalg.det(J)
        sv = np.linalg.svd(J, compute_uv=False)
        check[i] = np.linalg.svd(Jout, compute_uv=False)[-1] / sv[0] if sv[0] > 0 else 0.0
        resid[i] = np.linalg.norm(sysm.f(X[i], P[i])) / (scale_x * sv[0])
        rest = np.delete(ev, int(np.argmin(np.abs(ev))))
        stable[i] = bool(rest.size == 0 or np.max(rest.real) < 0)
        for k, v in _tests(chart, Y).items():
            tests[k].append(v)
    failures = [i for i in range(m) if not (check[i] <= settings.curve_check_tol and resid[i] <= settings.curve_check_tol)]
    found, rejected = [], []
    for kind in ("BT", "LP"):
        for i in _sign_changes(tests[kind]):
            Ya, Yb = Ys[i], Ys[i + 1]

            def tau(Y, kind=kind):
                return _tests(chart, Y)[kind]
            Y, okl = _locate(chart.at(Ya), Ya, Yb, tau, settings.newton_tol)
            J, Jin, Jout = chart.blocks(Y)
            ev = np.linalg.eigvals(J)
            small = np.sort(np.abs(ev))
            scale = max(float(np.linalg.norm(J)), 1e-300)
            accepted = small[1] <= 1e-4 * scale       # two eigenvalues at zero: a BT or a BP meeting a fold
            if accepted:
                found.append((i, kind, Y, okl, {"eigenvalues": [complex(e) for e in ev]}))
            else:
                rejected.append([kind, list(chart.values(Y)), f"second smallest |lambda| = {small[1]:.3g}"])
    specials, counters = [], {}
    for i, kind, Y, okl, extra in sorted(found, key=lambda f: f[0]):
        counters[kind] = counters.get(kind, 0) + 1
        x, p = chart.to_phys(Y)
        amps = sysm.amplitude_values(x)
        specials.append(SpecialPoint(
            branch=name, type=kind, label=f"{kind}{counters[kind]}", parameter=p1, value=float(p[k1]),
            a1=float(amps[0]), a2=float(amps[1]) if len(amps) > 1 else math.nan, state=tuple(x),
            parameters=sysm.parameter_dict(p), index=int(i), converged=bool(okl), confirmed_by_pycont=None,
            origin="autocable", message="" if okl else "refinement did not bracket a zero: location interpolated",
            extra=dict(extra, parameter2=p2, value2=float(p[k2]))))
    v1, v2 = chart.values(Ys[0]), chart.values(Ys[-1])
    where = "; the curve ends at ({}, {}) = ({:.8g}, {:.8g})"
    ends = (EndPoint("backward", back[1], v1[0], len(back[0]) - 1,
                     back[2] + (where.format(p1, p2, *v1) if back[1] != "not_run" else "")),
            EndPoint("forward", fwd[1], v2[0], len(fwd[0]) - 1,
                     fwd[2] + (where.format(p1, p2, *v2) if fwd[1] != "not_run" else "")))
    info = {"check": "sigma_min(J_out)/sigma_max(J) at a2 = 0 (and ||f|| / (xscale sigma_max(J)))",
            "check_tol": settings.curve_check_tol, "check_max": float(np.max(check)) if m else math.nan,
            "residual_max": float(np.max(resid)) if m else math.nan,
            "check_failures": failures[:50], "check_failure_count": len(failures),
            "rejected_candidates": rejected, "start_index": start_index, "started_from": sp0.name,
            "second_parameter": p2, "second_bounds": [lo2, hi2], "state_scale": scale_x, "time_scale": tscale,
            "defining_system": "f_in(x_in, 0) = 0, bordered test function of J_out (Z2: x_out -> -x_out)",
            "out_of_plane": [sysm.variables[i] for i in outer]}
    ch1 = _Chart(sysm, k1, base, scale_x, chart.s1)
    branch = _build_branch(name, "equilibrium", ch1, X, P, stable, eig, tuple(specials), ends, info,
                           extra_columns={"det_J": detJ, "check_residual": check}).replace(
        kind="branch_point", parameter2=p2)
    t2 = time.perf_counter()
    return ContinuationResult(branch, problem.at(**{p1: float(base[k1])}), settings,
                              {"continuation_s": t1 - t0, "analysis_s": t2 - t1, "points": m})
