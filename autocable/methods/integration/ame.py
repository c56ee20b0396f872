"""Time integration of the Cartesian amplitude equations (24) to a steady state; equilibria; stability.

The AME (22)-(24) of Sect. 4 are a 4-D autonomous slow flow y' = g(y; p), y = (r1, s1, r2, s2),
p = (eta, U, sigma_1, sigma_2, Omega), with Omega = omega1 + sigma (docs/model.md, C2). Amplitude
convention (autocable.model.ame): a_k = sqrt(r_k^2 + s_k^2) is the peak modal amplitude and, to first
order, q_k = r_k cos(Omega t) - s_k sin(Omega t). An equilibrium of (24) is a period-1 motion of q
(the "equilibrium branches" of Sect. 5); a periodic orbit of (24) is a quasi-periodic motion of q.

`AmeIntegrator.simulate` starts from the same state as the direct integration of eq. (21)
(`autocable.methods.integration.ode21`, rest with q2 = 1e-6), mapped to amplitudes by the first-order
relation above at t = 0: r_k = q_k(0), s_k = -q_k'(0)/Omega. It integrates with scipy's LSODA (or
Radau) and the analytic Jacobian, in chunks, f and J compiled to C (`compiled_cartesian`; the
numpy rows with ``compiled=False``); ``method="DOP853"`` runs each chunk in one call of the compiled
DOP853 of `autocable.codegen.cintegrate` (about 100x faster than LSODA at U = 1.3; the same method
as scipy's DOP853, agreeing with it to the tolerance), until

  steady (equilibrium): the Newton step from the current state, |J^{-1} g|, is below
      ``step_tol`` |y| + ``abs_tol`` and every eigenvalue of J has a negative real part: the flow is
      inside the linear neighbourhood of a stable equilibrium. The equilibrium is then refined by
      Newton (scipy.optimize.root with the Jacobian, then plain Newton polishing) so its amplitudes are
      exact to ~1e-12 relative; the reported a_k are those of the refined equilibrium;
  steady (no equilibrium): the envelope (min and max of a_1, a_2) over the last ``window`` time units
      agrees with that of the window before to ``envelope_tol`` and is not flat (a flat one is a slow
      approach to an equilibrium): a periodic (or quasi-periodic) slow flow, i.e. q is not
      period-1. a_k is then the half peak-to-peak of the first-order q_k over the last
      ``window_periods`` forcing periods, the convention of `Ode21Integrator`;
  diverged: max |y| exceeds ``blowup`` (amplitude of the order of the cable length: outside any
      validity of a cubic model). An integration that fails below it raises `ComputationError`.

Stability: eigenvalues of the analytic Jacobian of (24) at the equilibrium.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from autocable.errors import BudgetExceeded, ComputationError
from autocable.methods.integration.ode21 import DEFAULT_Q0, refined_peak
from autocable.model.ame import AmplitudeEquations
from autocable.model.premises import NOT_GIVEN, ArgumentError, check_call

METHODS = ("LSODA", "Radau", "BDF", "DOP853")


@dataclass(frozen=True)
class Equilibrium:
    """An equilibrium of the Cartesian AME (24) and its linear stability."""

    y: tuple                  # (r1, s1, r2, s2)
    amplitudes: tuple         # (a1, a2), peak modal amplitudes
    residual: float           # max |g(y)|
    eigenvalues: tuple        # of the Jacobian of (24), complex, sorted by decreasing real part
    converged: bool

    @property
    def stable(self) -> bool:
        return self.converged and max(e.real for e in self.eigenvalues) < 0.0

    @property
    def max_real(self) -> float:
        return max(e.real for e in self.eigenvalues)


@dataclass(frozen=True)
class AmeResponse:
    """The steady response of the AME at one parameter point; keys as `integration.Response`."""

    a1: float
    a2: float
    steady: bool
    periodic: bool            # the slow flow reached an equilibrium: q is period-1 (to first order)
    t_end: float
    U: float
    eta: float
    sigma: float
    Omega: float
    a1_min: float             # envelope of a_k(t) over the last window (equal to a_k at an equilibrium)
    a1_max: float
    a2_min: float
    a2_max: float
    message: str
    wall_seconds: float
    final_state: tuple        # (r1, s1, r2, s2) at t_end (the refined equilibrium if periodic)
    equilibrium: Equilibrium | None = None
    history: tuple = field(default=(), repr=False)   # (t, r1, s1, r2, s2) arrays if asked for


def compiled_cartesian(rhs):
    """The rows of a numeric Cartesian AME (`autocable.model.ame.CartesianRHS`) compiled to C
    (`autocable.codegen.cintegrate`, which also writes the Jacobian): returns (integrator, extend),
    ``extend(p)`` mapping the control vector p = (eta, U, sigma_k..., Omega) to the C parameters.

    As `CartesianRHS`, an aerodynamic row vanishes at U = 0 (no wind, its 1/U powers absent): the
    C field multiplies those rows by a switch ``wind`` (0 at U = 0) and writes a negative power of a
    parameter as a positive power of its inverse (set to 0 when the parameter is 0)."""
    import sympy as sp

    from autocable.codegen.cintegrate import compiled_integrator

    names = list(rhs.param_names)
    iU = names.index("U") if "U" in names else 1
    neg = [j for j in range(len(names)) if np.any(rhs.param_exponents[:, j] < 0)]
    params = names + ["ac_wind"] + [f"ac_inv_{names[j]}" for j in neg]
    P = [sp.Symbol(x) for x in params]
    Y = [sp.Symbol(x) for x in rhs.state_names]
    out = [sp.Integer(0)] * len(Y)
    for i, c in enumerate(rhs.coefficients):
        term = sp.Float(float(c), 17)
        for j, e in enumerate(rhs.param_exponents[i]):
            if e > 0:
                term *= P[j] ** int(e)
            elif e < 0:
                term *= P[len(names) + 1 + neg.index(j)] ** int(-e)
        if rhs.aero[i]:
            term *= P[len(names)]
        for k, e in enumerate(rhs.state_exponents[i]):
            if e:
                term *= Y[k] ** int(e)
        out[int(rhs.equation[i])] += term
    ci = compiled_integrator("ame_cartesian", rhs.state_names, params, out, None)

    def extend(p) -> np.ndarray:
        p = np.asarray(p, dtype=float)
        inv = [1.0 / p[j] if p[j] != 0.0 else 0.0 for j in neg]
        return np.concatenate([p, [0.0 if p[iU] == 0.0 else 1.0], inv])

    return ci, extend


def initial_amplitudes(q0, Omega: float) -> np.ndarray:
    """(r1, s1, r2, s2) from q0 = (q1, q1', q2, q2') at t = 0 by the first-order relation
    q_k = r_k cos(Omega t) - s_k sin(Omega t): r_k = q_k(0), s_k = -q_k'(0) / Omega."""
    q1, q1d, q2, q2d = (float(x) for x in q0)
    return np.array([q1, -q1d / Omega, q2, -q2d / Omega])


