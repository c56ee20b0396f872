"""Quasi-steady aerodynamics of the cable with a fixed rivulet (Sect. 2.3, eqs. 9-14).

Per unit length, eq. (11) gives b = 1/2 rho_a V L (c_d(phi) V + c_l(phi) a1 x V) with L the load
length (D by default; the paper prints the radius r, see `AeroSpec.load_length`). With the yaw beta
and slope alpha, eqs. (9)-(10) give the in-section wind U-tilde at the attack angle gamma, so that
U-tilde sin(gamma) = -U sin(alpha) sin(beta) and U-tilde cos(gamma) = U cos(alpha). The relative wind
in the section basis (a2: in-plane normal, a3: out of plane) is

    V2 = -U-tilde sin(gamma) - vdot = U sin(alpha) sin(beta) - vdot,   V3 = U cos(alpha) - wdot,

and eq. (12) gives phi = psi - Theta0 - theta with the relative-wind angle psi = arcsin(-V2/|V|).
Both psi and the twist theta are right-handed about the cable axis a1 (eq. 3: k2 = -w'' + kappa
theta), so phi depends only on the angle between the relative wind and the twisted section: turning
wind and section together by d leaves the load unchanged in the turned section (frame indifference,
`frame_residual`). The sense in which the coefficient curves of [36] are measured is not pinned down
by the paper against its data (docs/model.md, U4); ``angle_convention`` (ANGLE_SENSES) selects:

- ``"eq12"``: eq. (12) as printed, phi = psi - Theta0 - theta;
- ``"mirrored"``: the curves read the other way, c(-phi): phi = -(psi - theta) - Theta0. Frame
  indifferent like "eq12"; it has the in-plane terms of "reversed" and flips the terms odd in theta;
- ``"reversed"`` (legacy): phi = -psi - Theta0 - theta flips psi alone. It is NOT frame indifferent
  (the load depends on how the section is oriented in space, which no quasi-steady load can), and is
  kept readable only to reproduce older results; the spec reader warns.

The choice decides, for instance, whether galloping is super- or subcritical (see the sample model
spec). Lift and drag are the cubic fits of
eq. (13), a global polynomial in phi (not a Taylor series about the operating point). Projected on
a2, a3 (a1 x a2 = a3): b2 = |V| (c_d V2 - c_l V3), b3 = |V| (c_d V3 + c_l V2), in units of
1/2 rho_a L U_c^2 when velocities are measured in units of U_c.

Eq. (14) says the load is projected "on the a-hat_2, a-hat_3 axes", which the text does not tie to
the initial (a-bar) or the current, twisted (a) section axes. Eqs. (8) are written on the initial
axes, so ``load_axes = "reference"`` (the default) keeps b2, b3 above. ``"twisted"`` reads the hat as
the current axes, turned by theta about a1 in the sense in which eq. (12) measures angles (a
right-hand turn about a1 takes a3 towards -a2, the sense in which arcsin(-V2/|V|) grows):
a2 = cos(theta) a2-bar + sin(theta) a3-bar, a3 = -sin(theta) a2-bar + cos(theta) a3-bar, so
b2' = cos(theta) b2 + sin(theta) b3 and b3' = -sin(theta) b2 + cos(theta) b3 (AXES).

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


#: phi = s_psi * arcsin(-V2/|V|) - Theta0 - s_theta * theta: (s_psi, s_theta) by
#: `AeroSpec.angle_convention` (module docstring).
ANGLE_SENSES = {"eq12": (1, 1), "mirrored": (-1, -1), "reversed": (-1, 1)}
#: The sign of psi alone (the static angle phi0 = s_psi gamma - Theta0).
ANGLE_SIGNS = {k: v[0] for k, v in ANGLE_SENSES.items()}
#: The senses that keep the load frame indifferent (turning wind and section together).
FRAME_INDIFFERENT = ("eq12", "mirrored")
#: Readings kept only to reproduce older results.
LEGACY_SENSES = ("reversed",)
#: The axes of the projection of eq. (14), by `AeroSpec.load_axes` (module docstring).
AXES = ("reference", "twisted")


def quasi_steady_load(convention: str = "eq12", axes: str = "reference"):
    """(b2, b3) of eqs. (9)-(13) as exact sympy expressions in theta, vdot, wdot, U, alpha, beta,
    Theta0, A0..A3, B0..B3; velocities in units of U_c and force in units of 1/2 rho_a L U_c^2;
    components on the reference or the twisted section axes (``axes``, module docstring)."""
    if axes not in AXES:
        raise ValueError(f"axes must be one of {AXES}, got {axes!r}")
    V2 = U * sp.sin(ALPHA) * sp.sin(BETA) - VD
    V3 = U * sp.cos(ALPHA) - WD
    Vn = sp.sqrt(V2**2 + V3**2)
    s_psi, s_th = ANGLE_SENSES[convention]
    phi = s_psi * sp.asin(-V2 / Vn) - THETA0 - s_th * TH
    cl = A_SYMS[0] + A_SYMS[1] * phi + A_SYMS[2] / 2 * phi**2 + A_SYMS[3] / 6 * phi**3
    cd = B_SYMS[0] + B_SYMS[1] * phi + B_SYMS[2] / 2 * phi**2 + B_SYMS[3] / 6 * phi**3
    b2, b3 = Vn * (cd * V2 - cl * V3), Vn * (cd * V3 + cl * V2)
    if axes == "twisted":
        return sp.cos(TH) * b2 + sp.sin(TH) * b3, -sp.sin(TH) * b2 + sp.cos(TH) * b3
    return b2, b3


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
                convention: str = "eq12", axes: str = "reference") -> AeroExpansion:
    """Taylor coefficients of the load at U = 1 to cubic order, angles in radians (eq. 14)."""
    b2, b3 = quasi_steady_load(convention, axes)
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
def _linear_derivatives(lift: tuple, drag: tuple, alpha: float, convention: str, axes: str = "reference"):
    b2, b3 = quasi_steady_load(convention, axes)
    subs = _substitutions(lift, drag, alpha)
    subs[U] = 1
    zero = {TH: 0, VD: 0, WD: 0}
    exprs = [sp.diff(e.subs(subs), v).subs(zero) for e in (b2, b3) for v in (TH, VD, WD)]
    return sp.lambdify((BETA, THETA0), exprs, "math")


def linear_load(lift, drag, alpha: float, beta: float, theta0: float, convention: str = "eq12",
                axes: str = "reference") -> dict:
    """First-order coefficients only (fast, for calibration): keys like (2, (0, 1, 0))."""
    values = _linear_derivatives(tuple(lift), tuple(drag), alpha, convention, axes)(beta, theta0)
    keys = [(comp, m) for comp in (2, 3) for m in ((1, 0, 0), (0, 1, 0), (0, 0, 1))]
    return dict(zip(keys, (float(v) for v in values)))


# ------------------------------------------------------------------------------------------------
# The same cubic expansion by truncated Taylor arithmetic (for the calibration's screen)
# ------------------------------------------------------------------------------------------------
class _Jet:
    """A polynomial in (theta, vdot, wdot) truncated at total degree 3: {exponents: value}."""

    __slots__ = ("c",)

    def __init__(self, c):
        self.c = c

    @staticmethod
    def const(x: float) -> "_Jet":
        return _Jet({(0, 0, 0): float(x)})

    def __add__(self, o):
        o = o if isinstance(o, _Jet) else _Jet.const(o)
        out = dict(self.c)
        for m, v in o.c.items():
            out[m] = out.get(m, 0.0) + v
        return _Jet(out)

    __radd__ = __add__

    def __neg__(self):
        return _Jet({m: -v for m, v in self.c.items()})

    def __sub__(self, o):
        return self + (-(o if isinstance(o, _Jet) else _Jet.const(o)))

    def __mul__(self, o):
        if not isinstance(o, _Jet):
            return _Jet({m: v * o for m, v in self.c.items()})
        out = {}
        for m1, v1 in self.c.items():
            for m2, v2 in o.c.items():
                m = (m1[0] + m2[0], m1[1] + m2[1], m1[2] + m2[2])
                if sum(m) <= 3:
                    out[m] = out.get(m, 0.0) + v1 * v2
        return _Jet(out)

    __rmul__ = __mul__

    def compose(self, derivs) -> "_Jet":
        """f(self) from f and its first three derivatives at the constant part (Taylor in the rest)."""
        x0 = self.c.get((0, 0, 0), 0.0)
        h = self - x0
        out, power = _Jet.const(derivs[0]), _Jet.const(1.0)
        for n in (1, 2, 3):
            power = power * h
            out = out + power * (derivs[n] / math.factorial(n))
        return out


def _sqrt_d(x):
    r = math.sqrt(x)
    return (r, 0.5 / r, -0.25 / (x * r), 0.375 / (x * x * r))


def _asin_d(x):
    q = 1.0 - x * x
    return (math.asin(x), q ** -0.5, x * q ** -1.5, (1 + 2 * x * x) * q ** -2.5)


def expand_load_jet(lift, drag, alpha: float, beta: float, theta0: float,
                    convention: str = "eq12", axes: str = "reference") -> AeroExpansion:
    """`expand_load` by truncated Taylor arithmetic instead of sympy: the same coefficients of
    eq. (14) (tests assert 1e-12 relative) in about a millisecond instead of seconds, so that the
    calibration can screen thousands of (beta, Theta0) pairs."""
    if axes not in AXES:
        raise ValueError(f"axes must be one of {AXES}, got {axes!r}")
    th = _Jet({(1, 0, 0): 1.0})
    vd = _Jet({(0, 1, 0): 1.0})
    wd = _Jet({(0, 0, 1): 1.0})
    V2 = _Jet.const(math.sin(alpha) * math.sin(beta)) - vd
    V3 = _Jet.const(math.cos(alpha)) - wd
    n2 = V2 * V2 + V3 * V3
    Vn = n2.compose(_sqrt_d(n2.c[(0, 0, 0)]))
    inv = Vn.compose(_inv_d(Vn.c[(0, 0, 0)]))
    ratio = -V2 * inv
    s_psi, s_th = ANGLE_SENSES[convention]
    phi = ratio.compose(_asin_d(ratio.c[(0, 0, 0)])) * s_psi - theta0 - th * s_th
    phi2 = phi * phi
    phi3 = phi2 * phi
    cl = _Jet.const(lift[0]) + phi * lift[1] + phi2 * (lift[2] / 2) + phi3 * (lift[3] / 6)
    cd = _Jet.const(drag[0]) + phi * drag[1] + phi2 * (drag[2] / 2) + phi3 * (drag[3] / 6)
    b2, b3 = Vn * (cd * V2 - cl * V3), Vn * (cd * V3 + cl * V2)
    if axes == "twisted":
        c = th.compose((1.0, 0.0, -1.0, 0.0))     # cos(theta)
        s = th.compose((0.0, 1.0, 0.0, -1.0))     # sin(theta)
        b2, b3 = c * b2 + s * b3, -(s * b2) + c * b3
    tables = []
    for b in (b2, b3):
        table = {m: b.c.get(m, 0.0) for m in MONOMIALS}
        scale = max(abs(v) for v in table.values())
        tables.append({m: (0.0 if abs(v) < ROUNDOFF * scale else v) for m, v in table.items()})
    gamma = -math.asin(math.sin(alpha) * math.sin(beta)
                       / math.sqrt(math.cos(alpha) ** 2 + math.sin(alpha) ** 2 * math.sin(beta) ** 2))
    return AeroExpansion(b2=tables[0], b3=tables[1], alpha=alpha, beta=beta, theta0=theta0,
                         static_angle=ANGLE_SIGNS[convention] * gamma - theta0)


def _inv_d(x):
    return (1 / x, -1 / x**2, 2 / x**3, -6 / x**4)


def exact_load(lift, drag, alpha: float, beta: float, theta0: float, theta, vdot, wdot,
               convention: str = "eq12", axes: str = "reference", U: float = 1.0):
    """(b2, b3) of eqs. (9)-(13) without expansion, in the units of `quasi_steady_load` (numpy,
    vectorised): the reference the cubic expansion of eq. (14) is measured against."""
    import numpy as np
    vdot, wdot = (np.asarray(x, dtype=float) for x in (vdot, wdot))
    V2 = U * math.sin(alpha) * math.sin(beta) - vdot
    V3 = U * math.cos(alpha) - wdot
    return section_load(lift, drag, theta0, V2, V3, theta, convention, axes)


def section_load(lift, drag, theta0: float, V2, V3, theta, convention: str = "eq12",
                 axes: str = "reference"):
    """(b2, b3) of eqs. (11)-(13) from the relative wind (V2, V3) on the reference section axes and
    the twist theta (numpy, vectorised), in the units of `quasi_steady_load`: the load of one
    section, whatever produced its relative wind."""
    import numpy as np
    V2, V3, theta = (np.asarray(x, dtype=float) for x in (V2, V3, theta))
    Vn = np.sqrt(V2**2 + V3**2)
    s_psi, s_th = ANGLE_SENSES[convention]
    phi = s_psi * np.arcsin(-V2 / Vn) - theta0 - s_th * theta
    cl = lift[0] + lift[1] * phi + lift[2] / 2 * phi**2 + lift[3] / 6 * phi**3
    cd = drag[0] + drag[1] * phi + drag[2] / 2 * phi**2 + drag[3] / 6 * phi**3
    b2, b3 = Vn * (cd * V2 - cl * V3), Vn * (cd * V3 + cl * V2)
    if axes == "twisted":
        return np.cos(theta) * b2 + np.sin(theta) * b3, -np.sin(theta) * b2 + np.cos(theta) * b3
    return b2, b3


def turn(x2, x3, d):
    """The components on a2, a3 of the vector (x2, x3) turned by d about a1, in the sense in which
    psi = arcsin(-V2/|V|) and the twist theta grow (a3 goes towards -a2)."""
    import numpy as np
    return np.cos(d) * x2 - np.sin(d) * x3, np.sin(d) * x2 + np.cos(d) * x3


def frame_residual(lift, drag, theta0: float, V2, V3, theta, d: float, convention: str = "eq12",
                   axes: str = "reference", load=None) -> float:
    """Frame indifference of the quasi-steady load: turn the relative wind and the section together
    by d about a1 and compare the load with the original load turned by d (on the reference axes) or
    with the original load itself (on the twisted axes, which turn with the section). Returns the
    largest difference over the samples relative to the largest load; zero (to round-off) for a
    frame-indifferent sense. ``load(V2, V3, theta)`` replaces the exact load (e.g. by the cubic
    expansion of eq. 14)."""
    import numpy as np
    if load is None:
        def load(v2, v3, th):
            return section_load(lift, drag, theta0, v2, v3, th, convention, axes)
    b2, b3 = load(V2, V3, theta)
    W2, W3 = turn(V2, V3, d)
    c2, c3 = load(W2, W3, np.asarray(theta, dtype=float) + d)
    if axes == "reference":
        b2, b3 = turn(b2, b3, d)
    scale = max(float(np.max(np.abs(b2))), float(np.max(np.abs(b3))), 1e-300)
    return float(max(np.max(np.abs(c2 - b2)), np.max(np.abs(c3 - b3))) / scale)


#: The expansion of eq. (14) counts as in range while the cubic's error on the load change it
#: carries stays below this fraction of that change (a stated bound, not the paper's).
CUBIC_RTOL = 0.1


class CubicLoadError:
    """The error of the cubic load of eq. (14) against the exact quasi-steady load of eqs. (9)-(13)
    along a harmonic motion at mid-span: theta = Theta cos(psi2), wdot = -Wd sin(psi2),
    vdot = -Vd sin(psi1), over a grid of the two phases, at wind U (units of U_c). The error is the
    largest |cubic - exact| of the load change b - b(rest), both components, over the largest exact
    change. Note that with vdot = wdot = 0 on the reference axes the load is exactly cubic in theta
    (c_l, c_d are cubic in phi, eq. 13, and phi is linear in theta): the error comes from the
    velocities and their products with the twist, and from the turned axes."""

    def __init__(self, lift, drag, alpha: float, beta: float, theta0: float, convention: str = "eq12",
                 axes: str = "reference", n: int = 24):
        import numpy as np
        self.args = (tuple(lift), tuple(drag), alpha, beta, theta0)
        self.convention, self.axes = convention, axes
        self.exp = expand_load_jet(lift, drag, alpha, beta, theta0, convention, axes)
        psi = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
        self.p1, self.p2 = (x.ravel() for x in np.meshgrid(psi, psi))

    def __call__(self, theta_amp: float, vdot_amp: float, wdot_amp: float, U: float = 1.0) -> float:
        import numpy as np
        if U == 0.0 or not (math.isfinite(theta_amp) and math.isfinite(vdot_amp) and math.isfinite(wdot_amp)):
            return 0.0 if U == 0.0 else math.nan
        th = theta_amp * np.cos(self.p2)
        wd = -wdot_amp * np.sin(self.p2)
        vd = -vdot_amp * np.sin(self.p1)
        e2, e3 = exact_load(*self.args, th, vd, wd, self.convention, self.axes, U)
        z2, z3 = exact_load(*self.args, 0.0, 0.0, 0.0, self.convention, self.axes, U)
        c2 = sum(c * U ** (2 - b - cc) * th**a * vd**b * wd**cc for (a, b, cc), c in self.exp.b2.items())
        c3 = sum(c * U ** (2 - b - cc) * th**a * vd**b * wd**cc for (a, b, cc), c in self.exp.b3.items())
        d2, d3 = e2 - z2, e3 - z3
        scale = max(float(np.max(np.abs(d2))), float(np.max(np.abs(d3))), 1e-300)
        return float(max(np.max(np.abs(c2 - d2)), np.max(np.abs(c3 - d3))) / scale)

    def many(self, theta_amps, vdot_amps, wdot_amps, U, block: int = 256):
        """The error at many motions at once (arrays of one length; ``U`` an array or a number):
        the same operations as calling the object point by point, a block of points at a time
        (a branch of a scene has hundreds of points)."""
        import numpy as np
        th_a, vd_a, wd_a = (np.asarray(x, dtype=float).ravel() for x in (theta_amps, vdot_amps, wdot_amps))
        Us = np.broadcast_to(np.asarray(U, dtype=float), th_a.shape).astype(float)
        out = np.full(th_a.shape, np.nan)
        out[Us == 0.0] = 0.0
        todo = np.flatnonzero((Us != 0.0) & np.isfinite(th_a) & np.isfinite(vd_a) & np.isfinite(wd_a)
                              & np.isfinite(Us))
        cos2, sin2, sin1 = np.cos(self.p2), np.sin(self.p2), np.sin(self.p1)
        for i0 in range(0, len(todo), block):
            idx = todo[i0:i0 + block]
            u = Us[idx, None]
            th = th_a[idx, None] * cos2
            wd = -wd_a[idx, None] * sin2
            vd = -vd_a[idx, None] * sin1
            e2, e3 = exact_load(*self.args, th, vd, wd, self.convention, self.axes, u)
            z2, z3 = exact_load(*self.args, 0.0, 0.0, 0.0, self.convention, self.axes, u)
            c2 = sum(c * u ** (2 - b - cc) * th**a * vd**b * wd**cc for (a, b, cc), c in self.exp.b2.items())
            c3 = sum(c * u ** (2 - b - cc) * th**a * vd**b * wd**cc for (a, b, cc), c in self.exp.b3.items())
            d2, d3 = e2 - z2, e3 - z3
            scale = np.maximum(np.maximum(np.max(np.abs(d2), axis=1), np.max(np.abs(d3), axis=1)), 1e-300)
            out[idx] = np.maximum(np.max(np.abs(c2 - d2), axis=1), np.max(np.abs(c3 - d3), axis=1)) / scale
        return out
