"""The galloping cycles of eq. (21) at eta* = 0, continued in the wind speed U* from a Hopf point.

What it solves. Without support motion (eta* = 0) every forcing term of eq. (21) vanishes and the
system is autonomous (`ode21.is_autonomous`): a galloping cycle repeats with its own period T. A
cycle through y0 = (q1, q2, q1', q2') at wind U* is a zero of

    G(y0, T, U) = phi_T(y0; U) - y0                      (4 equations: the orbit closes after T)
    p(y0)       = <y0 - y_ref, F(y_ref)> / |F(y_ref)|    (the phase condition: y0 on the hyperplane
                                                           through the previous cycle's start, normal
                                                           to the flow there)

five equations in the six unknowns (y0, T, U): a curve, the branch of cycles. It is followed by
pseudo-arclength continuation (Keller; Seydel, "Practical Bifurcation and Stability Analysis",
Sects. 4.4 and 7.1): from a point x_c with unit tangent t_c a step h predicts x_c + h t_c and
Newton corrects on the five equations plus <x - x_c, t_c> = h, all in scaled unknowns (y0 over a
modal amplitude scale, T over the Hopf period, U over the Hopf wind), so that the branch passes
its folds in U, where continuation in U itself would stop. Newton's matrix is

    [ M - I   F(phi_T(y0))   dphi_T/dU ]      M = Phi(T), the monodromy,
    [ n^T     0              0         ]      n = F(y_ref) / |F(y_ref)|,
    [ t_c^T                            ]

and M and dphi_T/dU come from one integration of the state, the variational equations
Phi' = F_y Phi and the parameter sensitivity s' = F_y s + F_U (24 equations), compiled from
`autocable.model.symbolic.first_order_rhs` with eta = 0, Omega = 1, wind = 1, Uinv = 1/U
substituted (U > 0: without wind there is no galloping) and differentiated by sympy: nothing
here reads the model's terms, so another rung of the model with the same interface (an exact
quasi-steady load) is continued by the same code.

Where a branch starts. At a Hopf point (U_H, frequency omega, critical eigenvector q of the rest
state's matrix; `autocable.model.onset.Onset`) the cycles are born as y(t) = 2 r Re(q e^{i omega t})
with the normal form's a_k^2 = d(a_k^2)/dU (U - U_H) (`autocable.model.hopf`). The first point is
the pseudo-arclength step from the Hopf point (y0 = 0, T = 2 pi/omega, U_H) along Re q, at a
modal amplitude for which the normal form puts U a thousandth of U_H from U_H; U and T are
unknowns of the same Newton, so the normal form only provides the guess.

Floquet multipliers. Every point carries the eigenvalues of M: one is the trivial multiplier 1
(a shift along the cycle; `autonomous.split_multipliers` identifies it and checks F is its
eigenvector), the others decide: stable when every one has modulus below 1 -
`floquet21.STABILITY_MARGIN`.

Folds of cycles (LPC). Where the branch turns back in U the U component of the tangent changes
sign; the fold is refined by the Illinois variant of regula falsi on that component as a function
of the step length from the point before it (each evaluation one corrected step). U is extremal at
the fold, so its error is quadratic in the step's and the refinement stops when two successive
estimates of the fold's U agree to `FOLD_U_TOL`; at the fold a non-trivial multiplier passes +1.

Amplitudes. a_k as everywhere in autocable: half the peak-to-peak of q_k over the cycle, here
from `SAMPLES_PER_CYCLE` samples of one turn with Hermite-refined extremes
(`cycles.orbit_amplitudes`, its sampling error by Richardson), the peak modal amplitude (peak
displacement / l at mid-span).

Where a branch ends (`CycleBranch.end`): the cycle leaves |q_k| <= `ode21.DIVERGED` (the model's
range), U leaves [U_min, U_max], the point budget is spent, the cycle shrinks back to the rest
state (the branch ends at another Hopf point), the period grows without bound, the caller's
``stop_below`` is passed, or Newton fails at the smallest step.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from autocable.methods.integration.autonomous import split_multipliers
from autocable.methods.integration.cycles import orbit_amplitudes
from autocable.methods.integration.floquet21 import STABILITY_MARGIN
from autocable.methods.integration.ode21 import DIVERGED
from autocable.model.premises import ArgumentError
from autocable.model.symbolic import ETA, OMEGA, STATE, U, UINV, WIND, first_order_rhs

__all__ = ["CycleContinuation", "variational_system", "CyclePoint", "CycleFold", "CycleBranch", "HopfStart",
           "hopf_start", "stability_changes", "SAMPLES_PER_CYCLE", "FOLD_U_TOL"]

#: Samples of one turn for the amplitudes (as `shooting.ShootingSolver.cycle`: extremes to ~1e-11).
SAMPLES_PER_CYCLE = 256
#: `CycleContinuation.settle`: periods of each integration chunk between two Newton attempts, the
#: integration's relative tolerance (settling needs far less than the cycles' Newton), and the fraction
#: of its start below which the motion counts as decaying to rest.
SETTLE_CHUNK_PERIODS = 40
SETTLE_RTOL = 1e-8
SETTLE_REST_FRACTION = 1e-3
#: The fold's U* is refined until two successive estimates agree to this (U* units).
FOLD_U_TOL = 1e-9
#: The first point's distance from the Hopf point: the normal form puts its U* this fraction of U_H
#: away (small enough for the normal form's guess, large enough for a well-posed Newton).
START_OFFSET = 1e-3
#: Where the U component of the unit tangent is below NEAR_FOLD_TU the step is at most h_max times
#: |t_U| / NEAR_FOLD_TU, and never below NEAR_FOLD_MIN h_max (`CycleContinuation.branch`).
NEAR_FOLD_TU = 0.2
NEAR_FOLD_MIN = 0.05
#: A cycle whose largest amplitude falls below this fraction of the first point's is taken back on
#: the rest state (the branch ends at another Hopf point).
REST_FRACTION = 0.5
#: A period beyond this many Hopf periods ends the branch: the cycle approaches a homoclinic orbit
#: (it lingers near a saddle, its period grows without bound while U hardly moves; measured on the
#: 190 m stay: T from 2 to 3 Hopf periods over 300 points within 1e-4 of U*). Galloping cycles keep
#: a period near the Hopf period (within 30 % on the shipped models up to U* = 5).
PERIOD_LIMIT = 3.0
#: The period is also taken as growing without bound when over this many points U* moves by less
#: than `STALL_U` relative while T grows by 5 %.
STALL_POINTS = 25
STALL_U = 1e-4


@dataclass(frozen=True)
class HopfStart:
    """Where a branch starts: a Hopf point of the rest state (nondimensional, eq. 17-18 units)."""

    U: float                     # U_H
    frequency: float             # omega at the Hopf point (Im lambda)
    eigenvector: tuple           # q = (q1, q2, q1', q2') complex, A q = i omega q
    amplitude_slopes: tuple | None = None    # d(a_k^2)/dU* of the normal form (None: not known)


def hopf_start(onset) -> HopfStart:
    """The `HopfStart` of an `autocable.model.onset.Onset` (a Hopf point: a complex pair crossing)."""
    if onset.lyapunov is None or not onset.frequency > 0:
        raise ArgumentError("hopf_start", "onset", f"expected a Hopf point (a complex pair crossing), got a "
                                                   f"{onset.criticality} crossing at U* = {onset.U_star:.6g}")
    return HopfStart(float(onset.U_star), float(onset.frequency), tuple(complex(v) for v in onset.eigenvector),
                     None if onset.amplitude_slopes is None else tuple(float(s) for s in onset.amplitude_slopes))


@dataclass(frozen=True, eq=False)
class CyclePoint:
    """One cycle of the branch (nondimensional)."""

    U: float
    T: float                     # the cycle's own period
    state0: np.ndarray           # (q1, q2, q1', q2') on the phase hyperplane
    a1: float                    # half the peak-to-peak of q1 over the cycle
    a2: float
    a_errors: tuple              # the sampling errors of a1, a2 (Richardson)
    multipliers: np.ndarray      # the non-trivial Floquet multipliers, largest modulus first
    trivial: complex             # the trivial multiplier (1 up to the monodromy's accuracy)
    stable: bool
    tangent_U: float             # the U component of the unit tangent (scaled unknowns)
    residual: float              # |phi_T(y0) - y0| / |y0|
    iterations: int
    kind: str = ""               # "" a regular point, "LPC" a refined fold, "H" the Hopf point itself
    orbit: np.ndarray | None = field(default=None, repr=False)   # (SAMPLES_PER_CYCLE, 4) states of one turn

    @property
    def frequency(self) -> float:
        return 2 * math.pi / self.T

    @property
    def max_modulus(self) -> float:
        return float(np.abs(self.multipliers[0])) if len(self.multipliers) else math.nan


@dataclass(frozen=True, eq=False)
class CycleFold:
    """A fold of cycles (LPC): where the branch turns back in U (module docstring)."""

    point: CyclePoint
    U_change: float              # |U| change between the last two estimates (the refinement's error)
    refinements: int             # corrected steps of the refinement
    multiplier_nearest_one: complex   # the non-trivial multiplier nearest +1 there

    @property
    def U(self) -> float:
        return self.point.U


@dataclass(frozen=True, eq=False)
class CycleBranch:
    """A branch of cycles from one Hopf point, in continuation order (the Hopf point first)."""

    hopf: HopfStart
    points: tuple                # CyclePoint, the Hopf point (kind "H") first, folds in their place
    folds: tuple                 # CycleFold
    end: str                     # why the branch ended (one line)
    end_code: str                # "diverged", "U_max", "U_min", "budget", "rest", "period", "stop_below", "failed"
    seconds: float
    steps: int                   # corrected steps (accepted and rejected)

    @property
    def lowest_U(self) -> float:
        """The lowest wind speed U* on the branch (the Hopf point included)."""
        return min(p.U for p in self.points)


@dataclass(frozen=True, eq=False)
class _Flow:
    yT: np.ndarray
    M: np.ndarray
    S: np.ndarray                # d phi_T / dU
    status: str
    t: np.ndarray | None = None
    ys: np.ndarray | None = None


def variational_system(rhs) -> tuple[tuple[str, ...], tuple]:
    """The 24 equations of (y, Phi, s) for the autonomous first-order eq. (21) ``rhs`` (four
    expressions in `STATE` with the parameter U): the state, the monodromy's variational equations
    Phi' = J Phi and the U-sensitivity s' = J s + dF/dU; (names, expressions) in that order, as
    `CycleContinuation.system` compiles them (and `autocable.studies.gallop.DampedSystem` with the
    damping ratio a symbol too)."""
    import sympy as sp

    from autocable.model import derivatives
    memo: dict = {}
    jac = [[derivatives.diff(e, v, memo) for v in STATE] for e in rhs]
    dU = [derivatives.diff(e, U, {}) for e in rhs]
    phi = [[sp.Symbol(f"phi{i}{j}") for j in range(4)] for i in range(4)]
    sens = [sp.Symbol(f"s{i}") for i in range(4)]
    dphi = [sum((jac[i][k] * phi[k][j] for k in range(4)), sp.Integer(0)) for i in range(4) for j in range(4)]
    ds = [sum((jac[i][k] * sens[k] for k in range(4)), sp.Integer(0)) + dU[i] for i in range(4)]
    names = tuple(s.name for s in STATE) + tuple(f"phi{i}{j}" for i in range(4) for j in range(4)) \
        + tuple(f"s{i}" for i in range(4))
    return names, tuple(rhs) + tuple(dphi) + tuple(ds)


class CycleContinuation:
    """Continuation of the cycles of the autonomous eq. (21) of one ODE (module docstring).

    ``rtol``: the integrations' relative tolerance; ``tol``: Newton's on |phi_T(y0) - y0| / |y0|;
    ``amplitude_scale``: the modal amplitude that counts as much as U_H in the arclength (default a
    tenth of `ode21.DIVERGED`)."""

    def __init__(self, ode, *, rtol: float = 1e-11, tol: float = 1e-9, amplitude_scale: float = DIVERGED / 10):
        for name, v in (("rtol", rtol), ("tol", tol), ("amplitude_scale", amplitude_scale)):
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ArgumentError("CycleContinuation", name, f"expected a positive number, got {v!r}")
        self.ode = ode
        self.rtol, self.tol, self.A = float(rtol), float(tol), float(amplitude_scale)
        self._sys = None
        self.build_seconds = 0.0

    # -- the compiled system ---------------------------------------------------------------------
    def system(self):
        """The compiled DOP853 integrator of (y, Phi, s): 24 equations, parameter U (module docstring)."""
        if self._sys is None:
            import sympy as sp

            from autocable.codegen.cintegrate import compiled_integrator
            t0 = time.perf_counter()
            # eta = 0: autonomous; U > 0: the wind switch on and 1/U as itself
            fixed = {ETA: sp.Integer(0), OMEGA: sp.Integer(1), WIND: sp.Integer(1), UINV: 1 / U}
            rhs = [sp.sympify(e).xreplace(fixed) for e in first_order_rhs(self.ode)]
            names, exprs = variational_system(rhs)
            self._sys = compiled_integrator(f"gallop_{self.ode.content_hash()}", names, (U.name,), exprs, None)
            self.build_seconds = time.perf_counter() - t0
        return self._sys

    def rhs(self, y, U_star: float) -> np.ndarray:
        """F(y) of the autonomous eq. (21) at U*."""
        z = np.zeros(24)
        z[:4] = y
        return self.system().rhs(0.0, z, [float(U_star)])[:4]

    def flow(self, y0, T: float, U_star: float, samples: int = 0, rtol: float | None = None) -> _Flow:
        """phi_T(y0), its monodromy and U-sensitivity at U*, and with ``samples`` the states at
        ``samples`` + 1 equal steps over [0, T]; ``status`` is the integrator's ("done" or why not).
        ``rtol``: the integration's (default the continuation's)."""
        y0 = np.asarray(y0, float)
        z0 = np.concatenate([y0, np.eye(4).ravel(), np.zeros(4)])
        grid = np.linspace(0.0, T, samples + 1) if samples else np.array([0.0, T])
        scale = max(float(np.abs(y0).max()), 1e-9)
        turns = max(1.0, T / (2 * math.pi))
        rtol = self.rtol if rtol is None else rtol
        r = self.system().run(z0, grid, [float(U_star)], rtol=rtol, atol=rtol * 1e-2 * scale,
                              max_step=1.0, max_steps=int(200_000 * turns), bound=DIVERGED, n_bound=2)
        if not r.ok:
            return _Flow(r.y_reached[:4], np.full((4, 4), np.nan), np.full(4, np.nan), r.status)
        z = r.y[-1]
        return _Flow(z[:4].copy(), z[4:20].reshape(4, 4).copy(), z[20:24].copy(), "done",
                     r.t if samples else None, r.y[:, :4].copy() if samples else None)

    # -- Newton ----------------------------------------------------------------------------------
    def _scales(self, hopf: HopfStart) -> np.ndarray:
        return np.array([self.A] * 4 + [2 * math.pi / hopf.frequency, hopf.U])

    def _jacobian(self, x, fl: _Flow, n_ref, s) -> np.ndarray:
        """The five rows of Newton's matrix in scaled unknowns (module docstring)."""
        J = np.zeros((5, 6))
        J[:4, :4] = fl.M - np.eye(4)
        J[:4, 4] = self.rhs(fl.yT, x[5]) * s[4] / self.A
        J[:4, 5] = fl.S * s[5] / self.A
        J[4, :4] = n_ref
        return J

    def _correct(self, x, ref, s, *, centre=None, tangent=None, h: float = 0.0, fixed_U: bool = False,
                 max_iter: int = 8):
        """Newton from ``x`` on G = 0, the phase condition about ``ref`` = (y_ref, n_ref), and either
        <(x - centre)/s, tangent> = h or (``fixed_U``) U fixed. Returns (x, flow at x, iterations)
        or (None, the failed flow or None, iterations)."""
        x = np.array(x, float)
        y_ref, n_ref = ref
        floor = 1e-3 * self.A
        last = None
        for it in range(max_iter + 1):
            if not (x[4] > 0 and x[5] > 0):
                return None, None, it
            fl = self.flow(x[:4], x[4], x[5])
            if fl.status != "done":
                return None, fl, it
            g = fl.yT - x[:4]
            res = float(np.linalg.norm(g)) / max(float(np.linalg.norm(x[:4])), floor)
            if res < self.tol:
                return x, fl, it
            if it == max_iter or (last is not None and res > 2 * last and it > 2):
                return None, None, it
            last = res
            J = self._jacobian(x, fl, n_ref, s)
            r = np.concatenate([g / self.A, [float(n_ref @ (x[:4] - y_ref)) / self.A]])
            if fixed_U:
                A, b = J[:, :5], r
            else:
                A = np.vstack([J, tangent])
                b = np.concatenate([r, [float(tangent @ ((x - centre) / s)) - h]])
            try:
                dz = np.linalg.solve(A, b)
            except np.linalg.LinAlgError:
                return None, None, it
            if fixed_U:
                dz = np.concatenate([dz, [0.0]])
            x = x - dz * s
        return None, None, max_iter

    def _tangent(self, x, fl: _Flow, n_ref, s, previous) -> np.ndarray:
        """The unit tangent (scaled) at a converged point, oriented along ``previous``."""
        J = self._jacobian(x, fl, n_ref, s)
        t = np.linalg.solve(np.vstack([J, previous]), np.eye(6)[5])
        t /= np.linalg.norm(t)
        return t if float(t @ previous) > 0 else -t

    def _point(self, x, fl: _Flow, iterations: int, tangent, kind: str = "") -> CyclePoint:
        """Measure a converged cycle: its sampled turn (amplitudes), monodromy and multipliers."""
        y0, T, U_star = x[:4], x[4], x[5]
        m = SAMPLES_PER_CYCLE
        fs = self.flow(y0, T, U_star, samples=m)
        if fs.status != "done":
            fs = fl
            amps, errs, orbit = (math.nan, math.nan), (math.nan, math.nan), None
        else:
            amps, errs = orbit_amplitudes(fs.t, fs.ys)
            orbit = fs.ys[:-1]
        F0 = self.rhs(y0, U_star)
        trivial, mu, _ = split_multipliers(fs.M, F0)
        res = float(np.linalg.norm(fs.yT - y0)) / max(float(np.linalg.norm(y0)), 1e-300)
        stable = bool(len(mu) and float(np.abs(mu[0])) < 1.0 - STABILITY_MARGIN)
        return CyclePoint(U=float(U_star), T=float(T), state0=np.array(y0, float), a1=float(amps[0]),
                          a2=float(amps[1]), a_errors=tuple(float(e) for e in errs), multipliers=mu,
                          trivial=trivial, stable=stable, tangent_U=float(tangent[5]) if tangent is not None
                          else math.nan, residual=res, iterations=int(iterations), kind=kind, orbit=orbit)

    # -- one cycle at a given U ------------------------------------------------------------------
    def cycle_at(self, U_star: float, guess, T_guess: float, hopf: HopfStart) -> CyclePoint | None:
        """The cycle at wind U* by Newton on (y0, T) from ``guess`` (a neighbouring cycle's state0)
        and ``T_guess``; None when Newton does not converge. Its phase hyperplane passes through
        ``guess``, normal to the flow there."""
        if not (isinstance(U_star, (int, float)) and math.isfinite(U_star) and U_star > 0):
            raise ArgumentError("CycleContinuation.cycle_at", "U_star", f"expected a wind speed U* > 0, got {U_star!r}")
        s = self._scales(hopf)
        y = np.asarray(guess, float)
        F = self.rhs(y, U_star)
        n = F / max(float(np.linalg.norm(F)), 1e-300)
        x, fl, its = self._correct(np.concatenate([y, [T_guess, U_star]]), (y, n), s, fixed_U=True)
        if x is None:
            return None
        return self._point(x, fl, its, None)

    def settle(self, y0, U_star: float, T_guess: float, hopf: HopfStart, max_time: float,
               chunk_periods: int = SETTLE_CHUNK_PERIODS) -> tuple[CyclePoint | None, str]:
        """Where the motion from ``y0`` at wind U* settles: direct integration in chunks of
        ``chunk_periods`` periods (``T_guess`` to start with), after each of which the cycle the
        motion is near is solved by Newton (`cycle_at`, from the chunk's end state and the period
        measured over its last turns). Returns (the cycle, "cycle") once Newton finds a stable one,
        (None, "diverged") when the motion leaves |q_k| <= `ode21.DIVERGED`, (None, "rest") when it
        decays below `SETTLE_REST_FRACTION` of where it started, (None, "not settled") at ``max_time``.
        It finds the stable cycles that no branch from a Hopf point reaches (a branch closed on
        itself, or joined to the others beyond the range followed)."""
        y = np.asarray(y0, float)
        start = float(np.abs(y).max())
        t, T = 0.0, float(T_guess)
        while t < max_time:
            span = min(chunk_periods * T, max_time - t)
            fl = self.flow(y, span, U_star, rtol=SETTLE_RTOL)
            if fl.status != "done":
                return None, "diverged"
            y, t = fl.yT, t + span
            if float(np.abs(y).max()) < SETTLE_REST_FRACTION * start:
                return None, "rest"
            # the period of the motion now: upward crossings of q1's mean over a few turns
            turns = 6
            m = SAMPLES_PER_CYCLE // 8
            fs = self.flow(y, turns * T, U_star, samples=turns * m, rtol=SETTLE_RTOL)
            if fs.status != "done":
                return None, "diverged"
            q = fs.ys[:, 0] - fs.ys[:, 0].mean()
            up = [fs.t[i] - q[i] * (fs.t[i + 1] - fs.t[i]) / (q[i + 1] - q[i])
                  for i in range(len(q) - 1) if q[i] < 0.0 <= q[i + 1]]
            if len(up) >= 3:
                T = (up[-1] - up[0]) / (len(up) - 1)
            p = self.cycle_at(U_star, y, T, hopf)
            if p is not None and p.stable:
                return p, "cycle"
        return None, "not settled"

    def lowest_U_of(self, point: CyclePoint, hopf: HopfStart, U_min: float, rtol: float = 1e-4,
                    step: float = 0.03) -> tuple[float, bool]:
        """The lowest U* down to which the stable cycle ``point`` persists, followed at fixed U*
        (`cycle_at`, each from the last cycle's state, extrapolated): steps of ``step`` (relative)
        down until Newton fails or the cycle loses its stability, then bisection to ``rtol``
        (relative). Where a branch folds, Newton at fixed U* has no cycle beyond the fold, so the
        result is the fold's U* within ``rtol``. Returns (U*, True) or (U_min, False) when the cycle
        persists down to ``U_min``. For a cycle on no branch from a Hopf point (`settle`)."""
        last, prev = point, None

        def at(U):
            guess, T = last.state0, last.T
            if prev is not None and prev.U != last.U:
                w = (U - last.U) / (last.U - prev.U)
                guess, T = last.state0 + w * (last.state0 - prev.state0), last.T + w * (last.T - prev.T)
            c = self.cycle_at(U, guess, T, hopf)
            return c if c is not None and c.stable else None

        while True:
            U = max(last.U * (1.0 - step), U_min)
            c = at(U)
            if c is None:
                break
            prev, last = last, c
            if U <= U_min:
                return U_min, False
        lo, hi = U, last.U        # no stable cycle found at lo, one at hi
        while hi - lo > rtol * hi:
            mid = 0.5 * (lo + hi)
            c = at(mid)
            if c is None:
                lo = mid
            else:
                prev, last, hi = last, c, mid
        return hi, True

    # -- a branch --------------------------------------------------------------------------------
    def branch(self, hopf: HopfStart, *, U_min: float, U_max: float, max_points: int = 400,
               h0: float = 0.05, h_max: float = 0.15, h_min: float = 1e-6, stop_below: float | None = None,
               refine_folds: bool = True) -> CycleBranch:
        """The branch of cycles from the Hopf point ``hopf`` (module docstring), U* kept in
        [``U_min``, ``U_max``] (U_min > 0), at most ``max_points`` corrected points; ``h0``,
        ``h_max``, ``h_min``: the arclength steps in scaled unknowns. ``stop_below``: end as soon as
        the branch passes below this U* (a question answered: galloping exists below it)."""
        where = "CycleContinuation.branch"
        for name, v in (("U_min", U_min), ("U_max", U_max), ("h0", h0), ("h_max", h_max), ("h_min", h_min)):
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ArgumentError(where, name, f"expected a positive number, got {v!r}")
        if not U_min < hopf.U < U_max:
            raise ArgumentError(where, "U_max", f"expected U_min < U_H < U_max, got U_min = {U_min:g}, "
                                                f"U_H = {hopf.U:.6g}, U_max = {U_max:g}")
        if not (isinstance(max_points, int) and max_points >= 2):
            raise ArgumentError(where, "max_points", f"expected an integer >= 2, got {max_points!r}")
        start = time.perf_counter()
        s = self._scales(hopf)
        T_H = 2 * math.pi / hopf.frequency
        hopf_row = CyclePoint(U=hopf.U, T=T_H, state0=np.zeros(4), a1=0.0, a2=0.0, a_errors=(0.0, 0.0),
                              multipliers=np.empty(0, complex), trivial=complex(1.0), stable=False,
                              tangent_U=0.0, residual=0.0, iterations=0, kind="H")
        points, folds = [hopf_row], []
        steps = 0

        def done(code, text):
            return CycleBranch(hopf, tuple(points), tuple(folds), text, code, time.perf_counter() - start, steps)

        # the first point: the arclength step from the Hopf point along Re q (module docstring)
        q = np.asarray(hopf.eigenvector, complex)
        q = q * np.exp(-0.5j * np.angle(np.sum(q * q)))        # Re q orthogonal to Im q, |Re q| largest
        k = int(np.argmax(np.abs(q[:2])))
        slopes = hopf.amplitude_slopes
        if slopes is not None and math.isfinite(slopes[k]) and slopes[k] != 0.0:
            a0 = math.sqrt(abs(slopes[k]) * START_OFFSET * hopf.U)
            a0 = min(max(a0, 1e-6), 0.25 * self.A)
            dU = a0 ** 2 / slopes[k]
        else:
            a0, dU = 1e-2 * self.A, 0.0
        r0 = a0 / (2 * abs(q[k]))
        y_guess = 2 * r0 * q.real
        e = np.concatenate([q.real / np.linalg.norm(q.real), [0.0, 0.0]])
        x_H = np.array([0.0, 0.0, 0.0, 0.0, T_H, hopf.U])
        F = self.rhs(y_guess, hopf.U + dU)
        ref = (y_guess, F / np.linalg.norm(F))
        h_start = float(np.linalg.norm(y_guess)) / self.A
        x, fl, its = self._correct(np.concatenate([y_guess, [T_H, hopf.U + dU]]), ref, s, centre=x_H, tangent=e,
                                   h=h_start)
        steps += 1
        if x is None:
            return done("failed", f"no cycle converged next to the Hopf point at U* = {hopf.U:.8g} (Newton from "
                                  f"the normal form's cycle of amplitude {a0:.3g})")
        t = self._tangent(x, fl, ref[1], s, e)
        first = self._point(x, fl, its, t)
        points.append(first)
        a_first = max(first.a1, first.a2)
        grown = False
        h = h0
        budget_left = max_points - 1
        while True:
            if budget_left <= 0:
                return done("budget", f"the point budget ({max_points}) is spent at U* = {x[5]:.8g}")
            prev_pt = points[-1]
            F = self.rhs(x[:4], x[5])
            ref = (x[:4].copy(), F / np.linalg.norm(F))
            x_new = None
            while h >= h_min:
                steps += 1
                x_try, fl_try, its = self._correct(x + h * t * s, ref, s, centre=x, tangent=t, h=h)
                if x_try is not None:
                    t_try = self._tangent(x_try, fl_try, ref[1], s, t)
                    if float(t_try @ t) > 0.9 or h <= 4 * h_min:
                        x_new, fl_new, t_new, its_new = x_try, fl_try, t_try, its
                        break
                elif fl_try is not None and fl_try.status == "bound" and \
                        max(prev_pt.a1, prev_pt.a2) > 0.3 * DIVERGED:
                    return done("diverged", f"the cycle leaves the model's range |q_k| <= {DIVERGED:g} past "
                                            f"U* = {x[5]:.8g} (a = {max(prev_pt.a1, prev_pt.a2):.4g})")
                h *= 0.5
            if x_new is None:
                if x[4] > 1.5 * T_H and abs(t[4]) > 0.5:
                    return done("period", f"the period grows ({x[4] / T_H:.3g} Hopf periods) while U* stays near "
                                          f"{x[5]:.8g} and Newton fails at the smallest step (towards a homoclinic "
                                          "orbit)")
                code = "diverged" if max(prev_pt.a1, prev_pt.a2) > 0.3 * DIVERGED else "failed"
                return done(code, f"Newton failed at the smallest step ({h_min:g}) past U* = {x[5]:.8g}"
                            + (f" near the model's range |q_k| <= {DIVERGED:g}" if code == "diverged" else ""))
            budget_left -= 1
            # out of [U_min, U_max]: the point at the bound itself, by Newton at fixed U
            for bound, code, name in ((U_max, "U_max", "the upper"), (U_min, "U_min", "the lower")):
                if (x_new[5] - bound) * (1 if code == "U_max" else -1) > 0:
                    w = (bound - x[5]) / (x_new[5] - x[5])
                    y_b = x[:4] + w * (x_new[:4] - x[:4])
                    T_b = x[4] + w * (x_new[4] - x[4])
                    p = self.cycle_at(bound, y_b, T_b, hopf)
                    if p is not None:
                        points.append(p)
                    return done(code, f"reached {name} wind bound U* = {bound:.6g}")
            new = self._point(x_new, fl_new, its_new, t_new)
            if t_new[5] * t[5] < 0 and prev_pt.kind != "H":
                fold = self._fold(x, t, h, ref, s, hopf) if refine_folds else None
                if fold is not None:
                    folds.append(fold)
                    points.append(fold.point)
            points.append(new)
            a_new = max(new.a1, new.a2)
            grown = grown or a_new > 4 * a_first
            if stop_below is not None and new.U < stop_below:
                return done("stop_below", f"passed below U* = {stop_below:.8g} (at U* = {new.U:.8g})")
            if grown and a_new < REST_FRACTION * a_first:
                return done("rest", f"the cycle shrinks back onto the rest state near U* = {new.U:.8g} (another "
                                    "Hopf point)")
            if new.T > PERIOD_LIMIT * T_H:
                return done("period", f"the period grows beyond {PERIOD_LIMIT:g} Hopf periods at U* = {new.U:.8g} "
                                      "(towards a homoclinic orbit)")
            recent = points[-STALL_POINTS:]
            spread = max(p.U for p in recent) - min(p.U for p in recent)
            if len(recent) == STALL_POINTS and recent[0].kind != "H" and spread < STALL_U * new.U \
                    and new.T > 1.05 * recent[0].T:
                return done("period", f"the period grows ({recent[0].T / T_H:.3g} to {new.T / T_H:.3g} Hopf periods) "
                                      f"while U* stays within {STALL_U:g} of {new.U:.8g} (towards a homoclinic orbit)")
            if max(new.a1, new.a2) > DIVERGED:
                return done("diverged", f"the cycle leaves the model's range |q_k| <= {DIVERGED:g} at "
                                        f"U* = {new.U:.8g}")
            # the step: longer after an easy Newton, shorter after a hard one or a sharp turn, and
            # short where the branch runs nearly at constant U (|t_U| small): folds there may come in
            # a close pair that a long step jumps without t_U changing sign (the sample cable at
            # U* = 0.8400 and 0.8405, a stable window of 5e-4 in U* between them)
            turn = float(t_new @ t)
            if its_new >= 6 or turn < 0.97:
                h *= 0.6
            elif turn > 0.99 and its_new <= 4:
                # four Newton steps to 1e-9 are the norm from a predictor a few per cent off
                h = min(h * (1.5 if its_new <= 3 else 1.2), h_max)
            h = max(min(h, h_max * min(1.0, max(abs(t_new[5]) / NEAR_FOLD_TU, NEAR_FOLD_MIN))), h_min)
            x, t = x_new, t_new

    def _fold(self, x_a, t_a, h_b: float, ref, s, hopf: HopfStart) -> CycleFold | None:
        """Refine the fold between the point ``x_a`` (tangent ``t_a``) and its successor at step
        ``h_b``: the Illinois method on the tangent's U component g(h) as a function of the step h
        (each evaluation a corrected step from ``x_a``), until two successive estimates of the
        fold's U* agree to `FOLD_U_TOL` and |g| < 1e-8 (or the bracket is at round-off)."""
        def at(h):
            x, fl, its = self._correct(x_a + h * t_a * s, ref, s, centre=x_a, tangent=t_a, h=h)
            if x is None:
                return None
            t = self._tangent(x, fl, ref[1], s, t_a)
            return x, fl, its, t, float(t[5])

        lo, hi = 0.0, float(h_b)
        g_lo = float(t_a[5])
        got = at(hi)
        if got is None or got[4] * g_lo > 0:
            return None
        g_hi = got[4]
        Us = []
        side = 0
        n = 1
        for n in range(2, 80):
            h = hi - g_hi * (hi - lo) / (g_hi - g_lo)
            if not lo < h < hi:
                h = 0.5 * (lo + hi)
            got = at(h)
            if got is None:
                h = 0.5 * (lo + hi)
                got = at(h)
                if got is None:
                    return None
            x, fl, its, t, g = got
            Us.append(float(x[5]))
            if (len(Us) > 1 and abs(Us[-1] - Us[-2]) < FOLD_U_TOL and abs(g) < 1e-8) or g == 0.0 \
                    or hi - lo <= 1e-13 * hi:
                break
            # Illinois: halve the stale end's value when the same end moves twice
            if g * g_hi > 0:
                hi, g_hi = h, g
                if side == 1:
                    g_lo *= 0.5
                side = 1
            else:
                lo, g_lo = h, g
                if side == -1:
                    g_hi *= 0.5
                side = -1
        p = self._point(x, fl, its, t, kind="LPC")
        mu = p.multipliers
        near = complex(mu[int(np.argmin(np.abs(mu - 1.0)))]) if len(mu) else complex(math.nan, math.nan)
        change = abs(Us[-1] - Us[-2]) if len(Us) > 1 else math.nan
        return CycleFold(point=p, U_change=float(change), refinements=n, multiplier_nearest_one=near)


def stability_changes(points) -> list[dict]:
    """Where the cycles of a branch gain or lose stability between neighbouring points (the Hopf
    row left out), with the multiplier that crosses the unit circle on the unstable side: +1 (a
    fold, or a branch point of cycles), -1 (a period doubling) or a complex pair (a torus,
    Neimark-Sacker). Located between the two points, not refined (a fold is: `CycleFold`)."""
    out = []
    pts = [p for p in points if p.kind != "H" and len(p.multipliers)]
    for a, b in zip(pts[:-1], pts[1:]):
        if a.stable == b.stable:
            continue
        unstable = b if a.stable else a
        mu = unstable.multipliers[0]
        if a.kind == "LPC" or b.kind == "LPC":
            kind = "+1 (fold of cycles)"
        elif abs(mu.imag) > 1e-6 * abs(mu):
            kind = "complex pair (torus bifurcation, Neimark-Sacker)"
        elif mu.real > 0:
            kind = "+1 (fold or branch point of cycles)"
        else:
            kind = "-1 (period doubling)"
        out.append({"U_between": (min(a.U, b.U), max(a.U, b.U)), "gains": bool(b.stable), "multiplier": complex(mu),
                    "kind": kind})
    return out
