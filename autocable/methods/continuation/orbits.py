"""A stable periodic orbit of the amplitude equations found by integration: the start of a cycle
branch that no Hopf point reaches.

Why. Periodic solutions of the AME (periodic in a1, a2: quasi-periodic motions of the cable) whose
family passes through no Hopf point of the continued equilibria within a figure's range cannot be
started by `continue_cycles`: Fig. 8's P (U = 1.3, where every equilibrium of I is unstable), Fig.
10's P through Fig. 11's solution, and Fig. 4's backbone "for the islands" above U = 1 in the A2 = 0
AME (runs/island_1dof.toml; the 2-dof AME the Fig. 4 scenes use diverges there, docs/ordering.md). Integrating the AME at
one parameter value lands on such an orbit, and `compiled_cycles.continue_cycles_from_orbit`
continues it from there.
"""
from __future__ import annotations

from typing import Mapping

import numpy as np

from autocable.methods.continuation.problem import StartError
from autocable.methods.continuation.system import System

__all__ = ["periodic_orbit"]


def _crossings(t: np.ndarray, x: np.ndarray) -> tuple[int, np.ndarray, np.ndarray]:
    """The component with the largest swing over the samples, and the times and interpolated states
    of its upward crossings of its mid level (linear interpolation between samples)."""
    swing = x.max(axis=0) - x.min(axis=0)
    j = int(np.argmax(swing))
    g = x[:, j] - 0.5 * (x[:, j].max() + x[:, j].min())
    idx = np.nonzero((g[:-1] < 0) & (g[1:] >= 0))[0]
    w = (-g[idx] / (g[idx + 1] - g[idx]))[:, None]
    return j, t[idx] + w[:, 0] * (t[idx + 1] - t[idx]), (1 - w) * x[idx] + w * x[idx + 1]


def periodic_orbit(system: System, values: Mapping[str, float], x0, *, scale: float = 1.0,
                   chunks: int = 40, rtol: float = 1e-10, samples_per_period: int = 2000,
                   period_tol: float = 1e-6, seconds: float = 120.0,
                   max_steps: int = 5_000_000) -> tuple[np.ndarray, np.ndarray, float]:
    """One period of the stable periodic orbit reached by integrating x' = f(x; p) from ``x0``:
    (t, X, T), the states X at increasing times t covering [t0, t0 + T) about
    ``samples_per_period`` times, and the period T.

    Integrates with autocable's compiled DOP853 (`autocable.codegen.cintegrate`) in chunks of
    50 / (mean damping rate) time units, sampled coarsely; when the samples cross a Poincare
    section (the component with the largest swing, upwards through its mid level) at least four
    times, four more periods are integrated with ``samples_per_period`` samples each. The orbit is
    periodic when their return times agree to ``period_tol`` and the last two returns to the
    section are within ``period_tol`` x the orbit's swing (the norm of its max - min over a period);
    otherwise the next chunk goes on.

    Raises `StartError` with what happened instead: the orbit diverges or the integration fails,
    it settles on an equilibrium or dies down towards one (swing below 1e-6 of |x| + ``scale``;
    use an equilibria run with ``start = { integrate }``), or it is not periodic after ``chunks``
    chunks (a quasi-periodic or chaotic amplitude motion). Budget: ``seconds`` of wall time
    (`ContinuationSettings.orbit_seconds`), checked between the integrator's calls, and
    ``max_steps`` steps per call; spending either raises `BudgetExceeded`."""
    from autocable.codegen.cintegrate import compiled_integrator, sample_grid
    from autocable.errors import BudgetExceeded
    from autocable.methods.continuation.settings import Budget

    ci = compiled_integrator(f"{system.name}_flow", system.variables, system.parameter_names, system.rhs, None)
    p = system.parameter_vector(values)
    y = np.array(x0, dtype=float)
    start = np.round(y, 12).tolist()
    rate = abs(np.trace(system.jac(y, p))) / max(system.dimension, 1)
    chunk = 50.0 / rate if rate > 0 else 1000.0
    bound = 1e6 * (np.linalg.norm(y) + scale)
    atol = rtol * scale * 1e-3
    t = 0.0
    budget = Budget(f"integrating the AME from {start} to a periodic orbit", seconds,
                    hint="raise orbit_seconds in the run's steps, or start from other amplitudes")

    def run(t0: float, t1: float, dt: float):
        budget.check(at=f"(t = {t0:.6g})")
        r = ci.run(y, sample_grid(t0, t1, dt), p, rtol=rtol, atol=atol, bound=bound, n_bound=system.dimension,
                   max_steps=max_steps)
        if r.status == "step_budget":
            raise BudgetExceeded(f"integrating the AME from {start} to a periodic orbit took more than "
                                 f"{max_steps:,} steps between t = {t0:.6g} and {t1:.6g} (a stiff or "
                                 "fast-growing motion); start from other amplitudes")
        if not r.ok:
            raise StartError(f"integrating from {start}: the orbit diverges or the integration fails "
                             f"({r.status}) at t = {r.t_reached:.6g}; start elsewhere")
        return r.t, r.y

    for _ in range(int(chunks)):
        ts, xs = run(t, t + chunk, chunk / 20000)
        y, t = xs[-1].copy(), float(ts[-1])
        size = float(np.max(np.linalg.norm(xs, axis=1))) + scale
        if float(np.max(xs[-2000:].max(axis=0) - xs[-2000:].min(axis=0))) < 1e-9 * size:
            raise StartError(f"integrating from {start} settled on an equilibrium (amplitudes "
                             f"{', '.join(f'{v:.4g}' for v in system.amplitude_values(y))}): no periodic orbit "
                             f"here; continue it as an equilibrium (start = {{ integrate = [...] }})")
        _, cross, _ = _crossings(ts, xs)
        if len(cross) < 4:
            chunk *= 2.0          # fewer than three periods per chunk: look at longer stretches
            continue
        T_est = float(np.median(np.diff(cross)[-3:]))
        ts, xs = run(t, t + 4.5 * T_est, T_est / samples_per_period)
        y, t = xs[-1].copy(), float(ts[-1])
        _, cross, states = _crossings(ts, xs)
        if len(cross) < 4:
            continue
        periods = np.diff(cross)[-3:]
        T = float(periods[-1])
        # The returns are compared with the orbit's own swing, not with |x|: a slowly decaying
        # spiral into an equilibrium also returns with a steady period, but each return is a fixed
        # fraction of its (shrinking) swing away from the last.
        last = (ts >= cross[-2]) & (ts <= cross[-1])
        swing = float(np.linalg.norm(xs[last].max(axis=0) - xs[last].min(axis=0)))
        if swing < 1e-6 * size:
            raise StartError(f"integrating from {start}: the motion dies down to an equilibrium (its swing "
                             f"{swing:.3g} against |x| {size:.3g}): no periodic orbit here; continue it as an "
                             f"equilibrium (start = {{ integrate = [...] }})")
        if (np.max(np.abs(periods / T - 1.0)) <= period_tol
                and float(np.linalg.norm(states[-1] - states[-2])) <= period_tol * swing):
            keep = (ts >= cross[-2]) & (ts < cross[-2] + T)
            return ts[keep].copy(), xs[keep].copy(), T
    a = system.amplitude_values(y)
    raise StartError(f"integrating from {start}: no periodic orbit by t = {t:.6g} (amplitudes now "
                     f"{', '.join(f'{v:.4g}' for v in a)}; the return times to the section do not repeat "
                     f"to {period_tol:g}): the amplitude motion may be quasi-periodic; start elsewhere")
