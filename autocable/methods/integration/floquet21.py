"""Floquet multipliers of a period-1 response of eq. (21): stability of (21) itself, not of the AME.

Eq. (21) is forced by f = sin(Omega t) (Sect. 4, docs/model.md, C2), so a response repeating with the forcing
period T = 2 pi / Omega is a fixed point of the stroboscopic map over one period. Its stability is
that of the monodromy matrix M = Phi(T), the fundamental matrix of the variational equations

    y' = F(t, y),      Phi' = dF/dy (t, y(t)) Phi,      y(0) = state0,  Phi(0) = I,

integrated over one forcing period from forcing phase 0 (t = 0). F is the first-order right-hand side
of eq. (21) from `autocable.model.symbolic` and dF/dy its exact sympy Jacobian. State order
(q1, q2, q1', q2'), the order of `Ode21Integrator`'s ``final_state``; since the integrator stops at
whole forcing periods, its ``final_state`` is a valid ``state0``.

The eigenvalues mu of M are the Floquet multipliers. Eq. (21) is non-autonomous, so there is no
trivial multiplier 1: a period-1 response is asymptotically stable when every |mu| < 1.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from autocable.model.symbolic import PARAMETERS, STATE, T, first_order_rhs, parameter_values

#: `Floquet.stable` means max |mu| < 1 - STABILITY_MARGIN. The monodromy is integrated to rtol ~1e-10,
#: so its multipliers carry errors ~1e-9 (the linear test checks 1e-9); a margin of 1e-6 keeps a
#: neutral multiplier (a fold, a symmetry) from being called stable or unstable on integration noise,
#: and is four orders below the damping decrement 1 - exp(-2 pi xi_s) = 0.025 of the sample cable, so
#: it moves a detected stability boundary by a negligible amount.
STABILITY_MARGIN = 1e-6


@dataclass(frozen=True, eq=False)
class Floquet:
    """Multipliers of the monodromy of eq. (21) about one period-1 response."""

    multipliers: np.ndarray    # complex, (4,), sorted by modulus, largest first
    max_modulus: float
    stable: bool               # max_modulus < 1 - STABILITY_MARGIN
    monodromy: np.ndarray      # (4, 4), Phi(T) in the state order (q1, q2, q1', q2')
    period: float              # T = 2 pi / Omega
    residual: float            # |y(T) - state0| / |state0|: how periodic state0 really is
    final_state: tuple = ()    # y(T)
    seconds: float = 0.0


class Variational21:
    """Numeric right-hand side of eq. (21) and of its variational equations, built once per ODE.

    Lambdified from the same sympy expressions the compiled integrators use (no second hand-written
    model). Reuse one instance across many multiplier computations (a continuation).
    """

    def __init__(self, ode):
        import sympy as sp
        rhs = first_order_rhs(ode)
        jac = sp.Matrix(rhs).jacobian(sp.Matrix(STATE))
        args = (T, STATE, PARAMETERS)
        self.ode = ode
        self._f = sp.lambdify(args, list(rhs), "numpy", cse=True)
        self._jac = sp.lambdify(args, jac, "numpy", cse=True)

    @staticmethod
    def parameters(U: float, eta: float, Omega: float) -> tuple:
        vals = parameter_values(U, eta, Omega)
        return tuple(vals[p.name] for p in PARAMETERS)

    def rhs(self, t: float, y, p) -> np.ndarray:
        return np.array(self._f(t, y, p), dtype=float)

    def jacobian(self, t: float, y, p) -> np.ndarray:
        return np.array(self._jac(t, y, p), dtype=float)

    def _variational(self, t, z, p):
        y = z[:4]
        phi = z[4:].reshape(4, 4)
        out = np.empty(20)
        out[:4] = self._f(t, y, p)
        out[4:] = (np.array(self._jac(t, y, p), dtype=float) @ phi).ravel()
        return out

    def monodromy(self, U: float, eta: float, Omega: float, state0, *, rtol: float = 1e-10,
                  t0: float = 0.0):
        """(Phi(t0 + T), y(t0 + T)) over one forcing period T = 2 pi / Omega from y(t0) = state0."""
        from scipy.integrate import solve_ivp
        period = 2 * math.pi / Omega
        p = self.parameters(U, eta, Omega)
        y0 = np.asarray(state0, dtype=float)
        z0 = np.concatenate([y0, np.eye(4).ravel()])
        # Absolute tolerances scaled to each block: the state may be ~1e-4 while Phi is O(1).
        scale = max(float(np.max(np.abs(y0))), 1e-12)
        atol = np.concatenate([np.full(4, rtol * scale * 1e-2), np.full(16, rtol * 1e-2)])
        sol = solve_ivp(self._variational, (t0, t0 + period), z0, method="DOP853", args=(p,),
                        rtol=rtol, atol=atol)
        if not sol.success:
            raise RuntimeError(f"variational integration of eq. (21) failed: {sol.message}")
        z = sol.y[:, -1]
        return z[4:].reshape(4, 4), z[:4]


def multipliers_of(monodromy: np.ndarray) -> np.ndarray:
    """Eigenvalues of a monodromy matrix, sorted by modulus, largest first (ties: by angle)."""
    mu = np.linalg.eigvals(monodromy).astype(complex)
    order = np.lexsort((-np.angle(mu), -np.abs(mu)))
    return mu[order]


def floquet_multipliers(derivation, U: float, eta: float, sigma: float, state0, *,
                        rtol: float = 1e-10, system: Variational21 | None = None) -> Floquet:
    """Floquet multipliers of eq. (21) at (U*, eta*, Omega = omega1 + sigma) about the period-1
    response through ``state0`` = (q1, q2, q1', q2') at forcing phase 0.

    ``derivation`` is a `Derivation` (or its `TwoModeODE`). Pass ``system`` (a `Variational21` of
    the same ODE) to reuse the lambdified equations across calls.
    """
    start = time.perf_counter()
    ode = getattr(derivation, "ode", derivation)
    Omega = ode.omega1 + sigma
    if not Omega > 0:
        raise ValueError(f"sigma = {sigma} gives a non-positive forcing frequency Omega = {Omega}")
    if system is None:
        system = Variational21(ode)
    elif system.ode is not ode and system.ode != ode:
        raise ValueError("the Variational21 passed as `system` was built for another ODE")
    M, yT = system.monodromy(U, eta, Omega, state0, rtol=rtol)
    mu = multipliers_of(M)
    y0 = np.asarray(state0, dtype=float)
    residual = float(np.linalg.norm(yT - y0) / max(np.linalg.norm(y0), 1e-300))
    top = float(np.abs(mu[0]))
    return Floquet(multipliers=mu, max_modulus=top, stable=bool(top < 1.0 - STABILITY_MARGIN),
                   monodromy=M, period=2 * math.pi / Omega, residual=residual,
                   final_state=tuple(float(v) for v in yT), seconds=time.perf_counter() - start)


@dataclass(frozen=True, eq=False)
class ShootingResult:
    """A period-1 response of eq. (21) found by Newton's method on the stroboscopic map."""

    state0: np.ndarray         # (q1, q2, q1', q2') at forcing phase 0
    converged: bool
    iterations: int
    residual: float            # |y(T) - state0| / |state0| at the returned state0
    monodromy: np.ndarray      # at the returned state0 (the Newton Jacobian is M - I)
    message: str


