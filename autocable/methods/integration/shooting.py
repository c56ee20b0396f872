"""Steady responses of eq. (21) by shooting: Newton on the stroboscopic map.

What it solves. Eq. (21) is forced by f = sin(Omega t), Omega = omega1 + sigma (Sect. 4; docs/model.md, C2;
as in `ode21`), so a period-1 response is a fixed point of the period map
P(y) = phi_T(y), T = 2 pi / Omega, and a period-2 response a fixed point of P o P that is not one of
P. Newton on G(y) = phi_kT(y) - y (k = 1, 2) with G' = M - I, M = Phi(kT) the fundamental matrix of
the variational equations

    y' = F(t, y),   Phi' = dF/dy (t, y(t)) Phi,   y(0) = y0,  Phi(0) = I,

converges quadratically from a state near the response; M is then the monodromy and its eigenvalues
are the Floquet multipliers (the stability that `floquet21` computes, here a by-product).

How. The 20 equations (state and Phi) are written from the same sympy right-hand side as every
integrator of eq. (21) (`autocable.model.symbolic.first_order_rhs` and its exact Jacobian) and
compiled into the DOP853 integrator of `autocable.codegen.cintegrate` (content-hashed cache, build
lock): one C call per Newton step. `floquet21` does the same in Python (scipy's DOP853 over
lambdified functions, ~20 ms a period); here a period costs well under a millisecond. Newton's
first steps integrate the 20 equations at a coarse rtol; once the residual is below 1e-3 it goes
on by chord steps (the last monodromy kept) on the four state equations at the full rtol, and one
variational flow at the fixed point gives its monodromy. Every compiled run is prepared once per
(U*, eta*, Omega) and reused (`cintegrate.Repeated`): a point costs about as much in C as in Python.

Where Newton starts. From a short transient: the compiled `Ode21Integrator` integrates whole
forcing periods from the start state (rest with the q2 seed of `ode21.DEFAULT_Q0` unless told
otherwise), or from a caller's ``guess`` (a neighbouring point's response). Transient integration
stays the fallback and the judge: a fixed point found by Newton is accepted only when it is stable
(every |mu| < 1 - `floquet21.STABILITY_MARGIN`) and the transient's own state is seen moving towards
it (`_attracts`), so shooting reports the response integration would reach; otherwise the transient
goes on (stages of `TRANSIENT_STAGES` periods), and after the last stage `Ode21Integrator.simulate`
decides as it always has. What Newton finds steers the transient: an unstable period-1 orbit with a
real multiplier > 1 (the planar orbit past its pitchfork, Fig. 6) is left along its unstable
direction (`_escape`) instead of crept away from; one with a multiplier < -1 (a period doubling), or
a transient that repeats every two periods, calls for a period-2 attempt; one unstable only through
a complex pair (a torus: modulated motion, or galloping growth above U_c) hands over to integration
at once.

Classes (`RESPONSE_CLASSES`): ``rest`` (the period-1 fixed point has amplitudes below the
integration's absolute accuracy, e.g. eta* = 0 below flutter), ``period-1``, ``period-2``,
``quasi-periodic`` (an amplitude-modulated response: not periodic with T or 2T; the transient's
envelope, or no steady state within the time limit, which `message` says), ``diverged`` (|q_k| beyond
`ode21.DIVERGED`, e.g. above the critical wind U* > 1 of Sect. 3 where eq. (21) has no bounded
response), ``autonomous-periodic`` (eta* = 0, where eq. (21) is autonomous: a self-excited cycle,
galloping, with its own period, found by autonomous shooting with a phase condition and the period
as an unknown, `autonomous.newton_cycle`; its stability from the Floquet multipliers other than the
trivial 1, `autonomous.split_multipliers`). The last class was added after the others, so that
the integer codes of the earlier ones do not change.

Amplitudes. a_k as everywhere in autocable: half the peak-to-peak of q_k, sampled 64 times per
forcing period from forcing phase 0 with parabolic peaks (`ode21.half_range`), over one period
(period-1) or two (period-2). The samples fall on the same phases as `Ode21Integrator.simulate`'s
window, so both report the same number for the same orbit.
"""
from __future__ import annotations

import math
import threading
import time
from dataclasses import dataclass, field, replace

import numpy as np

from autocable.codegen.cintegrate import Repeated, sample_grid
from autocable.errors import ComputationError
from autocable.methods.integration.floquet21 import STABILITY_MARGIN, multipliers_of
from autocable.methods.integration.autonomous import newton_cycle, split_multipliers
from autocable.methods.integration.cycles import MAX_CROSSINGS_PER_PERIOD, orbit_amplitudes, own_cycles
from autocable.methods.integration.ode21 import (DEFAULT_Q0, DIVERGED, Ode21Integrator, grew, half_range,
                                                 is_autonomous, _stopped)
from autocable.model.premises import (NOT_GIVEN, SI_PARAMETERS, STAR_NAMES, ArgumentError, check_call, check_number,
                                      check_state, choose_parameter, parameter_from_si)
from autocable.model.symbolic import PARAMETERS, STATE, T, first_order_rhs, parameter_values

