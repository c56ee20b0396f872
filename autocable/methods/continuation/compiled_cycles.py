"""Periodic orbits from a Hopf point by autocable's own orthogonal collocation on the compiled C
kernel (``engine="compiled"``): the records of `autocable.methods.continuation.cycles.continue_cycles`, without
PyDSTool.

The method is AUTO's, as PyCont's LC-C runs it (Doedel, Keller & Kernevez 1991; AUTO-07p manual,
ch. 10), in autocable's chart (x~ = x / xscale, lam = (p_k - p0_k) / pscale):

* time scaled to [0, 1], u' = T f~(u, lam); ``ntst`` uniform mesh intervals, on each a polynomial
  of degree ``ncol`` through ``ncol + 1`` equally spaced nodes (Lagrange basis), collocated at the
  ``ncol`` Gauss-Legendre points; periodicity by sharing the first node; unknowns the nodal values,
  the period T and lam;
* AUTO's integral phase condition int_0^1 u . u_ref' dt = 0 (u_ref the previous cycle) and
  pseudo-arclength int_0^1 (u - u_0) . u_0' dt + (lam - lam_0) lam_0' = ds with AUTO's weights (the
  period does not count in the arclength, THL(11) = 0); the direction is AUTO's secant, scaled to
  unit norm; integrals by the Gauss rule of the collocation points;
* Newton with the sparse Jacobian (``scipy.sparse.linalg.splu``), AUTO's convergence test
  (max |du| / (1 + max |u|) and |d(T, lam)| / (1 + |(T, lam)|) below ``tol``) and at most
  `NEWTON_ITERATIONS` iterations (PyCont's MaxCorrIters), AUTO's step control (ADPTDS: the step
  doubles after one iteration, grows by 1.5 after two, by 1.1 after up to half the limit (never,
  with a limit of 5), halves at the limit, never above ``cycle_max_step``; a failed step is
  halved, and below ``min_step`` the branch ends);
* the start: the Hopf point as a degenerate cycle of period 2 pi / omega, the first direction the
  critical eigenfunction Re(q exp(2 pi i t)) of J (J q = i omega q) scaled to unit norm, lam' = 0;
  or (`continue_cycles_from_orbit`) a given periodic orbit, e.g. one found by integration
  (`autocable.methods.continuation.orbits`), refined by Newton at its parameter value with lam fixed (AUTO's
  start from a user-supplied solution, IPS = 2 with a given orbit), the first direction the
  branch's tangent there, continued both ways;
* special points of cycles on the branch, as AUTO puts them there: when lam' (the tangent's lam
  component, from the last Newton factorisation) changes sign inside a step (LPC), or the count
  of multipliers beyond -1 (PD) or of complex ones outside the unit circle (NS) changes, the step
  is shortened onto the zero of that test function (regula falsi in the arclength, to
  ``test_tol`` of the step) and the branch goes on from there. `cycles.cycle_result` then labels
  them from the multiplier crossings, as for PyCont's points.

F~ and DF~ at all collocation points come from one call of the kernel's batched chart
(`autocable.codegen.ckernel.CKernel.chart_batch`).

Floquet multipliers: the eigenvalues of the collocation monodromy matrix, the product over the mesh
intervals of the transfer matrices of the collocated variational equation Phi' = T J(u) Phi (the
interval's collocation block solved for its end node from its start node). This is the variational
integration of `cycles._monodromy` discretised by the same collocation as the cycle;
tests/test_compiled_cycles.py checks that the two agree. The Hopf point itself (the first row)
gets exp(J T) exactly, as `_monodromy` gives it.

(``floquet_rtol`` is not used: there is no integration.)

Amplitude extremes: the collocation polynomials sampled at ``_SAMPLES`` points per mesh interval,
each extreme refined by the parabola through its sample and the two next to it.

Differences from AUTO: the mesh is uniform (AUTO adapts it every 3 steps), so near a homoclinic
orbit (period blow-up) the two drift apart sooner; the start (the first direction and step) is
AUTO's. The branch ends as the PyCont path's does: "range" (lam left the range: the point outside
is dropped), "period_blowup" (T above ``max_period_ratio`` times the Hopf period; dropped too),
"max_points" (``cycle_max_points`` cycles, the Hopf point included), "no_convergence" (Newton
failed at ``min_step``), "error" (a numerical exception, message kept)."""
from __future__ import annotations