class AmeIntegrator:
    """Integrates the Cartesian AME (24) of one `AmplitudeEquations` (2 modes)."""

    def __init__(self, ame: AmplitudeEquations, *, method: str = "LSODA", rtol: float = 1e-10,
                 atol: float = 1e-16, values=None, compiled: bool = True):
        if not isinstance(ame, AmplitudeEquations):
            raise ArgumentError("AmeIntegrator", "ame", f"expected the amplitude equations of a derivation "
                                                        f"(ac.derive_ame(eq21).ame), got {type(ame).__name__}")
        if method not in METHODS:
            raise ValueError(f"unknown method {method!r}: use one of {METHODS}")
        if ame.n_modes != 2:
            raise ValueError(f"the Cartesian AME (24) of eq. (21) has 2 modes, got {ame.n_modes}")
        self.ame, self.method, self.rtol, self.atol = ame, method, rtol, atol
        self.rhs = ame.cartesian_rhs(values)
        # f and J of the time integration in C (`compiled_cartesian`): the same rows, summed in
        # another order; the numpy `rhs` stays for the few Newton and eigenvalue evaluations.
        self.compiled = compiled
        self._c = None

    def _numeric(self, p):
        """(f, J) for the time integration at the parameter vector ``p``, both called as (y, p)."""
        if self.compiled:
            if self._c is None:
                self._c = compiled_cartesian(self.rhs)
            ci, extend = self._c
            pe = extend(p)
            return (lambda x, _p: ci.rhs(0.0, x, pe)), (lambda x, _p: ci.jac(0.0, x, pe))
        return self.rhs.f, self.rhs.jacobian

    # -- parameters and equilibria -------------------------------------------------------------
    def parameters(self, U: float, eta: float, sigma: float, rho: float | None = None) -> np.ndarray:
        """p = (eta, U, sigma_1, sigma_2, Omega) with Omega = omega1 + sigma (Sect. 4, docs/model.md, C2)."""
        return self.ame.control(eta=eta, U=U, sigma=sigma, rho=rho)

    def stability(self, y, p) -> tuple:
        """Eigenvalues of the Jacobian of (24) at y, by decreasing real part."""
        ev = np.linalg.eigvals(self.rhs.jacobian(np.asarray(y, float), p))
        return tuple(complex(e) for e in sorted(ev, key=lambda e: -e.real))

    def refine(self, y, p, *, tol: float = 1e-14, maxiter: int = 50) -> Equilibrium:
        """The equilibrium of (24) nearest (in Newton's sense) to y: scipy's hybrid Powell root finder
        with the analytic Jacobian, then Newton steps until the step is below ``tol`` |y| (so a_k is
        exact to ~1e-12 relative, limited only by the conditioning of J)."""
        from scipy.optimize import root

        f, J = self.rhs.f, self.rhs.jacobian
        y = np.asarray(y, dtype=float)
        sol = root(lambda x: f(x, p), y, jac=lambda x: J(x, p), method="hybr", tol=1e-15)
        x = sol.x if np.all(np.isfinite(sol.x)) else y.copy()
        converged = False
        for _ in range(maxiter):
            try:
                step = np.linalg.solve(J(x, p), f(x, p))
            except np.linalg.LinAlgError:
                break
            x = x - step
            if not np.all(np.isfinite(x)):
                break
            if np.max(np.abs(step)) <= tol * max(np.max(np.abs(x)), 1e-300):
                converged = True
                break
        if not np.all(np.isfinite(x)):
            x = y
        residual = float(np.max(np.abs(f(x, p))))
        # Newton stalls at exact zero steps for the trivial solution: accept a vanishing residual too.
        converged = converged or residual == 0.0
        return Equilibrium(y=tuple(float(v) for v in x),
                           amplitudes=tuple(float(a) for a in self.ame.amplitudes(x)),
                           residual=residual, eigenvalues=self.stability(x, p), converged=converged)

    def equilibrium_near(self, amplitudes_complex, U: float, eta: float, sigma: float,
                         rho: float | None = None) -> Equilibrium:
        """The AME equilibrium Newton finds from r_k + i s_k = ``amplitudes_complex`` (e.g. the first
        harmonic of a direct integration of eq. (21)): the branch of (24) that response sits on."""
        c = np.asarray(amplitudes_complex, dtype=complex)
        return self.refine(np.array([c[0].real, c[0].imag, c[1].real, c[1].imag]),
                           self.parameters(U, eta, sigma, rho))

    # -- the steady response -------------------------------------------------------------------
    def simulate(self, U: float, eta: float, sigma: float, q0=DEFAULT_Q0, *, rho: float | None = None,
                 y0=None, chunk: float = 250.0, max_time: float = 60000.0, step_tol: float = 1e-6,
                 abs_tol: float = 1e-12, window: float = 4000.0, envelope_tol: float = 1e-4,
                 window_periods: int = 20, blowup: float = 1.0, keep_history: bool = False,
                 progress=None, max_evaluations: int = 5_000_000) -> AmeResponse:
        """Integrate (24) from ``q0`` = (q1, q1', q2, q2') (or from ``y0`` = (r1, s1, r2, s2)) until
        steady (module docstring); give up at ``max_time`` (t* units, as eq. (21)). Budget: the
        scipy methods raise `BudgetExceeded` after ``max_evaluations`` of the right-hand side, the
        compiled DOP853 (`_c_chunk`) has a step budget per chunk."""
        from scipy.integrate import solve_ivp

        check_call("AmeIntegrator.simulate", U=U, eta=eta, sigma=sigma, q0=q0 if y0 is None else NOT_GIVEN,
                   max_time=max_time)
        start = time.perf_counter()
        p = self.parameters(U, eta, sigma, rho)
        Omega = float(p[-1])
        if not Omega > 0:
            raise ValueError(f"sigma = {sigma} gives a non-positive forcing frequency Omega = {Omega}")
        check_call("AmeIntegrator.simulate", sigma=sigma, max_time=max_time, omega1=Omega - float(sigma))
        y = np.asarray(y0, dtype=float) if y0 is not None else initial_amplitudes(q0, Omega)
        f, J = self._numeric(p)

        evaluations = [0]

        def rhs(_t, x):
            evaluations[0] += 1      # counted here, checked per step in `blow` (outside LSODA's
            return f(x, p)           # Fortran callback, where an exception prints a C traceback)

        def blow(t, x):
            if evaluations[0] > max_evaluations:
                raise BudgetExceeded(f"the AME integration spent its budget of {max_evaluations:,} "
                                     f"right-hand side evaluations at t = {t:.6g} (a stiff slow flow); "
                                     "lower max_time or use method='DOP853'")
            return blowup - np.max(np.abs(x))
        blow.terminal = True

        # Samples a few times per forcing period: the slow flow varies on scales >> 2 pi / Omega.
        dt = (2 * math.pi / Omega) / 8
        ts, ys = [np.array([0.0])], [y[None, :]]
        t, message = 0.0, ""
        steady = periodic = False
        eq = None
        while t < max_time - 1e-9:
            t1 = min(t + chunk, max_time)
            grid = np.arange(t + dt, t1, dt)
            grid = np.append(grid[grid < t1 - 1e-9], t1)
            if self.method == "DOP853" and self.compiled:
                sol = self._c_chunk(y, t, grid, p, blowup)
            else:
                # An explicit method takes no Jacobian (scipy warns about a jac=None too).
                jac = {} if self.method == "DOP853" else {"jac": lambda _t, x: J(x, p)}
                sol = solve_ivp(rhs, (t, t1), y, method=self.method, t_eval=grid,
                                rtol=self.rtol, atol=self.atol, events=blow, **jac)
            grew = sol.status == 1
            if not grew and (sol.status == -1 or not np.all(np.isfinite(sol.y))):
                # The integrator stopped (or produced a non-finite state) while max |y| stayed
                # below ``blowup``, checked at every step: a numerical failure, not growth.
                failure = BudgetExceeded if "step_budget" in str(sol.message) else ComputationError
                raise failure(f"the AME (24) could not be integrated from t = {t:g} while the "
                              f"amplitudes stayed below {blowup:g}: {sol.message}")
            if sol.y.size:
                ts.append(sol.t)
                ys.append(sol.y.T)
            if grew:
                t = float(sol.t_events[0][0]) if sol.t_events[0].size else float(sol.t[-1])
                return self._response(U, eta, sigma, Omega, (math.inf, math.inf), (math.inf,) * 4,
                                      False, False, t, "the AME diverged (no bounded steady state)",
                                      start, sol.y[:, -1] if sol.y.size else y, None, ts, ys,
                                      keep_history)
            y, t = sol.y[:, -1].copy(), float(sol.t[-1])
            a = self.ame.amplitudes(y)
            if progress:
                progress(t, tuple(a))
            # Equilibrium test: Newton's step from here is tiny and the linearisation is stable.
            try:
                Jy = J(y, p)
                step = np.linalg.solve(Jy, f(y, p))
                ev = np.linalg.eigvals(Jy)
            except np.linalg.LinAlgError:
                step, ev = None, None
            if step is not None and np.max(ev.real) < 0.0 and \
                    np.linalg.norm(step) <= step_tol * np.linalg.norm(y) + abs_tol:
                cand = self.refine(y, p)
                close = np.linalg.norm(np.subtract(cand.y, y)) <= 1e-3 * np.linalg.norm(y) + 1e3 * abs_tol
                if cand.stable and close:
                    eq, steady, periodic, message = cand, True, True, "steady (stable AME equilibrium)"
                    break
            # Envelope test for a non-stationary slow flow.
            tt = np.concatenate(ts)
            if tt[-1] >= 2 * window:
                yy = np.concatenate(ys)
                amps = self.ame.amplitudes(yy)
                last = tt > tt[-1] - window
                prev = (tt > tt[-1] - 2 * window) & ~last
                env = np.array([[refined_peak(amps[m, k], sign) for k in (0, 1) for sign in (-1, 1)]
                                for m in (prev, last)])
                scale = max(np.max(np.abs(env)), abs_tol)
                # A flat envelope is a slow approach to an equilibrium, left to the Newton test.
                swing = max(env[1][1] - env[1][0], env[1][3] - env[1][2])
                repeats = np.max(np.abs(env[1] - env[0])) <= envelope_tol * scale
                if swing > 10 * envelope_tol * scale and repeats:
                    steady = True
                    message = "steady envelope (AME not at an equilibrium: q is not period-1)"
                    break
            # Keep memory bounded: only what the envelope test and the final window need.
            if not keep_history and len(ts) > 4:
                tt, yy = np.concatenate(ts), np.concatenate(ys)
                keep = tt > tt[-1] - 2 * window - chunk
                ts, ys = [tt[keep]], [yy[keep]]
        if eq is not None:
            amps, env = eq.amplitudes, (eq.amplitudes[0],) * 2 + (eq.amplitudes[1],) * 2
            return self._response(U, eta, sigma, Omega, amps, env, steady, periodic, t, message, start,
                                  np.array(eq.y), eq, ts, ys, keep_history)
        if not message:
            message = f"not steady after t = {t:g} (AME still changing)"
        amps, env = self._window_amplitudes(ts, ys, Omega, window, window_periods)
        return self._response(U, eta, sigma, Omega, amps, env, steady, False, t, message, start, y, None,
                              ts, ys, keep_history)

    def _c_chunk(self, y, t: float, grid, p, blowup: float):
        """One chunk by the compiled DOP853 (the method scipy's "DOP853" runs in Python), in the
        shape of solve_ivp's result: status 0 done, 1 stopped at max |y| > ``blowup`` (the
        terminal event, located at the step that crosses it), -1 failed (step budget or size, or a
        non-finite state)."""
        from types import SimpleNamespace
        if self._c is None:
            self._c = compiled_cartesian(self.rhs)
        ci, extend = self._c
        # A step budget: a bounded slow flow takes a few steps per time unit; without one a
        # collapsing step could spin for a billion steps inside one call.
        r = ci.run(y, np.concatenate([[t], grid]), extend(p), rtol=self.rtol, atol=self.atol,
                   bound=blowup, n_bound=len(y), max_steps=100_000 + int(400 * (grid[-1] - t)))
        # Growth past ``blowup`` is checked after every step: a non-finite state without it is a
        # numerical failure (e.g. one step from a bounded state to inf), not a divergence.
        status = {"done": 0, "bound": 1}.get(r.status, -1)
        return SimpleNamespace(status=status, t=r.t[1:], y=r.y[1:].T,
                               t_events=[np.array([r.t_reached]) if r.status == "bound" else np.empty(0)],
                               message=f"the compiled DOP853 stopped ({r.status}) at t = {r.t_reached:g}")

    def _window_amplitudes(self, ts, ys, Omega, window, window_periods):
        """Half peak-to-peak of the first-order q_k over the last forcing periods (the convention of
        eq. (21)'s integrator), and the envelope of a_k(t) over the last window."""
        tt, yy = np.concatenate(ts), np.concatenate(ys)
        span = window_periods * 2 * math.pi / Omega
        sel = tt >= tt[-1] - span
        fine = np.linspace(max(tt[-1] - span, tt[0]), tt[-1], window_periods * 64 + 1)
        amps = []
        for k in (0, 1):
            if sel.sum() > 1:
                r, s = (np.interp(fine, tt[sel], yy[sel, j]) for j in (2 * k, 2 * k + 1))
            else:
                r, s = (np.full_like(fine, yy[-1, j]) for j in (2 * k, 2 * k + 1))
            q = r * np.cos(Omega * fine) - s * np.sin(Omega * fine)
            amps.append(0.5 * (refined_peak(q, 1) - refined_peak(q, -1)))
        a = self.ame.amplitudes(yy[tt >= tt[-1] - window])
        env = (float(a[:, 0].min()), float(a[:, 0].max()), float(a[:, 1].min()), float(a[:, 1].max()))
        return tuple(amps), env

    def _response(self, U, eta, sigma, Omega, amps, env, steady, periodic, t, message, start, y, eq,
                  ts, ys, keep_history) -> AmeResponse:
        hist = ()
        if keep_history:
            tt, yy = np.concatenate(ts), np.concatenate(ys)
            hist = (tt, yy[:, 0], yy[:, 1], yy[:, 2], yy[:, 3])
        return AmeResponse(a1=float(amps[0]), a2=float(amps[1]), steady=steady, periodic=periodic,
                           t_end=float(t), U=U, eta=eta, sigma=sigma, Omega=Omega,
                           a1_min=float(env[0]), a1_max=float(env[1]), a2_min=float(env[2]),
                           a2_max=float(env[3]), message=message,
                           wall_seconds=time.perf_counter() - start,
                           final_state=tuple(float(v) for v in y), equilibrium=eq, history=hist)


