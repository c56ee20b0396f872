"""Autonomous shooting: a limit cycle of y' = F(y) with its period as an unknown.

What it solves. An autonomous system (eq. (21) at eta* = 0, where every forcing term vanishes;
`ode21.is_autonomous`) has no period imposed from outside: a self-excited cycle (galloping) repeats
with its own period T, and any point of it is as good as any other. The unknowns are the state y
and T; the equations are

    phi_T(y) - y = 0                       (n equations: the orbit closes after T)
    y_k = 0                                (the phase condition: y starts on the section y_k = 0)

so that y_k is removed from the unknowns and T takes its place: n equations in n unknowns. Newton's
matrix is the monodromy M = Phi(T) minus I with column k replaced by dphi_T/dT = F(phi_T(y))
(Keller's method with the simplest phase condition, a Poincare section; Seydel, "Practical
Bifurcation and Stability Analysis", Sect. 7.1). It converges quadratically from a point near
the cycle and a period near its own, which the caller takes from a transient (`cycles.own_cycles`).

Floquet multipliers. M always has the multiplier 1 with eigenvector F(y) (a shift along the
cycle is again the cycle), whatever the stability: it is identified (the multiplier nearest 1, its
eigenvector checked against F) and left out of the stability verdict, which the others decide
(`split_multipliers`).

Generic: `newton_cycle` takes the flow and the vector field as functions, so that the same code
serves eq. (21) (`shooting.ShootingSolver.cycle`) and a closed-form check (the van der Pol
oscillator, tests/test_autonomous.py).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np


@dataclass(frozen=True, eq=False)
class Cycle:
    """A closed orbit found by `newton_cycle`."""

    state0: np.ndarray          # y on the section y_k = 0
    period: float
    monodromy: np.ndarray       # Phi(T) at state0
    residual: float             # |phi_T(y) - y| / max(|y|, floor)
    iterations: int
    converged: bool


def newton_cycle(flow: Callable, rhs: Callable, y0, T0: float, section: int, *, tol: float = 1e-10,
                 max_iter: int = 12, floor: float = 1e-12) -> Cycle:
    """Newton for a cycle through the section y[``section``] = 0 from (``y0``, ``T0``).

    ``flow(y, T)`` returns (phi_T(y), Phi(T)) or None (the integration failed or left its bound);
    ``rhs(y)`` returns F(y). The start is put on the section (y[section] = 0). Steps are damped
    (halved up to 5 times) when the full step does not reduce the residual; a period that would
    turn non-positive is halved towards zero instead."""
    y = np.array(y0, dtype=float)
    y[section] = 0.0
    T = float(T0)
    n = len(y)
    free = [i for i in range(n) if i != section]

    def residual(y_, got_):
        return float(np.linalg.norm(got_[0] - y_)) / max(float(np.linalg.norm(y_)), floor)

    got = flow(y, T)
    if got is None:
        return Cycle(y, T, np.full((n, n), np.nan), math.inf, 0, False)
    res = residual(y, got)
    for it in range(max_iter + 1):
        yT, M = got
        if res < tol:
            return Cycle(y, T, M, res, it, True)
        if it == max_iter:
            break
        A = M - np.eye(n)
        A[:, section] = rhs(yT)
        try:
            step = np.linalg.solve(A, yT - y)
        except np.linalg.LinAlgError:
            break
        lam = 1.0
        for _ in range(6):
            dy = np.zeros(n)
            dy[free] = step[free]
            y_new, T_new = y - lam * dy, T - lam * step[section]
            if T_new <= 0:
                lam *= 0.5
                continue
            got_new = flow(y_new, T_new)
            if got_new is not None:
                res_new = residual(y_new, got_new)
                if res_new < res:
                    break
            lam *= 0.5
        else:
            break
        y, T, got, res = y_new, T_new, got_new, res_new
    return Cycle(y, T, got[1], res, it, False)


def split_multipliers(M: np.ndarray, F: np.ndarray) -> tuple[complex, np.ndarray, float]:
    """(the trivial multiplier, the others sorted by modulus largest first, how far M F is from F
    relative to |F|): the trivial one is the eigenvalue nearest 1 (on a cycle M F(y0) = F(y0), so it
    is 1 to the accuracy of the monodromy; the third value checks that F is its eigenvector)."""
    mu = np.linalg.eigvals(M).astype(complex)
    i = int(np.argmin(np.abs(mu - 1.0)))
    rest = np.delete(mu, i)
    order = np.lexsort((-np.angle(rest), -np.abs(rest)))
    F = np.asarray(F, float)
    check = float(np.linalg.norm(M @ F - F)) / max(float(np.linalg.norm(F)), 1e-300)
    return complex(mu[i]), rest[order], check
