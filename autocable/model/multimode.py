"""Eq. (21) with N in-plane and N' out-of-plane modes, as plain data: the "two modes suffice?" check.

The same convention as `equations.TwoModeODE`, for every mode e (in-plane modes v1, v2, ... by
frequency, then out-of-plane modes w1, w2, ...):

    x_e'' + sum_j c_j * U**u_j * (eta f)**a_j (eta f')**b_j (eta f'')**d_j * M_j(x, x') = 0,

x = (v1, ..., w1, ...) the modal coordinates, f = sin(Omega t), primes d/dt* (eq. 17). Each term is
named by (equation, monomial), e.g. ("v2", "v1dot*eta*fdot"). With one mode per plane the table is
eq. (21) itself (tests compare every coefficient with `TwoModeODE`).

`first_order_rhs_n` writes the first-order system in sympy with the parameters of `symbolic.py`
(U, eta, Omega, wind, Uinv), so `symbolic.parameter_values` sets them.
"""
from __future__ import annotations

import hashlib
import json
from dataclasses import asdict, dataclass, field

import numpy as np
import sympy as sp

from autocable.model.equations import FORCING_NAMES
from autocable.model.modes_n import ModeInfo
from autocable.model.symbolic import ETA, OMEGA, T, U, UINV, WIND


@dataclass(frozen=True)
class NTerm:
    """One term of the N-mode equations, left-hand-side convention of `equations.Term`."""

    equation: int              # index of the mode whose equation holds the term
    powers: tuple              # exponents of (x_1..x_n, x_1'..x_n')
    forcing: tuple             # exponents of eta f, eta f', eta f''
    u_power: int
    coefficient: float
    origin: str                # linear, damping, structural, inertia, aerodynamic

    def factor(self, U: float, eta: float, f: float, fdot: float, fddot: float) -> float:
        """coefficient * U**u * forcing factors; zero for aerodynamic terms at U = 0 (no wind)."""
        if self.origin == "aerodynamic" and U == 0.0:
            return 0.0
        value = self.coefficient * U ** self.u_power
        for base, p in zip((eta * f, eta * fdot, eta * fddot), self.forcing):
            if p:
                value *= base ** p
        return value


def _monomial(state_names, powers, forcing, u_power) -> str:
    parts = [n if p == 1 else f"{n}^{p}" for n, p in zip(state_names, powers) if p]
    eta = sum(forcing)
    if eta:
        parts.append("eta" if eta == 1 else f"eta^{eta}")
    parts += [n if p == 1 else f"{n}^{p}" for n, p in zip(FORCING_NAMES, forcing) if p]
    if u_power > 0:
        parts.append("U" if u_power == 1 else f"U^{u_power}")
    text = "*".join(parts) or "1"
    if u_power < 0:
        text += "/U" if u_power == -1 else f"/U^{-u_power}"
    return text


@dataclass(frozen=True)
class NModeODE:
    """The N-mode Galerkin model: `modes` (in-plane first), `terms`, modal damping ratio `xi_s`."""

    modes: tuple[ModeInfo, ...]
    terms: tuple[NTerm, ...]
    xi_s: float
    provenance: dict = field(default_factory=dict, compare=False, hash=False)

    @property
    def n(self) -> int:
        return len(self.modes)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(m.name for m in self.modes)

    @property
    def state_names(self) -> tuple[str, ...]:
        """Displacements then velocities: ("v1", ..., "w1", ..., "v1dot", ..., "w1dot", ...)."""
        return self.names + tuple(f"{n}dot" for n in self.names)

    @property
    def omegas(self) -> tuple[float, ...]:
        return tuple(m.omega for m in self.modes)

    def index(self, name: str) -> int:
        return self.names.index(name)

    def key(self, term: NTerm) -> tuple[str, str]:
        """(equation, monomial): the name of a coefficient."""
        return (self.names[term.equation],
                _monomial(self.state_names, term.powers, term.forcing, term.u_power))

    def table(self) -> dict[tuple[str, str], float]:
        """Every coefficient by (equation, monomial)."""
        out: dict[tuple[str, str], float] = {}
        for t in self.terms:
            k = self.key(t)
            out[k] = out.get(k, 0.0) + t.coefficient
        return out

    def accelerations(self, state, U: float, eta: float, f: float, fdot: float, fddot: float):
        """x'' at one state (x, x'): a slow, exact reference evaluation."""
        state = np.asarray(state, dtype=float)
        acc = np.zeros(self.n)
        for t in self.terms:
            m = t.factor(U, eta, f, fdot, fddot)
            if m == 0.0:
                continue
            for x, p in zip(state, t.powers):
                if p:
                    m *= x ** p
            acc[t.equation] -= m
        return acc

    def linear_matrix(self, U: float) -> np.ndarray:
        """Jacobian of the first-order form (x, x') at rest with eta = 0."""
        n = self.n
        A = np.zeros((2 * n, 2 * n))
        A[:n, n:] = np.eye(n)
        for t in self.terms:
            if sum(t.forcing) or sum(t.powers) != 1:
                continue
            A[n + t.equation, t.powers.index(1)] -= t.factor(U, 0.0, 0.0, 0.0, 0.0)
        return A

    def to_dict(self) -> dict:
        return {"modes": [asdict(m) for m in self.modes], "xi_s": self.xi_s,
                "provenance": self.provenance, "terms": [asdict(t) for t in self.terms]}

    @classmethod
    def from_dict(cls, data: dict) -> "NModeODE":
        modes = tuple(ModeInfo(**{**m, "twist": tuple(m["twist"])}) for m in data["modes"])
        terms = tuple(NTerm(int(t["equation"]), tuple(t["powers"]), tuple(t["forcing"]), int(t["u_power"]),
                            float(t["coefficient"]), t["origin"]) for t in data["terms"])
        return cls(modes=modes, terms=terms, xi_s=float(data["xi_s"]),
                   provenance=dict(data.get("provenance", {})))

    def content_hash(self) -> str:
        payload = json.dumps([[asdict(m) for m in self.modes], self.xi_s,
                              [asdict(t) for t in self.terms]], sort_keys=True)
        return hashlib.sha256(payload.encode()).hexdigest()[:12]


def state_symbols(ode: NModeODE) -> tuple[sp.Symbol, ...]:
    """(x_1..x_n, x_1'..x_n') as sympy symbols named by `NModeODE.state_names`."""
    return tuple(sp.Symbol(n, real=True) for n in ode.state_names)


def first_order_rhs_n(ode: NModeODE) -> tuple[sp.Expr, ...]:
    """(x', x'') of the N-mode equations with f = sin(Omega t); parameters as in `symbolic.py`."""
    X = state_symbols(ode)
    n = ode.n
    f = sp.sin(OMEGA * T)
    forcing = (ETA * f, ETA * OMEGA * sp.cos(OMEGA * T), -ETA * OMEGA**2 * f)
    acc = [[] for _ in range(n)]
    for term in ode.terms:
        m = sp.Float(-term.coefficient, 17)
        for x, p in zip(X, term.powers):
            if p:
                m *= x**p
        for x, p in zip(forcing, term.forcing):
            if p:
                m *= x**p
        if term.origin == "aerodynamic":
            m *= WIND * (U**term.u_power if term.u_power >= 0 else UINV ** (-term.u_power))
        elif term.u_power:
            m *= U**term.u_power
        acc[term.equation].append(m)
    return tuple(X[n:]) + tuple(sp.expand(sp.Add(*a)) for a in acc)
