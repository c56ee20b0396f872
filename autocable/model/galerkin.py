"""Galerkin projection of eqs. (19)-(20) onto one in-plane and one out-of-plane mode: eq. (21).

The nondimensional equations (eq. 17 units, primes d/ds, dots d/dt*), with the corrections of
docs/model.md, M3 and M4, and v_t = vhat eta f + v the total in-plane displacement (Sect. 2.4):

  R1 = -delta^2 int v + (delta/2) int (v_t'^2 + w'^2) + v_t'' B + tau v'' + b2 - m* v_t_tt = 0
  R2 = w'' B + tau w'' + b3 - m* w_tt = 0
  B  = eta f sin(alpha) - int (delta v_t - v_t'^2/2 - w'^2/2)

(the quasi-static terms of R1 cancel by eq. 15, leaving Irvine's -delta^2 int v), with
v = phi1 q1, w = phi2 q2 and the slaved twist theta = theta2 q2 entering the loads b2, b3.
Each equation is projected on its own mode and divided by the modal mass m* int phi_k^2, so that
q_k'' has a unit coefficient; modal damping 2 xi_s omega_k q_k' is added (Sect. 3), replacing
the viscous terms (the damping of the quasi-static motion is therefore not modelled).

Modelling choices, explicit: the twist is the linear slaved field of the out-of-plane mode (the
trial functions of Sect. 3); the mean aerodynamic load is left to the static state (see aero.py).

Every integral is computed by a pluggable integrator (`shapes.ClosedFormIntegrator` or
`shapes.QuadratureIntegrator`), so the whole table can be computed two independent ways.
"""
from __future__ import annotations

import math
from collections import defaultdict

from autocable.model.aero import AeroExpansion
from autocable.model.equations import Term, TwoModeODE
from autocable.model.modes import Modes
from autocable.model.statics import CableStatics

# Symbols of the projection, in the order of the exponent tuples below.
SYMBOLS = ("q1", "q2", "q1dot", "q2dot", "q1ddot", "q2ddot", "E", "Ed", "Edd", "U")
_INDEX = {name: i for i, name in enumerate(SYMBOLS)}
_ZERO = (0,) * len(SYMBOLS)


def _mono(**powers) -> tuple:
    e = list(_ZERO)
    for name, p in powers.items():
        e[_INDEX[name]] = p
    return tuple(e)


def _add_exp(a: tuple, b: tuple) -> tuple:
    return tuple(x + y for x, y in zip(a, b))


class Field:
    """sum of coefficient * monomial(symbols) * product of shape functions of s (a sorted key)."""

    def __init__(self, terms=None):
        self.terms = dict(terms or {})

    @staticmethod
    def of(shape: str | None, coefficient: float = 1.0, **powers) -> "Field":
        key = (shape,) if shape else ()
        return Field({(_mono(**powers), key): coefficient})

    def __add__(self, other: "Field") -> "Field":
        out = defaultdict(float, self.terms)
        for k, c in other.terms.items():
            out[k] += c
        return Field(out)

    def __mul__(self, other):
        if isinstance(other, (int, float)):
            return Field({k: c * other for k, c in self.terms.items()})
        out = defaultdict(float)
        for (e1, s1), c1 in self.terms.items():
            for (e2, s2), c2 in other.terms.items():
                out[(_add_exp(e1, e2), tuple(sorted(s1 + s2)))] += c1 * c2
        return Field(out)

    __rmul__ = __mul__

    def power(self, n: int) -> "Field":
        out = Field.of(None)
        for _ in range(n):
            out = out * self
        return out

    def integrate(self, integrator) -> dict:
        """int_0^1 ds: a polynomial {exponents: number}."""
        out = defaultdict(float)
        for (e, key), c in self.terms.items():
            out[e] += c * integrator(key)
        return dict(out)


def _pmul(p1: dict, p2: dict) -> dict:
    out = defaultdict(float)
    for e1, c1 in p1.items():
        for e2, c2 in p2.items():
            out[_add_exp(e1, e2)] += c1 * c2
    return dict(out)


def _padd(*ps: dict) -> dict:
    out = defaultdict(float)
    for p in ps:
        for e, c in p.items():
            out[e] += c
    return dict(out)


def _pscale(p: dict, a: float) -> dict:
    return {e: a * c for e, c in p.items()}


