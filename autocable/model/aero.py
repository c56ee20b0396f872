"""Quasi-steady aerodynamics of the cable with a fixed rivulet (Sect. 2.3, eqs. 9-14).

Per unit length, eq. (11) gives b = 1/2 rho_a V L (c_d(phi) V + c_l(phi) a1 x V) with L the load
length (D by default; the paper prints the radius r, see `AeroSpec.load_length`). With the yaw beta
and slope alpha, eqs. (9)-(10) give the in-section wind U-tilde at the attack angle gamma, so that
U-tilde sin(gamma) = -U sin(alpha) sin(beta) and U-tilde cos(gamma) = U cos(alpha). The relative wind
in the section basis (a2: in-plane normal, a3: out of plane) is

    V2 = -U-tilde sin(gamma) - vdot = U sin(alpha) sin(beta) - vdot,   V3 = U cos(alpha) - wdot,

and eq. (12) gives phi = arcsin(-V2/|V|) - Theta0 - theta. The sense in which phi follows the
relative-wind angle is a convention shared with the source of the A_k, B_k fits ([36]); the paper's
text does not pin it down against its data (docs/model.md, U4). ``angle_convention = "reversed"`` takes
phi = -arcsin(-V2/|V|) - Theta0 - theta instead (ANGLE_SIGNS); the choice decides, for instance,
whether galloping is super- or subcritical (see the sample model spec). Lift and drag are the cubic fits of
eq. (13), a global polynomial in phi (not a Taylor series about the operating point). Projected on
a2, a3 (a1 x a2 = a3): b2 = |V| (c_d V2 - c_l V3), b3 = |V| (c_d V3 + c_l V2), in units of
1/2 rho_a L U_c^2 when velocities are measured in units of U_c.

The load is expanded to cubic order in (theta, vdot, wdot) about the static state (eq. 14). The mean
load (the zeroth-order term) is dropped: it belongs to the static equilibrium, as in the paper, whose
Gamma_{1,23} has no U^2 term. Because b is homogeneous of degree 2 in (U, vdot, wdot),
the coefficient of theta^a vdot^b wdot^c carries U^(2-b-c): this is where the 1/U terms of
Appendix A come from, an expansion valid for cable velocities small against the wind. At U = 0 there
is no wind and the whole load is absent.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from itertools import product

import sympy as sp

TH, VD, WD, U = sp.symbols("theta vdot wdot U", real=True)
ALPHA, BETA, THETA0 = sp.symbols("alpha beta Theta0", real=True)
A_SYMS = sp.symbols("A0:4", real=True)
B_SYMS = sp.symbols("B0:4", real=True)

#: Exponent triples (a, b, c) of theta^a vdot^b wdot^c up to cubic order, constant term excluded.
#: Relative size below which an expansion coefficient is round-off of an exact zero.
ROUNDOFF = 1e-13

MONOMIALS = tuple(m for m in product(range(4), repeat=3) if 1 <= sum(m) <= 3)


#: phi = sign * arcsin(-V2/|V|) - Theta0 - theta, by `AeroSpec.angle_convention`.
ANGLE_SIGNS = {"eq12": 1, "reversed": -1}


def quasi_steady_load(convention: str = "eq12"):
    """(b2, b3) of eqs. (9)-(13) as exact sympy expressions in theta, vdot, wdot, U, alpha, beta,
    Theta0, A0..A3, B0..B3; velocities in units of U_c and force in units of 1/2 rho_a L U_c^2."""
    V2 = U * sp.sin(ALPHA) * sp.sin(BETA) - VD
    V3 = U * sp.cos(ALPHA) - WD
    Vn = sp.sqrt(V2**2 + V3**2)
    phi = ANGLE_SIGNS[convention] * sp.asin(-V2 / Vn) - THETA0 - TH
    cl = A_SYMS[0] + A_SYMS[1] * phi + A_SYMS[2] / 2 * phi**2 + A_SYMS[3] / 6 * phi**3
    cd = B_SYMS[0] + B_SYMS[1] * phi + B_SYMS[2] / 2 * phi**2 + B_SYMS[3] / 6 * phi**3
    return Vn * (cd * V2 - cl * V3), Vn * (cd * V3 + cl * V2)


@dataclass(frozen=True)
class AeroExpansion:
    """Cubic expansion of (b2, b3) at U = 1: ``b2[(a, b, c)]`` multiplies theta^a vdot^b wdot^c.

    At wind speed U the same monomial carries U^(2 - b - c) (homogeneity, see module docstring).
    """

    b2: dict
    b3: dict
    alpha: float
    beta: float
    theta0: float
    static_angle: float          # phi0 = +-gamma - Theta0 (sign: angle_convention) [rad]

    def polynomial(self, component: int):
        """The expanded load of eq. (14) as a sympy polynomial in theta, vdot, wdot with U symbolic."""
        table = self.b2 if component == 2 else self.b3
        return sum(sp.Float(c) * U ** (2 - b - cc) * TH**a * VD**b * WD**cc
                   for (a, b, cc), c in table.items())


def _substitutions(lift, drag, alpha):
    subs = {ALPHA: alpha}
    subs.update(dict(zip(A_SYMS, lift)))
    subs.update(dict(zip(B_SYMS, drag)))
    return subs


def expand_load(lift, drag, alpha: float, beta: float, theta0: float,
                convention: str = "eq12") -> AeroExpansion:
    """Taylor coefficients of the load at U = 1 to cubic order, angles in radians (eq. 14)."""
    b2, b3 = quasi_steady_load(convention)
    subs = _substitutions(lift, drag, alpha)
    subs.update({BETA: beta, THETA0: theta0, U: 1})
    zero = {TH: 0, VD: 0, WD: 0}
    tables = []
    for expr in (b2.subs(subs), b3.subs(subs)):
        # Differentiate incrementally along a tree so each partial derivative is taken once.
        cache = {(0, 0, 0): expr}

        def partial(m):
            if m not in cache:
                a, b, c = m
                if a:
                    cache[m] = sp.diff(partial((a - 1, b, c)), TH)
                elif b:
                    cache[m] = sp.diff(partial((a, b - 1, c)), VD)
                else:
                    cache[m] = sp.diff(partial((a, b, c - 1)), WD)
            return cache[m]

        table = {}
        for m in MONOMIALS:
            value = float(partial(m).subs(zero).evalf(18))
            table[m] = value / (math.factorial(m[0]) * math.factorial(m[1]) * math.factorial(m[2]))
        # Derivatives that vanish identically (e.g. by the symmetry of beta = 0) come out of the
        # float evaluation as ~1e-16 times the table's scale: make them the exact zeros they are.
        scale = max(abs(c) for c in table.values())
        table = {m: (0.0 if abs(c) < ROUNDOFF * scale else c) for m, c in table.items()}
        tables.append(table)
    gamma = -math.asin(math.sin(alpha) * math.sin(beta)
                       / math.sqrt(math.cos(alpha) ** 2 + math.sin(alpha) ** 2 * math.sin(beta) ** 2))
    return AeroExpansion(b2=tables[0], b3=tables[1], alpha=alpha, beta=beta, theta0=theta0,
                         static_angle=ANGLE_SIGNS[convention] * gamma - theta0)


@lru_cache(maxsize=8)
def _linear_derivatives(lift: tuple, drag: tuple, alpha: float, convention: str):
    b2, b3 = quasi_steady_load(convention)
    subs = _substitutions(lift, drag, alpha)
    subs[U] = 1
    zero = {TH: 0, VD: 0, WD: 0}
    exprs = [sp.diff(e.subs(subs), v).subs(zero) for e in (b2, b3) for v in (TH, VD, WD)]
    return sp.lambdify((BETA, THETA0), exprs, "math")


def linear_load(lift, drag, alpha: float, beta: float, theta0: float, convention: str = "eq12") -> dict:
    """First-order coefficients only (fast, for calibration): keys like (2, (0, 1, 0))."""
    values = _linear_derivatives(tuple(lift), tuple(drag), alpha, convention)(beta, theta0)
    keys = [(comp, m) for comp in (2, 3) for m in ((1, 0, 0), (0, 1, 0), (0, 0, 1))]
    return dict(zip(keys, (float(v) for v in values)))
