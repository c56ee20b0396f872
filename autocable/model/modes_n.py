"""The first N linear modes of eqs. (19)-(20): trial functions for the N-mode check of eq. (21).

`modes.linear_modes` gives the two trial functions of Sect. 3 (the first symmetric in-plane mode and
the first out-of-plane mode). Here the same linear problems give as many modes as asked for:

In-plane (eq. 19_1 linearised, with the Irvine term of docs/model.md, M3),
    tau v'' - delta^2 int_0^1 v ds = m* v_tt,   v(0) = v(1) = 0,   m* = pi^2 tau:
  * symmetric modes (cos(b (s - 1/2)) - cos(b/2)) / N, omega = b / pi, with b the k-th root of
    Irvine's equation tan(b/2) = b/2 - (4/lambda^2)(b/2)^3, b/2 in ((2k-1) pi/2, (2k+1) pi/2);
  * antisymmetric modes sin(2 k pi s), omega = 2k exactly: int v = 0, so the sag term leaves them
    taut-string modes.
Out-of-plane (eq. 19_2 linearised, tau w'' = m* w_tt): sin(k pi s), omega = k, each with the twist
slaved through the quasi-static eq. (19)_3 as corrected (docs/model.md, M4: (1 + chi)):
    chi theta'' - delta^2 theta + (1 + chi) delta w'' = 0,   theta' + delta w' = 0 at s = 0, 1.
With w = sin(k pi s) and kappa = delta / sqrt(chi) the solution is
    theta = B sin(k pi s) + C cosh(kappa (s - 1/2)) + D sinh(kappa (s - 1/2)),
    B = -(1 + chi) delta (k pi)^2 / (chi (k pi)^2 + delta^2),
and the two boundary conditions, (B + delta) k pi (+-1) + theta_h'(0 or 1) = 0, split by symmetry:
for odd k (w symmetric about s = 1/2) D = 0 and C = k pi (B + delta) / (kappa sinh(kappa/2)); for
even k (w antisymmetric) C = 0 and D = -k pi (B + delta) / (kappa cosh(kappa/2)): the twist of an
antisymmetric mode has no cosh part. k = 1 is the twist of `modes.linear_modes`.

Every mode is normalised to a unit maximum of |displacement| (Sect. 5), the sine modes rising from
s = 0, the symmetric in-plane modes positive at mid-span. For the symmetric in-plane modes
max |cos(b (s - 1/2)) - c| = 1 + |c| with c = cos(b/2) (an extremum of the cosine of the opposite
sign to c lies inside the span), so N = 1 + |c|, which is 1 - c for the first mode as in
`modes.linear_modes`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq

from autocable.model.shapes import ExpPoly, Shape, cos_term, cosh_term, poly, scaled, sin_term
from autocable.model.statics import CableStatics

IN_PLANE, OUT_OF_PLANE = "in-plane", "out-of-plane"
SYMMETRIC, ANTISYMMETRIC = "symmetric", "antisymmetric"


def irvine_roots(lambda2: float, count: int) -> tuple[float, ...]:
    """The first ``count`` symmetric in-plane roots b (omega = b/pi) of Irvine's equation.

    Pole-free form cos(x)(x - 4x^3/lambda^2) - sin(x) = 0, x = b/2, one root in each interval
    ((2k-1) pi/2, (2k+1) pi/2), where the left side changes sign (it is -+1 at the ends).
    The first one is `modes.irvine_root` (same bracket, same tolerances).
    """
    def g(x):
        return math.cos(x) * (x - 4.0 * x**3 / lambda2) - math.sin(x)

    roots = []
    for k in range(1, count + 1):
        lo = (2 * k - 1) * math.pi / 2 * (1 + 1e-15)
        hi = (2 * k + 1) * math.pi / 2 * (1 - 1e-15)
        roots.append(2.0 * brentq(g, lo, hi, xtol=1e-15, rtol=1e-15, maxiter=200))
    return tuple(roots)


def sinh_term(k: float, shift: float) -> ExpPoly:
    """sinh(k (s - shift))."""
    return ExpPoly._collect([(0, complex(k), 0.5 * math.exp(-k * shift)),
                             (0, complex(-k), -0.5 * math.exp(k * shift))])


@dataclass(frozen=True)
class ModeInfo:
    """One trial function: ``name`` is also the prefix of its shapes (name, name_d, name_dd and,
    out of plane, name_th for the slaved twist)."""

    name: str                 # "v1", "v2", ... in-plane by frequency; "w1", "w2", ... out of plane
    plane: str                # IN_PLANE or OUT_OF_PLANE
    symmetry: str             # about s = 1/2: SYMMETRIC or ANTISYMMETRIC
    k: int                    # index within its (plane, symmetry) family, from 1
    omega: float              # nondimensional natural frequency (eq. 17 units)
    wavenumber: float         # b (symmetric in-plane), 2 k pi (antisymmetric in-plane), k pi (out of plane)
    twist: tuple = ()         # out of plane: (B, C, D, kappa) of the slaved twist


@dataclass(frozen=True)
class ModeSet:
    """The trial functions, in-plane first (by frequency), then out-of-plane (by k)."""

    modes: tuple[ModeInfo, ...]
    shapes: dict              # name -> Shape, including vhat, vhat_d, vhat_dd (eq. 15)

    @property
    def in_plane(self) -> tuple[ModeInfo, ...]:
        return tuple(m for m in self.modes if m.plane == IN_PLANE)

    @property
    def out_of_plane(self) -> tuple[ModeInfo, ...]:
        return tuple(m for m in self.modes if m.plane == OUT_OF_PLANE)


def _in_plane_candidates(st: CableStatics, n_in: int):
    """(omega, symmetry, k, wavenumber) of the lowest n_in in-plane modes."""
    sym = [(b / math.pi, SYMMETRIC, k + 1, b) for k, b in enumerate(irvine_roots(st.lambda2, n_in))]
    anti = [(2.0 * k, ANTISYMMETRIC, k, 2 * k * math.pi) for k in range(1, n_in + 1)]
    return sorted(sym + anti)[:n_in]


def _symmetric_in_plane(name: str, b: float):
    c = math.cos(b / 2)
    # The first mode keeps the expression of `modes.linear_modes` (1 - c, c < 0 there) bit for bit.
    norm = 1.0 - c if c < 0 else 1.0 + c
    phi = scaled(cos_term(b, 0.5), 1 / norm, poly(-c / norm))
    direct = {
        name: lambda s: (np.cos(b * (s - 0.5)) - c) / norm,
        f"{name}_d": lambda s: -b * np.sin(b * (s - 0.5)) / norm,
        f"{name}_dd": lambda s: -b * b * np.cos(b * (s - 0.5)) / norm,
    }
    return phi, direct


def _sine(name: str, kk: float):
    phi = sin_term(kk)
    direct = {
        name: lambda s: np.sin(kk * s),
        f"{name}_d": lambda s: kk * np.cos(kk * s),
        f"{name}_dd": lambda s: -kk * kk * np.sin(kk * s),
    }
    return phi, direct


def slaved_twist(st: CableStatics, k: int, twist_ends: str = "natural") -> tuple[float, float, float, float]:
    """(B, C, D, kappa) of the twist slaved to w = sin(k pi s) (module docstring). With
    ``twist_ends = "restrained"`` (theta = 0 at both ends) the particular part B sin(k pi s) already
    vanishes there, so the homogeneous part does too: C = D = 0."""
    delta, chi = st.delta, st.chi
    kp = k * math.pi
    B = -(1 + chi) * delta * kp**2 / (chi * kp**2 + delta**2)
    kappa = delta / math.sqrt(chi)
    if twist_ends == "restrained":
        return B, 0.0, 0.0, kappa
    if k % 2:
        return B, kp * (B + delta) / (kappa * math.sinh(kappa / 2)), 0.0, kappa
    return B, 0.0, -kp * (B + delta) / (kappa * math.cosh(kappa / 2)), kappa


def mode_set(st: CableStatics, n_in: int, n_out: int, twist_ends: str = "natural") -> ModeSet:
    """The lowest ``n_in`` in-plane and ``n_out`` out-of-plane modes with their shapes (the twist
    end conditions as in `modes.linear_modes`)."""
    if n_in < 1 or n_out < 1:
        raise ValueError(f"need at least one mode per plane, got n_in = {n_in}, n_out = {n_out}")
    modes, exps, direct = [], {}, {}
    for i, (omega, sym, k, wn) in enumerate(_in_plane_candidates(st, n_in), start=1):
        name = f"v{i}"
        phi, dfun = _symmetric_in_plane(name, wn) if sym == SYMMETRIC else _sine(name, wn)
        modes.append(ModeInfo(name, IN_PLANE, sym, k, omega, wn))
        exps.update({name: phi, f"{name}_d": phi.derivative(), f"{name}_dd": phi.derivative().derivative()})
        direct.update(dfun)
    for k in range(1, n_out + 1):
        name = f"w{k}"
        psi, dfun = _sine(name, k * math.pi)
        B, C, D, kappa = slaved_twist(st, k, twist_ends)
        th = scaled(sin_term(k * math.pi), B,
                    scaled(cosh_term(kappa, 0.5), C) if C else scaled(sinh_term(kappa, 0.5), D))
        modes.append(ModeInfo(name, OUT_OF_PLANE, SYMMETRIC if k % 2 else ANTISYMMETRIC, k, float(k),
                              k * math.pi, (B, C, D, kappa)))
        exps.update({name: psi, f"{name}_d": psi.derivative(), f"{name}_dd": psi.derivative().derivative(),
                     f"{name}_th": th})
        direct.update(dfun)
        direct[f"{name}_th"] = (lambda s, B=B, C=C, D=D, kp=k * math.pi, ka=kappa:
                                B * np.sin(kp * s) + C * np.cosh(ka * (s - 0.5)) + D * np.sinh(ka * (s - 0.5)))
    vhat = poly(0.0, st.C2, st.C1)
    exps.update({"vhat": vhat, "vhat_d": vhat.derivative(), "vhat_dd": vhat.derivative().derivative()})
    direct.update({"vhat": lambda s: st.C1 * s * s + st.C2 * s,
                   "vhat_d": lambda s: 2 * st.C1 * s + st.C2,
                   "vhat_dd": lambda s: 2 * st.C1 + 0 * s})
    shapes = {name: Shape(name, exps[name], direct[name]) for name in exps}
    return ModeSet(modes=tuple(modes), shapes=shapes)