#: Appendix A names (eqs. 26-27), by (equation, powers of q1 q2 q1' q2', powers of eta f, eta f',
#: eta f'', power of U). ASCII: zeta, xi; a bar is "_bar". Where the derivation's U or eta
#: dependence differs from the printed one, the derived term keeps the name (see NAME_NOTES).
APPENDIX_NAMES = {
    (1, (0, 0, 1, 0), (0, 0, 0), 1): "zeta11", (1, (0, 0, 1, 0), (0, 2, 0), -1): "zeta12",
    (1, (0, 0, 1, 0), (0, 1, 0), 0): "zeta13",
    (1, (1, 0, 0, 0), (1, 0, 0), 0): "k11", (1, (1, 0, 0, 0), (2, 0, 0), 0): "k12",
    (1, (0, 1, 0, 0), (0, 0, 0), 2): "k21", (1, (0, 1, 0, 0), (0, 2, 0), 0): "k22",
    (1, (0, 1, 0, 0), (0, 1, 0), 1): "k23",
    (1, (0, 0, 0, 1), (0, 1, 0), 0): "zeta21", (1, (0, 0, 0, 1), (0, 0, 0), 1): "zeta22",
    (1, (0, 0, 0, 1), (0, 2, 0), -1): "zeta23",
    (1, (2, 0, 0, 0), (0, 0, 0), 0): "k31", (1, (2, 0, 0, 0), (1, 0, 0), 0): "k32",
    (1, (0, 2, 0, 0), (0, 0, 0), 0): "k51", (1, (0, 2, 0, 0), (1, 0, 0), 0): "k52",
    (1, (0, 2, 0, 0), (0, 0, 0), 2): "k53", (1, (0, 2, 0, 0), (0, 1, 0), 1): "k54",
    (1, (3, 0, 0, 0), (0, 0, 0), 0): "k4", (1, (0, 3, 0, 0), (0, 0, 0), 2): "k6",
    (1, (1, 2, 0, 0), (0, 0, 0), 0): "k7",
    (1, (0, 0, 2, 0), (0, 1, 0), -1): "zeta61", (1, (0, 0, 2, 0), (0, 0, 0), 0): "zeta62",
    (1, (0, 0, 1, 1), (0, 0, 0), 0): "zeta31", (1, (0, 0, 1, 1), (0, 1, 0), -1): "zeta32",
    (1, (0, 0, 0, 2), (0, 0, 0), 0): "zeta19", (1, (0, 0, 0, 2), (0, 1, 0), -1): "zeta22_bar",
    (1, (0, 1, 1, 0), (0, 1, 0), 0): "zeta41", (1, (0, 1, 1, 0), (0, 0, 0), 1): "zeta42",
    (1, (0, 1, 0, 1), (0, 0, 0), 1): "zeta51", (1, (0, 1, 0, 1), (0, 1, 0), 0): "zeta52",
    (1, (0, 0, 3, 0), (0, 0, 0), -1): "zeta8", (1, (0, 0, 0, 3), (0, 0, 0), -1): "zeta21_bar",
    (1, (0, 1, 2, 0), (0, 0, 0), 0): "zeta12_bar", (1, (0, 2, 1, 0), (0, 0, 0), 1): "zeta13_bar",
    (1, (0, 1, 0, 2), (0, 0, 0), 0): "zeta14", (1, (0, 2, 0, 1), (0, 0, 0), 1): "zeta15",
    (1, (0, 1, 1, 1), (0, 0, 0), 0): "zeta16", (1, (0, 0, 2, 1), (0, 0, 0), -1): "zeta17",
    (1, (0, 0, 0, 0), (2, 0, 0), 0): "k01", (1, (0, 0, 0, 0), (3, 0, 0), 0): "k02",
    (1, (0, 0, 0, 0), (0, 1, 0), 1): "zeta01", (1, (0, 0, 0, 0), (0, 3, 0), -1): "zeta02",
    (1, (0, 0, 0, 0), (0, 0, 1), 0): "m0",
    (2, (0, 0, 1, 0), (0, 1, 0), 0): "xi1", (2, (0, 0, 1, 0), (0, 0, 0), 1): "xi12",
    (2, (0, 0, 1, 0), (0, 2, 0), -1): "xi13",
    (2, (0, 0, 0, 1), (0, 0, 0), 1): "xi21", (2, (0, 0, 0, 1), (0, 1, 0), 0): "xi22",
    (2, (0, 0, 0, 1), (0, 2, 0), -1): "xi23",
    (2, (0, 1, 0, 0), (1, 0, 0), 0): "h11", (2, (0, 1, 0, 0), (2, 0, 0), 0): "h12",
    (2, (0, 1, 0, 0), (0, 1, 0), 1): "h13", (2, (0, 1, 0, 0), (0, 0, 0), 2): "h14",
    (2, (0, 1, 0, 0), (0, 2, 0), 0): "h15",
    (2, (0, 2, 0, 0), (0, 0, 0), 2): "h21", (2, (0, 2, 0, 0), (0, 1, 0), 1): "h22",
    (2, (1, 1, 0, 0), (0, 0, 0), 0): "h41", (2, (1, 1, 0, 0), (1, 0, 0), 0): "h42",
    (2, (0, 3, 0, 0), (0, 0, 0), 0): "h31", (2, (0, 3, 0, 0), (0, 0, 0), 2): "h32",
    (2, (2, 1, 0, 0), (0, 0, 0), 0): "h5",
    (2, (0, 0, 2, 0), (0, 0, 0), 0): "xi61", (2, (0, 0, 2, 0), (0, 1, 0), -1): "xi62",
    (2, (0, 0, 0, 2), (0, 0, 0), 0): "xi71", (2, (0, 0, 0, 2), (0, 1, 0), -1): "xi72",
    (2, (0, 1, 1, 0), (0, 0, 0), 1): "xi41", (2, (0, 1, 1, 0), (0, 1, 0), 0): "xi42",
    (2, (0, 1, 0, 1), (0, 1, 0), 0): "xi51", (2, (0, 1, 0, 1), (0, 0, 0), 1): "xi52",
    (2, (0, 0, 1, 1), (0, 0, 0), 0): "xi81", (2, (0, 0, 1, 1), (0, 1, 0), -1): "xi82",
    (2, (0, 2, 0, 1), (0, 0, 0), 1): "xi15", (2, (0, 1, 1, 1), (0, 0, 0), 0): "xi16",
    (2, (0, 2, 1, 0), (0, 0, 0), 1): "xi9", (2, (0, 1, 2, 0), (0, 0, 0), 0): "xi10",
    (2, (0, 0, 3, 0), (0, 0, 0), -1): "xi11_bar", (2, (0, 0, 2, 1), (0, 0, 0), -1): "xi12_bar",
    (2, (0, 1, 0, 2), (0, 0, 0), 0): "xi13_bar", (2, (0, 0, 1, 2), (0, 0, 0), -1): "xi14",
    (2, (0, 0, 0, 3), (0, 0, 0), -1): "xi17",
    (2, (0, 0, 0, 0), (0, 2, 0), 0): "xi01", (2, (0, 0, 0, 0), (0, 1, 0), 1): "xi02",
    (2, (0, 0, 0, 0), (0, 3, 0), -1): "xi03",
}

