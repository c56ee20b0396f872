"""Galerkin projection of eqs. (19)-(20) onto N modes: the N-mode eq. (21) (`multimode.NModeODE`).

The residuals are those of `galerkin.py` (docs/model.md, M3 and M4, included), with
v = sum_i phi_i x_i over the in-plane modes, w = sum_j psi_j x_j and the slaved twist
theta = sum_j theta_j x_j over the out-of-plane ones (`modes_n.mode_set`), v_t = vhat eta f + v:

  R_v = -delta^2 int v + (delta/2) int (v_t'^2 + w'^2) + v_t'' B + tau v'' + b2 - m* v_t_tt
  R_w = w'' B + tau w'' + b3 - m* w_tt
  B   = eta f sin(alpha) - int (delta v_t - v_t'^2/2 - w'^2/2)

R_v is projected on each phi_i, R_w on each psi_j, and divided by the modal mass m* int phi^2; the
modal damping 2 xi_s omega q' is added, as for eq. (21). The modes are orthogonal in the mass, and
in the stiffness because they are eigenfunctions: the cross inertia and cross linear-stiffness
integrals are round-off, checked (<= 1e-12 of the diagonal) and dropped. Integrals that vanish by
the symmetry of the modes about s = 1/2 come out of the closed form as round-off too; they are made
the exact zeros they are when |int| <= 1e-10 int |.| (the latter by quadrature). The closed form
needs that margin: the slaved twist of w1 is dominated by C cosh(kappa (s - 1/2)) with C ~ -477
(its mean balances the end slopes, int theta = [w']/delta), so a product's exponential terms are
far larger than the product, and a zero comes out at ~2e-12 of int |.|.
"""
from __future__ import annotations

import math
from collections import defaultdict

import numpy as np

from autocable.model.aero import AeroExpansion
from autocable.model.modes_n import IN_PLANE, ModeSet
from autocable.model.multimode import NModeODE, NTerm
from autocable.model.shapes import ClosedFormIntegrator
from autocable.model.statics import CableStatics

#: Relative size below which a cross mass or a cross stiffness is round-off of zero.
ZERO_TOL = 1e-12
#: Relative size (to the integral of the absolute value) below which an integral is a zero.
INTEGRAL_ZERO_TOL = 1e-10


class Algebra:
    """Monomials in (x, x', x'', eta f, eta f', eta f'', U) for n modes: exponent tuples."""

    def __init__(self, names):
        n = len(names)
        self.n = n
        self.symbols = (tuple(names) + tuple(f"{a}dot" for a in names) + tuple(f"{a}ddot" for a in names)
                        + ("E", "Ed", "Edd", "U"))
        self.index = {s: i for i, s in enumerate(self.symbols)}
        self.zero = (0,) * len(self.symbols)

    def mono(self, **powers) -> tuple:
        e = list(self.zero)
        for name, p in powers.items():
            e[self.index[name]] = p
        return tuple(e)

    def field(self, shape: str | None, coefficient: float = 1.0, **powers) -> "Field":
        return Field({(self.mono(**powers), (shape,) if shape else ()): coefficient}, self)


class Field:
    """sum of coefficient * monomial * product of shape functions of s (sorted names)."""

    def __init__(self, terms, algebra: Algebra):
        self.terms, self.algebra = dict(terms), algebra

    def __add__(self, other: "Field") -> "Field":
        out = defaultdict(float, self.terms)
        for k, c in other.terms.items():
            out[k] += c
        return Field(out, self.algebra)

    def __mul__(self, other):
        if isinstance(other, (int, float)):
            return Field({k: c * other for k, c in self.terms.items()}, self.algebra)
        out = defaultdict(float)
        for (e1, s1), c1 in self.terms.items():
            for (e2, s2), c2 in other.terms.items():
                out[(tuple(a + b for a, b in zip(e1, e2)), tuple(sorted(s1 + s2)))] += c1 * c2
        return Field(out, self.algebra)

    __rmul__ = __mul__

    def power(self, n: int) -> "Field":
        out = self.algebra.field(None)
        for _ in range(n):
            out = out * self
        return out

    def integrate(self, integrator) -> dict:
        out = defaultdict(float)
        for (e, key), c in self.terms.items():
            out[e] += c * integrator(key)
        return dict(out)


