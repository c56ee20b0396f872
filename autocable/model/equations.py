"""The two-mode equations of motion, eq. (21), as plain data.

Eq. (21) of Luongo & Zulli is written here in one convention, for both equations k = 1, 2:

    q_k'' + sum_j  c_j * U**u_j * (eta f)**a_j (eta f')**b_j (eta f'')**d_j * M_j(q1, q2, q1', q2') = 0

where primes are derivatives with respect to the paper's nondimensional time t* = omega t (eq. 17),
U is the nondimensional wind speed U* = U/U_c and eta the nondimensional support amplitude eta* = eta/l
(eq. 18), f(t) = sin(Omega t). Every term of Appendix A (eqs. 26-27) is one `Term`: the linear
stiffness omega_k^2 q_k and the modal damping 2 xi_s omega_k q_k' included. The forcing terms
Gamma_{1,23}, Gamma_{2,22}, which the paper writes on the right-hand side, are stored here on the
left-hand side (M_j = 1) with the opposite sign; `Term.appendix_value` gives them in the paper's sign.

Aerodynamic terms exist only when there is wind: at U = 0 they are absent, not singular (their 1/U
powers come from expanding the quasi-steady load for cable velocities small against the wind).
"""
from __future__ import annotations

import hashlib
import json
import math
from dataclasses import asdict, dataclass, field, replace

import numpy as np

#: Names of the four state variables, in the order of `Term.powers`.
STATE_NAMES = ("q1", "q2", "q1dot", "q2dot")
#: Names of the three forcing factors, each multiplied by eta, in the order of `Term.forcing`.
FORCING_NAMES = ("f", "fdot", "fddot")

ORIGINS = ("linear", "damping", "structural", "inertia", "aerodynamic")


def monomial_name(powers, forcing, u_power) -> str:
    """A readable ASCII name for a term that has no Appendix A name, e.g. ``q1dot^2*eta*fdot/U``."""
    parts = []
    for name, p in zip(STATE_NAMES, powers):
        if p:
            parts.append(name if p == 1 else f"{name}^{p}")
    eta = sum(forcing)
    if eta:
        parts.append("eta" if eta == 1 else f"eta^{eta}")
    for name, p in zip(FORCING_NAMES, forcing):
        if p:
            parts.append(name if p == 1 else f"{name}^{p}")
    if u_power > 0:
        parts.append("U" if u_power == 1 else f"U^{u_power}")
    text = "*".join(parts) or "1"
    if u_power < 0:
        text += "/U" if u_power == -1 else f"/U^{-u_power}"
    return text


@dataclass(frozen=True)
class Term:
    """One term of eq. (21) in the left-hand-side convention of this module."""

    equation: int                         # 1: in-plane q1, 2: out-of-plane q2
    powers: tuple[int, int, int, int]     # exponents of q1, q2, q1', q2'
    forcing: tuple[int, int, int]         # exponents of eta f, eta f', eta f''
    u_power: int                          # exponent of U (negative for the 1/U terms)
    coefficient: float
    origin: str                           # one of ORIGINS
    name: str = ""                        # Appendix A name (ASCII), or "" if the paper has none

    @property
    def eta_power(self) -> int:
        return sum(self.forcing)

    @property
    def is_forcing(self) -> bool:
        """True for the terms of Gamma_{1,23}, Gamma_{2,22} (no state variable)."""
        return not any(self.powers)

    @property
    def appendix_value(self) -> float:
        """The coefficient in the paper's sign convention (forcing terms on the right-hand side)."""
        return -self.coefficient if self.is_forcing else self.coefficient

    @property
    def label(self) -> str:
        """The Appendix A name if there is one, else the monomial, prefixed by the equation."""
        return self.name or f"eq{self.equation}:{monomial_name(self.powers, self.forcing, self.u_power)}"

    def factor(self, U: float, eta: float, f: float, fdot: float, fddot: float) -> float:
        """coefficient * U**u * (eta f)**a (eta f')**b (eta f'')**d; zero for aerodynamic terms at U = 0."""
        if self.origin == "aerodynamic" and U == 0.0:
            return 0.0
        value = self.coefficient * U ** self.u_power
        for base, p in zip((eta * f, eta * fdot, eta * fddot), self.forcing):
            if p:
                value *= base ** p
        return value