#: The response classes, in the order of their integer codes (`RESPONSE_CODES`).
RESPONSE_CLASSES = ("rest", "period-1", "period-2", "quasi-periodic", "diverged", "autonomous-periodic")
RESPONSE_CODES = {name: k for k, name in enumerate(RESPONSE_CLASSES)}
#: Transient stages (forcing periods integrated before each shooting attempt). The damping
#: decrement of the sample cable is 1 - exp(-2 pi xi_s) = 0.025 a period, so 30 periods shrink a
#: start's distance to the response by ~e^-0.75 and 60 by ~e^-1.5: enough for Newton's basin away
#: from bifurcations (eq. (21) is weakly nonlinear at these amplitudes); the later stages serve slow
#: approaches (near folds and pitchforks). The stages only carry the start into an orbit's basin
#: (Newton, not the stage, fixes the orbit to the solver's rtol): the first at FIRST_STAGE_RTOL,
#: the later ones at STAGE_RTOL. A long transient's fate can hang on small errors: at U* = 0.96,
#: eta* = 5.7e-4, sigma = 0.01 the transient from rest wanders for 26000 time units past a stable
#: orbit and then diverges (at rtol 1e-10 and 1e-12 alike); stages at 1e-6 landed on the orbit,
#: at 1e-7 and 1e-8 they diverge as integration does (tests/test_shooting.py).
TRANSIENT_STAGES = (30, 30, 60, 120, 120, 240, 480, 1000)  # each >= 3
FIRST_STAGE_RTOL = 1e-6
STAGE_RTOL = 1e-8
#: The loosest rtol of the judge (`ShootingSolver._attracts`), used when the distance it judges is
#: a good part of the orbit's size; closer starts are judged at tighter tolerances.
JUDGE_RTOL = 1e-5
#: Samples per forcing period for the amplitudes (the same as `Ode21Integrator.simulate`).
SAMPLES_PER_PERIOD = 64
#: Newton's first steps integrate the variational equations at this rtol, down to a residual of
#: COARSE_SWITCH; then chord steps on the state alone at the solver's rtol (1e-11), which alone
#: decides convergence (`ShootingSolver._chord`).
COARSE_RTOL = 1e-8
COARSE_SWITCH = 1e-3
_EYE4 = np.eye(4).ravel()
_EYE4.flags.writeable = False
#: The monodromy returned with a fixed point (its Floquet multipliers) is integrated at this rtol:
#: its entries are O(1), so they carry about ten digits, two more than the stability test and the
#: multipliers reported need; the fixed point itself is at the solver's rtol.
MONODROMY_RTOL = 1e-10
#: Version of the shooting algorithm (part of a sweep's provenance).
SHOOTING_VERSION = "3"     # 3: autonomous shooting at eta* = 0


@dataclass(frozen=True, eq=False)
class SteadyResponse:
    """The steady response of eq. (21) at one parameter point, as shooting classifies it.

    ``a1 .. a2_max`` follow `ode21.Response` (a_k the half peak-to-peak of q_k over the orbit; the
    envelope the min/max of that over single forcing periods); ``math.inf`` when diverged and the
    transient's envelope when quasi-periodic. ``multipliers`` are the Floquet multipliers of the
    period-k map of the returned orbit (k = ``periods``; empty when there is no orbit)."""

    response: str              # one of RESPONSE_CLASSES
    a1: float
    a2: float
    a1_min: float
    a1_max: float
    a2_min: float
    a2_max: float
    U: float
    eta: float
    sigma: float
    Omega: float
    periods: int               # 1 or 2 for an orbit found by shooting, 0 otherwise
    state0: tuple              # (q1, q2, q1', q2') at forcing phase 0 (the orbit, or the last state)
    multipliers: np.ndarray    # complex, sorted by modulus, largest first
    residual: float            # |phi_kT(y) - y| / max(|y|, floor) at state0
    newton_iterations: int
    transient_periods: int     # forcing periods integrated before shooting succeeded (or in total)
    fallback: bool             # True when `Ode21Integrator.simulate` decided
    t_end: float
    message: str
    wall_seconds: float
    details: dict = field(default_factory=dict)
    #: the response's period (2 pi k / Omega for a period-k orbit, the cycle's own period when
    #: autonomous-periodic); nan otherwise
    period: float = math.nan
    #: the stated error of a1, a2 (autonomous-periodic: the sampling error of the orbit's extremes)
    a1_error: float = math.nan
    a2_error: float = math.nan
    #: autonomous-periodic: the trivial multiplier (1 up to the monodromy's accuracy), excluded from
    #: ``multipliers`` and from the stability verdict
    trivial_multiplier: complex = complex(math.nan, math.nan)

    @property
    def steady(self) -> bool:
        return self.response in ("rest", "period-1", "period-2", "quasi-periodic", "autonomous-periodic") and \
            "not steady" not in self.message

    @property
    def periodic(self) -> bool:
        """Periodic: period-1 in the forcing (the meaning of ``periodic`` in `ode21.Response`), or a
        cycle of the autonomous eq. (21) with its own period."""
        return self.response in ("rest", "period-1", "autonomous-periodic")

    @property
    def max_modulus(self) -> float:
        return float(np.abs(self.multipliers[0])) if len(self.multipliers) else math.nan


def _norm(v) -> float:
    """The 2-norm of a short vector (np.linalg.norm's checks cost more than the sum here)."""
    return math.sqrt(float(v @ v))


def periodic_half_range(x: np.ndarray) -> float:
    """Half the peak-to-peak of one turn of a periodic signal sampled uniformly (the last sample
    one step before the first repeats), each extreme refined by the parabola through it and its
    two neighbours taken cyclically (`ode21.refined_peak` for an extreme inside the window)."""
    x = np.asarray(x, dtype=float)

    def peak(y):
        i = int(np.argmax(y))
        a, b, c = y[i - 1], y[i], y[(i + 1) % len(y)]
        den = a - 2 * b + c
        return b - 0.125 * (a - c) ** 2 / den if den < 0 else b

    return 0.5 * (peak(x) + peak(-x))


@dataclass(frozen=True, eq=False)
class _Stage:
    """A transient stage that ran to its end: the samples (as `CRun`, whose other fields only a
    stopped run needs)."""

    y: np.ndarray
    ok: bool = True


