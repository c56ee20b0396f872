"""The exact quasi-steady load projected on the modes: the "exact" rung of the model ladder.

Eq. (21) carries the load of eqs. (11)-(13) expanded to cubic order in (theta, vdot, wdot) about
the static state (eq. 14), then projected on the modes. Here the same section load is evaluated
without expansion, at the exact relative velocity and angle of each section, and projected by
Gauss-Legendre quadrature over the span:

    F_k = K / (m* int phi_k^2) * sum_j w_j phi_k(s_j) [b_k(s_j) - b_k,static]      (k = 1: b2, k = 2: b3)

with, at the node s_j, the twist theta = theta2(s_j) q2, the in-plane velocity
vdot = nu (phi1(s_j) q1' + vhat(s_j) eta f') and the out-of-plane one wdot = nu phi2(s_j) q2'
(velocities in units of U_c, as in `autocable.model.galerkin._aero_field`), the relative wind
V2 = U sin(alpha) sin(beta) - vdot, V3 = U cos(alpha) - wdot, and

    phi = s_psi psi - Theta0 - s_theta theta,   psi = atan2(-V2, V3),
    b2 = |V| (c_d(phi) V2 - c_l(phi) V3),   b3 = |V| (c_d(phi) V3 + c_l(phi) V2)

on the reference axes (turned by theta on the twisted ones, as in `autocable.model.aero`). The
angle sense (s_psi, s_theta) is the model's reading (`aero.ANGLE_SENSES`). Eq. (12) writes psi as
arcsin(-V2/|V|); the two agree while V3 > 0 (the wind's normal component exceeds the cable's
out-of-plane velocity), which holds at rest (cos(alpha) > 0) and for every motion the cubic model
can describe. Beyond, arcsin folds the angle back (a wind from behind would read as one from the
front) while atan2 continues it: the physically right angle, and the one a curve given over 360
degrees needs. The static load (the mean wind on the cable at rest) is subtracted, as eq. (21)
leaves it to the static state (`autocable.model.aero`). With the static state's angle and speed
the load is smooth in (theta, vdot, wdot), and its cubic Taylor polynomial is the load of eq. (14):
eq. (21) is the cubic truncation of this rung (tests/test_exact_load.py: the difference falls as
amplitude^4 along random directions).

What the rung does not change: the structural terms of eq. (21) (the cable's own nonlinearity is
cubic already at the order of eqs. 8), the slaved twist law (linear in q2), the modal damping. So
its linearisation at rest, its Hopf points, their frequency and first Lyapunov coefficient are
those of eq. (21).

Plain data: `ExactLoad` holds the nodes, weights and mode values; `forces` evaluates the
generalized forces with numpy and `force_exprs` writes them as sympy expressions for the compiled
right-hand sides (`autocable.model.symbolic.first_order_rhs`).
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np
import sympy as sp

from autocable.model.aero import ANGLE_SENSES, AXES
from autocable.model.curves import curves_from_dict

#: The loads the model ladder offers: eq. (21)'s cubic expansion (the paper) or the exact load.
LOADS = ("cubic", "exact")

#: Gauss-Legendre nodes over the span, and the accuracy they are chosen for: the generalized forces
#: within QUADRATURE_RTOL of a 128-node quadrature, relative to the largest force, at the largest
#: motions the validity checks accept (`edge_states`: phi swept by +-15 deg about the static angle,
#: the default valid range of the paper's fits, `autocable.model.curves.DEFAULT_HALF_WIDTH_DEG`) with
#: the relative wind at least half the wind at every section (a cable moving with the wind is outside
#: the quasi-steady model). Measured (`quadrature_error`, five draws of 300 such states): 24 nodes
#: give at most 1.0e-10 on the 190 m stay, 5.6e-11 on the Dongting stay, 1.6e-11 on the Meiko-Nishi
#: stay, 8e-15 on the sample; 20 nodes up to 4.8e-10 (the tolerance without a margin), 16 up to
#: 3.5e-9, 12 up to 2.9e-8 (stays). The stays' Irvine in-plane mode and restrained twist make the
#: integrand vary more along the span than the sample's (14 nodes hold it there). The worst state of
#: a draw is heavy-tailed (one count gives 4e-10 on one draw and 9e-9 on another), so one count with
#: a margin for all models, not a per-model choice from one draw. A cable moving at the wind's own
#: speed near mid-span (|V| -> 0 there: the sqrt and atan2 of the load are singular just off the real
#: axis) converges slowly: 3e-8 at 24 nodes, 1e-6 at 12. `exact_load_of(..., nodes=n)` takes more.
QUADRATURE_RTOL = 5e-10
DEFAULT_NODES = 24


@dataclass(frozen=True)
class ExactLoad:
    """Everything the exact load of one model needs (module docstring), as plain numbers."""

    nodes: tuple             # s_j in (0, 1)
    weights: tuple           # w_j, sum 1
    phi1: tuple              # mode values at the nodes
    phi2: tuple
    theta2: tuple
    vhat: tuple
    K: float                 # load scale rho_a L U_c^2 l / (2 EA)
    nu: float                # omega l / U_c
    mass1: float             # m* int phi1^2
    mass2: float             # m* int phi2^2
    alpha: float
    beta: float
    theta0: float
    convention: str
    axes: str
    curves: dict             # `autocable.model.curves` to_dict()

    @property
    def static_angle(self) -> float:
        """phi0 of the cable at rest (radians)."""
        s_psi, _ = ANGLE_SENSES[self.convention]
        return s_psi * math.atan2(-math.sin(self.alpha) * math.sin(self.beta), math.cos(self.alpha)) - self.theta0

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict) -> "ExactLoad":
        d = dict(data)
        for k in ("nodes", "weights", "phi1", "phi2", "theta2", "vhat"):
            d[k] = tuple(float(x) for x in d[k])
        return cls(**d)


def exact_load_of(shapes: dict, m_star: float, mass1_integral: float, mass2_integral: float, K: float,
                  nu: float, alpha: float, beta: float, theta0: float, convention: str, axes: str,
                  curves, nodes: int = DEFAULT_NODES) -> ExactLoad:
    """The `ExactLoad` of a model from its mode shapes (`autocable.model.shapes.Shape` by name:
    phi1, phi2, theta2, vhat), scales and wind angles, on ``nodes`` Gauss-Legendre nodes."""
    if convention not in ANGLE_SENSES:
        raise ValueError(f"angle convention must be one of {tuple(ANGLE_SENSES)}, got {convention!r}")
    if axes not in AXES:
        raise ValueError(f"axes must be one of {AXES}, got {axes!r}")

    x, w = np.polynomial.legendre.leggauss(int(nodes))
    s, w = 0.5 * (x + 1.0), 0.5 * w

    def at(name):
        return _mirrored(np.broadcast_to(shapes[name].evaluate(s), s.shape))

    return ExactLoad(nodes=tuple(float(v) for v in s), weights=_mirrored(w),
                     phi1=at("phi1"), phi2=at("phi2"), theta2=at("theta2"), vhat=at("vhat"),
                     K=float(K), nu=float(nu), mass1=float(m_star * mass1_integral),
                     mass2=float(m_star * mass2_integral), alpha=float(alpha), beta=float(beta),
                     theta0=float(theta0), convention=convention, axes=axes, curves=curves.to_dict())


def edge_states(ex: ExactLoad, count: int = 300, seed: int = 0, sweep_deg: float = 15.0,
                min_speed: float = 0.5):
    """States at the edge of what the validity checks accept, for the accuracy of the quadrature:
    ``count`` random directions of (q2, q1', q2', eta f') (eta f' = 0 in half of them) at U* = 0.6,
    1.2 or 2, each scaled (bisection) until phi sweeps +-``sweep_deg`` about the static angle
    somewhere along the span, those kept whose relative wind is at least ``min_speed`` U at every
    node of ``ex``. Returns (X, U): X an (n, 4) array of (q2, q1', q2', eta f'), U the n winds."""
    rng = np.random.default_rng(seed)
    D = rng.normal(size=(count, 4))
    D[rng.uniform(size=count) < 0.5, 3] = 0.0
    U = rng.choice([0.6, 1.2, 2.0], size=count)
    target = math.radians(sweep_deg)

    def swept(a):
        phi, _ = section_angles(ex, a * D[:, 0], a * D[:, 1], a * D[:, 2], U, a * D[:, 3])
        return np.max(np.abs(phi - ex.static_angle), axis=-1)

    lo, hi = np.zeros(count), np.full(count, 1e-3)
    for _ in range(40):
        short = swept(hi) < target
        if not short.any():
            break
        hi = np.where(short, 2.0 * hi, hi)
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        below = swept(mid) < target
        lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
    X = hi[:, None] * D
    _, V2, V3 = _kinematics(ex, X[:, 0], X[:, 1], X[:, 2], U, X[:, 3])
    keep = np.min(np.hypot(V2, V3), axis=-1) >= min_speed * U
    return X[keep], U[keep]


def quadrature_error(ex: ExactLoad, reference: ExactLoad, X, U) -> float:
    """The largest difference of the forces of ``ex`` from those of ``reference`` at the states
    (X, U) of `edge_states`, relative to the largest force at each state."""
    args = (X[:, 0], X[:, 1], X[:, 2], U, X[:, 3])
    ref = np.array(forces(reference, *args))
    scale = np.maximum(np.max(np.abs(ref), axis=0), 1e-300)
    return float(np.max(np.abs(np.array(forces(ex, *args)) - ref) / scale))


def _mirrored(values) -> tuple:
    """Node values made exactly equal at mirrored nodes (s, 1 - s) where they agree to round-off.
    The first pair's shapes are symmetric about mid-span, and so is the load without support motion
    (only vhat, carried by eta f', is not): with equal values at mirrored nodes the two halves of the
    quadrature sum are the same expression once eta = 0 is substituted, and sympy and the C code keep
    one of them, halving the cost of the autonomous right-hand side (galloping)."""
    v = np.asarray(values, dtype=float)
    r = v[::-1]
    if np.all(np.abs(v - r) <= 1e-13 * max(float(np.max(np.abs(v))), 1e-300)):
        v = 0.5 * (v + r)
    return tuple(float(x) for x in v)


def _section(ex: ExactLoad, curves, V2, V3, theta, lib):
    """(b2, b3) of one section and its angle phi, with ``lib`` numpy or sympy."""
    s_psi, s_th = ANGLE_SENSES[ex.convention]
    if lib is np:
        Vn = np.sqrt(V2 * V2 + V3 * V3)
        psi = np.arctan2(-V2, V3)
    else:
        Vn = sp.sqrt(V2 * V2 + V3 * V3)
        psi = sp.atan2(-V2, V3)
    phi = s_psi * psi - ex.theta0 - s_th * theta
    if lib is np:
        cl, cd = curves.lift(phi), curves.drag(phi)
    else:
        cl, cd = curves.lift_expr(phi), curves.drag_expr(phi)
    b2, b3 = Vn * (cd * V2 - cl * V3), Vn * (cd * V3 + cl * V2)
    if ex.axes == "twisted":
        c, s = (np.cos(theta), np.sin(theta)) if lib is np else (sp.cos(theta), sp.sin(theta))
        b2, b3 = c * b2 + s * b3, -s * b2 + c * b3
    return b2, b3, phi


def section_angles(ex: ExactLoad, q2, v1, v2, U, Ed=0.0):
    """(phi, theta) at every node for states (arrays broadcast against the nodes on the last axis):
    the angle of eq. (12) and the twist along the span, radians."""
    theta, V2, V3 = _kinematics(ex, q2, v1, v2, U, Ed)
    s_psi, s_th = ANGLE_SENSES[ex.convention]
    return s_psi * np.arctan2(-V2, V3) - ex.theta0 - s_th * theta, theta


def _kinematics(ex: ExactLoad, q2, v1, v2, U, Ed):
    q2, v1, v2, U, Ed = (np.asarray(x, dtype=float)[..., None] for x in (q2, v1, v2, U, Ed))
    phi1, phi2, theta2, vhat = (np.asarray(x) for x in (ex.phi1, ex.phi2, ex.theta2, ex.vhat))
    theta = theta2 * q2
    vdot = ex.nu * (phi1 * v1 + vhat * Ed)
    wdot = ex.nu * phi2 * v2
    V2 = U * math.sin(ex.alpha) * math.sin(ex.beta) - vdot
    V3 = U * math.cos(ex.alpha) - wdot
    return theta, V2, V3


def forces(ex: ExactLoad, q2, v1, v2, U, Ed=0.0):
    """(F1, F2): the generalized aerodynamic forces per unit modal mass (the accelerations the load
    adds to q1'', q2'') at states given as numpy arrays (broadcast), wind U in units of U_c."""
    curves = curves_from_dict(ex.curves)
    theta, V2, V3 = _kinematics(ex, q2, v1, v2, U, Ed)
    b2, b3, _ = _section(ex, curves, V2, V3, theta, np)
    Uarr = np.asarray(U, dtype=float)
    z2, z3, _ = _section(ex, curves, Uarr * math.sin(ex.alpha) * math.sin(ex.beta), Uarr * math.cos(ex.alpha),
                         np.zeros_like(Uarr), np)
    w = np.asarray(ex.weights)
    F1 = ex.K / ex.mass1 * np.sum(w * np.asarray(ex.phi1) * (b2 - np.asarray(z2)[..., None]), axis=-1)
    F2 = ex.K / ex.mass2 * np.sum(w * np.asarray(ex.phi2) * (b3 - np.asarray(z3)[..., None]), axis=-1)
    return F1, F2


def force_exprs(ex: ExactLoad, q2, v1, v2, U, Ed):
    """(F1, F2) of `forces` as sympy expressions in the given symbols (``Ed`` = eta f').

    Written for the compiled right-hand sides, where they are the cost (`autocable bench
    exact-load`): per node one sqrt and one atan2 of the same V2 (atan2(-V2, V3) = -atan2(V2, V3):
    sympy would otherwise print -V2 as a second linear combination), the polynomial curves in
    Horner form, and the products of node constants (weights times mode values) folded into one
    number per node and force."""
    curves = curves_from_dict(ex.curves)
    s_psi, s_th = ANGLE_SENSES[ex.convention]
    f = lambda x: sp.Float(x, 17)  # noqa: E731 - a short name keeps the formulas readable
    sa_sb, ca = f(math.sin(ex.alpha) * math.sin(ex.beta)), f(math.cos(ex.alpha))
    # The static load is U^2 times its value at U = 1 (the load is homogeneous of degree 2 in the
    # velocities): one number per component instead of a second evaluation of the curves.
    z2, z3, _ = _section(ex, curves, np.array(math.sin(ex.alpha) * math.sin(ex.beta)),
                         np.array(math.cos(ex.alpha)), np.array(0.0), np)
    phi = sp.Dummy("phi")
    lift, drag = curves.lift_expr(phi), curves.drag_expr(phi)
    if lift.is_polynomial(phi) and drag.is_polynomial(phi):
        lift, drag = sp.horner(lift, phi), sp.horner(drag, phi)
    U_sa_sb, U_ca = U * sa_sb, U * ca
    F1, F2 = sp.Integer(0), sp.Integer(0)
    for s_w, p1, p2, th2, vh in zip(ex.weights, ex.phi1, ex.phi2, ex.theta2, ex.vhat):
        theta = f(th2) * q2
        V2 = U_sa_sb - f(ex.nu * p1) * v1 - f(ex.nu * vh) * Ed
        V3 = U_ca - f(ex.nu * p2) * v2
        Vn = sp.sqrt(V2 * V2 + V3 * V3)
        angle = -s_psi * sp.atan2(V2, V3) - f(ex.theta0) - s_th * theta
        cl, cd = lift.xreplace({phi: angle}), drag.xreplace({phi: angle})
        b2, b3 = cd * V2 - cl * V3, cd * V3 + cl * V2
        if ex.axes == "twisted":
            c, sn = sp.cos(theta), sp.sin(theta)
            b2, b3 = c * b2 + sn * b3, -sn * b2 + c * b3
        F1 += f(s_w * p1) * Vn * b2
        F2 += f(s_w * p2) * Vn * b3
    int1 = float(np.dot(ex.weights, ex.phi1))
    int2 = float(np.dot(ex.weights, ex.phi2))
    F1 = f(ex.K / ex.mass1) * (F1 - f(float(z2) * int1) * U**2)
    F2 = f(ex.K / ex.mass2) * (F2 - f(float(z3) * int2) * U**2)
    return F1, F2