import math
import time
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
import scipy.sparse as sps
from scipy.linalg import expm
from scipy.sparse.linalg import splu

from autocable.codegen.ckernel import compiled_kernel
from autocable.methods.continuation.chart import _Chart
from autocable.methods.continuation.problem import (ContinuationResult, ContinuationSettings, EquilibriumProblem,
                                                    Progress, StartError, _resolve)
from autocable.methods.continuation.cycle_records import cycle_result
from autocable.methods.continuation.events import _crossing_distance, _cycle_counts
from autocable.results import EndPoint, SpecialPoint

#: Newton iterations per step (PyCont passes its MaxCorrIters = 5 to AUTO as ITNW).
NEWTON_ITERATIONS = 5
#: Samples per mesh interval for the amplitude extremes (refined by a parabola).
_SAMPLES = 16
#: Regula falsi iterations when a special point of cycles is put on the branch.
_LOCATE_ITERATIONS = 12


def _lagrange(nodes: np.ndarray, at: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Values and first derivatives of the Lagrange basis on ``nodes`` at the points ``at``:
    arrays len(at) x len(nodes)."""
    m1 = len(nodes)
    L = np.ones((len(at), m1))
    D = np.zeros((len(at), m1))
    for l in range(m1):
        others = [nodes[r] for r in range(m1) if r != l]
        den = np.prod([nodes[l] - o for o in others])
        for i, z in enumerate(at):
            L[i, l] = np.prod([z - o for o in others]) / den
            D[i, l] = sum(np.prod([z - o for r, o in enumerate(others) if r != q]) for q in range(m1 - 1)) / den
    return L, D


@dataclass(frozen=True, eq=False)
class _Mesh:
    """The collocation layout of one (ntst, ncol, n): indices, basis matrices, the sparsity pattern."""

    N: int
    m: int
    n: int
    w: np.ndarray       # Gauss weights on [0, 1] (m)
    Lz: np.ndarray      # basis at the Gauss points (m x (m+1))
    Dz: np.ndarray      # its derivative in the local variable s in [0, 1]
    Ls: np.ndarray      # basis at the sampling points (_SAMPLES x (m+1))
    idx: np.ndarray     # node indices of each interval (N x (m+1)), periodic
    rows: np.ndarray    # COO pattern of the Jacobian
    cols: np.ndarray

    @property
    def nu(self) -> int:
        return self.N * self.m * self.n

    @property
    def h(self) -> float:
        return 1.0 / self.N


@lru_cache(maxsize=16)
def _mesh(N: int, m: int, n: int) -> _Mesh:
    g, w = np.polynomial.legendre.leggauss(m)
    z, w = (g + 1) / 2, w / 2
    nodes = np.arange(m + 1) / m
    Lz, Dz = _lagrange(nodes, z)
    Ls, _ = _lagrange(nodes, np.arange(_SAMPLES) / _SAMPLES)
    idx = (np.arange(N)[:, None] * m + np.arange(m + 1)[None, :]) % (N * m)
    nu = N * m * n
    # Collocation rows (j, i, a) against node columns (idx[j, l], b), then the T and lam columns.
    j, i, a, l, b = np.meshgrid(np.arange(N), np.arange(m), np.arange(n), np.arange(m + 1), np.arange(n),
                                indexing="ij")
    r_blk = ((j * m + i) * n + a).ravel()
    c_blk = (idx[j, l] * n + b).ravel()
    r_col = np.arange(nu)
    rows = np.concatenate([r_blk, r_col, r_col, np.full(nu + 2, nu), np.full(nu + 2, nu + 1)])
    cols = np.concatenate([c_blk, np.full(nu, nu), np.full(nu, nu + 1), np.arange(nu + 2), np.arange(nu + 2)])
    return _Mesh(N, m, n, w, Lz, Dz, Ls, idx, rows, cols)


class _Collocation:
    """The collocation system of one branch: residual, Jacobian, inner products, monodromy."""

    def __init__(self, kernel, chart: _Chart, mesh: _Mesh):
        self.kernel, self.chart, self.mesh = kernel, chart, mesh
        self.cfg = kernel.config(chart.base, chart.k, chart.xscale, chart.pscale)

    # -- layout: Y = (nodal values (N m) x n, T, lam) ------------------------------------------
    def nodes(self, Y) -> np.ndarray:
        ms = self.mesh
        return Y[:ms.nu].reshape(ms.N * ms.m, ms.n)

    def at_gauss(self, U) -> tuple[np.ndarray, np.ndarray]:
        """u and du/ds (s the local variable of an interval) at the Gauss points: N x m x n each."""
        ms = self.mesh
        V = U[ms.idx]                                   # N x (m+1) x n
        return np.einsum("il,jln->jin", ms.Lz, V), np.einsum("il,jln->jin", ms.Dz, V)

    def gauss_row(self, vz) -> np.ndarray:
        """The row r with r . Y = int_0^1 u . v dt (v given at the Gauss points, N x m x n)."""
        ms = self.mesh
        contrib = ms.h * np.einsum("i,il,jin->jln", ms.w, ms.Lz, vz)
        out = np.zeros((ms.N * ms.m, ms.n))
        np.add.at(out, ms.idx, contrib)
        return np.concatenate([out.ravel(), [0.0, 0.0]])

    def norm2(self, dY) -> float:
        """AUTO's squared norm: int_0^1 |du|^2 dt + dlam^2 (the period has weight 0)."""
        uz, _ = self.at_gauss(self.nodes(dY))
        return float(self.mesh.h * np.einsum("i,jin,jin->", self.mesh.w, uz, uz) + dY[-1] ** 2)

    def evaluate(self, Y):
        """(F~, DF~) at every Gauss point of Y."""
        ms = self.mesh
        uz, duz = self.at_gauss(self.nodes(Y))
        pts = np.concatenate([uz.reshape(-1, ms.n), np.full((ms.N * ms.m, 1), Y[-1])], axis=1)
        f, df = self.kernel.chart_batch(self.cfg, pts)
        return uz, duz, f.reshape(ms.N, ms.m, ms.n), df.reshape(ms.N, ms.m, ms.n, ms.n + 1)

    def blocks(self, T: float, df) -> np.ndarray:
        """d(collocation residual)/d(nodes): N x m x n x (m+1) x n (Dz I - h T Lz J)."""
        ms = self.mesh
        eye = np.eye(ms.n)
        J = df[..., :ms.n]
        return (ms.Dz[None, :, None, :, None] * eye[None, None, :, None, :]
                - ms.h * T * ms.Lz[None, :, None, :, None] * J[:, :, :, None, :])

    def system(self, Y, phase_row, arc_row, arc_rhs):
        """Residual G(Y) and its Jacobian (CSC) of collocation, phase and arclength."""
        ms = self.mesh
        T = Y[-2]
        uz, duz, f, df = self.evaluate(Y)
        res = (duz - ms.h * T * f).ravel()
        G = np.concatenate([res, [phase_row @ Y, arc_row @ Y - arc_rhs]])
        data = np.concatenate([self.blocks(T, df).ravel(), (-ms.h * f).ravel(),
                               (-ms.h * T * df[..., ms.n]).ravel(), phase_row, arc_row])
        A = sps.csc_matrix((data, (ms.rows, ms.cols)), shape=(ms.nu + 2, ms.nu + 2))
        return G, A

    def monodromy(self, Y) -> np.ndarray:
        """The collocation monodromy matrix of Phi' = T J(u) Phi over one period."""
        ms = self.mesh
        n, m = ms.n, ms.m
        _, _, _, df = self.evaluate(Y)
        B = self.blocks(Y[-2], df).reshape(ms.N, m * n, (m + 1) * n)
        A0, Ar = B[:, :, :n], B[:, :, n:]
        # Each interval: the interior and end nodes from the start node; the end rows transfer.
        P = -np.linalg.solve(Ar, A0)[:, -n:, :]
        M = np.eye(n)
        for Pj in P:
            M = Pj @ M
        return M

    def samples(self, Y) -> np.ndarray:
        """The cycle at _SAMPLES uniform points per interval (chart units), in time order."""
        ms = self.mesh
        V = self.nodes(Y)[ms.idx]
        return np.einsum("sl,jln->jsn", ms.Ls, V).reshape(-1, ms.n)


def _extremes(sysm, samples_phys) -> tuple[tuple[float, float], tuple[float, float]]:
    """(mins, maxs) of a1, a2 over a periodic sampled cycle, each refined by the parabola through
    the extreme sample and its two periodic neighbours (NaN for a missing a2)."""
    amps = sysm.amplitude_values(samples_phys)
    lo, hi = [math.nan, math.nan], [math.nan, math.nan]
    K = len(samples_phys)
    for k, a in enumerate(amps[:2]):
        a = np.asarray(a, float) * np.ones(K)
        for sign, out in ((1.0, hi), (-1.0, lo)):
            v = sign * a
            i = int(np.argmax(v))
            am, a0, ap = v[i - 1], v[i], v[(i + 1) % K]
            curv = am - 2 * a0 + ap
            best = a0 - (ap - am) ** 2 / (8 * curv) if curv < 0 else a0
            out[k] = sign * max(best, a0)
    return (lo[0], lo[1]), (hi[0], hi[1])


def _hopf_start(col: _Collocation, hp: SpecialPoint, YH_chart: np.ndarray, T_H: float):
    """The degenerate cycle at the Hopf point and the first direction (the critical eigenfunction)."""
    ms = col.mesh
    x, p = col.chart.to_phys(YH_chart)
    J = col.kernel.jac(x, p)
    ev, vecs = np.linalg.eig(J)
    omega = 2 * math.pi / T_H
    q = vecs[:, int(np.argmin(np.abs(ev - 1j * omega)))]
    t = np.arange(ms.N * ms.m) / (ms.N * ms.m)
    phi = np.real(q[None, :] * np.exp(2j * math.pi * t)[:, None])
    Y0 = np.concatenate([np.tile(YH_chart[:-1], ms.N * ms.m), [T_H, YH_chart[-1]]])
    d0 = np.concatenate([phi.ravel(), [0.0, 0.0]])
    return Y0, d0 / math.sqrt(col.norm2(d0))


def _newton(col: _Collocation, Yp, phase_row, arc_row, arc_rhs, tol: float,
            iterations: int = NEWTON_ITERATIONS):
    """AUTO's corrector from the predictor Yp: (Y, iterations, LU of the last Jacobian), or
    (None, iterations, None) on failure."""
    Y = Yp.copy()
    nu = col.mesh.nu
    for it in range(1, iterations + 1):
        G, A = col.system(Y, phase_row, arc_row, arc_rhs)
        if not np.all(np.isfinite(G)):
            return None, it, None
        try:
            lu = splu(A)
        except RuntimeError:  # an exactly singular factor
            return None, it, None
        dY = lu.solve(G)
        Y = Y - dY
        if not np.all(np.isfinite(Y)):
            return None, it, None
        du = np.max(np.abs(dY[:nu])) / (1.0 + np.max(np.abs(Y[:nu])))
        dl = np.max(np.abs(dY[nu:]) / (1.0 + np.abs(Y[nu:])))
        if du <= tol and dl <= tol:
            return Y, it, lu
    return None, iterations, None


@dataclass
class _Point:
    """An accepted cycle: the unknowns, the Newton iterations, the tangent's lam component (the
    LPC test function: it changes sign at a fold of cycles) and the Floquet multipliers."""

    Y: np.ndarray
    nit: int
    lam_dot: float
    mults: np.ndarray
    located: bool = False    # put on a zero of a test function (the next step does not test)


class _Stepper:
    """Steps along the branch from a point and direction, and the test functions at the result."""

    def __init__(self, col: _Collocation, tol: float):
        self.col, self.tol = col, tol

    def step(self, Y, d, ref, s: float) -> _Point | None:
        col = self.col
        phase = col.gauss_row(ref)
        arc = col.gauss_row(col.at_gauss(col.nodes(d))[0])
        arc[-1] = d[-1]
        Yn, nit, lu = _newton(col, Y + s * d, phase, arc, arc @ Y + s, self.tol)
        if Yn is None:
            return None
        # The tangent t: [G_Y; arc] t = e_last (the last Jacobian, at the converged point to tol).
        e = np.zeros(len(Yn))
        e[-1] = 1.0
        lam_dot = float(lu.solve(e)[-1])
        mu = np.linalg.eigvals(col.monodromy(Yn))
        return _Point(Yn, nit, lam_dot, mu[np.argsort(-np.abs(mu))])

    def locate(self, Y, d, ref, a: _Point, b: _Point, ds: float, g, test_tol: float) -> _Point | None:
        """The point of the step [0, ds] from Y where g (a function of a _Point) vanishes, by the
        Illinois variant of regula falsi on the arclength, as AUTO puts a special point on the
        branch. None when g does not change sign or a corrector fails."""
        s0, s1, g0, g1 = 0.0, ds, g(a), g(b)
        if not (np.isfinite(g0) and np.isfinite(g1)) or g0 * g1 >= 0:
            return None
        best, side, last = None, 0, math.inf
        for _ in range(_LOCATE_ITERATIONS):
            s = s1 - g1 * (s1 - s0) / (g1 - g0)
            pt = self.step(Y, d, ref, s)
            if pt is None:
                return None
            gs = g(pt)
            best = pt
            if gs == 0 or abs(s - last) <= test_tol * ds:
                break
            last = s
            if gs * g1 < 0:
                s0, g0 = s1, g1
                side = 0
            else:
                g0 = g0 / 2 if side == 1 else g0
                side = 1
            s1, g1 = s, gs
        return best


def continue_cycles_compiled(source: ContinuationResult, hopf: str | SpecialPoint,
                             settings: ContinuationSettings | None = None, *, name: str | None = None,
                             progress: Progress | None = None) -> ContinuationResult:
    """`autocable.methods.continuation.cycles.continue_cycles` by autocable's collocation on the C kernel (same
    arguments and records; the module docstring gives the method). Raises ValueError for a label
    that is not a Hopf point and `autocable.codegen.ckernel.KernelBuildError` (one line) when the
    kernel cannot be built."""
    hp, problem, base_settings = _resolve(source, hopf)
    settings = settings or base_settings
    if hp.type != "H":
        raise ValueError(f"{hp.name} is a {hp.type} point, not a Hopf point")
    name = name or f"{source.branch.name}_{hp.label}_cycles"
    sysm = problem.system
    t0 = time.perf_counter()
    kernel = compiled_kernel(sysm)
    chart = _Chart(sysm, sysm.parameter_names.index(problem.parameter),
                   sysm.parameter_vector(hp.parameters), problem.state_scale, problem.span)
    YH = chart.to_chart(hp.state, hp.value)
    T_H = float(hp.extra.get("period", math.nan))
    if not (math.isfinite(T_H) and T_H > 0):
        raise ValueError(f"{hp.name} has no Hopf period (omega): cannot start cycles there")
    col = _Collocation(kernel, chart, _mesh(int(settings.ntst), int(settings.ncol), sysm.dimension))
    Y, d = _hopf_start(col, hp, YH, T_H)
    ref = col.at_gauss(col.nodes(d))[1]        # the phase reference: first the eigenfunction's u'
    x_h, p_h = chart.to_phys(YH)
    hopf_mu = np.linalg.eigvals(expm(kernel.jac(x_h, p_h) * T_H))
    accepted = [_Point(Y, 0, 0.0, hopf_mu[np.argsort(-np.abs(hopf_mu))])]
    t_setup = time.perf_counter()
    reason, message, ds = _march(col, problem, settings, Y, d, ref, accepted, T_H, "the Hopf period", name,
                                 progress)
    t1 = time.perf_counter()
    X, P, periods, mults, amin, amax = _records(col, accepted, first_state=x_h)
    side = EndPoint("forward", reason, chart.value(accepted[-1].Y[-1]), len(accepted), message)
    info = {"from": hp.name, "hopf_period": T_H, "engine": "compiled", "floquet": "collocation monodromy",
            "ntst": settings.ntst, "ncol": settings.ncol, "final_step": ds}
    return cycle_result(name, problem, settings, chart, X, P, periods, mults, amin, amax, None, side, info,
                        {"setup_s": t_setup - t0, "collocation_s": t1 - t_setup, "points": len(accepted)},
                        t_analysis=t1)


def continue_cycles_from_orbit(problem: EquilibriumProblem, settings: ContinuationSettings, t, X, period: float,
                               *, name: str = "cycles", directions: str = "both",
                               progress: Progress | None = None) -> ContinuationResult:
    """The branch of periodic orbits through a known one: ``X`` (states at the times ``t``, one
    period ``period``, e.g. from `autocable.methods.continuation.orbits.periodic_orbit`) at the start value of
    ``problem`` (its ``values``), continued in ``problem.parameter`` over its range, in
    ``directions`` ("both", "forward" = increasing parameter, "backward").

    The orbit is put on the collocation mesh (periodic linear interpolation) and refined by Newton
    at the fixed start value, with the phase condition against itself; the first direction is the
    branch's tangent there (lam' > 0 forward). Each direction then goes on as from a Hopf point
    (`continue_cycles_compiled`); the period blow-up compares with ``period``. The records are
    those of `cycles.cycle_result`, ordered from the backward end to the forward end. Raises
    `StartError` when Newton does not converge on the given orbit."""
    if directions not in ("both", "forward", "backward"):
        raise ValueError(f'directions must be "both", "forward" or "backward", got {directions!r}')
    sysm = problem.system
    t0 = time.perf_counter()
    kernel = compiled_kernel(sysm)
    chart = _Chart.of(problem)
    col = _Collocation(kernel, chart, _mesh(int(settings.ntst), int(settings.ncol), sysm.dimension))
    ms = col.mesh
    t = np.asarray(t, float)
    X = np.asarray(X, float).reshape(len(t), sysm.dimension)
    if not (math.isfinite(period) and period > 0):
        raise StartError(f"the orbit's period must be a positive number, got {period!r}")
    tn = t[0] + period * np.arange(ms.N * ms.m) / (ms.N * ms.m)
    nodes = np.column_stack([np.interp(tn, t, X[:, j], period=period) for j in range(ms.n)]) / chart.xscale
    lam0 = chart.lam(problem.values[problem.parameter])
    Y0 = np.concatenate([nodes.ravel(), [period, lam0]])
    phase = col.gauss_row(col.at_gauss(col.nodes(Y0))[1])
    fix = np.zeros(len(Y0))
    fix[-1] = 1.0
    Y, nit, lu = _newton(col, Y0, phase, fix, lam0, settings.tol, iterations=4 * NEWTON_ITERATIONS)
    if Y is None:
        raise StartError(f"the collocation Newton did not converge on the given orbit (period {period:.6g}) at "
                         f"{problem.parameter} = {chart.value(lam0):.6g}: it is not a periodic orbit of the system "
                         f"there, or ntst = {settings.ntst} intervals are too few for it")
    e = np.zeros(len(Y))
    e[-1] = 1.0
    tangent = lu.solve(e)                      # G_Y t = 0, phase . t = 0, lam' = 1
    d0 = tangent / math.sqrt(col.norm2(tangent))
    mu = np.linalg.eigvals(col.monodromy(Y))
    mu = mu[np.argsort(-np.abs(mu))]
    T0 = float(Y[-2])
    t_setup = time.perf_counter()
    arms, ends, final = {}, [], settings.cycle_step
    for direction, sign in (("backward", -1.0), ("forward", 1.0)):
        if directions not in ("both", direction):
            continue
        d = sign * d0
        accepted = [_Point(Y, nit, float(d[-1]), mu)]
        ref = col.at_gauss(col.nodes(Y))[1]
        reason, message, final = _march(col, problem, settings, Y, d, ref, accepted, T0, "the start orbit's period",
                                        f"{name} ({direction})", progress)
        arms[direction] = accepted
        ends.append(EndPoint(direction, reason, chart.value(accepted[-1].Y[-1]), len(accepted), message))
    t1 = time.perf_counter()
    points = list(reversed(arms.get("backward", [])))
    points += arms["forward"][1:] if points and "forward" in arms else arms.get("forward", [])
    Xs, P, periods, mults, amin, amax = _records(col, points)
    info = {"from": "orbit", "start_value": chart.value(lam0), "start_period": T0, "start_index": (
        len(arms["backward"]) - 1 if "backward" in arms else 0), "engine": "compiled",
        "floquet": "collocation monodromy", "ntst": settings.ntst, "ncol": settings.ncol, "final_step": final}
    return cycle_result(name, problem, settings, chart, Xs, P, periods, mults, amin, amax, None, tuple(ends), info,
                        {"setup_s": t_setup - t0, "collocation_s": t1 - t_setup, "points": len(points)},
                        t_analysis=t1, first_is_hopf=False)


def _march(col: _Collocation, problem, settings: ContinuationSettings, Y, d, ref, accepted: list,
           T_ref: float, ref_name: str, name: str, progress: Progress | None) -> tuple[str, str, float]:
    """Steps from ``Y`` (the last of ``accepted``) along the unit direction ``d`` with AUTO's step
    control and special-point location, appending every accepted cycle to ``accepted``, until an
    end; returns (end reason, message, last step). ``T_ref``: the period the blow-up test compares with."""
    chart = col.chart
    lo, hi = chart.lam(problem.bounds[0]), chart.lam(problem.bounds[1])
    ds = settings.cycle_step
    stepper = _Stepper(col, settings.tol)
    reason, message = "max_points", ""
    try:
        while len(accepted) < settings.cycle_max_points:
            if len(accepted) > 1:
                # AUTO's ADPTDS from the previous step's Newton iterations.
                nit = accepted[-1].nit
                n1 = max(NEWTON_ITERATIONS // 2, 2)
                if nit <= 1:
                    ds *= 2.0
                elif nit == 2:
                    ds *= 1.5
                elif nit <= n1:
                    ds *= 1.1
                elif nit >= NEWTON_ITERATIONS:
                    ds *= 0.5
                ds = min(ds, settings.cycle_max_step)
            while True:
                new = stepper.step(Y, d, ref, ds)
                if new is not None:
                    break
                ds *= 0.5
                if ds < settings.min_step:
                    raise _Stop("no_convergence",
                                f"the collocation Newton failed at the minimum step {settings.min_step:g} near "
                                f"{problem.parameter} = {chart.value(Y[-1]):.6g}")
            step = ds
            prev = accepted[-1]
            if len(accepted) > 1 and not prev.located:
                # A fold (LPC: lam' changes sign) or a multiplier through -1 (PD) or a complex pair
                # through the unit circle (NS) inside the step: the step ends on it, as in AUTO.
                c0, c1 = _cycle_counts(prev.mults), _cycle_counts(new.mults)
                tests = [lambda pt: pt.lam_dot] if prev.lam_dot * new.lam_dot < 0 else []
                tests += [(lambda kind: lambda pt: _crossing_distance(pt.mults, kind))(kind)
                          for slot, kind in ((1, "PD"), (2, "NS"))
                          if -1 not in c0 and -1 not in c1 and c0[slot] != c1[slot]]
                for g in tests:
                    hit = stepper.locate(Y, d, ref, prev, new, ds, g, settings.test_tol)
                    if hit is not None:
                        step = float(_arc(col, d, hit.Y - Y))
                        new = hit
                        new.located = True
                        break
            lam, T = float(new.Y[-1]), float(new.Y[-2])
            if not lo - 1e-12 <= lam <= hi + 1e-12:
                raise _Stop("range", f"{problem.parameter} left the range")
            if T > settings.max_period_ratio * T_ref:
                raise _Stop("period_blowup",
                            f"the period reached {T:.4g} (> {settings.max_period_ratio:g} x {ref_name} "
                            f"{T_ref:.4g}) at {problem.parameter} = {chart.value(lam):.6g}: a homoclinic orbit "
                            f"is near; lower cycle_max_step to approach it more closely")
            # AUTO's secant direction, scaled to unit norm; the next phase reference is this cycle.
            sec = (new.Y - Y) / step
            d = sec / math.sqrt(col.norm2(sec))
            Y = new.Y
            ref = col.at_gauss(col.nodes(Y))[1]
            accepted.append(new)
            if progress and len(accepted) % 10 == 0:
                progress(f"{name}: {problem.parameter} = {chart.value(lam):.6g}, period {T:.4g}, "
                         f"{len(accepted)} cycles")
    except _Stop as stop:
        reason, message = stop.reason, stop.message
    except (np.linalg.LinAlgError, ValueError, FloatingPointError) as exc:
        reason, message = "error", f"the collocation failed: {type(exc).__name__}: {' '.join(str(exc).split())}"
    return reason, message, ds


def _records(col: _Collocation, points, first_state=None):
    """Per cycle: x(0), the parameter vector, the period, the multipliers and the amplitude extremes
    (``first_state``: the first point is a degenerate cycle, the Hopf point, at that state)."""
    chart, sysm = col.chart, col.chart.system
    X, P, periods, mults, amin, amax = [], [], [], [], [], []
    for i, pt in enumerate(points):
        lam, T = float(pt.Y[-1]), float(pt.Y[-2])
        if i == 0 and first_state is not None:
            samples = np.asarray(first_state, float)[None, :]
        else:
            samples = col.samples(pt.Y) * chart.xscale
        lo_, hi_ = _extremes(sysm, samples)
        X.append(samples[0])
        P.append(chart.p(lam))
        periods.append(T)
        mults.append(pt.mults)
        amin.append(lo_)
        amax.append(hi_)
    return X, P, periods, mults, amin, amax


def _arc(col: _Collocation, d, dY) -> float:
    """AUTO's arclength of the step dY along the unit direction d."""
    uz, _ = col.at_gauss(col.nodes(d))
    vz, _ = col.at_gauss(col.nodes(dY))
    return col.mesh.h * float(np.einsum("i,jin,jin->", col.mesh.w, uz, vz)) + d[-1] * dY[-1]


class _Stop(Exception):
    """The end of a cycle branch (reason code and message)."""

    def __init__(self, reason: str, message: str):
        super().__init__(message)
        self.reason, self.message = reason, message


__all__ = ["continue_cycles_compiled", "continue_cycles_from_orbit", "NEWTON_ITERATIONS"]