# -- time series (Fig. 11) ----------------------------------------------------------------------------
def ame_time_series(system, values: dict, y0, t_end: float, dt: float, *, rtol: float = 1e-10,
                    atol: float = 1e-16, keep_stopped: bool = False):
    """The AME ``system`` (a `autocable.methods.continuation.system.System`, e.g. the Cartesian AME (24) of
    `ame_system`) integrated from ``y0`` over [0, t_end], sampled every ``dt``: (t, states).

    One call of autocable's compiled DOP853 (`autocable.codegen.cintegrate`, dense output at the
    sample times) with the parameters ``values`` over the system's defaults. Raises RuntimeError if
    the integration stops before t_end (a blow-up or a step-size collapse); with ``keep_stopped``
    returns (t, states, message) instead, the samples up to the stop and why it stopped ("" if it
    did not): a solution that leaves every bound is a result, and what came before it is kept."""
    from autocable.codegen.cintegrate import compiled_integrator, sample_grid

    ci = compiled_integrator(f"{system.name}_flow", system.variables, system.parameter_names,
                             system.rhs, None)
    grid = sample_grid(0.0, t_end, dt)
    r = ci.run(np.asarray(y0, float), grid, system.parameter_vector(values), rtol=rtol, atol=atol)
    why = "" if r.ok else (f"the AME integration stopped at t = {r.t_reached:.6g} of {t_end:g} "
                           f"({r.status}): no bounded solution over [0, t_end]")
    if keep_stopped:
        return r.t, r.y, why
    if why:
        raise RuntimeError(why)
    return r.t, r.y


