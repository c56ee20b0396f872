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
from autocable.methods.integration.ode21 import DEFAULT_Q0, Ode21Integrator

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


def sweep(integrator, parameter: str, values, fixed: dict, *, directions=("up", "down"),
          q0=DEFAULT_Q0, progress=None, **options) -> tuple[SweepPoint, ...]:
    """Steady responses of ``integrator`` at ``values`` of ``parameter`` (one of sigma, U, eta),
    the other two from ``fixed``; ``options`` go to ``simulate`` (e.g. max_time)."""
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
    for direction in directions:
        if direction not in ("up", "down"):
            raise ValueError(f"sweep direction must be 'up' or 'down', got {direction!r}")
        carried = None
        for value in (values if direction == "up" else values[::-1]):
            point = dict(base, **{parameter: value})
            try:
                if is_ode21:
                    start = q0 if carried is None else tuple(c + d for c, d in zip(carried, q0))
                    r = integrator.simulate(point["U"], point["eta"], point["sigma"], start, **options)
                    ok = r.steady and math.isfinite(r.a1)
                    # simulate takes (q1, q1', q2, q2'); its final state is (q1, q2, q1', q2').
                    carried = (r.final_state[0], r.final_state[2], r.final_state[1], r.final_state[3]) if ok else None
                else:
                    if carried is None:
                        r = integrator.simulate(point["U"], point["eta"], point["sigma"], q0, **options)
                    else:
                        r = integrator.simulate(point["U"], point["eta"], point["sigma"], y0=carried, **options)
                    ok = r.steady and math.isfinite(r.a1)
                    carried = tuple(r.final_state) if ok else None
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
                                  wall_seconds=r.wall_seconds, period=getattr(r, "period", math.nan),
                                  a1_error=getattr(r, "a1_error", math.nan),
                                  a2_error=getattr(r, "a2_error", math.nan)))
            if progress:
                progress(out[-1])
    return tuple(out)


def _failed_point(parameter, value, direction, method, why: str) -> SweepPoint:
    """A point whose integration failed: no amplitude (nan), not steady, the reason as its message."""
    nan = math.nan
    return SweepPoint(parameter=parameter, value=value, direction=direction, method=method, a1=nan, a2=nan,
                      a1_min=nan, a1_max=nan, a2_min=nan, a2_max=nan, steady=False, periodic=False,
                      message="integration failed: " + " ".join(why.split()), wall_seconds=nan)


def to_rows(points) -> list[dict]:
    """Plain rows (for CSV) of a sweep."""
    return [dict(p.__dict__) for p in points]