class ShootingSolver:
    """Shooting for eq. (21) of one `TwoModeODE`: the compiled integrators are built once (cached
    across processes by content hash) and reused for every point. Built from a `Derivation`
    (``ac.derive(...)``) instead of its ``ode``, it keeps the cable, and `steady` takes SI values
    too (``wind_m_s``, ``deck_amplitude_m``, ``deck_frequency_Hz``, as `frequency_response`)."""

    def __init__(self, ode, *, rtol: float = 1e-11, transient_rtol: float = 1e-10,
                 transient_atol: float = 1e-13):
        from autocable.model.derive import Derivation
        # a Derivation carries the cable's scales (eqs. 17-18) for SI values; eq. (21) is its ode
        self.cable = ode if isinstance(ode, Derivation) else None
        ode = ode.ode if isinstance(ode, Derivation) else ode
        self.ode = ode
        self.rtol = float(rtol)
        self.integrator = Ode21Integrator(ode, engine="compiled", rtol=transient_rtol, atol=transient_atol)
        self._var = None
        # Repeated runs per (kind, U, eta, Omega, length): a point's Newton steps, judge and
        # stages reuse them, and a sweep's next point builds its own (oldest dropped). Their
        # buffers are written by every call, so each thread has its own (a Dask worker on an
        # existing scheduler may run several tasks on one solver at once).
        self._local = threading.local()

    def _star_values(self, U, eta, sigma, wind_m_s, deck_amplitude_m, deck_frequency_Hz) -> tuple:
        """(U*, eta*, sigma) of `steady`'s arguments: each quantity given once, nondimensional as
        given (checked by `check_call` after), SI converted on the solver's cable by
        `parameter_from_si` (refused by its keyword without a cable or outside the premises)."""
        f = "ShootingSolver.steady"
        out = []
        for name, star, si in (("U", U, wind_m_s), ("eta", eta, deck_amplitude_m), ("sigma", sigma, deck_frequency_Hz)):
            kind = choose_parameter(f, name, star, si)
            keyword = SI_PARAMETERS[name][0]
            if kind is None:
                star_name = f" ({STAR_NAMES[name]})" if STAR_NAMES[name] != name else ""
                raise ArgumentError(f, name, f"missing: give {name}{star_name} or {keyword} (in {SI_PARAMETERS[name][1]})")
            if kind[0] == "star":
                out.append(kind[1])
                continue
            if self.cable is None:
                raise ArgumentError(f, keyword, "SI values need the cable (its length, U_c and omega): build the "
                                                "solver from the Derivation, ShootingSolver(ac.derive(...)), not its "
                                                ".ode")
            from autocable.model.units import units_of
            units = units_of(self.cable.spec, self.cable.statics)
            out.append(parameter_from_si(f, name, kind[1], units, self.ode.omega1))
        return tuple(out)

    # -- the compiled variational system -------------------------------------------------------
    def _variational(self):
        if self._var is None:
            import sympy as sp

            from autocable.codegen.cintegrate import compiled_integrator
            rhs = first_order_rhs(self.ode)
            jac = sp.Matrix(rhs).jacobian(sp.Matrix(STATE))
            phi = sp.Matrix(4, 4, lambda i, j: sp.Symbol(f"phi{i}{j}", real=True))
            dphi = jac * phi
            names = tuple(s.name for s in STATE) + tuple(f"phi{i}{j}" for i in range(4) for j in range(4))
            self._var = compiled_integrator(f"eq21var_{self.ode.content_hash()}", names,
                                            tuple(p.name for p in PARAMETERS),
                                            tuple(rhs) + tuple(dphi[i, j] for i in range(4) for j in range(4)),
                                            T.name)
        return self._var

    def _parameters(self, U: float, eta: float, Omega: float) -> list:
        pars = parameter_values(U, eta, Omega)
        return [pars[p.name] for p in PARAMETERS]

    def _repeated(self, key, make):
        runs = getattr(self._local, "runs", None)
        if runs is None:
            runs = self._local.runs = {}
        r = runs.get(key)
        if r is None:
            if len(runs) >= 64:
                runs.pop(next(iter(runs)))
            r = runs[key] = make()
        return r

    def flow(self, U: float, eta: float, Omega: float, y0, periods: int = 1, rtol: float | None = None):
        """(y(kT), Phi(kT)) from y(0) = ``y0`` over k = ``periods`` forcing periods, or None when
        the orbit leaves |q_k| <= `ode21.DIVERGED` (or the integration fails); ``rtol`` defaults
        to the solver's."""
        rtol = self.rtol if rtol is None else float(rtol)
        y0 = np.asarray(y0, dtype=float)
        run = self._repeated(("flow", U, eta, Omega, periods), lambda: Repeated(
            self._variational(), [0.0, periods * 2 * math.pi / Omega], self._parameters(U, eta, Omega),
            max_step=1.0, max_steps=200_000 * periods, bound=DIVERGED, n_bound=2))
        z0 = np.concatenate([y0, _EYE4])
        scale = max(float(np.abs(y0).max()), 1e-9)
        ys = run(z0, rtol, rtol * 1e-2 * scale)
        if ys is None:
            return None
        z = ys[-1]
        return z[:4].copy(), z[4:].reshape(4, 4).copy()

    def newton(self, U: float, eta: float, Omega: float, guess, periods: int = 1, *,
               tol: float = 1e-11, max_iter: int = 10, floor: float = 1e-12):
        """Newton on phi_kT(y) - y from ``guess``: (y, M, residual, iterations, converged).

        The residual is |phi_kT(y) - y| / max(|y|, ``floor``); ``floor`` keeps the rest state y = 0
        (eta* = 0) convergent in absolute terms. Steps are damped (halved up to 6 times) when the
        full step does not reduce the residual, which widens the basin a little; a step that four
        halvings do not make reduce the residual ends the attempt (far from any fixed point, more
        transient is cheaper than more Newton)."""
        y = np.asarray(guess, dtype=float).copy()
        # The first steps only need to get close: the flow at COARSE_RTOL costs about 2.4 times
        # fewer DOP853 steps (rtol^(1/8)); the last steps, the residual test and the returned
        # monodromy are at the solver's rtol.
        rt = max(COARSE_RTOL, self.rtol)
        fine = rt == self.rtol

        def residual(y_, got_):
            return _norm(got_[0] - y_) / max(_norm(y_), floor)

        got = self.flow(U, eta, Omega, y, periods, rt)
        if got is None:
            return y, None, math.inf, 0, False
        yT, M = got
        res = residual(y, got)
        for it in range(1, max_iter + 1):
            if not fine and res < COARSE_SWITCH:
                done = self._chord(U, eta, Omega, y, yT, M, periods, tol, floor, it, max_iter)
                if done is not None:
                    return done
                rt, fine = self.rtol, True
                got = self.flow(U, eta, Omega, y, periods, rt)
                if got is None:
                    return y, None, math.inf, it, False
                yT, M = got
                res = residual(y, got)
            if fine and res < tol:
                return y, M, res, it - 1, True
            try:
                step = np.linalg.solve(M - _EYE4.reshape(4, 4), yT - y)
            except np.linalg.LinAlgError:
                return y, M, res, it, False
            lam = 1.0
            for _ in range(5):
                y_new = y - lam * step
                got = self.flow(U, eta, Omega, y_new, periods, rt)
                if got is not None:
                    res_new = residual(y_new, got)
                    if res_new < res or res_new < tol:
                        break
                lam *= 0.5
            else:
                return y, M, res, it, False
            y, (yT, M), res = y_new, got, res_new
        return y, M, res, max_iter, fine and res < tol

    def _state_flow(self, U: float, eta: float, Omega: float, y0, periods: int):
        """y(kT) from y(0) = ``y0`` at the solver's rtol, the four equations of eq. (21) alone (the
        tolerances of `flow`), or None when the run stopped early."""
        run = self._repeated(("state", U, eta, Omega, periods), lambda: Repeated(
            self.integrator._c_integrator(), [0.0, periods * 2 * math.pi / Omega],
            self._parameters(U, eta, Omega), max_step=1.0, max_steps=200_000 * periods, bound=DIVERGED,
            n_bound=2))
        scale = max(float(np.abs(y0).max()), 1e-9)
        ys = run(y0, self.rtol, self.rtol * 1e-2 * scale)
        return None if ys is None else ys[-1].copy()

    def _chord(self, U, eta, Omega, y, yT, M, periods, tol, floor, it, max_iter):
        """Newton's last steps, once the residual is below COARSE_SWITCH: the chord method, keeping
        the monodromy ``M`` of the last coarse flow (taken that close to the fixed point, it differs
        from the fixed point's by about the residual times the nonlinearity, so each step gains
        several digits; measured: two steps from 1e-3 to below 1e-11), on flows of the state alone,
        a fifth of the work of a variational flow, then one variational flow at the fixed point for
        its monodromy (the Floquet multipliers). The same fixed point as Newton at the solver's
        rtol, whose residual decides: (y, M, residual, iterations, True), or None when a step does
        not halve the residual (Newton takes over)."""
        try:
            # one inverse for every step: the chord's matrix does not change
            A_inv = np.linalg.inv(M - _EYE4.reshape(4, 4))
            y = y - A_inv @ (yT - y)
            last = math.inf
            for k in range(it, max_iter + 1):
                yT = self._state_flow(U, eta, Omega, y, periods)
                if yT is None:
                    return None
                d = yT - y
                res = _norm(d) / max(_norm(y), floor)
                if res < tol:
                    got = self.flow(U, eta, Omega, y, periods, max(MONODROMY_RTOL, self.rtol))
                    return None if got is None else (y, got[1], res, k, True)
                if not res < 0.5 * last:
                    return None
                last = res
                y = y - A_inv @ d
        except np.linalg.LinAlgError:
            return None
        return None

    # -- orbit measurements --------------------------------------------------------------------
    def orbit_amplitudes(self, U: float, eta: float, Omega: float, y0, periods: int):
        """(a1, a2, envelope) of the period-k orbit through ``y0`` (k = ``periods``): the half
        peak-to-peak of q_k from 64 k samples over one turn of the orbit, each extreme refined by
        the parabola through its neighbours taken cyclically (`periodic_half_range`), as inside
        ode21's window of 20 periods; the envelope is (a, a) for k = 1 and, for k = 2, the min/max
        of the same over each of the two forcing periods."""
        n = SAMPLES_PER_PERIOD
        period = 2 * math.pi / Omega
        ig = self.integrator

        def make():
            # the grid, budget and bound of `Ode21Integrator.run_compiled`, checked once
            grid = sample_grid(0.0, periods * period, period / n)
            if len(grid) != periods * n + 1:
                raise ComputationError(f"the sample grid over {periods} period(s) has {len(grid)} times, "
                                       f"expected {periods * n + 1}")
            return Repeated(ig._c_integrator(), grid, self._parameters(U, eta, Omega), max_step=1.0,
                            max_steps=ig._budget(0.0, periods * period, len(grid)), n_bound=2)

        ys = self._repeated(("orbit", U, eta, Omega, periods), make)(np.asarray(y0, float), ig.rtol, ig.atol)
        if ys is None:
            pars = parameter_values(U, eta, Omega)
            r = ig.run_compiled(tuple(y0), 0.0, periods * period, period / n, pars)
            raise ComputationError("eq. (21) could not be integrated over the orbit found by shooting "
                                   f"({_stopped(r, 0.0, periods * period)})")
        w = ys[:-1, :2].copy()
        amps = (periodic_half_range(w[:, 0]), periodic_half_range(w[:, 1]))
        if periods == 1:
            return amps, [(a, a) for a in amps]
        # one forcing period of a period-2 orbit is not periodic: ode21's window rule, extended by
        # a quarter period either side so that its extremes are interior
        ext = np.concatenate([w[-n // 4:], w, w[:n // 4 + 1]])
        per = [[half_range(ext[i * n:(i + 1) * n + n // 2 + 1, k]) for i in range(periods)] for k in (0, 1)]
        return amps, [(min(p), max(p)) for p in per]

    def _attracts(self, U, eta, Omega, y_star, y_tr, periods: int, mu_max: float) -> bool:
        """The judge: integrating on from the transient's state ``y_tr``, its
        distance to the fixed point ``y_star`` of the period-k map has shrunk by a quarter after
        as many periods as the slowest multiplier ``mu_max`` needs to halve it (at least 4, at
        most 200 turns; the margin allows for the non-normal start of the approach): it is in the
        orbit's basin, not only in Newton's. A coexisting stable
        orbit that Newton reached from a state integration carries elsewhere (the other side of a
        resonance's hysteresis) fails: its distance grows."""
        d0 = _norm(np.asarray(y_tr) - y_star)
        size = max(_norm(y_star), 1e-12)
        if d0 <= 1e-6 * size:
            return True
        turns = 200 if not 0.0 < mu_max < 1.0 else min(200, max(4, math.ceil(math.log(0.5) / math.log(mu_max))))
        period = 2 * math.pi / Omega
        n = turns * periods
        # The integration error must stay far below the quarter of d0 that decides. Each period
        # adds about rtol |y*| or less (measured: 1.2e-3 |y*| after 28 periods at rtol 1e-5 with
        # the step free, Fig. 5a's setting), so rtol = 1e-3 d0 / (n |y*|) keeps the total to a
        # few per cent of that quarter: JUDGE_RTOL for a fresh transient (d0 a good part of |y*|),
        # tighter for a start already near the orbit (a neighbouring point's). The step is left to
        # the error control (up to half a period): the judge samples only period ends.
        rtol = min(JUDGE_RTOL, 1e-3 * d0 / (max(n, 3) * size))
        atol = rtol * 1e-2 * max(float(np.abs(y_star).max()), 1e-9)
        r = self._stage_run(np.asarray(y_tr, float), max(n, 3), period, parameter_values(U, eta, Omega), rtol,
                            atol, max_step=period / 2)
        if not r.ok:
            return False
        return bool(_norm(r.y[-1] - y_star) < 0.75 * d0)

    # -- autonomous cycles (eta* = 0) ----------------------------------------------------------
    def flow_time(self, U: float, eta: float, Omega: float, y0, T: float, rtol: float | None = None):
        """(y(T), Phi(T)) from y(0) = ``y0`` over a time ``T`` (not a whole number of forcing
        periods: the period of an autonomous cycle), or None as `flow`."""
        rtol = self.rtol if rtol is None else float(rtol)
        y0 = np.asarray(y0, dtype=float)
        scale = max(float(np.abs(y0).max()), 1e-9)
        turns = max(1, math.ceil(T * Omega / (2 * math.pi)))
        r = self._variational().run(np.concatenate([y0, _EYE4]), np.array([0.0, float(T)]),
                                    self._parameters(U, eta, Omega), rtol=rtol, atol=rtol * 1e-2 * scale,
                                    max_step=1.0, max_steps=200_000 * turns, bound=DIVERGED, n_bound=2)
        if not r.ok:
            return None
        z = r.y[-1]
        return z[:4].copy(), z[4:].reshape(4, 4).copy()

    def _vector_field(self, U: float, eta: float, Omega: float):
        """F(y) of eq. (21) at (U*, eta* = 0, Omega): the right-hand side at t = 0 (autonomous)."""
        f = self.integrator._scipy_rhs()
        pars = parameter_values(U, eta, Omega)
        p = tuple(pars[s.name] for s in PARAMETERS)
        return lambda y: np.asarray(f(0.0, tuple(float(v) for v in y), p), float)

    def _sampled(self, U, eta, Omega, y, t1: float, dt: float):
        """The compiled transient integrator's samples from ``y`` over [0, t1] every ``dt``, or None."""
        r = self.integrator.run_compiled(tuple(float(v) for v in y), 0.0, t1, dt,
                                         parameter_values(U, eta, Omega), bound=DIVERGED)
        return r if r.ok else None

    def cycle(self, U: float, eta: float, Omega: float, y_from, *, judge: bool = True,
              floor: float = 1e-10):
        """Autonomous shooting (`autonomous.newton_cycle`) for the self-excited cycle of eq. (21) at
        eta* = 0 near the state ``y_from`` = (q1, q2, q1', q2'): the start and the period are read
        from a few cycles integrated from it (`cycles.own_cycles`). Returns a dict (state0, period,
        amplitudes and their errors, the trivial and the other multipliers, residual, iterations,
        and why it was refused) or None when no cycle could be started from there. Accepted
        (``"accepted"``) when it converged, is not the rest state, is stable by the non-trivial
        multipliers and (``judge``) integration from ``y_from`` approaches it."""
        period = 2 * math.pi / Omega
        n = SAMPLES_PER_PERIOD
        r = self._sampled(U, eta, Omega, y_from, 8 * period, period / n)
        cyc = own_cycles(r.t, r.y, min_cycles=2) if r is not None else None
        if cyc is None:
            return None
        F = self._vector_field(U, eta, Omega)
        c = newton_cycle(lambda y, T: self.flow_time(U, eta, Omega, y, T), F, cyc.section[-1], cyc.period,
                         cyc.coordinate, floor=floor)
        out = {"converged": c.converged, "iterations": c.iterations, "residual": c.residual,
               "period": c.period, "state0": c.state0, "accepted": False}
        if not c.converged:
            out["why"] = "Newton did not converge"
            return out
        if float(np.max(np.abs(c.state0[:2]))) < floor:
            out["why"] = "converged on the rest state"
            return out
        M = c.monodromy
        got = self.flow_time(U, eta, Omega, c.state0, c.period, max(MONODROMY_RTOL, self.rtol))
        if got is not None:
            M = got[1]
        trivial, mu, check = split_multipliers(M, F(c.state0))
        out.update(trivial=trivial, multipliers=mu, eigen_check=check)
        mu_max = float(np.abs(mu[0])) if len(mu) else 0.0
        if not mu_max < 1.0 - STABILITY_MARGIN:
            out["why"] = f"unstable (largest non-trivial |mu| = {mu_max:.6g})"
            return out
        # the orbit sampled over one turn, 4 n samples (its extremes to ~1e-11 relative)
        T = c.period
        m = 4 * n
        ro = self.integrator.run_compiled(tuple(c.state0), 0.0, T * (1 + 1e-12), T / m,
                                          parameter_values(U, eta, Omega))
        if not ro.ok:
            out["why"] = "the orbit could not be sampled"
            return out
        amps, errs = orbit_amplitudes(ro.t[:m + 1], ro.y[:m + 1])
        out.update(amplitudes=amps, errors=errs)
        if judge and not self._cycle_attracts(U, eta, Omega, c.state0, T, y_from, cyc.coordinate, mu_max):
            out["why"] = "integration from the transient does not approach it"
            return out
        out["accepted"] = True
        return out

    def _cycle_attracts(self, U, eta, Omega, y_star, T, y_tr, k: int, mu_max: float) -> bool:
        """The judge of a cycle (as `_attracts` for a forced orbit): integrating on from the
        transient's state ``y_tr``, its crossings of the section q_k = 0 get closer to the cycle's
        ``y_star`` by a quarter over as many turns as the slowest non-trivial multiplier needs to
        halve the distance (4 to 200 turns)."""
        turns = 200 if not 0.0 < mu_max < 1.0 else min(200, max(4, math.ceil(math.log(0.5) / math.log(mu_max))))
        r = self._sampled(U, eta, Omega, y_tr, (turns + 2) * T, T / SAMPLES_PER_PERIOD)
        if r is None:
            return False
        # every crossing a section point (a period may hold several: the nearest of the first
        # and of the last few measure the distance to the cycle)
        cyc = own_cycles(r.t, r.y, min_cycles=2, coordinate=k, crossings_per_period=1)
        if cyc is None:
            return False
        size = max(_norm(np.asarray(y_star)), 1e-12)
        n = min(MAX_CROSSINGS_PER_PERIOD, len(cyc.section) // 2)
        d0 = min(_norm(v - y_star) for v in cyc.section[:n])
        if d0 <= 1e-6 * size:
            return True
        return bool(min(_norm(v - y_star) for v in cyc.section[-n:]) < 0.75 * d0)

    # -- the steady response -------------------------------------------------------------------
    def steady(self, U: float = NOT_GIVEN, eta: float = NOT_GIVEN, sigma: float = NOT_GIVEN, q0=DEFAULT_Q0, *,
               guess=None, stages=TRANSIENT_STAGES, max_time: float = 60000.0, rest_floor: float | None = None,
               wind_m_s=NOT_GIVEN, deck_amplitude_m=NOT_GIVEN, deck_frequency_Hz=NOT_GIVEN) -> SteadyResponse:
        """The steady response of eq. (21) at (U*, eta*, sigma) reached from ``q0`` = (q1, q1',
        q2, q2') (the command-line order of `Ode21Integrator.simulate`), by shooting after short
        transients; ``guess`` = (q1, q2, q1', q2') at phase 0 (e.g. a neighbouring point's
        ``state0``) is tried first, before any transient.

        In SI instead, on a solver built from a `Derivation` (eqs. 17-18, as `frequency_response`
        converts; one kind per quantity): ``wind_m_s`` for U (U* = U/U_c), ``deck_amplitude_m``
        for eta (eta* = eta/l), ``deck_frequency_Hz`` for sigma (sigma = 2 pi f/omega - omega1).
        The response's ``U``, ``eta``, ``sigma`` are the nondimensional values."""
        U, eta, sigma = self._star_values(U, eta, sigma, wind_m_s, deck_amplitude_m, deck_frequency_Hz)
        check_call("ShootingSolver.steady", U=U, eta=eta, sigma=sigma, q0=q0, max_time=max_time,
                   omega1=self.ode.omega1)
        if guess is not None:
            check_state("ShootingSolver.steady", "guess", guess, "(q1, q2, q1', q2')")
        if rest_floor is not None:
            check_number("ShootingSolver.steady", "rest_floor", rest_floor, 0.0, lo_open=True,
                         what="the amplitude below which a response is rest")
        start = time.perf_counter()
        Omega = self.ode.omega1 + sigma
        if not Omega > 0:
            raise ValueError(f"sigma = {sigma} gives a non-positive forcing frequency Omega = {Omega}")
        period = 2 * math.pi / Omega
        floor = 1e3 * self.integrator.atol if rest_floor is None else float(rest_floor)
        pars = parameter_values(U, eta, Omega)
        q1, q1d, q2, q2d = (float(x) for x in q0)
        y = np.array([q1, q2, q1d, q2d])
        done = 0
        newton_total = 0
        tried = []

        def result(kind, amps, env, k, state, mu, res, msg, fallback=False, t_end=None, **extra):
            if kind in ("period-1", "period-2", "rest") and "period" not in extra:
                extra["period"] = k * period
            return SteadyResponse(kind, float(amps[0]), float(amps[1]), float(env[0][0]), float(env[0][1]),
                                  float(env[1][0]), float(env[1][1]), float(U), float(eta), float(sigma),
                                  float(Omega), k, tuple(float(v) for v in state),
                                  np.asarray(mu, complex), float(res), newton_total, done, fallback,
                                  done * period if t_end is None else float(t_end), msg,
                                  time.perf_counter() - start, {"attempts": tried}, **extra)

        autonomous = is_autonomous(eta)

        def attempt_cycle(y_from, judge=True):
            """Autonomous shooting from ``y_from`` (eta* = 0): the accepted SteadyResponse or None."""
            nonlocal newton_total
            got = self.cycle(U, eta, Omega, y_from, judge=judge, floor=floor)
            if got is None:
                return None
            newton_total += got["iterations"]
            tried.append({"autonomous": True, "after_transient_periods": done, "converged": got["converged"],
                          "iterations": got["iterations"],
                          "residual": got["residual"] if math.isfinite(got["residual"]) else None,
                          **({"refused": got["why"]} if not got["accepted"] else {})})
            if not got["accepted"]:
                return None
            amps, errs, Tc, tr = got["amplitudes"], got["errors"], got["period"], got["trivial"]
            return result("autonomous-periodic", amps, [(a, a) for a in amps], 1, got["state0"],
                          got["multipliers"], got["residual"],
                          f"autonomous periodic orbit by shooting (eta* = 0: a self-excited cycle of own period "
                          f"{Tc:.9g}, frequency {2 * math.pi / Tc:.9g}; {got['iterations']} Newton steps, residual "
                          f"{got['residual']:.1e}; trivial multiplier {tr.real:.9f}, excluded from the stability "
                          f"verdict); a1 = {amps[0]:.9e} +- {errs[0]:.1e}, a2 = {amps[1]:.9e} +- {errs[1]:.1e}",
                          period=Tc, a1_error=errs[0], a2_error=errs[1], trivial_multiplier=tr)

        def attempt(y_from, k, judge_from):
            """Shoot for a period-k orbit from ``y_from``; (accepted SteadyResponse or None, the
            fixed point and its monodromy when Newton converged)."""
            nonlocal newton_total
            ys, M, res, its, ok = self.newton(U, eta, Omega, y_from, k, floor=floor)
            newton_total += its
            tried.append({"periods": k, "after_transient_periods": done, "converged": bool(ok),
                          "iterations": its, "residual": res if math.isfinite(res) else None})
            if not ok:
                return None, None, None
            mu = multipliers_of(M)
            if not float(np.abs(mu[0])) < 1.0 - STABILITY_MARGIN:
                tried[-1]["unstable"] = True
                return None, ys, M
            if k == 2:
                # A period-1 orbit is a fixed point of the period-2 map too.
                got = self.flow(U, eta, Omega, ys, 1)
                if got is None or float(np.linalg.norm(got[0] - ys)) <= 1e-6 * max(float(np.linalg.norm(ys)), floor):
                    tried[-1]["is_period1"] = True
                    return None, ys, M
            if judge_from is not None and not self._attracts(U, eta, Omega, ys, judge_from, k,
                                                             float(np.abs(mu[0]))):
                tried[-1]["not_attracting"] = True
                return None, ys, M
            amps, env = self.orbit_amplitudes(U, eta, Omega, ys, k)
            if k == 1 and max(amps) < floor:
                return result("rest", amps, env, 1, ys, mu, res,
                              f"at rest (amplitudes below {floor:.0e}; stable fixed point of the period "
                              "map)"), ys, M
            return result("period-1" if k == 1 else "period-2", amps, env, k, ys, mu, res,
                          f"period-{k} orbit by shooting ({its} Newton steps, residual {res:.1e})"), ys, M

        left = None          # the unstable orbit the transient was last pushed away from
        if guess is not None:
            got = attempt(np.asarray(guess, float), 1, np.asarray(guess, float))[0]
            if got is None and autonomous and float(np.max(np.abs(guess))) > floor:
                got = attempt_cycle(np.asarray(guess, float))
            if got is not None:
                return got
        for n in stages:
            t0 = done * period
            if t0 + n * period > max_time:
                break
            r = self._stage_run(y, n, period, pars, FIRST_STAGE_RTOL if done == 0 else STAGE_RTOL)
            if not r.ok:
                if not grew(r):
                    # stopped while |q_k| <= DIVERGED at moderate velocities: the integrator failed,
                    # the response did not grow
                    raise ComputationError(
                        f"eq. (21) could not be integrated in the transient from t = {t0:.6g} while the "
                        f"response stayed bounded (|q_k| <= {DIVERGED:g}): "
                        f"{_stopped(r, 0.0, n * period).split(' (integrating')[0]}")
                done += int(r.t_reached / period)
                # each stage integrates from t = 0 (the forcing is T-periodic): shift to real time
                why = _stopped(r, 0.0, n * period).split(" at t = ")[0]
                return result("diverged", (math.inf, math.inf), ((math.inf, math.inf),) * 2, 0, r.y_reached,
                              [], math.inf, f"the response diverged (no bounded steady state): {why} at "
                              f"t = {t0 + r.t_reached:.6g}", t_end=t0 + r.t_reached)
            y = r.y[-1]
            done += n
            # how far the last period ends are from repeating with period 1 and with period 2
            d1 = _norm(r.y[-1] - r.y[-2])
            d2 = _norm(r.y[-1] - r.y[-3])
            if left is not None and np.linalg.norm(y - left) < 0.5 * np.linalg.norm(left):
                # still on the way out from the unstable orbit just left: Newton would go back to it
                continue
            got, ys, M = attempt(y, 1, y)
            if got is not None:
                return got
            if autonomous:
                # eta* = 0: no forcing period to lock to; a bounded motion away from rest is a cycle
                # of its own period (or on its way to one): autonomous shooting, else more transient
                if float(np.max(np.abs(y[:2]))) > floor:
                    got = attempt_cycle(y)
                    if got is not None:
                        return got
                continue
            if M is None:
                if d2 < 0.1 * d1:
                    # the transient repeats every two periods, not every one: a period-2 orbit
                    got = attempt(y, 2, y)[0]
                    if got is not None:
                        return got
                continue                    # no orbit near yet: more transient
            mu = multipliers_of(M)
            real = np.abs(mu.imag) < 1e-9
            outside = np.abs(mu) > 1.0 + STABILITY_MARGIN
            if np.any(real & outside & (mu.real < 0)):
                # past a period doubling: a period-2 orbit nearby
                got = attempt(y, 2, y)[0]
                if got is not None:
                    return got
            elif np.any(real & outside):
                y_new = self._escape(y, ys, M, tried)
                left = ys if y_new is not y else None
                y = y_new
            elif np.any(outside):
                # only a complex pair outside the unit circle (a Neimark-Sacker / Hopf instability of
                # the forced orbit): the transient leaves along a torus, i.e. an amplitude-modulated
                # response or galloping growth; integration decides from here
                tried[-1]["torus"] = True
                break
        return self._fallback(U, eta, sigma, y, done, period, max_time, result, attempt, attempt_cycle)

    def _stage_run(self, y, n: int, period: float, pars: dict, rtol: float = STAGE_RTOL,
                   atol: float | None = None, max_step: float = 1.0):
        """A transient stage: n forcing periods from ``y`` at ``rtol`` (not below the transient
        integrator's; ``atol`` defaults to rtol / 1000), stopping beyond `ode21.DIVERGED`, sampled
        only at the last three period ends: a `CRun`, or when it ran to the end only its ``ok``
        and samples ``y`` (the common case, kept cheap)."""
        p = [pars[q.name] for q in PARAMETERS]
        st = self.integrator
        grid = (0.0, (n - 2) * period, (n - 1) * period, n * period)
        budget = st._budget(0.0, n * period, len(grid))
        run = self._repeated(("stage", period, n, max_step, *p), lambda: Repeated(
            st._c_integrator(), grid, p, max_step=max_step, max_steps=budget, bound=DIVERGED, n_bound=2))
        rtol = max(float(rtol), st.rtol)
        atol = max(rtol * 1e-3 if atol is None else float(atol), st.atol)
        ys = run(np.asarray(y, float), rtol, atol)
        if ys is not None:
            return _Stage(ys.copy())
        # stopped early: the same run again, with its status and where it stopped
        return st._c_integrator().run(np.asarray(y, float), np.array(grid), p, rtol=rtol, atol=atol,
                                      max_step=max_step, max_steps=budget, bound=DIVERGED, n_bound=2)

    @staticmethod
    def _escape(y, y_star, M, tried, size: float = 0.1):
        """The transient sits near an unstable period-1 orbit ``y_star`` that it leaves along a
        real multiplier mu > 1 (the pitchfork of the planar orbit into bi-modal motion, Fig. 6):
        integration would spend log(1/|y - y*|) / log(mu) periods, thousands near the bifurcation,
        creeping out. Jump to the point of that eigendirection at ``size`` |y*| on the transient's
        side (the sign of its projection), on the unstable manifold to first order, so the same
        attractor is reached. Other instabilities: ``y`` unchanged."""
        w, v = np.linalg.eig(M)
        real = np.abs(w.imag) < 1e-9
        if not np.any(real & (w.real > 1.0)):
            return y
        i = int(np.argmax(np.where(real, w.real, -np.inf)))
        e = np.real(v[:, i])
        e /= np.linalg.norm(e)
        side = float(np.dot(np.asarray(y) - y_star, e))
        if side == 0.0:
            return y
        tried[-1]["escape"] = {"multiplier": float(w[i].real), "side": 1 if side > 0 else -1}
        return y_star + math.copysign(size * max(float(np.linalg.norm(y_star)), 1e-9), side) * e


    def _fallback(self, U, eta, sigma, y, done, period, max_time, result, attempt, attempt_cycle=None):
        """Transient integration decides: `Ode21Integrator.simulate` from the last state."""
        q0 = (y[0], y[2], y[1], y[3])
        r = self.integrator.simulate(U, eta, sigma, q0, max_time=max(max_time - done * period, period))
        t_end = done * period + r.t_end
        env = ((r.a1_min, r.a1_max), (r.a2_min, r.a2_max))
        fs = np.asarray(r.final_state, float)
        if not math.isfinite(r.a1):
            return result("diverged", (r.a1, r.a2), env, 0, fs, [], math.inf,
                          r.message, fallback=True, t_end=t_end)
        if r.autonomous and (r.periodic or not r.steady):
            # integration reached a cycle of its own period (eta* = 0), or is still approaching one
            # slowly (near the onset): autonomous shooting from its end state, judged by integration
            # from there; else report the integration's cycle, or go on below
            got = attempt_cycle(fs)
            if got is not None:
                return replace(got, fallback=True, t_end=t_end, message=got.message + " after transient "
                               f"integration to t = {t_end:.6g}")
        if r.autonomous and r.periodic:
            return result("autonomous-periodic", (r.a1, r.a2), env, 1, fs, [], math.nan,
                          f"transient integration from t = {done * period:.6g}: {r.message}", fallback=True,
                          t_end=t_end, period=r.period, a1_error=r.a1_error, a2_error=r.a2_error)
        if r.steady and (r.periodic or max(r.a1, r.a2) < 1e3 * self.integrator.atol):
            # integration reached a periodic (or rest) response: polish it by Newton from there
            # (its end state is in the orbit's basin), else report the integration's numbers with
            # the multipliers of the state it ended in.
            got = attempt(fs, 1, fs)[0]
            if got is not None:
                return replace(got, fallback=True, t_end=t_end, message=got.message + " after transient "
                               f"integration to t = {t_end:.6g}")
            got = self.flow(r.U, r.eta, r.Omega, fs, 1)
            mu = multipliers_of(got[1]) if got is not None else []
            kind = "rest" if max(r.a1, r.a2) < 1e3 * self.integrator.atol else "period-1"
            return result(kind, (r.a1, r.a2), env, 1, fs, mu, math.nan,
                          f"transient integration from t = {done * period:.6g}: {r.message}",
                          fallback=True, t_end=t_end)
        if r.steady:
            # A period-2 orbit the transient stages did not get close enough to: its end state is.
            got = attempt(fs, 2, None)[0]
            if got is not None:
                return got
        # Steady envelope but not period-1 nor period-2: amplitude-modulated.
        return result("quasi-periodic", (r.a1, r.a2), env, 0, fs, [], math.nan,
                      f"transient integration from t = {done * period:.6g}: {r.message}"
                      + ("" if r.steady else " (amplitude-modulated, or too slow to settle)"),
                      fallback=True, t_end=t_end)


def response_json(r: SteadyResponse) -> dict:
    """The keys `autocable simulate --method ode21 --json` prints, plus ``floquet_multipliers``
    ([re, im] pairs), ``max_multiplier_modulus`` and ``response``; strict JSON: a non-finite number
    is null, and ``response``/``message`` say why (e.g. diverged)."""
    def num(x):
        x = float(x)
        return x if math.isfinite(x) else None

    return {"a1": num(r.a1), "a2": num(r.a2), "steady": r.steady, "periodic": r.periodic,
            "t_end": num(r.t_end), "U": r.U, "eta": r.eta, "sigma": r.sigma, "Omega": r.Omega,
            "a1_min": num(r.a1_min), "a1_max": num(r.a1_max), "a2_min": num(r.a2_min),
            "a2_max": num(r.a2_max),
            "amplitude_convention": "a_k = half the peak-to-peak of q_k over the orbit (period-1: one "
                                    "forcing period, period-2: two), 64 samples per period from forcing "
                                    "phase 0 (peak modal amplitude = peak displacement / l)",
            "message": r.message, "method": "shooting", "wall_seconds": r.wall_seconds,
            "response": r.response, "response_periods": r.periods,
            "floquet_multipliers": [[float(m.real), float(m.imag)] for m in r.multipliers],
            "max_multiplier_modulus": num(r.max_modulus) if len(r.multipliers) else None,
            "state0": [num(v) for v in r.state0], "shooting_residual": num(r.residual),
            "newton_iterations": r.newton_iterations, "transient_periods": r.transient_periods,
            "fallback_to_integration": r.fallback,
            **({"autonomous": True, "period": num(r.period), "a1_error": num(r.a1_error), "a2_error": num(r.a2_error),
                "trivial_multiplier": [float(r.trivial_multiplier.real), float(r.trivial_multiplier.imag)],
                "amplitude_convention": "a_k = half the peak-to-peak of q_k over one turn of the cycle's own "
                                        "period, extremes Hermite-refined from 256 samples; a_k_error by "
                                        "Richardson against 128 samples (peak modal amplitude = peak "
                                        "displacement / l)"}
               if r.response == "autonomous-periodic" else {})}
