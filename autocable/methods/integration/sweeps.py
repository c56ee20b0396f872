"""Brute-force sweeps: steady responses at sampled parameter values, swept up and down.

These are the "empty boxes" of Figs. 9-10 (direct numerical integration of eq. 21) and the
brute-force rung of the method ladder. Each point starts from the final state of the previous one,
so a sweep follows an attractor until it disappears; sweeping both ways shows coexisting attractors
(the two sides of a hysteresis loop). A diverged or non-steady point is kept with its message, and
the next point restarts from the default start.

Modelling choice (eq. 21): the carried state gets the start's small offset ``q0`` added (by
default q2 = 1e-6, the out-of-plane imperfection every run starts from). Eq. (21) is symmetric
under q2 -> -q2 and rest is a solution at eta = 0, so a carried state with a2 ~ 1e-30 would sit on
the invariant mono-modal (or rest) subspace even where it is unstable and be reported as a steady
attractor: the offset lets an unstable a2 = 0 response leave, and decays where it is stable.

Works with `ode21.Ode21Integrator` (eq. 21) and `ame.AmeIntegrator` (the AME):
both have ``simulate(U, eta, sigma, q0=..., **options)``; the state is carried as the eq. (21)
start q0 = (q1, q1', q2, q2') for the former and as the AME state y0 = (r1, s1, r2, s2) for the
latter. Eq. (21) runs end on a whole number of forcing periods, so the carried state starts the next
point at the same forcing phase (f = sin(Omega t) restarts at t = 0).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from autocable.errors import ComputationError
from autocable.methods.integration.ode21 import DEFAULT_Q0, DIVERGED, Ode21Integrator

PARAMETERS = ("sigma", "U", "eta")


@dataclass(frozen=True)
class SweepPoint:
    """One sampled steady response of a sweep."""

    parameter: str
    value: float
    direction: str          # "up" or "down"
    method: str             # "ode21" or "ame"
    a1: float
    a2: float
    a1_min: float
    a1_max: float
    a2_min: float
    a2_max: float
    steady: bool
    periodic: bool          # period-1 in the forcing (eq. 21) / an AME equilibrium
    message: str
    wall_seconds: float
    #: eq. (21) at eta* = 0: the response's own period and the stated errors of a1, a2 when it is a
    #: self-excited cycle (`ode21`, "Autonomous responses"); nan otherwise
    period: float = math.nan
    a1_error: float = math.nan
    a2_error: float = math.nan


class PeriodOneShortcut:
    """Ends an eq. (21) integration (`Ode21Integrator.simulate`'s ``shortcut``) as soon as it is
    seen converging to a stable period-1 orbit, instead of integrating on until the amplitudes
    change by less than 1e-8 between chunks of 100 periods (several hundred forcing periods from a
    neighbouring point's state, and thousands while a decaying out-of-plane seed q2 falls to
    1e-22 on a planar response).

    After a chunk, when the states at the last 21 period ends step by less than `TRY_STEP` of
    their size from one period to the next (an approach, not a modulated motion), Newton on the
    period map P(y) = phi_T(y) from the last of them finds the orbit y* (the state flows of the
    same compiled DOP853 at rtol 1e-11, the monodromy by central differences). It is accepted
    only when it is stable with a margin (every Floquet multiplier of modulus below `MU_MAX`),
    the integration's own state is within `CLOSE` of |y*| of it and that distance shrank over the
    last 20 periods, and when the integration would itself have called the response steady before
    max_time (`_settles_in_time`, from the deviation and the monodromy): a slow approach that the
    integration reports "not steady" stays so, and so does the next point's start. The
    integration at its full tolerance has then already chosen the attractor (no loose-tolerance
    transient decides which side of a basin boundary it lands on, unlike `ShootingSolver.steady`'s
    stages); the amplitudes are y*'s, from 64 samples over its period from phase 0 as in the
    integration's window. At most `ATTEMPTS` Newton solves per point; a stable orbit found too
    far away is kept and the distance measured again after the next chunks.

    Checked against the full integration on the overlay points of the figure scenes
    (tests/test_sweep_shortcut.py): the same class (periodic, steady, diverged) at every point and
    the same a_k to 1e-6 of max(a1, a2) at the periodic ones. A point that is not steady ends at
    max_time as before, but it may start from a state 1e-8 away from the full integration's (its
    neighbour's orbit): its end window is then another sample of the same modulated motion.
    """

    #: the largest step between successive period-end states (relative) at which Newton is tried
    TRY_STEP = 1e-3
    #: the largest distance of the integration's state from the orbit (relative) that is accepted
    CLOSE = 1e-3
    #: the largest Floquet multiplier modulus accepted: far enough inside the unit circle that the
    #: differenced monodromy (error ~1e-7) cannot misjudge it; slower approaches integrate on
    MU_MAX = 0.999
    #: Newton solves per point at most (a modulated motion never passes the test)
    ATTEMPTS = 3
    #: Newton's tolerance on |P(y) - y| / |y| and the flows' rtol
    TOL, RTOL = 1e-10, 1e-11

    def __init__(self, integrator: Ode21Integrator):
        self.integrator = integrator
        self.accepted = 0
        self._tries = 0
        self._orbit = None          # the stable orbit Newton found at this point, not yet reached
        self._runs: dict = {}

    def start_point(self) -> None:
        """A new sweep point: its Newton budget anew."""
        self._tries = 0
        self._orbit = None

    def _run(self, U: float, eta: float, Omega: float, samples: int):
        """A prepared compiled run over one forcing period (``samples`` + 1 grid times)."""
        from autocable.codegen.cintegrate import Repeated, sample_grid
        from autocable.model.symbolic import PARAMETERS, parameter_values
        key = (U, eta, Omega, samples)
        if key not in self._runs:
            if len(self._runs) > 4:
                self._runs.clear()
            period = 2 * math.pi / Omega
            grid = [0.0, period] if samples == 1 else sample_grid(0.0, period, period / samples)
            pars = parameter_values(U, eta, Omega)
            self._runs[key] = Repeated(self.integrator._c_integrator(), grid, [pars[q.name] for q in PARAMETERS],
                                       max_step=1.0, max_steps=200_000, bound=DIVERGED, n_bound=2)
        return self._runs[key]

    def _phi(self, run, y):
        import numpy as np
        ys = run(np.asarray(y, float), self.RTOL, self.RTOL * 1e-2 * max(float(np.abs(y).max()), 1e-9))
        return None if ys is None else ys[-1].copy()

    def _monodromy(self, run, y):
        """d phi_T / dy at ``y`` by central differences (step 1e-5 of |y|), or None."""
        import numpy as np
        h = 1e-5 * max(float(np.linalg.norm(y)), 1e-12)
        M = np.empty((4, 4))
        for j in range(4):
            e = np.zeros(4)
            e[j] = h
            plus, minus = self._phi(run, y + e), self._phi(run, y - e)
            if plus is None or minus is None:
                return None
            M[:, j] = (plus - minus) / (2 * h)
        return M

    def newton(self, U: float, eta: float, Omega: float, y):
        """Newton on the period map P(y) = phi_T(y) from ``y``: (y*, monodromy at y*, largest
        Floquet multiplier modulus, steps, relative residual), or None when it does not converge
        in 8 steps (a flow that fails, a singular step)."""
        import numpy as np
        y = np.array(y, float)
        if not float(np.linalg.norm(y)) > 0:
            return None
        run = self._run(U, eta, Omega, 1)
        for its in range(8):
            yT = self._phi(run, y)
            M = None if yT is None else self._monodromy(run, y)
            if M is None:
                return None
            res = float(np.linalg.norm(yT - y)) / float(np.linalg.norm(y))
            if res < self.TOL:
                break
            try:
                y = y - np.linalg.solve(M - np.eye(4), yT - y)
            except np.linalg.LinAlgError:
                return None
            if not np.all(np.isfinite(y)) or not float(np.linalg.norm(y)) > 0:
                return None
        else:
            return None
        return y, M, float(np.max(np.abs(np.linalg.eigvals(M)))), its, res

    #: the prediction's margins: twice the predicted periods, plus this many, must fit before max_time
    SETTLE_MARGIN_PERIODS = 200

    def _settles_in_time(self, amps, delta, M, period: float, t: float, max_time: float,
                         steady_tol: float) -> bool:
        """Whether integrating on would call the response steady before ``max_time``, so that the
        shortcut never turns a slow approach that the integration reports "not steady" (and whose
        next point then starts from q0) into a steady one. `Ode21Integrator.simulate` stops when
        each a_k changes by less than steady_tol of max(a_k, 1e-14) between chunks. The state's
        deviation ``delta`` from the orbit evolves by the monodromy ``M`` (linear theory, the
        deviation being below `CLOSE`): written in M's eigenvectors, delta_n = sum_i c_i mu_i^n v_i,
        mode k's part |(q_k, q_k')| is at most sum_i |c_i| |mu_i|^n (|v_i,q_k| + |v_i,q_k'|), which
        also sees a slow mode with a small share of the deviation. The periods until that bound is
        below a tenth of the tolerance for both modes, doubled, plus `SETTLE_MARGIN_PERIODS`, must
        fit before max_time."""
        import numpy as np

        try:
            mu, V = np.linalg.eig(M)
            c = np.abs(np.linalg.solve(V, delta))
        except np.linalg.LinAlgError:
            return False
        if not np.all(np.isfinite(c)) or not float(np.max(np.abs(mu))) < 1.0:
            return False
        left = int((max_time - t) / period) - self.SETTLE_MARGIN_PERIODS
        if left <= 0:
            return False
        n = np.arange(0, left // 2 + 1, dtype=float)
        decay = np.abs(mu)[None, :] ** n[:, None]                   # periods x eigenvalues
        for k in (0, 1):
            share = c * (np.abs(V[k]) + np.abs(V[k + 2]))
            need = 0.1 * steady_tol * max(amps[k], 1e-14)
            if not float((decay @ share)[-1]) <= need:
                return False
        return True

    def __call__(self, U: float, eta: float, Omega: float, ends, t: float, max_time: float,
                 steady_tol: float = 1e-8):
        import numpy as np

        from autocable.methods.integration.shooting import periodic_half_range

        ends = np.asarray(ends, float)
        if not np.all(np.isfinite(ends)):
            return None
        key = (U, eta, Omega)
        if self._orbit is not None and self._orbit[0] == key:
            # Newton found this point's stable orbit at an earlier chunk, the integration was still
            # too far from it: only the distance is measured again
            _, y, M, mu_max, its, res = self._orbit
        else:
            y = ends[-1].copy()
            size = float(np.linalg.norm(y))
            if self._tries >= self.ATTEMPTS or not size > 0:
                return None
            if not float(np.max(np.linalg.norm(np.diff(ends, axis=0), axis=1))) < self.TRY_STEP * size:
                return None
            self._tries += 1
            got = self.newton(U, eta, Omega, y)
            if got is None:
                return None
            y, M, mu_max, its, res = got
            if not mu_max < self.MU_MAX:
                return None
            self._orbit = (key, y, M, mu_max, its, res)
        d = np.linalg.norm(ends - y, axis=1)
        y_size = float(np.linalg.norm(y))
        if not (d[-1] <= self.CLOSE * y_size and d[-1] < d[0]):
            return None
        ig = self.integrator
        sampled = self._run(U, eta, Omega, 64)(y, ig.rtol, ig.atol)
        if sampled is None:
            return None
        w = sampled[:-1, :2]
        amps = (periodic_half_range(w[:, 0]), periodic_half_range(w[:, 1]))
        if not self._settles_in_time(amps, ends[-1] - y, M, 2 * math.pi / Omega, t, max_time, steady_tol):
            return None
        self.accepted += 1
        return (amps, tuple(float(v) for v in y),
                f"period-1 orbit by Newton on the period map from the integration's state ({its} steps, "
                f"residual {res:.1e}; that state {d[-1] / y_size:.1e} of |y*| from it and approaching; "
                f"largest multiplier modulus {mu_max:.4f})")


class RecurrenceStop:
    """Ends an eq. (21) integration (`Ode21Integrator.simulate`'s ``recurrence``) as "not steady"
    once its response is seen to be a recurrent modulated motion, instead of integrating on to
    max_time only to report the same (Figs. 4a-c above U_c, 8, 9 and 10: more than half of the
    overlays' integration time before this stop).

    The integration calls a response steady when its amplitudes over the last forcing periods
    change by less than steady_tol (1e-8) between chunks of 100 periods; that happens only when the
    motion converges to a period-1 (or a short subharmonic) orbit. The stop is taken after a
    judged chunk when all three hold:

    1. **no decay**: over the last 2 `HALF` chunks the median relative change of the later half is
       at least that of the earlier half, and at least `FLOOR` times steady_tol. An approach to an
       orbit, however slow, shrinks its changes geometrically (by mu^100 a chunk, mu the largest
       Floquet multiplier modulus);
    2. **no drift**: for each mode the later half's amplitudes overlap the range of the earlier
       half's. A growth away from an unstable orbit, or a decaying out-of-plane seed on a planar
       response (whose relative change per chunk is constant), drifts;
    3. **no stable period-1 orbit in reach**: Newton on the period map from the state reached
       (`PeriodOneShortcut.newton`) does not converge, or converges to an orbit with a Floquet
       multiplier of modulus >= 1. When it finds a stable one the integration goes on to max_time
       as before (a long modulated transient may still end on it), and the test is not repeated
       at this point.

    What it cannot see is a modulated transient that ends, after the stop and before max_time, on
    a stable orbit Newton did not reach from the stop's state (or on a subharmonic one); the
    integration to max_time can miss the same ending just after max_time. Checked against
    integrating to max_time on every overlay point of the figure scenes
    (tests/test_sweep_shortcut.py): the same class at every point. The amplitudes a not-steady
    point reports (not drawn: a not-steady point has no box) are those of its window at the stop.
    """

    #: chunks in each half of the compared stretch (2 x 6 chunks of 100 periods: ~1200 periods)
    HALF = 6
    #: the later half's median change must be at least this many times steady_tol
    FLOOR = 1e3

    def __init__(self, integrator: Ode21Integrator, periods: PeriodOneShortcut | None = None):
        # a sweep's own shortcut lends its prepared period-map runs (its Newton), else one of our own
        self.periods = periods if periods is not None else PeriodOneShortcut(integrator)
        self.stopped = 0
        self._done = False

    def start_point(self) -> None:
        """A new sweep point: the Newton check may be made again."""
        self._done = False

    def __call__(self, U: float, eta: float, Omega: float, amps, changes, state, t: float,
                 max_time: float, steady_tol: float = 1e-8):
        import statistics

        h = self.HALF
        if self._done or len(changes) < 2 * h:
            return None
        early, late = changes[-2 * h:-h], changes[-h:]
        m_early, m_late = statistics.median(early), statistics.median(late)
        if not (m_late >= m_early and m_late >= self.FLOOR * steady_tol):
            return None
        a_early, a_late = amps[-2 * h:-h], amps[-h:]
        for k in (0, 1):
            lo_e, hi_e = min(a[k] for a in a_early), max(a[k] for a in a_early)
            lo_l, hi_l = min(a[k] for a in a_late), max(a[k] for a in a_late)
            if lo_l > hi_e or hi_l < lo_e:
                return None
        # once per point: Newton's answer does not change while the motion stays recurrent
        self._done = True
        got = self.periods.newton(U, eta, Omega, state)
        if got is not None and got[2] < 1.0:
            return None
        self.stopped += 1
        orbit = ("Newton on the period map from the state does not converge" if got is None else
                 f"the period-1 orbit Newton finds from the state is unstable (largest multiplier "
                 f"modulus {got[2]:.4f})")
        return (f"a recurrent modulated motion: the median change between chunks is {m_late:.1e} over "
                f"the last {h} chunks and {m_early:.1e} over the {h} before, the amplitudes do not drift, "
                f"and {orbit}; stopped before max_time = {max_time:g}")


def sweep(integrator, parameter: str, values, fixed: dict, *, directions=("up", "down"),
          q0=DEFAULT_Q0, progress=None, shortcut: PeriodOneShortcut | None = None,
          recurrence: RecurrenceStop | None = None, **options) -> tuple[SweepPoint, ...]:
    """Steady responses of ``integrator`` at ``values`` of ``parameter`` (one of sigma, U, eta),
    the other two from ``fixed``; ``options`` go to ``simulate`` (e.g. max_time). ``shortcut``
    (eq. (21) only): a `PeriodOneShortcut` that ends each integration once it converges to a
    stable period-1 orbit; ``recurrence`` (eq. (21) only): a `RecurrenceStop` that ends it as not
    steady once it is a recurrent modulated motion.

    A point that starts from ``q0`` itself (the first of a direction, or one after a point with
    no steady response) is the same computation in both directions: it is integrated once and its
    response reused (``wall_seconds`` 0 where reused). Above the critical wind, where every point
    is modulated or diverges, that halves the sweep."""
    if parameter not in PARAMETERS:
        raise ValueError(f"sweep parameter must be one of {PARAMETERS}, got {parameter!r}")
    values = sorted(float(v) for v in values)
    if not values:
        raise ValueError("a sweep needs at least one parameter value")
    base = {"sigma": 0.0, "U": 0.0, "eta": 0.0}
    unknown = set(fixed) - set(base)
    if unknown:
        raise ValueError(f"unknown fixed parameters {sorted(unknown)}; use sigma, U, eta")
    base.update({k: float(v) for k, v in fixed.items()})
    is_ode21 = isinstance(integrator, Ode21Integrator)
    method = "ode21" if is_ode21 else "ame"
    out = []
    from_q0: dict = {}      # value -> the response from q0 (deterministic: reused by the other direction)
    for direction in directions:
        if direction not in ("up", "down"):
            raise ValueError(f"sweep direction must be 'up' or 'down', got {direction!r}")
        carried = None
        for value in (values if direction == "up" else values[::-1]):
            point = dict(base, **{parameter: value})
            wall = None
            try:
                if carried is None and value in from_q0:
                    r, wall = from_q0[value], 0.0
                    ok = r.steady and math.isfinite(r.a1)
                    carried = _carried(r, is_ode21) if ok else None
                elif is_ode21:
                    start = q0 if carried is None else tuple(c + d for c, d in zip(carried, q0))
                    for stop in (shortcut, recurrence):
                        if stop is not None:
                            stop.start_point()
                    r = integrator.simulate(point["U"], point["eta"], point["sigma"], start,
                                            shortcut=shortcut, recurrence=recurrence, **options)
                    if carried is None:
                        from_q0[value] = r
                    ok = r.steady and math.isfinite(r.a1)
                    carried = _carried(r, is_ode21) if ok else None
                else:
                    if carried is None:
                        r = integrator.simulate(point["U"], point["eta"], point["sigma"], q0, **options)
                        from_q0[value] = r
                    else:
                        r = integrator.simulate(point["U"], point["eta"], point["sigma"], y0=carried, **options)
                    ok = r.steady and math.isfinite(r.a1)
                    carried = _carried(r, is_ode21) if ok else None
            except ComputationError as exc:
                # One point the integrator cannot carry (its step size collapses, a budget runs out)
                # is that point's result, kept with the reason; it must not take the sweep's other
                # points, nor the scene's continuation results, with it.
                carried = None
                out.append(_failed_point(parameter, value, direction, method, str(exc)))
                if progress:
                    progress(out[-1])
                continue
            out.append(SweepPoint(parameter=parameter, value=value, direction=direction, method=method,
                                  a1=r.a1, a2=r.a2, a1_min=r.a1_min, a1_max=r.a1_max,
                                  a2_min=r.a2_min, a2_max=r.a2_max, steady=r.steady,
                                  periodic=r.periodic, message=r.message,
                                  wall_seconds=r.wall_seconds if wall is None else wall,
                                  period=getattr(r, "period", math.nan),
                                  a1_error=getattr(r, "a1_error", math.nan),
                                  a2_error=getattr(r, "a2_error", math.nan)))
            if progress:
                progress(out[-1])
    return tuple(out)


def _carried(r, is_ode21: bool) -> tuple:
    """The state a steady response hands the next point: eq. (21)'s simulate takes (q1, q1', q2, q2')
    and ends in (q1, q2, q1', q2'); the AME's carries its own state."""
    if is_ode21:
        return (r.final_state[0], r.final_state[2], r.final_state[1], r.final_state[3])
    return tuple(r.final_state)


def _failed_point(parameter, value, direction, method, why: str) -> SweepPoint:
    """A point whose integration failed: no amplitude (nan), not steady, the reason as its message."""
    nan = math.nan
    return SweepPoint(parameter=parameter, value=value, direction=direction, method=method, a1=nan, a2=nan,
                      a1_min=nan, a1_max=nan, a2_min=nan, a2_max=nan, steady=False, periodic=False,
                      message="integration failed: " + " ".join(why.split()), wall_seconds=nan)


def to_rows(points) -> list[dict]:
    """Plain rows (for CSV) of a sweep."""
    return [dict(p.__dict__) for p in points]
