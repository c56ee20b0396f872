"""Direct integration of the N-mode equations (`multimode.NModeODE`): the check that two modes suffice.

The rung of the method ladder that tests the Galerkin truncation of Sect. 3 itself: the
same spec, the same nondimensionalisation and forcing f = sin(Omega t), Omega = omega1 + sigma, but
n_in in-plane and n_out out-of-plane modes. The steady response is found as in
`integration.Ode21Integrator` (chunks of forcing periods until the amplitudes stop changing), with
the same amplitude convention: a_k is half the peak-to-peak of the modal coordinate over the last
forcing periods. ``a1`` is the first in-plane (symmetric) mode and ``a2`` the first out-of-plane
mode, as in eq. (21); ``amplitudes`` holds every mode's.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from autocable.codegen.compat import PyDSToolError
from autocable.errors import ComputationError
from autocable.methods.integration.ode21 import DIVERGED, first_divergence, half_range
from autocable.model.derive_n import derive_nmode
from autocable.model.modes_n import IN_PLANE, OUT_OF_PLANE, SYMMETRIC
from autocable.model.multimode import NModeODE, first_order_rhs_n
from autocable.model.symbolic import PARAMETERS, T, parameter_values

#: What this rung solves, its declared accuracy and what its cost grows with (the method ladder,
#: `autocable.studies.ladder`, reads this).
METHOD_INFO = {
    "name": "nmode-integration",
    "solves": "steady response of the N-mode Galerkin model (n_in in-plane, n_out out-of-plane modes "
              "from the same spec) at one (U, eta, sigma), by direct time integration; a1, a2 are the "
              "first in-plane and out-of-plane modal amplitudes as in eq. (21)",
    "accuracy": "integration error of DOP853 at rtol 1e-10 plus the steady-state test (1e-8 relative "
                "between chunks); reproduces eq. (21) exactly with n_in = n_out = 1; the truncation "
                "error of eq. (21) is what it measures",
    "cost_drivers": "number of terms (89 for 1+1 modes, 360 for 2+2, 1209 for 3+3 on the sample "
                    "cable), the settling time ~ 1/(xi_s omega) per point, one C build per model",
    "knobs": {"n_in": "in-plane modes", "n_out": "out-of-plane modes", "rtol": "integration tolerance"},
}


@dataclass(frozen=True)
class NModeResponse:
    """The steady response of the N-mode model at one parameter point (fields as `Response`)."""

    a1: float
    a2: float
    amplitudes: dict           # mode name -> half peak-to-peak over the last window
    steady: bool
    periodic: bool
    diverged: bool
    t_end: float
    U: float
    eta: float
    sigma: float
    Omega: float
    message: str
    wall_seconds: float
    final_state: tuple         # (x, x') at t_end in `NModeODE.state_names` order
    a1_min: float = math.nan   # envelope of the half peak-to-peak over single forcing periods of
    a1_max: float = math.nan   # the last window (as `Response`): min = max for a period-1 response
    a2_min: float = math.nan
    a2_max: float = math.nan
    history: tuple = field(default=(), repr=False)   # (t, states) if asked for


def default_start(ode: NModeODE, seed: float = 1e-6) -> tuple:
    """Rest, with every out-of-plane mode seeded at ``seed`` (as eq. (21)'s q2 = 1e-6), so that an
    unstable planar motion is never reported as the response."""
    x = [seed if m.plane == OUT_OF_PLANE else 0.0 for m in ode.modes]
    return tuple(x + [0.0] * ode.n)


class NModeIntegrator:
    """Integrates the N-mode model of a spec (or of its `Derivation`); built once, reused."""

    def __init__(self, derivation_or_spec, n_in: int = 2, n_out: int = 2, engine: str = "dopri",
                 rtol: float = 1e-10, atol: float = 1e-13, ode: NModeODE | None = None):
        if engine not in ("dopri", "scipy"):
            raise ValueError(f"unknown engine {engine!r}: use 'dopri' or 'scipy'")
        self.ode = ode if ode is not None else derive_nmode(derivation_or_spec, n_in, n_out)
        self.engine, self.rtol, self.atol = engine, rtol, atol
        self._rhs = None
        self._generator = None
        self._numeric = None
        self.build_seconds = 0.0
        names = self.ode.names
        # a1 is the first symmetric in-plane mode, as in eq. (21); it is the lowest one unless
        # lambda^2 > 4 pi^2 (see statics.regime_warnings), when an antisymmetric mode comes first.
        first_sym = [m.name for m in self.ode.modes if m.plane == IN_PLANE and m.symmetry == SYMMETRIC]
        if not first_sym:
            n_plane = sum(m.plane == IN_PLANE for m in self.ode.modes)
            raise ValueError(f"the {n_plane} lowest in-plane modes hold no symmetric mode (Irvine's lambda^2 "
                             "exceeds 4 pi^2): take more in-plane modes")
        self._i1 = names.index(first_sym[0])
        self._i2 = names.index(next(m.name for m in self.ode.modes if m.plane == OUT_OF_PLANE))

    def _sym(self):
        if self._rhs is None:
            self._rhs = first_order_rhs_n(self.ode)
        return self._rhs

    def _compiled(self):
        if self._generator is None:
            from autocable.codegen.pydstool import VectorField, make_ode_generator
            vf = VectorField(name=f"nmode_{self.ode.content_hash()}", variables=self.ode.state_names,
                             rhs=self._sym(), parameters=tuple((p.name, 0.0) for p in PARAMETERS))
            t0 = time.perf_counter()
            # No Jacobian: DOP853 is explicit, and the sympy Jacobian of ~1000 terms costs more than it saves.
            self._generator = make_ode_generator(vf, "Dopri", jacobian=False, algparams={
                "rtol": self.rtol, "atol": self.atol, "max_step": 1.0})
            self.build_seconds = time.perf_counter() - t0
        return self._generator

    def run(self, y0, t0: float, t1: float, dt: float, pars: dict):
        """Samples (t, states) on t0, t0 + dt, ..., states in `NModeODE.state_names` order."""
        if self.engine == "dopri":
            from autocable.codegen.pydstool import integrate
            return integrate(self._compiled(), list(y0), pars, t0, t1, dt,
                             algparams={"rtol": self.rtol, "atol": self.atol})
        import sympy as sp
        from scipy.integrate import solve_ivp
        from autocable.model.multimode import state_symbols
        if self._numeric is None:
            self._numeric = sp.lambdify((T, state_symbols(self.ode), PARAMETERS), self._sym(), "numpy")
        p = tuple(pars[s.name] for s in PARAMETERS)
        n = int(math.floor((t1 - t0) / dt * (1 + 1e-12))) + 1
        grid = t0 + dt * np.arange(n)
        f = self._numeric
        sol = solve_ivp(lambda t, y: f(t, y, p), (t0, grid[-1]), list(y0), method="DOP853",
                        t_eval=grid, rtol=self.rtol, atol=self.atol)
        if not sol.success:
            raise ComputationError(f"scipy DOP853 failed: {sol.message}")
        return sol.t, sol.y.T

    def _judge(self, y0, t0: float, t1: float, dt: float, pars: dict, reason: str,
               max_evaluations: int = 500_000):
        """After PyDSTool failed on [t0, t1] from ``y0``: the same chunk by scipy's DOP853, stopping
        where a modal coordinate passes `DIVERGED`. Returns the samples (t, states) up to there when
        the response grows past it (a divergence); raises `ComputationError` otherwise (the failure
        happened at a bounded state, or the check itself ran out of ``max_evaluations``)."""
        import sympy as sp
        from scipy.integrate import solve_ivp

        from autocable.model.multimode import state_symbols
        if self._numeric is None:
            self._numeric = sp.lambdify((T, state_symbols(self.ode), PARAMETERS), self._sym(), "numpy")
        f, p, n = self._numeric, tuple(pars[s.name] for s in PARAMETERS), self.ode.n
        count = [0]

        def rhs(t, y):
            count[0] += 1
            if count[0] > max_evaluations:
                raise ComputationError(f"eq. (21) with {n} modes could not be integrated from t = {t0:g} "
                                       f"to {t1:g} ({reason}), and the check for growth spent "
                                       f"{max_evaluations:,} evaluations without |q| passing {DIVERGED:g}")
            return f(t, y, p)

        def grown(t, y):
            return DIVERGED - np.max(np.abs(y[:n]))
        grown.terminal = True
        grid = t0 + dt * np.arange(int(math.floor((t1 - t0) / dt * (1 + 1e-12))) + 1)
        sol = solve_ivp(rhs, (t0, grid[-1]), list(y0), method="DOP853", t_eval=grid, events=grown,
                        rtol=self.rtol, atol=self.atol)
        if sol.status == 1:
            return sol.t, sol.y.T
        raise ComputationError(f"eq. (21) with {n} modes could not be integrated from t = {t0:g} to "
                               f"{t1:g} while the response stayed bounded (|q| <= {DIVERGED:g}): {reason}")

    def simulate(self, U: float, eta: float, sigma: float, x0=None, *, periods_per_chunk: int = 100,
                 window_periods: int = 20, max_time: float = 60000.0, steady_tol: float = 1e-8,
                 samples_per_period: int = 64, keep_history: bool = False, progress=None) -> NModeResponse:
        """Integrate from ``x0`` (state order of `NModeODE.state_names`; default `default_start`)
        until every modal amplitude changes by less than ``steady_tol`` (relative) between chunks."""
        start = time.perf_counter()
        ode = self.ode
        Omega = ode.modes[self._i1].omega + sigma
        if not Omega > 0:
            raise ValueError(f"sigma = {sigma} gives a non-positive forcing frequency Omega = {Omega}")
        y = tuple(float(v) for v in (default_start(ode) if x0 is None else x0))
        if len(y) != 2 * ode.n:
            raise ValueError(f"the start state needs {2 * ode.n} values {ode.state_names}, got {len(y)}")
        period = 2 * math.pi / Omega
        dt = period / samples_per_period
        pars = parameter_values(U, eta, Omega)
        t, chunk = 0.0, periods_per_chunk * period
        keep = window_periods * samples_per_period + 1
        window = np.array([y])
        previous, steady, history, amps = None, False, [], None
        n = ode.n

        def result(amps, steady, periodic, diverged, msg):
            env = [(math.inf, math.inf)] * 2
            if amps is not None:
                m = samples_per_period
                env = [(amps[i], amps[i]) for i in (self._i1, self._i2)]
                if len(window) > m:
                    per = [[half_range(window[j:j + m + 1, i]) for j in range(0, len(window) - m, m)]
                           for i in (self._i1, self._i2)]
                    env = [(min(p), max(p)) for p in per]
            hist = ()
            if history:
                hist = (np.concatenate([h[0] for h in history]), np.concatenate([h[1] for h in history]))
            inf = math.inf
            amp = dict(zip(ode.names, amps)) if amps is not None else {k: inf for k in ode.names}
            return NModeResponse(a1=float(amp[ode.names[self._i1]]), a2=float(amp[ode.names[self._i2]]),
                                 amplitudes=amp, steady=steady, periodic=periodic, diverged=diverged,
                                 t_end=t, U=U, eta=eta, sigma=sigma, Omega=Omega, message=msg,
                                 wall_seconds=time.perf_counter() - start,
                                 final_state=tuple(float(v) for v in y), history=hist,
                                 a1_min=env[0][0], a1_max=env[0][1], a2_min=env[1][0], a2_max=env[1][1])

        while t < max_time - 1e-9:
            t1 = min(t + chunk, max_time)
            if t1 - t < dt * (1 - 1e-9):
                # less than one sample interval is left before max_time (the chunks end on the
                # sample grid): another chunk would not advance t (as in `Ode21Integrator.simulate`)
                break
            try:
                tt, ys = self.run(y, t, t1, dt, pars)
            except (PyDSToolError, ComputationError) as exc:
                # A blow-up and a numerical failure both stop the integrator: growth past the
                # bound (`_judge`) is a result, the rest raises ComputationError.
                why = str(exc).splitlines()[0]
                tt, ys = self._judge(y, t, t1, dt, pars, why)
                if keep_history and len(tt):
                    history.append((tt, ys))
                y, t = tuple(ys[-1]) if len(ys) else y, float(tt[-1]) if len(tt) else t
                return result(None, False, False, True, f"the response diverged between t = {t:g} and "
                              f"{t1:g} (no bounded steady state): {why}")
            stop = first_divergence(tt, ys, n)
            if stop is not None:
                if keep_history and stop > 0:
                    history.append((tt[:stop], ys[:stop]))
                y, t = tuple(ys[stop]), float(tt[stop])
                return result(None, False, False, True, "the response diverged (no bounded steady state): "
                              f"|q| > {DIVERGED:g} at t = {t:.6g}")
            if keep_history:
                history.append((tt[:-1], ys[:-1]))
            # a last chunk shorter than the window is not judged (as in `Ode21Integrator.simulate`)
            overlapping = float(tt[-1]) - t < min(chunk, window_periods * period) * (1 - 1e-9)
            y, t = tuple(ys[-1]), float(tt[-1])
            window = np.concatenate([window, ys[1:]])[-keep:]
            amps = tuple(half_range(window[:, i]) for i in range(n))
            if progress:
                progress(t, (amps[self._i1], amps[self._i2]))
            if previous is not None and not overlapping:
                # Modes that stay at round-off (an unexcited antisymmetric mode) must not block the test.
                floor = 1e3 * self.atol
                change = max((abs(a - b) / max(abs(a), floor) for a, b in zip(amps, previous)
                              if max(abs(a), abs(b)) > floor), default=0.0)
                if change < steady_tol:
                    steady = True
                    break
            previous = amps
        periodic = self._is_periodic(window, samples_per_period, n, 1e3 * self.atol)
        msg = "steady" if steady else f"not steady after t = {t:g} (amplitudes still changing)"
        return result(amps, steady, periodic, False, msg)

    @staticmethod
    def _is_periodic(window: np.ndarray, m: int, n: int, floor: float, tol: float = 1e-6) -> bool:
        """Period-1 in the forcing over the window (as `Ode21Integrator._is_periodic`)."""
        if len(window) <= m:
            return False
        scale = np.max(np.abs(window[:, :n]))
        return bool(np.max(np.abs(window[m:, :n] - window[:-m, :n])) < max(tol * scale, floor))
