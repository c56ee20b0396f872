"""Every equilibrium of the AME (24) at one parameter point that Newton reaches from a fixed grid of
starts: the start of a branch that no labelled point leads to (an isola, like Fig. 4's looped
island, or a disconnected branch, like Fig. 7's II), found without a start tuned to one model.

Why Newton and not integration: an isola's stable part can have a small basin (integrating the
sample's AME at Fig. 4a's U* = 0.85 from 80 starts never reaches the island; Newton from this grid
does), and a start that goes round a cycle costs an integration's whole budget. Newton converges
to unstable equilibria too; each is returned with its stability (the eigenvalues of the exact
Jacobian), and the caller picks.

The grid is in the Cartesian state (r_k, s_k) = a_k (cos g_k, sin g_k): amplitudes a1 on a geometric
grid scaled by the scene's state scale, a2 from zero up, and phases around the circle, so the
result does not depend on the model beyond that scale. It is deterministic: the same system,
parameters and scale give the same list."""
from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import Mapping

import numpy as np

from autocable.methods.continuation.equilibrium_analysis import equilibrium_near
from autocable.methods.continuation.system import System

__all__ = ["Equilibrium", "find_equilibria", "search_grid"]

#: a1 of the grid, in units of the state scale; a2 as a fraction of a1; phases (rad)
A1_FACTORS = (0.04, 0.1, 0.25, 0.5, 0.8, 1.2, 2.0, 4.0)
A2_FRACTIONS = (0.0, 0.05, 0.2, 0.6, 1.2)
PHASES1 = tuple(k * math.pi / 4 for k in range(8))
PHASES2 = tuple(k * math.pi / 4 for k in range(4))


@dataclass(frozen=True)
class Equilibrium:
    """One equilibrium: its state, modal amplitudes, whether it is stable, the residual |f|."""

    state: tuple[float, ...]
    amplitudes: tuple[float, ...]
    stable: bool
    residual: float


def search_grid(dimension: int, scale: float) -> list[np.ndarray]:
    """The starts: 8 a1 x 8 phases, each with a2 = 0 and with 4 a2 x 4 phases: 1088 starts for two
    modes; one mode (``dimension`` 2) takes the 64 a1 x phase starts."""
    starts = []
    n_modes = dimension // 2
    for f1, g1 in itertools.product(A1_FACTORS, PHASES1):
        a1 = f1 * scale
        first = [a1 * math.cos(g1), a1 * math.sin(g1)]
        if n_modes == 1:
            starts.append(np.array(first))
            continue
        for frac in A2_FRACTIONS:
            for g2 in (PHASES2 if frac else (0.0,)):
                a2 = frac * a1
                y = np.zeros(dimension)
                y[:2] = first
                y[2:4] = (a2 * math.cos(g2), a2 * math.sin(g2))
                starts.append(y)
    return starts


def find_equilibria(system: System, values: Mapping[str, float], *, scale: float, rhs=None,
                    max_amplitude: float = 0.1) -> list[Equilibrium]:
    """The distinct equilibria Newton converges to from `search_grid`, largest a1 first.

    ``rhs``: an object with ``f(x, p)`` and ``jac(x, p)`` (the system's compiled kernel; default
    the system itself). Each converged start is polished by `equilibrium_near` on the exact field;
    two are the same equilibrium when their states agree to 1e-6 of (|x| + scale). Equilibria with
    an amplitude above ``max_amplitude`` (outside the cubic model's range) are left out."""
    from scipy.optimize import root

    rhs = system if rhs is None else rhs
    p = system.parameter_vector(values)
    found: list[Equilibrium] = []
    for y0 in search_grid(system.dimension, scale):
        sol = root(lambda x: rhs.f(x, p), y0, jac=lambda x: rhs.jac(x, p), method="hybr",
                   options={"xtol": 1e-12})
        if not sol.success or not np.all(np.isfinite(sol.x)):
            continue
        x, ok, res = equilibrium_near(system, sol.x, p, scale=scale)
        if not ok:
            continue
        amps = tuple(float(a) for a in system.amplitude_values(x))
        if max(amps, default=0.0) > max_amplitude:
            continue
        tol = 1e-6 * (float(np.linalg.norm(x)) + scale)
        if any(float(np.linalg.norm(np.asarray(e.state) - x)) <= tol for e in found):
            continue
        stable = bool(np.max(np.linalg.eigvals(system.jac(x, p)).real) < 0)
        found.append(Equilibrium(tuple(float(v) for v in x), amps, stable, float(res)))
    found.sort(key=lambda e: (-e.amplitudes[0], e.state))
    return found