def shoot_period1(system: Variational21, U: float, eta: float, Omega: float, guess, *,
                  rtol: float = 1e-10, tol: float = 1e-11, max_iter: int = 25) -> ShootingResult:
    """Newton on P(y) = phi_T(y) - y, P' = M - I: converges to the period-1 response nearest
    ``guess`` whatever its stability (integration only finds stable ones). ``tol`` is relative to
    |y|; the residual floor is set by the integration's ``rtol``."""
    y = np.asarray(guess, dtype=float).copy()
    M = np.eye(4)
    res = math.inf
    for it in range(1, max_iter + 1):
        M, yT = system.monodromy(U, eta, Omega, y, rtol=rtol)
        r = yT - y
        res = float(np.linalg.norm(r) / max(np.linalg.norm(y), 1e-300))
        if not np.all(np.isfinite(r)):
            return ShootingResult(y, False, it, math.inf, M, "the orbit left the finite range")
        if res < tol:
            return ShootingResult(y, True, it, res, M, "converged")
        try:
            y = y - np.linalg.solve(M - np.eye(4), r)
        except np.linalg.LinAlgError:
            return ShootingResult(y, False, it, res, M, "a multiplier equals 1 (fold): M - I singular")
    return ShootingResult(y, False, max_iter, res, M, f"no convergence in {max_iter} Newton steps")
