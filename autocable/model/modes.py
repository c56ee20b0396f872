"""Linear modes of eqs. (19)-(20): the Galerkin trial functions of Sect. 3.

In-plane (eq. 19_1 linearised, with the Irvine term of docs/model.md, M3):
    tau v'' - delta^2 int_0^1 v ds = m* v_tt,   v(0) = v(1) = 0,   m* = pi^2 tau.
Its first symmetric mode is phi1(s) = (cos(b (s - 1/2)) - cos(b/2)) / (1 - cos(b/2)), b = pi omega1,
with b the first root above pi of Irvine's equation tan(b/2) = b/2 - (4/lambda^2)(b/2)^3.

Out-of-plane (eq. 19_2 linearised): tau w'' = m* w_tt, so phi2(s) = sin(pi s) and omega2 = 1 exactly.
Its twist is slaved through the quasi-static eq. (19)_3 as corrected (docs/model.md, M4: (1 + chi)):
    chi theta'' - delta^2 theta + (1 + chi) delta w'' = 0,   chi (theta' + delta w') = 0 at s = 0, 1,
solved in closed form: theta = B sin(pi s) + C cosh(k (s - 1/2)), k = delta / sqrt(chi).
The paper's scaling assumes a twist that "does not vanish at the ends" (Sect. 2.2), and with the
natural conditions C is about 2 pi/delta: the twist is large and nearly uniform. Held at the
anchorages instead (``twist_ends = "restrained"``, theta(0) = theta(1) = 0), the homogeneous part
must vanish at both ends, so C = 0 and theta = B sin(pi s), B = -(1 + chi) delta pi^2 /
(chi pi^2 + delta^2): about -0.19 for the sample cable, some 2500 times smaller.
Both modes are normalised to a unit maximum displacement (Sect. 5); the twist follows phi2.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq

from autocable.model.shapes import Shape, cos_term, cosh_term, poly, scaled, sin_term
from autocable.model.statics import CableStatics


def irvine_root(lambda2: float) -> float:
    """First symmetric in-plane root b = pi omega1 of tan(b/2) = b/2 - (4/lambda^2)(b/2)^3.

    Solved in the pole-free form cos(x)(x - 4x^3/lambda^2) - sin(x) = 0, x = b/2 in (pi/2, 3pi/2).
    """
    def g(x):
        return math.cos(x) * (x - 4.0 * x**3 / lambda2) - math.sin(x)

    lo, hi = math.pi / 2 * (1 + 1e-15), 3 * math.pi / 2 * (1 - 1e-15)
    return 2.0 * brentq(g, lo, hi, xtol=1e-15, rtol=1e-15, maxiter=200)


@dataclass(frozen=True)
class Modes:
    """The two trial functions with their frequencies (nondimensional, eq. 17)."""

    omega1: float
    omega2: float
    b: float                  # pi * omega1
    twist_B: float            # theta = B sin(pi s) + C cosh(k (s - 1/2))
    twist_C: float
    twist_k: float
    shapes: dict              # name -> Shape: phi1, phi1_d, phi1_dd, phi2, phi2_d, phi2_dd, theta2,
                              #                vhat, vhat_d, vhat_dd
    twist_D: float = 0.0      # + D sinh(k (s - 1/2)): nonzero only for an antisymmetric out-of-plane
                              # mode (an even pair, `autocable.model.mode_pairs`)


TWIST_ENDS = ("natural", "restrained")


def linear_modes(st: CableStatics, twist_ends: str = "natural") -> Modes:
    """The first symmetric in-plane and out-of-plane modes, unit maximum, with the slaved twist.

    ``twist_ends``: "natural" (eq. 20 as printed) or "restrained" (theta = 0 at s = 0, 1); see the
    module docstring."""
    if twist_ends not in TWIST_ENDS:
        raise ValueError(f"twist_ends must be one of {TWIST_ENDS}, got {twist_ends!r}")
    b = irvine_root(st.lambda2)
    cb = math.cos(b / 2)
    norm = 1.0 - cb
    phi1 = scaled(cos_term(b, 0.5), 1 / norm, poly(-cb / norm))
    phi2 = sin_term(math.pi)

    delta, chi = st.delta, st.chi
    B = -(1 + chi) * delta * math.pi**2 / (chi * math.pi**2 + delta**2)
    k = delta / math.sqrt(chi)
    # natural: chi (theta' + delta w') = 0 at the ends; restrained: theta = 0 there, which the
    # particular part B sin(pi s) already meets, so the cosh part must vanish.
    C = math.pi * (B + delta) / (k * math.sinh(k / 2)) if twist_ends == "natural" else 0.0
    theta = scaled(sin_term(math.pi), B, scaled(cosh_term(k, 0.5), C))
    vhat = poly(0.0, st.C2, st.C1)

    pi = math.pi
    direct = {
        "phi1": lambda s: (np.cos(b * (s - 0.5)) - cb) / norm,
        "phi1_d": lambda s: -b * np.sin(b * (s - 0.5)) / norm,
        "phi1_dd": lambda s: -b * b * np.cos(b * (s - 0.5)) / norm,
        "phi2": lambda s: np.sin(pi * s),
        "phi2_d": lambda s: pi * np.cos(pi * s),
        "phi2_dd": lambda s: -pi * pi * np.sin(pi * s),
        "theta2": lambda s: B * np.sin(pi * s) + C * np.cosh(k * (s - 0.5)),
        "vhat": lambda s: st.C1 * s * s + st.C2 * s,
        "vhat_d": lambda s: 2 * st.C1 * s + st.C2,
        "vhat_dd": lambda s: 2 * st.C1 + 0 * s,
    }
    exps = {"phi1": phi1, "phi1_d": phi1.derivative(), "phi1_dd": phi1.derivative().derivative(),
            "phi2": phi2, "phi2_d": phi2.derivative(), "phi2_dd": phi2.derivative().derivative(),
            "theta2": theta, "vhat": vhat, "vhat_d": vhat.derivative(),
            "vhat_dd": vhat.derivative().derivative()}
    shapes = {name: Shape(name, exps[name], direct[name]) for name in direct}
    return Modes(omega1=b / math.pi, omega2=1.0, b=b, twist_B=B, twist_C=C, twist_k=k, shapes=shapes)


def ritz_omega1(st: CableStatics, n_terms: int = 60) -> float:
    """omega1 by a Rayleigh-Ritz sine series: an independent check of `irvine_root`.

    Stiffness: tau pi^2 j^2/2 delta_ij + delta^2 g_i g_j with g_j = int sin(j pi s) ds; mass m*/2.
    """
    j = np.arange(1, n_terms + 1)
    g = (1 - np.cos(j * np.pi)) / (j * np.pi)
    K = np.diag(st.tau * (j * np.pi) ** 2 / 2) + st.delta**2 * np.outer(g, g)
    M = st.m_star / 2
    w2 = np.linalg.eigvalsh(K / M)
    return float(np.sqrt(w2.min()))


def twist_peak(B: float, C: float, k: float) -> float:
    """max over s in [0, 1] of |theta2(s)| = |B sin(pi s) + C cosh(k (s - 1/2))|, the slaved twist
    per unit q2 (radians per unit modal amplitude): both terms are even about s = 1/2, so the
    extreme is at mid-span or at an end, or where theta2' = 0 between (a dense grid finds it)."""
    s = np.linspace(0.0, 1.0, 2001)
    return float(np.max(np.abs(B * np.sin(math.pi * s) + C * np.cosh(k * (s - 0.5)))))