@dataclass(frozen=True)
class TwoModeODE:
    """Eq. (21): two Galerkin modes, in-plane q1 and out-of-plane q2 (with its slaved twist).

    `terms` holds every term of both equations (Appendix A, eqs. 26-27); `omega1`, `omega2` are the
    nondimensional natural frequencies (eq. 17 units, omega2 = 1 by construction); `xi_s` the modal
    damping ratio; `provenance` says where the numbers came from (model hash, choices made).
    """

    terms: tuple[Term, ...]
    omega1: float
    omega2: float
    xi_s: float
    provenance: dict = field(default_factory=dict, compare=False, hash=False)
    #: The exact quasi-steady load (`autocable.model.exact_load.ExactLoad`) that replaces the cubic
    #: aerodynamic terms in the dynamics, or None (eq. 21 as the paper writes it). The aerodynamic
    #: terms stay in `terms`: they are the exact load's cubic Taylor expansion (its linearisation,
    #: Hopf points and first Lyapunov coefficients are theirs).
    exact_load: object = field(default=None, compare=False, hash=False)

    # -- views -------------------------------------------------------------------------------------
    def equation(self, k: int) -> tuple[Term, ...]:
        return tuple(t for t in self.terms if t.equation == k)

    def find(self, k: int, powers, forcing=(0, 0, 0), u_power: int | None = None) -> tuple[Term, ...]:
        """The terms of equation k with the given monomial and forcing (and U power if given)."""
        powers, forcing = tuple(powers), tuple(forcing)
        return tuple(t for t in self.equation(k)
                     if t.powers == powers and t.forcing == forcing
                     and (u_power is None or t.u_power == u_power))

    def coefficients(self) -> dict[str, float]:
        """Flat map label -> value in the paper's convention (Appendix A names where they exist)."""
        out: dict[str, float] = {}
        for t in self.terms:
            out[t.label] = t.appendix_value
        return out

    # -- numerics ------------------------------------------------------------------------------------
    def _accelerations(self, state, U: float, eta: float, f: float, fdot: float, fddot: float):
        state = np.asarray(state, dtype=float)
        acc = np.zeros(2)
        for t in self.terms:
            m = t.factor(U, eta, f, fdot, fddot)
            if m == 0.0:
                continue
            for x, p in zip(state, t.powers):
                if p:
                    m *= x ** p
            acc[t.equation - 1] -= m
        return acc

    def accelerations(self, state, U: float, eta: float, f: float, fdot: float, fddot: float):
        """(q1'', q2'') at one state (q1, q2, q1', q2'): a slow, exact reference evaluation (with the
        exact load in place of the cubic aerodynamic terms when the ODE carries one)."""
        if self.exact_load is None:
            return self._accelerations(state, U, eta, f, fdot, fddot)
        from autocable.model.exact_load import forces
        acc = replace(self, terms=tuple(t for t in self.terms if t.origin != "aerodynamic"),
                      exact_load=None)._accelerations(state, U, eta, f, fdot, fddot)
        if U != 0.0:
            q1, q2, v1, v2 = (float(x) for x in state)
            F1, F2 = forces(self.exact_load, q2, v1, v2, U, eta * fdot)
            acc = acc + np.array([float(F1), float(F2)])
        return acc

    def linear_matrix(self, U: float) -> np.ndarray:
        """Jacobian of the first-order form (q1, q2, q1', q2') at rest with eta = 0."""
        A = np.zeros((4, 4))
        A[0, 2] = A[1, 3] = 1.0
        for t in self.terms:
            if t.eta_power or sum(t.powers) != 1:
                continue
            j = t.powers.index(1)
            A[1 + t.equation, j] -= t.factor(U, 0.0, 0.0, 0.0, 0.0)
        return A

    # -- persistence ---------------------------------------------------------------------------------
    def to_dict(self) -> dict:
        out = {"omega1": self.omega1, "omega2": self.omega2, "xi_s": self.xi_s,
               "provenance": self.provenance,
               "terms": [asdict(t) for t in self.terms]}
        if self.exact_load is not None:
            out["exact_load"] = self.exact_load.to_dict()
        return out

    @classmethod
    def from_dict(cls, data: dict) -> "TwoModeODE":
        terms = tuple(Term(equation=int(t["equation"]), powers=tuple(t["powers"]),
                           forcing=tuple(t["forcing"]), u_power=int(t["u_power"]),
                           coefficient=float(t["coefficient"]), origin=t["origin"],
                           name=t.get("name", "")) for t in data["terms"])
        exact = None
        if data.get("exact_load") is not None:
            from autocable.model.exact_load import ExactLoad
            exact = ExactLoad.from_dict(data["exact_load"])
        return cls(terms=terms, omega1=float(data["omega1"]), omega2=float(data["omega2"]),
                   xi_s=float(data["xi_s"]), provenance=dict(data.get("provenance", {})), exact_load=exact)

    def content_hash(self) -> str:
        """A short hash of the equations' content (used to name compiled builds)."""
        content = [self.omega1, self.omega2, self.xi_s, [asdict(t) for t in self.terms]]
        if self.exact_load is not None:     # another rung: another right-hand side and build
            content.append(self.exact_load.to_dict())
        payload = json.dumps(content, sort_keys=True)
        return hashlib.sha256(payload.encode()).hexdigest()[:12]


def is_finite_table(ode: TwoModeODE) -> bool:
    return all(math.isfinite(t.coefficient) for t in ode.terms)
