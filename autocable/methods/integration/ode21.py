"""Direct time integration of eq. (21): the brute-force reference of the method ladder.

f(t) = sin(Omega t) with Omega = omega1 + sigma (docs/model.md, C2). The right-hand side is
compiled (PyDSTool's Dopri generator, DOP853 in C) and integrated in chunks of forcing periods until
the response amplitudes stop changing. Amplitudes follow the convention used throughout autocable:
a_k is the peak modal amplitude, half the peak-to-peak of q_k over the last forcing periods
(docs/model.md, C1), i.e. the peak displacement divided by the cable length for modes of unit
maximum. A response is called periodic when it repeats with the forcing period (period-1); an
amplitude-modulated (quasi-periodic in q_k) response is steady only in its envelope.

Autonomous responses. At eta* = 0 eq. (21) has no forcing (`is_autonomous`) and a galloping cycle
repeats with its own period, not the forcing's: there the amplitudes, their steadiness and the
periodicity are judged on whole cycles of the response found from its own zero crossings
(`autocable.methods.integration.cycles`), sampled twice as finely, and the amplitudes carry a
stated error (``a1_error``, ``a2_error``).

`engine="compiled"` integrates the same sympy right-hand side with autocable's own DOP853 in C
(`autocable.codegen.cintegrate`: Hairer's coefficients, step control and dense output, one C call
per chunk of forcing periods, and a stop as soon as |q_k| exceeds `DIVERGED` instead of spending the
step budget on a finite-time blow-up). It takes the same steps as PyDSTool's Dopri up to the
restart details and agrees with it to ~1e-9 relative on the steady amplitudes
(tests/test_compiled_integration.py); the scenes use it. `engine="scipy"` integrates the same
right-hand side with scipy's DOP853 in Python: a slow independent cross-check of both.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace

import numpy as np

from autocable.codegen.compat import PyDSToolError
from autocable.errors import ComputationError
from autocable.methods.integration.cycles import own_cycles
from autocable.model.equations import TwoModeODE
from autocable.model.premises import NOT_GIVEN, ArgumentError, check_call, check_state
from autocable.model.symbolic import PARAMETERS, STATE, T, first_order_rhs, parameter_values

#: Default start: rest, with a tiny out-of-plane seed so that an unstable planar motion is never
#: reported as the response (issue: q2 = 1e-6).
DEFAULT_Q0 = (0.0, 0.0, 1e-6, 0.0)   # order (q1, q1', q2, q2') as on the command line
#: A modal amplitude this large (a tenth of the cable length) is far outside the model's validity:
#: the response is reported as diverged.
DIVERGED = 0.1
#: A modal velocity this large where the integrator stopped (its step size collapsing, a spent step
#: budget, a non-finite state) means the velocities blew up in finite time at bounded q_k, driven by
#: the cubic loads in q_k' (eq. 2); a bounded motion with |q_k| <= DIVERGED at frequencies near 1
#: has |q_k'| of the same order, a hundred times smaller. Measured on a calibration candidate: q' was
#: 3e5 at |q| = 0.06 when the step reached 6e-14 (t = 30.3, U* = 1.3).
VELOCITY_DIVERGED = 100 * DIVERGED
#: Accepted integration steps per unit time beyond which a chunk is taken as blowing up (see run).
STEPS_PER_TIME_UNIT_CAP = 400
#: The engines of `Ode21Integrator` (module docstring).
ENGINES = ("dopri", "compiled", "scipy")
#: The engine the scenes' overlays and time evolutions use: the fastest that meets the accuracy
#: (the compiled DOP853 agrees with PyDSTool's Dopri to ~1e-9 on the steady amplitudes).
SCENE_ENGINE = "compiled"


#: Periodicity of an autonomous cycle: the states at successive crossings of the Poincare section
#: agree to this, relative to their size. The section's velocities come from the Hermite
#: interpolant (third order in the sample step): at 128 samples per period their scatter on a
#: converged cycle is 3e-7 (measured on a galloping cycle), thirty times below it.
SECTION_TOL = 1e-5


def is_autonomous(eta: float) -> bool:
    """Whether eq. (21) is autonomous at this eta*: every forcing term carries eta* (f, f', f''
    enter as eta* f, eta* f', eta* f'': `autocable.model.symbolic.first_order_rhs`), so at eta* = 0
    the right-hand side does not depend on time and a response may repeat with any period."""
    return float(eta) == 0.0


class IntegrationError(RuntimeError):
    """An engine stopped before the end of the interval (step budget, step size collapsing,
    non-finite state or a bound exceeded); `Ode21Integrator.simulate` tells growth (a result) from
    failure (`ComputationError`) by where the state was when it stopped."""


def first_divergence(tt, ys, n: int) -> int | None:
    """The index of the first sample whose modal coordinates (the first ``n`` columns of ``ys``)
    pass `DIVERGED`, or None when every sample stays within it. A non-finite sample before any
    such growth is a numerical failure, not a divergence: `ComputationError`."""
    finite = np.all(np.isfinite(ys), axis=1)
    grown = np.max(np.abs(np.where(finite[:, None], ys[:, :n], 0.0)), axis=1) > DIVERGED
    if not (grown.any() or not finite.all()):
        return None
    stop = int(np.argmax(grown | ~finite))
    if not grown[:stop + 1].any():
        raise ComputationError(f"eq. (21) reached a non-finite state at t = {tt[stop]:.6g} from a bounded "
                               f"one (|q_k| <= {DIVERGED:g}): a numerical failure; check the parameters "
                               "or loosen the tolerances")
    return stop


def _failed(t0: float, t1: float, reason: str) -> ComputationError:
    """The integrator failed while |q_k| stayed within `DIVERGED`: a numerical failure, not growth."""
    return ComputationError(f"eq. (21) could not be integrated from t = {t0:g} to {t1:g} while the "
                            f"response stayed bounded (|q_k| <= {DIVERGED:g}): {reason}; check the "
                            "parameters or loosen the tolerances")


@dataclass(frozen=True)
class Response:
    """The steady response of eq. (21) at one parameter point."""

    a1: float
    a2: float
    steady: bool
    periodic: bool
    t_end: float
    U: float
    eta: float
    sigma: float
    Omega: float
    a1_min: float          # envelope of the half peak-to-peak over single forcing periods
                           # (autonomous: over the response's own single cycles)
    a1_max: float
    a2_min: float
    a2_max: float
    message: str
    wall_seconds: float
    final_state: tuple     # (q1, q2, q1', q2') at t_end
    history: tuple = field(default=(), repr=False)   # (t, q1, q2, q1', q2') arrays if asked for
    #: True for a self-excited cycle of the autonomous eq. (21) (eta* = 0) measured on its own period
    autonomous: bool = False
    #: the response's period: 2 pi / Omega for a period-1 response, the cycle's own period when
    #: ``autonomous``, nan otherwise
    period: float = math.nan
    #: the stated error of a1, a2 (`cycles.own_cycles`: the per-cycle scatter plus the sampling
    #: error by Richardson from the window at half the sampling); nan where not measured
    a1_error: float = math.nan
    a2_error: float = math.nan
    #: a run ended at max_time while its amplitudes fell exponentially (`decay_rate`): the rate r
    #: of exp(-r t*) (t* units); nan otherwise
    decay_rate: float = math.nan


#: `decay_rate`: the judged chunks it fits (the last ones), the fewest it needs, and how far the
#: per-chunk rates may scatter about their mean (relative) for the decay to count as exponential.
DECAY_CHUNKS = 8
DECAY_MIN_CHUNKS = 4
DECAY_SCATTER = 0.2


def decay_rate(times, amplitudes) -> float | None:
    """The rate r > 0 of an exponential decay exp(-r t) of the envelope max(a1, a2) over the last
    `DECAY_CHUNKS` judged chunks (``times``, ``amplitudes`` = [(a1, a2), ...], oldest first), from a
    least-squares fit of its logarithm; None unless every chunk fell and every chunk's own rate lies
    within `DECAY_SCATTER` of their mean. A response settling on a cycle slows down (its rates
    shrink chunk by chunk) and a modulated one rises and falls: neither passes. Below the onset the
    trivial state of eq. (21) is a stable focus, so a small response decays at the linear rate
    (the least damped eigenvalue's real part) for as long as it takes: that is its steady state."""
    pts = [(float(t), max(a)) for t, a in zip(times, amplitudes)
           if all(math.isfinite(x) and x > 0 for x in a)][-DECAY_CHUNKS:]
    if len(pts) < DECAY_MIN_CHUNKS or len(pts) < min(DECAY_CHUNKS, len(times)):
        return None
    t = np.array([p[0] for p in pts])
    y = np.log([p[1] for p in pts])
    rates = -np.diff(y) / np.diff(t)
    mean = float(np.mean(rates))
    if not (np.all(rates > 0) and np.all(np.abs(rates - mean) <= DECAY_SCATTER * mean)):
        return None
    return float(-np.polyfit(t, y, 1)[0])


def _decaying(rate: float, times, amplitudes, rest_floor: float) -> str:
    """The message of a run that ended decaying exponentially (`decay_rate`)."""
    n = min(DECAY_CHUNKS, len(times))
    a, t = max(amplitudes[-1]), times[-1]
    rest = t + math.log(a / rest_floor) / rate
    # "not steady" stays in it: callers (shooting's fallback, sweeps) read a run that has not settled by it
    return (f"not steady after t = {t:g} but decaying to rest: max(a1, a2) = {a:.3g} falls as "
            f"exp(-{rate:.4g} t*) over the last {n} chunks (halving every {math.log(2) / rate:.4g}); "
            f"below the rest floor {rest_floor:.0e} near t = {rest:.4g}")


def refined_peak(samples: np.ndarray, sign: int) -> float:
    """Extreme of a sampled smooth signal, refined by a parabola through the best sample."""
    y = sign * samples
    i = int(np.argmax(y))
    if 0 < i < len(y) - 1:
        a, b, c = y[i - 1], y[i], y[i + 1]
        den = a - 2 * b + c
        if den < 0:
            return sign * (b - 0.125 * (a - c) ** 2 / den)
    return sign * y[i]


def _stopped(r, t0: float, t1: float) -> str:
    """Why the compiled engine stopped inside [t0, t1] (one line)."""
    why = {"bound": f"|q_k| > {DIVERGED:g}", "not_finite": "a non-finite state",
           "step_budget": f"more than {r.accepted:,} integration steps",
           "step_too_small": "the step size collapsed"}.get(r.status, r.status)
    if r.status != "bound" and grew(r):
        y = np.asarray(r.y_reached, float)
        why += (f" with |q_k'| = {np.max(np.abs(y[2:])):.3g} at |q_k| = {np.max(np.abs(y[:2])):.3g} "
                "(the velocities blow up in finite time)")
    return f"{why} at t = {r.t_reached:.6g} (integrating from t = {t0:g} to {t1:g})"


def grew(r) -> bool:
    """Whether a compiled run (`CRun`) that stopped early stopped because eq. (21)'s state grew: past
    `DIVERGED` in q_k, or with the integrator stopping (step size collapsing, step budget, non-finite
    state) at a velocity beyond `VELOCITY_DIVERGED` or a non-finite one (a finite-time blow-up of the
    velocities while |q_k| <= DIVERGED). Any other early stop is a numerical failure."""
    if r.status == "bound":
        return True
    y = np.asarray(r.y_reached, float)
    return r.status != "done" and bool(not np.all(np.isfinite(y)) or np.max(np.abs(y[2:]), initial=0.0) > VELOCITY_DIVERGED)


def half_ranges(w: np.ndarray) -> np.ndarray:
    """`half_range` of every row of ``w`` (m x k samples), vectorised: the same parabolic peaks."""
    w = np.asarray(w, dtype=float)
    if w.shape[0] == 0:
        return np.empty(0)

    def peak(y):
        i = np.argmax(y, axis=1)
        rows = np.arange(len(y))
        best = y[rows, i]
        inner = (i > 0) & (i < y.shape[1] - 1)
        a = y[rows, np.maximum(i - 1, 0)]
        c = y[rows, np.minimum(i + 1, y.shape[1] - 1)]
        den = a - 2 * best + c
        ok = inner & (den < 0)
        with np.errstate(divide="ignore", invalid="ignore"):
            refined = best - 0.125 * (a - c) ** 2 / den
        return np.where(ok, refined, best)

    return 0.5 * (peak(w) + peak(-w))


def half_range(x: np.ndarray) -> float:
    """Half the peak-to-peak of the samples ``x``, each extreme refined by a parabola (`refined_peak`):
    the amplitude a_k of Sect. 5 over a window of the response."""
    return 0.5 * (refined_peak(x, 1) - refined_peak(x, -1))


class Ode21Integrator:
    """Integrates one `TwoModeODE`; the compiled generator is built once and reused."""

    def __init__(self, ode: TwoModeODE, engine: str = "dopri", rtol: float = 1e-10, atol: float = 1e-13):
        if engine not in ENGINES:
            raise ArgumentError("Ode21Integrator", "engine", f"expected one of {', '.join(ENGINES)}, got {engine!r}")
        if not isinstance(ode, TwoModeODE):
            raise ArgumentError("Ode21Integrator", "ode", f"expected the TwoModeODE of a derivation "
                                                         f"(derive(spec).ode), got {type(ode).__name__}")
        self.ode, self.engine, self.rtol, self.atol = ode, engine, rtol, atol
        self._rhs = first_order_rhs(ode)
        self._generator = None
        self._numeric = None
        self._c = None
        self.build_seconds = 0.0

    def with_tolerances(self, rtol: float, atol: float) -> "Ode21Integrator":
        """The same integrator at other tolerances, sharing the compiled generator."""
        other = Ode21Integrator(self.ode, self.engine, rtol, atol)
        other._generator, other._numeric, other._c = self._generator, self._numeric, self._c
        return other

    # -- engines -------------------------------------------------------------------------------
    def _compiled(self):
        if self._generator is None:
            from autocable.codegen.pydstool import VectorField, make_ode_generator
            vf = VectorField(name=f"eq21_{self.ode.content_hash()}",
                             variables=tuple(s.name for s in STATE), rhs=self._rhs,
                             parameters=tuple((p.name, 0.0) for p in PARAMETERS))
            t0 = time.perf_counter()
            self._generator = make_ode_generator(vf, "Dopri", algparams={
                "rtol": self.rtol, "atol": self.atol, "max_step": 1.0})
            self.build_seconds = time.perf_counter() - t0
        return self._generator

    def _c_integrator(self):
        if self._c is None:
            from autocable.codegen.cintegrate import compiled_integrator
            t0 = time.perf_counter()
            self._c = compiled_integrator(f"eq21_{self.ode.content_hash()}", tuple(s.name for s in STATE),
                                          tuple(p.name for p in PARAMETERS), self._rhs, T.name)
            self.build_seconds = time.perf_counter() - t0
        return self._c

    @staticmethod
    def _budget(t0: float, t1: float, n_samples: int) -> int:
        # A bounded response takes about 27 accepted steps per forcing period (about 4 per time
        # unit) at rtol 1e-10; a hundred times that only a blow-up needs, and stopping there
        # spares the multi-million-step retries of a finite-time blow-up.
        return n_samples + 10_000 + int(STEPS_PER_TIME_UNIT_CAP * (t1 - t0))

    def run_compiled(self, y0, t0: float, t1: float, dt: float, pars: dict, bound: float = math.inf,
                     last: int | None = None):
        """The compiled engine's `CRun` (autocable.codegen.cintegrate) over [t0, t1] sampled every
        ``dt``, state order (q1, q2, q1', q2'), stopping early once |q1| or |q2| exceeds ``bound``.
        ``last``: only t0 and the last ``last`` samples of that grid are computed (the dense output
        costs three stages per step that has a sample; the steps are the same)."""
        from autocable.codegen.cintegrate import sample_grid
        grid = sample_grid(t0, t1, dt)
        n = len(grid)
        if last is not None and n - last > 1:
            grid = np.concatenate([grid[:1], grid[n - last:]])
        p = [pars[s.name] for s in PARAMETERS]
        return self._c_integrator().run(y0, grid, p, rtol=self.rtol, atol=self.atol, max_step=1.0,
                                        max_steps=self._budget(t0, t1, n), bound=bound, n_bound=2)

    def _scipy_rhs(self):
        if self._numeric is None:
            import sympy as sp
            f = sp.lambdify((T, STATE, PARAMETERS), self._rhs, "math")
            self._numeric = f
        return self._numeric

    def run(self, y0, t0: float, t1: float, dt: float, pars: dict) -> tuple[np.ndarray, np.ndarray]:
        """Samples (t, states) on t0, t0+dt, ..., states in the order (q1, q2, q1', q2')."""
        if self.engine == "dopri":
            from autocable.codegen.pydstool import integrate
            # Tolerances are per integrator object while the compiled generator is shared; the
            # buffer holds the samples and the accepted steps (see _budget).
            budget = 2 * int((t1 - t0) / dt) + self._budget(t0, t1, 0)
            return integrate(self._compiled(), list(y0), pars, t0, t1, dt,
                             algparams={"rtol": self.rtol, "atol": self.atol}, max_points=budget)
        if self.engine == "compiled":
            r = self.run_compiled(y0, t0, t1, dt, pars)
            if not r.ok:
                raise IntegrationError(_stopped(r, t0, t1))
            return r.t, r.y
        from scipy.integrate import solve_ivp
        f = self._scipy_rhs()
        p = tuple(pars[s.name] for s in PARAMETERS)
        n = int(math.floor((t1 - t0) / dt * (1 + 1e-12))) + 1
        grid = t0 + dt * np.arange(n)
        sol = solve_ivp(lambda t, y: f(t, y, p), (t0, grid[-1]), list(y0), method="DOP853",
                        t_eval=grid, rtol=self.rtol, atol=self.atol)
        if not sol.success:
            raise IntegrationError(f"scipy DOP853 failed: {sol.message}")
        return sol.t, sol.y.T

    def _judge(self, y, t0: float, t1: float, dt: float, pars: dict, reason: str):
        """After another engine failed on [t0, t1] from ``y``: the same chunk by the compiled engine,
        stopping at |q_k| > `DIVERGED`. Returns its run when the response grows past the bound (a
        divergence, the samples up to it included); raises `ComputationError` otherwise."""
        r = self.run_compiled(y, t0, t1, dt, pars, bound=DIVERGED)
        if grew(r):
            return r
        raise _failed(t0, t1, reason)

    # -- the steady response -------------------------------------------------------------------
    def simulate(self, U: float, eta: float, sigma: float, q0=DEFAULT_Q0, *,
                 periods_per_chunk: int = 100, window_periods: int = 20, max_time: float = 60000.0,
                 steady_tol: float = 1e-8, samples_per_period: int = 64,
                 keep_history: bool = False, progress=None, shortcut=None, recurrence=None) -> Response:
        """Integrate from ``q0`` = (q1, q1', q2, q2') until the amplitudes are steady.

        Steady: the amplitudes over the last ``window_periods`` forcing periods change by less than
        ``steady_tol`` (relative) between two consecutive chunks, or are at rest (all below 1e3 x
        atol and not growing). Stops at ``max_time`` otherwise.

        ``shortcut`` (forced responses only, eta* != 0): called after every chunk as
        ``shortcut(U, eta, Omega, ends, t, max_time, steady_tol)`` with ``ends`` the states (q1, q2,
        q1', q2') at the last ``window_periods + 1`` period ends, oldest first, ``t`` the time
        reached; it returns None (integrate on) or
        ``((a1, a2), state, note)``: the period-1 orbit this integration is converging to, which
        ends the run as a steady periodic response with those amplitudes, ``state`` as its final
        state and ``note`` in its message (`autocable.methods.integration.sweeps.PeriodOneShortcut`).

        ``recurrence`` (forced responses only): called after every judged chunk that is not steady
        as ``recurrence(U, eta, Omega, amps, changes, state, t, max_time, steady_tol)`` with the
        amplitudes and relative changes of all judged chunks so far and the state (q1, q2, q1', q2')
        reached; it returns None (integrate on) or a note: the response will not be called steady
        before max_time, which ends the run there as not steady
        (`autocable.methods.integration.sweeps.RecurrenceStop`).
        """
        check_call("Ode21Integrator.simulate", U=U, eta=eta, sigma=sigma, q0=q0, max_time=max_time,
                   omega1=self.ode.omega1)
        start = time.perf_counter()
        Omega = self.ode.omega1 + sigma
        if not Omega > 0:
            raise ValueError(f"sigma = {sigma} gives a non-positive forcing frequency Omega = {Omega}")
        period = 2 * math.pi / Omega
        autonomous = is_autonomous(eta)
        if autonomous:
            # the cycles' extremes and section states are Hermite-interpolated: twice the samples
            # make their error 16 (extremes) and 8 (section velocities) times smaller
            samples_per_period *= 2
        dt = period / samples_per_period
        pars = parameter_values(U, eta, Omega)
        q1, q1d, q2, q2d = (float(x) for x in q0)
        y = (q1, q2, q1d, q2d)
        t = 0.0
        chunk = periods_per_chunk * period
        previous, steady, at_rest, history = None, False, False, []
        rest_floor = 1e3 * self.atol
        amps = (math.nan, math.nan)
        keep = window_periods * samples_per_period + 1
        window = np.array([y])
        cycles = None
        steps = []           # |change| of each amplitude between consecutive chunks
        judged, changes = [], []     # the judged chunks' amplitudes and relative changes, for ``recurrence``
        judged_t = []                # and when each ended, for `decay_rate`
        while t < max_time - 1e-9:
            t1 = min(t + chunk, max_time)
            if t1 - t < dt * (1 - 1e-9):
                # Less than one sample interval is left before max_time (the chunks end on the
                # sample grid): another chunk would not advance t.
                break
            if self.engine == "compiled":
                # One C call per chunk, stopping at the divergence bound itself, computing only the
                # samples the rolling window keeps unless the history is asked for.
                r = self.run_compiled(y, t, t1, dt, pars, bound=DIVERGED,
                                      last=None if keep_history else keep)
                if not r.ok:
                    # Growth past the bound, or a finite-time blow-up of the velocities, is the
                    # physics (a result); any other stop happened with |q_k| <= DIVERGED (checked
                    # after every step) at moderate velocities: the integrator failed.
                    if not grew(r):
                        raise _failed(t, t1, _stopped(r, t, t1))
                    if keep_history and len(r.t):
                        history.append((r.t, r.y))
                    return self._response(U, eta, sigma, Omega, (math.inf, math.inf), False, False,
                                          r.t_reached, None, "the response diverged (no bounded steady "
                                          f"state): {_stopped(r, t, t1)}", start,
                                          tuple(r.y_reached), history)
                tt, ys = r.t, r.y
            else:
                try:
                    tt, ys = self.run(y, t, t1, dt, pars)
                except (PyDSToolError, IntegrationError) as exc:
                    # A finite-time blow-up of the cubic model ends in a collapsing step or a spent
                    # step budget, and so does a numerical failure: the compiled engine, stopping
                    # at the bound, tells them apart.
                    why = str(exc).splitlines()[0]
                    r = self._judge(y, t, t1, dt, pars, why)
                    if keep_history and len(r.t):
                        history.append((r.t, r.y))
                    return self._response(U, eta, sigma, Omega, (math.inf, math.inf), False, False,
                                          r.t_reached, None, f"the response diverged between t = {t:g} "
                                          f"and {t1:g} (no bounded steady state): {_stopped(r, t, t1)}; "
                                          f"{self.engine}: {why}", start, tuple(r.y_reached), history)
            stop = first_divergence(tt, ys, 2)
            if stop is not None:
                # Keep the samples up to the first one beyond the bound.
                if keep_history and stop > 0:
                    history.append((tt[:stop], ys[:stop]))
                return self._response(U, eta, sigma, Omega, (math.inf, math.inf), False, False,
                                      float(tt[stop]), None, "the response diverged (no bounded steady "
                                      f"state): |q_k| > {DIVERGED:g} at t = {tt[stop]:.6g}",
                                      start, tuple(ys[stop]), history)
            if keep_history:
                history.append((tt[:-1], ys[:-1]))
            # A last chunk shorter than the window (max_time is rarely a whole number of chunks)
            # leaves most of the previous window's samples in the new one: its extremes, hence a
            # modulated motion's amplitudes, are then often unchanged, which is no evidence of a
            # steady response. Such a chunk is not judged.
            overlapping = float(tt[-1]) - t < min(chunk, window_periods * period) * (1 - 1e-9)
            y, t = tuple(ys[-1]), float(tt[-1])
            # A rolling window across chunks: the last chunk may be shorter than the window.
            window = np.concatenate([window, ys[1:]])[-keep:]
            amps = (half_range(window[:, 0]), half_range(window[:, 1]))
            if autonomous:
                # judged on the response's own cycles (module docstring); rest keeps the window's
                # amplitudes (no zero crossings to count)
                cycles = own_cycles(dt * np.arange(len(window)), window)
                if cycles is not None:
                    amps = cycles.amplitudes
            if progress:
                progress(t, amps)
            if shortcut is not None and not autonomous and len(window) == keep:
                got = shortcut(U, eta, Omega, window[::samples_per_period], t, max_time, steady_tol)
                if got is not None:
                    orbit_amps, orbit_state, note = got
                    return self._response(U, eta, sigma, Omega, orbit_amps, True, True, t, None,
                                          f"steady: {note}", start, orbit_state, history,
                                          samples_per_period, period=period)
            if previous is not None and not overlapping:
                steps.append([abs(a - b) for a, b in zip(amps, previous)])
                change = max(abs(a - b) / max(abs(a), 1e-14) for a, b in zip(amps, previous))
                # Rest: below the integration's own absolute accuracy and not growing. A decaying
                # 1e-20 never meets a relative test (it keeps halving), yet it is the rest state;
                # a growing one (unstable rest) is not steady.
                rest = max(amps) < rest_floor and all(a <= b for a, b in zip(amps, previous))
                if autonomous and cycles is not None and not rest and all(
                        abs(a - b) <= e for a, b, e in zip(amps, previous, cycles.errors)):
                    # A cycle's amplitude is measured on samples whose phase drifts against it:
                    # the chunk-to-chunk change cannot fall below the per-cycle scatter (2.4e-7 of
                    # the amplitude for a cycle twice the forcing's frequency: 64 samples a
                    # cycle, `cycles`). Steady once the change is within that scatter; what the
                    # approach may still have to go is in the stated error (`_cycle_response`).
                    change = 0.0
                if change < steady_tol or rest:
                    steady, at_rest = True, rest and not change < steady_tol
                    break
                judged.append(amps)
                judged_t.append(t)
                changes.append(change)
                if recurrence is not None and not autonomous:
                    note = recurrence(U, eta, Omega, judged, changes, y, t, max_time, steady_tol)
                    if note is not None:
                        return self._response(U, eta, sigma, Omega, amps, False,
                                              self._is_periodic(window, samples_per_period, rest_floor),
                                              t, window, f"not steady at t = {t:g} (amplitudes still "
                                              f"changing): {note}", start, y, history, samples_per_period)
            previous = amps
        rate = None if steady else decay_rate(judged_t, judged)
        if autonomous and cycles is not None and not at_rest:
            r = self._cycle_response(U, eta, sigma, Omega, cycles, steady, t, window, dt, start, y,
                                     history, steps)
            return r if rate is None else replace(r, decay_rate=rate,
                                                  message=_decaying(rate, judged_t, judged, rest_floor))
        periodic = self._is_periodic(window, samples_per_period, rest_floor)
        msg = ("steady" if not at_rest else f"at rest (amplitudes below {rest_floor:.0e} and decaying)") \
            if steady else f"not steady after t = {t:g} (amplitudes still changing)"
        if rate is not None:
            msg = _decaying(rate, judged_t, judged, rest_floor)
        r = self._response(U, eta, sigma, Omega, amps, steady, periodic, t, window, msg, start, y,
                           history, samples_per_period,
                           period=period if periodic and not at_rest else math.nan)
        return r if rate is None else replace(r, decay_rate=rate)

    def _cycle_response(self, U, eta, sigma, Omega, cycles, steady, t, window, dt, start, y, history, steps):
        """The response of the autonomous eq. (21) measured on its own cycles: periodic when steady
        and the Poincare section's states repeat to `SECTION_TOL`; a_k the mean per-cycle half
        peak-to-peak, its error the sum of the per-cycle scatter, the Richardson estimate of the
        sampling error (the fourth-order Hermite extremes from every other sample differ by 15
        times it) and what the approach has left to go: the last change between chunks times
        rho / (1 - rho), rho the ratio of the last two changes (a geometric approach; ten times
        the last change, the bound for rho = 0.91, when they shrink more slowly than that)."""
        coarse = own_cycles(2 * dt * np.arange(len(window[::2])), window[::2])
        errs = []
        for k in (0, 1):
            e = cycles.errors[k]
            if coarse is not None:
                e += abs(cycles.amplitudes[k] - coarse.amplitudes[k]) / 15.0
            if steps:
                last = steps[-1][k]
                rho = last / steps[-2][k] if len(steps) > 1 and steps[-2][k] > 0 else 1.0
                e += last * rho / (1.0 - rho) if rho < 0.9 else last * 10.0
            errs.append(e)
        periodic = bool(steady and cycles.section_change < SECTION_TOL)
        Tc = cycles.period
        if periodic:
            msg = (f"steady: autonomous periodic response (eta* = 0), own period {Tc:.9g} (frequency "
                   f"{2 * math.pi / Tc:.9g}) over {cycles.count} cycles; a1 = {cycles.amplitudes[0]:.9e} "
                   f"+- {errs[0]:.1e}, a2 = {cycles.amplitudes[1]:.9e} +- {errs[1]:.1e}")
        elif steady:
            msg = (f"steady amplitudes but the cycles do not repeat (Poincare section change "
                   f"{cycles.section_change:.1e} > {SECTION_TOL:g}): not periodic")
        else:
            msg = (f"not steady after t = {t:g} (amplitudes of the own cycles, period {Tc:.6g}, still "
                   "changing)")
        r = self._response(U, eta, sigma, Omega, cycles.amplitudes, steady, periodic, t, None, msg, start, y,
                           history)
        return replace(r, a1_min=cycles.ranges[0][0], a1_max=cycles.ranges[0][1],
                       a2_min=cycles.ranges[1][0], a2_max=cycles.ranges[1][1], autonomous=True,
                       period=Tc if periodic else math.nan, a1_error=errs[0], a2_error=errs[1])

    def envelope(self, U: float, eta: float, sigma: float, y0, t_end: float, *,
                 samples_per_period: int = 64, chunk_periods: int = 200, Omega: float | None = None,
                 keep_failed: bool = False):
        """The amplitude envelope of eq. (21) from ``y0`` = (q1, q2, q1', q2') over [0, t_end]
        (Fig. 11): the half peak-to-peak of q1, q2 over each forcing period (``samples_per_period``
        samples, parabolic peaks), at the period's mid time. Returns (t, a1, a2, message); a
        divergence (|q_k| > `DIVERGED`, or a non-finite sample) ends the arrays
        at the last whole period before it; an integrator failure at a bounded state raises
        `ComputationError`, or with ``keep_failed`` (compiled engine) ends the arrays at the last
        whole period before it, the message starting "eq. (21) could not be integrated".
        ``Omega`` overrides omega1 + sigma."""
        check_call("Ode21Integrator.envelope", U=U, eta=eta, sigma=sigma if Omega is None else NOT_GIVEN,
                   max_time=t_end, omega1=self.ode.omega1, time_name="t_end")
        # a start beyond the model's range is the studies' to try (it ends as a divergence)
        check_state("Ode21Integrator.envelope", "y0", y0, "(q1, q2, q1', q2')", limit=False)
        Om = self.ode.omega1 + sigma if Omega is None else float(Omega)
        if not Om > 0:
            raise ValueError(f"sigma = {sigma} gives a non-positive forcing frequency Omega = {Om}")
        period, n = 2 * math.pi / Om, int(samples_per_period)
        pars = parameter_values(U, eta, Om)
        q, t = tuple(float(v) for v in y0), 0.0
        ts, a1s, a2s = [], [], []
        message = "bounded over [0, t_end]"
        while t < t_end - 1e-9:
            t1 = min(t + chunk_periods * period, t_end)
            t1 = t + max(1, int(round((t1 - t) / period))) * period
            stop, blowup = "", ""
            if self.engine == "compiled":
                r = self.run_compiled(q, t, t1, period / n, pars, bound=DIVERGED)
                tt, ys = r.t, r.y
                if not r.ok:
                    why = _stopped(r, t, t1)
                    if grew(r):
                        stop = "bound"
                        if r.status != "bound":
                            blowup = f"eq. (21) diverges at t = {r.t_reached:.6g} ({why.split(' at t = ')[0]})"
                    elif keep_failed:
                        stop = str(_failed(t, t1, why))
                    else:
                        raise _failed(t, t1, why)
            else:
                try:
                    tt, ys = self.run(q, t, t1, period / n, pars)
                except (PyDSToolError, IntegrationError) as exc:
                    r = self._judge(q, t, t1, period / n, pars, str(exc).splitlines()[0])
                    tt, ys, stop = r.t, r.y, "bound"
            m = (len(tt) - 1) // n
            idx = np.arange(m)[:, None] * n + np.arange(n + 1)[None, :]
            w = ys[:, :2][idx] if m else np.empty((0, n + 1, 2))
            bad = ~np.all(np.isfinite(w), axis=(1, 2)) | (np.max(np.abs(np.nan_to_num(w, nan=np.inf)),
                                                                 axis=(1, 2), initial=0.0) > DIVERGED)
            good = m if not bad.any() else int(np.argmax(bad))
            ts.append(tt[:good * n:n] + 0.5 * period)
            a1s.append(half_ranges(w[:good, :, 0]))
            a2s.append(half_ranges(w[:good, :, 1]))
            if good < m or stop == "bound":
                # the first period with a sample beyond the bound, or the one the integration stopped in
                message = (blowup if good == m and blowup else
                           f"eq. (21) diverges at t = {tt[good * n]:.6g} (|q| > {DIVERGED:g})")
                break
            if stop:
                # a failure at a bounded state (keep_failed): the envelope ends with the last whole period
                message = stop
                break
            q, t = tuple(ys[m * n]), float(tt[m * n])
        cat = (lambda parts: np.concatenate(parts) if parts else np.empty(0))
        return cat(ts), cat(a1s), cat(a2s), message

    @staticmethod
    def _is_periodic(window: np.ndarray, n: int, floor: float, tol: float = 1e-6) -> bool:
        """Period-1 in the forcing: q(t) and q(t + T) agree over the window, to ``tol`` relative to
        its size or to ``floor`` (the integration's own absolute accuracy), whichever is larger."""
        if len(window) <= n:
            return False
        scale = np.max(np.abs(window[:, :2]))
        return bool(np.max(np.abs(window[n:, :2] - window[:-n, :2])) < max(tol * scale, floor))

    def _response(self, U, eta, sigma, Omega, amps, steady, periodic, t, window, msg, start, y,
                  history, n=64, period=math.nan):
        env = [(a, a) for a in amps]
        if window is not None and len(window) > n:
            per = [[half_range(window[i:i + n + 1, k]) for i in range(0, len(window) - n, n)]
                   for k in (0, 1)]
            env = [(min(p), max(p)) for p in per]
        hist = ()
        if history:
            tt = np.concatenate([h[0] for h in history])
            ys = np.concatenate([h[1] for h in history])
            hist = (tt, ys[:, 0], ys[:, 1], ys[:, 2], ys[:, 3])
        return Response(a1=float(amps[0]), a2=float(amps[1]), steady=steady, periodic=periodic,
                        t_end=t, U=U, eta=eta, sigma=sigma, Omega=Omega,
                        a1_min=env[0][0], a1_max=env[0][1], a2_min=env[1][0], a2_max=env[1][1],
                        message=msg, wall_seconds=time.perf_counter() - start,
                        final_state=tuple(float(v) for v in y), history=hist, period=period)
