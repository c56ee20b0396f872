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
from autocable.methods.continuation.monomials import Monomials
from autocable.methods.continuation.system import System

__all__ = ["Equilibrium", "Monomials", "find_equilibria", "search_grid"]

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


def _newton_all(system: System, X: np.ndarray, p, scale: float, bound: float, iters: int = 20) -> np.ndarray:
    """Damped Newton from every row of ``X`` at once (`System.f_many`, `jac_many`, one batched solve
    per step): the rows that converged (step below 1e-12 of |x| + scale), the others dropped (a
    singular Jacobian, a non-finite or far state: beyond ``bound``). ``iters``: 20 steps, because
    on the 184 search points of the figure scenes on the sample and three calibration candidates
    40 found the same stable equilibria at 1.4 times the cost. A polynomial field is evaluated
    by `Monomials`."""
    system = Monomials.of(system) or system
    X = np.array(X, float)
    with np.errstate(all="ignore"):
        F = system.f_many(X, p)            # f at X, kept from the accepted trial of each step
    live = np.ones(len(X), bool)
    done = np.zeros(len(X), bool)
    best = np.full(len(X), np.inf)         # the smallest |f| so far, and the steps since it fell by 10 %
    stall = np.zeros(len(X), int)
    for _ in range(iters):
        idx = np.flatnonzero(live & ~done)
        if not idx.size:
            break
        Xa, Fa = X[idx], F[idx]
        J = system.jac_many(Xa, p)
        with np.errstate(all="ignore"):
            det = np.linalg.det(J)
        ok = np.isfinite(det) & (det != 0) & np.all(np.isfinite(Fa), axis=1)
        step = np.zeros_like(Xa)
        if ok.any():
            step[ok] = np.linalg.solve(J[ok], Fa[ok][..., None])[..., 0]
        f0 = np.linalg.norm(Fa, axis=1)
        # a start wandering without getting closer to a root (six steps without |f| falling by
        # 10 %) is dropped: it costs most of the search and converges nowhere
        fell = f0 < 0.9 * best[idx]
        best[idx] = np.where(fell, f0, best[idx])
        stall[idx] = np.where(fell, 0, stall[idx] + 1)
        ok &= stall[idx] < 6
        # damped: a step that does not reduce |f| is halved (up to 6 times), which widens each
        # root's basin (without it the middle response of the Duffing test is missed)
        lam = np.ones(len(Xa))
        Fn = Fa.copy()
        check = np.flatnonzero(ok)
        for _ in range(6):
            if not check.size:
                break
            with np.errstate(all="ignore"):
                trial = system.f_many(Xa[check] - lam[check, None] * step[check], p)
            Fn[check] = trial
            worse = ~(np.linalg.norm(trial, axis=1) < f0[check]) & (f0[check] > 0)
            check = check[worse]
            lam[check] *= 0.5
        if check.size:                     # still not lower after the last halving: f where it ends
            with np.errstate(all="ignore"):
                Fn[check] = system.f_many(Xa[check] - lam[check, None] * step[check], p)
        Xn = Xa - lam[:, None] * step
        size = np.linalg.norm(Xn, axis=1)
        bad = ~ok | ~np.all(np.isfinite(Xn), axis=1) | (size > bound)
        live[idx[bad]] = False
        X[idx], F[idx] = Xn, Fn
        done[idx[~bad & (np.linalg.norm(lam[:, None] * step, axis=1) <= 1e-12 * (size + scale))]] = True
    return X[done & live]


def find_equilibria(system: System, values: Mapping[str, float], *, scale: float,
                    max_amplitude: float = 0.1) -> list[Equilibrium]:
    """The distinct equilibria Newton converges to from `search_grid`, largest a1 first.

    Newton runs from all the starts at once (`_newton_all`); each distinct converged state is
    polished by `equilibrium_near` on the exact field and its stability taken from the
    eigenvalues. Two states are the same equilibrium when they agree to 1e-6 of (|x| + scale).
    Equilibria with an amplitude above ``max_amplitude`` (outside the cubic model's range) are
    left out. (Against scipy's hybrid Powell method from the same grid, start by start, on the
    search points of Figs. 4a, 4c, 7, 9 and 10 and on a restrained-twist candidate at Fig. 4a's
    setting: the same stable equilibria everywhere, a few more unstable ones, and the same
    branches in every figure scene to 1e-14; about 0.3 s a search point against 0.35-0.65 s.)"""
    p = system.parameter_vector(values)
    starts = np.array(search_grid(system.dimension, scale))
    converged = _newton_all(system, starts, p, scale, bound=10.0 * max_amplitude * math.sqrt(system.dimension))
    found: list[Equilibrium] = []

    def seen(x) -> bool:
        return any(float(np.linalg.norm(np.asarray(e.state) - x)) <= 1e-6 * (float(np.linalg.norm(x)) + scale)
                   for e in found)

    for x0 in converged:
        if seen(x0):                       # most starts converge to a root already polished
            continue
        x, ok, res = equilibrium_near(system, x0, p, scale=scale)
        amps = tuple(float(a) for a in system.amplitude_values(x))
        if not ok or max(amps, default=0.0) > max_amplitude or seen(x):
            continue
        stable = bool(np.max(np.linalg.eigvals(system.jac(x, p)).real) < 0)
        found.append(Equilibrium(tuple(float(v) for v in x), amps, stable, float(res)))
    found.sort(key=lambda e: (-e.amplitudes[0], e.state))
    return found