# -- comparison with the direct integration of eq. (21) ----------------------------------------------
#: Comparison statuses (`Comparison.status`).
STATUSES = {
    "same-branch": "both at period-1 states on the same AME equilibrium branch",
    "different-branch": "from the same start the AME and eq. (21) settle on different branches; "
                        "eq. (21)'s response lies on another AME equilibrium (see rel_a1_nearest)",
    "no-ame-branch": "eq. (21) is period-1 but no AME equilibrium lies near its response: MSM fails",
    "quasi-periodic-21": "eq. (21) is not period-1 (amplitude-modulated): an AME equilibrium is not "
                         "the right comparison",
    "ame-not-equilibrium": "the AME does not settle on an equilibrium (q not period-1 in the AME)",
    "diverged-both": "both eq. (21) and the AME diverge (no bounded response)",
    "diverged-21": "eq. (21) diverges, the AME does not",
    "diverged-ame": "the AME diverges, eq. (21) does not",
}


@dataclass(frozen=True)
class Comparison:
    """The AME and eq. (21) at one parameter point, started from the same state."""

    U: float
    eta: float
    sigma: float
    ame: AmeResponse
    ode: object                 # integration.Response (a1 = inf when eq. (21) diverged)
    ode_error: str              # why eq. (21) has no response ("" if it has one)
    harmonics: tuple            # first harmonics r_k + i s_k of eq. (21)'s q_k over its last period
    nearest: Equilibrium | None  # the AME equilibrium Newton finds from `harmonics`
    status: str                 # a key of STATUSES
    rel_a1: float               # |a1_AME - a1_(21)| / a1_(21), same start
    rel_a2: float               # |a2_AME - a2_(21)| / max(a2_(21), a1_(21)), same start
    rel_a1_nearest: float       # the same for the nearest AME equilibrium

    @property
    def note(self) -> str:
        return STATUSES[self.status]