#: Where the derived term differs in form from the printed Appendix A.
NAME_NOTES = {
    "zeta15": "printed as zeta15 q2^2 q2' without U; the load theta^2 wdot is linear in velocity, so U^1",
    "zeta22_bar": "printed as zeta22_bar/U q2'^2; the derived term is zeta22_bar eta f'/U q2'^2 "
                  "(vdot wdot^2 with vdot = vhat eta f')",
}


def _aero_field(table: dict, nu: float) -> Field:
    """sum c_abc U^(2-b-c) theta^a (nu vdot_t)^b (nu wdot)^c on the modes (eq. 14)."""
    theta = Field.of("theta2", q2=1)
    vdot = Field.of("phi1", nu, q1dot=1) + Field.of("vhat", nu, Ed=1)
    wdot = Field.of("phi2", nu, q2dot=1)
    total = Field()
    for (a, b, c), coeff in table.items():
        if coeff == 0.0:
            continue
        total = total + theta.power(a) * vdot.power(b) * wdot.power(c) * Field.of(None, coeff, U=2 - b - c)
    return total


def aero_scales(spec_aero, cable, st: CableStatics) -> tuple[float, float]:
    """(K, nu): the nondimensional load scale K = rho_a L U_c^2 l / (2 EA) (eq. 17: b* = l b / EA)
    and the velocity ratio nu = omega l / U_c that turns d/dt* velocities into units of U_c."""
    L = cable.diameter_m if spec_aero.load_length == "diameter" else cable.diameter_m / 2
    Uc = spec_aero.critical_wind_speed_m_s
    K = spec_aero.air_density_kg_m3 * L * Uc**2 * cable.length_m / (2 * cable.axial_stiffness_N)
    nu = st.omega_ref * cable.length_m / Uc
    return K, nu