def _total(fields) -> Field:
    fields = list(fields)
    out = fields[0]
    for f in fields[1:]:
        out = out + f
    return out


def _pmul(p1: dict, p2: dict) -> dict:
    out = defaultdict(float)
    for e1, c1 in p1.items():
        for e2, c2 in p2.items():
            out[tuple(a + b for a, b in zip(e1, e2))] += c1 * c2
    return dict(out)


def _padd(*ps: dict) -> dict:
    out = defaultdict(float)
    for p in ps:
        for e, c in p.items():
            out[e] += c
    return dict(out)


def _pscale(p: dict, a: float) -> dict:
    return {e: a * c for e, c in p.items()}


class ExactZeroIntegrator:
    """Closed-form integrals (`shapes.ClosedFormIntegrator`), with those that vanish by symmetry
    (|int| <= INTEGRAL_ZERO_TOL int |.|, the latter by Gauss-Legendre quadrature) set to exactly zero."""

    name = "closed-form"

    def __init__(self, shapes: dict, nodes: int = 128):
        self._closed = ClosedFormIntegrator(shapes)
        x, w = np.polynomial.legendre.leggauss(nodes)
        self._s, self._w = 0.5 * (x + 1.0), 0.5 * w
        self._shapes = shapes
        self._memo: dict = {}
        self.zeros = 0

    def __call__(self, key: tuple) -> float:
        if key not in self._memo:
            value = self._closed(key)
            prod = np.ones_like(self._s)
            for name in key:
                prod = prod * self._shapes[name].evaluate(self._s)
            if abs(value) <= INTEGRAL_ZERO_TOL * float(np.dot(self._w, np.abs(prod))):
                value = 0.0
                self.zeros += 1
            self._memo[key] = value
        return self._memo[key]


def _aero_field(alg: Algebra, ms: ModeSet, table: dict, nu: float) -> Field:
    """sum c_abc U^(2-b-c) theta^a (nu vdot_t)^b (nu wdot)^c (eq. 14) on the modes."""
    theta = _total(alg.field(f"{m.name}_th", **{m.name: 1}) for m in ms.out_of_plane)
    vdot = _total([alg.field(m.name, nu, **{f"{m.name}dot": 1}) for m in ms.in_plane]
                  + [alg.field("vhat", nu, Ed=1)])
    wdot = _total(alg.field(m.name, nu, **{f"{m.name}dot": 1}) for m in ms.out_of_plane)
    total = Field({}, alg)
    powers = {}
    for (a, b, c), coeff in table.items():
        if coeff == 0.0:
            continue
        for base, p in (("t", a), ("v", b), ("w", c)):
            if (base, p) not in powers:
                powers[(base, p)] = {"t": theta, "v": vdot, "w": wdot}[base].power(p)
        total = total + powers[("t", a)] * powers[("v", b)] * powers[("w", c)] * alg.field(None, coeff, U=2 - b - c)
    return total