def first_harmonics(ode_integrator, response, samples: int = 128) -> tuple:
    """r_k + i s_k = (2/T) int_T q_k e^{-i Omega t} dt over one forcing period after eq. (21)'s
    steady state (q_k = r_k cos(Omega t) - s_k sin(Omega t) + other harmonics, t absolute)."""
    from autocable.model.symbolic import parameter_values

    Om = response.Omega
    T = 2 * math.pi / Om
    q1, q2, v1, v2 = response.final_state
    tt, ys = ode_integrator.run((q1, q2, v1, v2), response.t_end, response.t_end + T, T / samples,
                                parameter_values(response.U, response.eta, Om))
    tt, ys = tt[:samples], ys[:samples]
    e = np.exp(-1j * Om * tt)
    return tuple(complex(2.0 * np.mean(ys[:, k] * e)) for k in (0, 1))


def compare_with_ode21(ame_integrator: AmeIntegrator, ode_integrator, U: float, eta: float,
                       sigma: float, q0=DEFAULT_Q0, *, max_time: float = 60000.0) -> Comparison:
    """Integrate the AME and eq. (21) (`Ode21Integrator`) from the same start ``q0`` and classify
    the pair (`STATUSES`). A blow-up of eq. (21) (growth past `ode21.DIVERGED`, however the
    integrator ends) is a divergence; an integration that fails at a bounded state raises
    `ComputationError`, not counted as one."""
    a = ame_integrator.simulate(U, eta, sigma, q0, max_time=max_time)
    ame_div = not math.isfinite(a.a1)
    o = ode_integrator.simulate(U, eta, sigma, q0, max_time=max_time)
    err = "" if math.isfinite(o.a1) else o.message
    nan = math.nan
    if not math.isfinite(o.a1):
        status = "diverged-both" if ame_div else "diverged-21"
        return Comparison(U, eta, sigma, a, o, err or "diverged", (), None, status, nan, nan, nan)
    rel1 = abs(a.a1 - o.a1) / o.a1 if o.a1 > 0 else nan
    rel2 = abs(a.a2 - o.a2) / max(o.a2, o.a1) if o.a1 > 0 else nan
    if ame_div:
        return Comparison(U, eta, sigma, a, o, "", (), None, "diverged-ame", nan, nan, nan)
    if not o.periodic:
        return Comparison(U, eta, sigma, a, o, "", (), None, "quasi-periodic-21", rel1, rel2, nan)
    h = first_harmonics(ode_integrator, o)
    near = ame_integrator.equilibrium_near(h, U, eta, sigma)
    hy = np.array([h[0].real, h[0].imag, h[1].real, h[1].imag])
    # Newton may wander to a remote equilibrium: that is not the branch eq. (21) sits on.
    found = near.converged and np.linalg.norm(np.subtract(near.y, hy)) <= 0.5 * np.linalg.norm(hy)
    rel_near = abs(near.amplitudes[0] - o.a1) / o.a1 if found and o.a1 > 0 else nan
    if not a.periodic:
        status = "ame-not-equilibrium"
    elif not found:
        status = "no-ame-branch"
    elif np.linalg.norm(np.subtract(near.y, a.final_state)) <= 1e-6 * np.linalg.norm(a.final_state) + 1e-13:
        status = "same-branch"
    else:
        status = "different-branch"
    return Comparison(U, eta, sigma, a, o, "", h, near, status, rel1, rel2, rel_near)