def project(st: CableStatics, modes: Modes, aero: AeroExpansion | None, K: float, nu: float,
            xi_s: float, integrator, provenance: dict | None = None) -> TwoModeODE:
    """The two-mode ODE (21) as a term table, every integral taken by ``integrator``."""
    I = integrator
    d, tau, ms, sa = st.delta, st.tau, st.m_star, math.sin(st.alpha)
    v = Field.of("phi1", q1=1)
    v_t = v + Field.of("vhat", E=1)
    v_t_d = Field.of("phi1_d", q1=1) + Field.of("vhat_d", E=1)
    v_t_dd = Field.of("phi1_dd", q1=1) + Field.of("vhat_dd", E=1)
    v_dd = Field.of("phi1_dd", q1=1)
    v_t_tt = Field.of("phi1", q1ddot=1) + Field.of("vhat", Edd=1)
    w_d = Field.of("phi2_d", q2=1)
    w_dd = Field.of("phi2_dd", q2=1)
    w_tt = Field.of("phi2", q2ddot=1)
    phi1, phi2 = Field.of("phi1"), Field.of("phi2")

    B = _padd({_mono(E=1): sa},
              _pscale((v_t * d + (v_t_d * v_t_d) * -0.5 + (w_d * w_d) * -0.5).integrate(I), -1.0))
    stretch = (v_t_d * v_t_d + w_d * w_d).integrate(I)

    int_phi1 = I(("phi1",))
    groups1 = {
        "structural": _padd(_pscale(v.integrate(I), -d * d * int_phi1),
                            _pscale(stretch, d / 2 * int_phi1),
                            _pmul((phi1 * v_t_dd).integrate(I), B),
                            _pscale((phi1 * v_dd).integrate(I), tau)),
        "inertia": _pscale((phi1 * v_t_tt).integrate(I), -ms),
    }
    groups2 = {
        "structural": _padd(_pmul((phi2 * w_dd).integrate(I), B), _pscale((phi2 * w_dd).integrate(I), tau)),
        "inertia": _pscale((phi2 * w_tt).integrate(I), -ms),
    }
    if aero is not None:
        groups1["aerodynamic"] = _pscale((phi1 * _aero_field(aero.b2, nu)).integrate(I), K)
        groups2["aerodynamic"] = _pscale((phi2 * _aero_field(aero.b3, nu)).integrate(I), K)

    terms = []
    omegas = (modes.omega1, modes.omega2)
    for k, groups, test in ((1, groups1, ("phi1", "phi1")), (2, groups2, ("phi2", "phi2"))):
        modal_mass = ms * I(test)
        acc_key = _mono(**{f"q{k}ddot": 1})
        acc = groups["inertia"].get(acc_key, 0.0)
        if not math.isclose(-acc, modal_mass, rel_tol=1e-12):
            raise AssertionError(f"modal mass of equation {k}: {-acc} != {modal_mass}")
        for origin, poly in groups.items():
            for e, c in sorted(poly.items()):
                if e == acc_key or c == 0.0:
                    continue
                if e[_INDEX["q1ddot"]] or e[_INDEX["q2ddot"]]:
                    raise AssertionError(f"unexpected inertia coupling {e} in equation {k}")
                powers = e[0:4]
                forcing = e[6:9]
                u_power = e[9]
                key = (k, powers, forcing, u_power)
                kind = origin
                if origin == "structural" and sum(powers) == 1 and not any(forcing) \
                        and powers[k - 1] == 1:
                    kind = "linear"
                terms.append(Term(equation=k, powers=powers, forcing=forcing, u_power=u_power,
                                  coefficient=-c / modal_mass, origin=kind,
                                  name=APPENDIX_NAMES.get(key, "")))
        damping_powers = (0, 0, 1, 0) if k == 1 else (0, 0, 0, 1)
        terms.append(Term(equation=k, powers=damping_powers, forcing=(0, 0, 0), u_power=0,
                          coefficient=2 * xi_s * omegas[k - 1], origin="damping"))
    return TwoModeODE(terms=tuple(terms), omega1=modes.omega1, omega2=modes.omega2, xi_s=xi_s,
                      provenance=dict(provenance or {}, integrator=integrator.name))


def linear_aero_matrix(integrator, K: float, nu: float, m_star: float, lin: dict) -> dict:
    """The linear aerodynamic terms of eq. (21) at U = 1 from first-order load coefficients ``lin``
    (keys (component, monomial)), for calibration: {(equation, state index): coefficient}."""
    I = integrator
    out = {}
    for k, test, comp in ((1, "phi1", 2), (2, "phi2", 3)):
        mass_norm = m_star * I((test, test))
        out[(k, 2)] = -K * nu * lin[(comp, (0, 1, 0))] * I(tuple(sorted((test, "phi1")))) / mass_norm
        out[(k, 3)] = -K * nu * lin[(comp, (0, 0, 1))] * I(tuple(sorted((test, "phi2")))) / mass_norm
        out[(k, 1)] = -K * lin[(comp, (1, 0, 0))] * I(tuple(sorted((test, "theta2")))) / mass_norm
    return out