def project_n(st: CableStatics, ms: ModeSet, aero: AeroExpansion | None, K: float, nu: float,
              xi_s: float, integrator, provenance: dict | None = None) -> NModeODE:
    """The N-mode equations as a term table, every integral taken by ``integrator``."""
    I = integrator
    names = tuple(m.name for m in ms.modes)
    alg = Algebra(names)
    n = alg.n
    d, tau, mstar, sa = st.delta, st.tau, st.m_star, math.sin(st.alpha)
    vin, vout = ms.in_plane, ms.out_of_plane

    def modal(suffix, modes, dot=""):
        return _total(alg.field(m.name + suffix, **{m.name + dot: 1}) for m in modes)

    v = modal("", vin)
    v_d, v_dd = modal("_d", vin), modal("_dd", vin)
    v_t = v + alg.field("vhat", E=1)
    v_t_d = v_d + alg.field("vhat_d", E=1)
    v_t_dd = v_dd + alg.field("vhat_dd", E=1)
    v_t_tt = modal("", vin, "ddot") + alg.field("vhat", Edd=1)
    w_d, w_dd, w_tt = modal("_d", vout), modal("_dd", vout), modal("", vout, "ddot")

    B = _padd({alg.mono(E=1): sa},
              _pscale((v_t * d + (v_t_d * v_t_d) * -0.5 + (w_d * w_d) * -0.5).integrate(I), -1.0))
    stretch = (v_t_d * v_t_d + w_d * w_d).integrate(I)
    int_v = v.integrate(I)
    b2 = _aero_field(alg, ms, aero.b2, nu) if aero is not None else None
    b3 = _aero_field(alg, ms, aero.b3, nu) if aero is not None else None

    terms, worst_cross = [], 0.0
    for e, mode in enumerate(ms.modes):
        test = alg.field(mode.name)
        if mode.plane == IN_PLANE:
            groups = {
                "structural": _padd(_pscale(int_v, -d * d * I((mode.name,))),
                                    _pscale(stretch, d / 2 * I((mode.name,))),
                                    _pmul((test * v_t_dd).integrate(I), B),
                                    _pscale((test * v_dd).integrate(I), tau)),
                "inertia": _pscale((test * v_t_tt).integrate(I), -mstar),
            }
            load = b2
        else:
            groups = {
                "structural": _padd(_pmul((test * w_dd).integrate(I), B),
                                    _pscale((test * w_dd).integrate(I), tau)),
                "inertia": _pscale((test * w_tt).integrate(I), -mstar),
            }
            load = b3
        if load is not None:
            groups["aerodynamic"] = _pscale((test * load).integrate(I), K)

        modal_mass = mstar * I((mode.name, mode.name))
        acc_key = alg.mono(**{f"{mode.name}ddot": 1})
        acc = groups["inertia"].get(acc_key, 0.0)
        if not math.isclose(-acc, modal_mass, rel_tol=1e-12):
            raise AssertionError(f"modal mass of equation {mode.name}: {-acc} != {modal_mass}")
        stiff_key = alg.mono(**{mode.name: 1})
        stiffness = abs(groups["structural"].get(stiff_key, 0.0))
        for origin, poly in groups.items():
            for ex, c in sorted(poly.items()):
                if ex == acc_key or c == 0.0:
                    continue
                powers, forcing, u_power = ex[:2 * n], ex[3 * n:3 * n + 3], ex[3 * n + 3]
                if any(ex[2 * n:3 * n]):
                    # Cross inertia: zero by mass orthogonality; anything else is a bug.
                    if sum(ex) != 1 or abs(c) > ZERO_TOL * modal_mass:
                        raise AssertionError(f"inertia coupling {ex} = {c} in equation {mode.name}")
                    worst_cross = max(worst_cross, abs(c) / modal_mass)
                    continue
                linear = origin == "structural" and sum(powers) == 1 and not any(forcing) and not u_power
                if linear and ex != stiff_key:
                    # Cross stiffness: zero because the modes are eigenfunctions of the same problem.
                    if abs(c) > ZERO_TOL * stiffness:
                        raise AssertionError(f"stiffness coupling {ex} = {c} in equation {mode.name}")
                    worst_cross = max(worst_cross, abs(c) / stiffness)
                    continue
                terms.append(NTerm(equation=e, powers=powers, forcing=forcing, u_power=u_power,
                                   coefficient=-c / modal_mass, origin="linear" if linear else origin))
        damping = tuple(1 if i == n + e else 0 for i in range(2 * n))
        terms.append(NTerm(equation=e, powers=damping, forcing=(0, 0, 0), u_power=0,
                           coefficient=2 * xi_s * mode.omega, origin="damping"))
    prov = dict(provenance or {}, integrator=getattr(integrator, "name", ""),
                orthogonality_residual=worst_cross)
    return NModeODE(modes=ms.modes, terms=tuple(terms), xi_s=xi_s, provenance=prov)
