"""Eq. (21): the Galerkin table, computed two independent ways, and its physics checks."""
import math
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from autocable.model import aero as aero_mod
from autocable.model.derive import derive
from autocable.spec import load_model
from conftest import SAMPLE



@pytest.fixture(scope="module")
def closed():
    return derive(load_model(SAMPLE), integrator="closed-form", use_cache=False)


@pytest.fixture(scope="module")
def quad():
    return derive(load_model(SAMPLE), integrator="quadrature", use_cache=False)


def test_two_integrators_agree_to_1e8(closed, quad):
    a, b = closed.ode.coefficients(), quad.ode.coefficients()
    assert set(a) == set(b)
    assert len(a) > 70
    scale = {k: max(abs(a[k]), abs(b[k])) for k in a}
    worst = max(abs(a[k] - b[k]) / scale[k] for k in a if scale[k] > 0)
    assert worst < 1e-8


def test_linear_terms_are_the_modal_frequencies(closed):
    ode = closed.ode
    (k1,) = ode.find(1, (1, 0, 0, 0))
    (k2,) = ode.find(2, (0, 1, 0, 0), u_power=0)
    assert k1.coefficient == pytest.approx(ode.omega1**2, rel=1e-12)
    assert k2.coefficient == pytest.approx(1.0, rel=1e-12)      # omega2 = 1 by construction
    (d1,) = ode.find(1, (0, 0, 1, 0), u_power=0)
    assert d1.origin == "damping" and d1.coefficient == pytest.approx(2 * 0.004 * ode.omega1)


def test_trivial_solution_loses_stability_at_U_1(closed):
    """Calibrated rivulet angle: the largest growth rate of the linearised eq. (21) at eta = 0
    crosses zero at U* = 1 (bisection to 1e-10), through the in-plane mode."""
    ode = closed.ode

    def growth(U):
        return max(np.linalg.eigvals(ode.linear_matrix(U)).real)

    lo, hi = 0.9, 1.1
    assert growth(lo) < 0 < growth(hi)
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if growth(mid) < 0 else (lo, mid)
    assert abs(0.5 * (lo + hi) - 1.0) < 1e-6
    lam, vec = np.linalg.eig(ode.linear_matrix(1.0))
    i = int(np.argmax(lam.real))
    assert abs(vec[1, i]) < 1e-6 * abs(vec[0, i])          # in-plane: mono-modal onset (Fig. 3)
    # the out-of-plane pair stays damped over the wind range of Sect. 5
    for U in np.linspace(0, 1.3, 27):
        lam, vec = np.linalg.eig(ode.linear_matrix(U))
        for l, v in zip(lam, vec.T):
            if abs(v[1]) > abs(v[0]):
                assert l.real < 0


def test_no_wind_means_no_aerodynamic_term(closed):
    ode = closed.ode
    aero_terms = [t for t in ode.terms if t.origin == "aerodynamic"]
    assert aero_terms and any(t.u_power < 0 for t in aero_terms)
    for t in aero_terms:
        assert t.factor(0.0, 1e-3, 0.3, 0.2, -0.1) == 0.0
    state = (1e-3, 2e-3, -1e-3, 5e-4)
    a0 = ode.accelerations(state, 0.0, 1e-3, 0.3, 0.2, -0.1)
    assert np.all(np.isfinite(a0))
    # the U -> 0 limit is not continuous (1/U terms) but U = 0 is defined: no wind, no load
    a_small = ode.accelerations(state, 1e-9, 1e-3, 0.3, 0.2, -0.1)
    assert not np.allclose(a0, a_small)


@pytest.mark.slow
def test_cubic_expansion_matches_exact_load_to_fourth_order(closed):
    """Eq. (14): the expanded load differs from eqs. (9)-(13) by O(|x|^4), with U symbolic."""
    spec = closed.spec
    b2, b3 = aero_mod.quasi_steady_load()
    subs = {aero_mod.ALPHA: closed.statics.alpha, aero_mod.BETA: closed.beta,
            aero_mod.THETA0: closed.theta0}
    subs.update(dict(zip(aero_mod.A_SYMS, spec.aero.lift)))
    subs.update(dict(zip(aero_mod.B_SYMS, spec.aero.drag)))
    exp = aero_mod.expand_load(spec.aero.lift, spec.aero.drag, closed.statics.alpha, closed.beta, closed.theta0)
    direction = (0.3, -0.5, 0.4)
    for comp, exact in ((2, b2), (3, b3)):
        f_exact = sp.lambdify((aero_mod.TH, aero_mod.VD, aero_mod.WD, aero_mod.U), exact.subs(subs))
        poly = sp.lambdify((aero_mod.TH, aero_mod.VD, aero_mod.WD, aero_mod.U), exp.polynomial(comp))
        U = 0.7
        static = f_exact(0, 0, 0, U)
        errors = []
        for h in (2e-2, 1e-2):
            x = [h * d for d in direction]
            errors.append(abs(f_exact(*x, U) - static - poly(*x, U)))
        order = math.log(errors[0] / errors[1], 2)
        assert 3.6 < order < 4.4, (comp, errors)


def test_derivation_reports_terms_not_in_eq21(closed):
    """Terms the derivation produces that eq. (21) does not list are kept and named by monomial."""
    extra = [t.label for t in closed.ode.terms if not t.name and t.origin not in ("linear", "damping")]
    assert "eq1:eta^2*fdot^2" in extra          # aerodynamic, absent from Gamma_{1,23}


def test_quasi_static_inertia_m0(closed):
    """m0 = -int(phi1 vhat) / int(phi1^2) (the support motion's inertia -m* vhat eta f'' projected,
    on the paper's right-hand side), computed here: Irvine's phi1 (`_hand_modes`) and eq. (15)'s
    quasi-static shape vhat = C1 s^2 + C2 s with C1 = 3 delta (delta cos a - 2 sin a) / (12 tau +
    delta^2), C2 = cos a - C1 (eq. 16 with docs/model.md M2's 12 H^3 cos alpha: vhat(1) = cos a)."""
    import tomllib

    from scipy.integrate import quad
    (m0,) = closed.ode.find(1, (0, 0, 0, 0), (0, 0, 1))
    delta, tau, (M1, I1, P1, _, _) = _hand_modes(SAMPLE)
    a = math.radians(tomllib.loads(SAMPLE.read_text())["cable"]["chord_slope_deg"])
    C1 = 3 * delta * (delta * math.cos(a) - 2 * math.sin(a)) / (12 * tau + delta ** 2)
    C2 = math.cos(a) - C1
    b = math.pi * closed.ode.omega1
    norm = 1 - math.cos(b / 2)
    overlap = quad(lambda s: (math.cos(b * (s - 0.5)) - math.cos(b / 2)) / norm * (C1 * s * s + C2 * s),
                   0.0, 1.0, epsabs=1e-14, epsrel=1e-13)[0]
    assert m0.name == "m0"
    assert m0.appendix_value == pytest.approx(-overlap / M1, rel=1e-11)
    assert m0.coefficient == pytest.approx(overlap / M1, rel=1e-11)     # moved to the left-hand side


def test_cache_round_trip(closed, tmp_path, monkeypatch):
    monkeypatch.setenv("AUTOCABLE_CACHE", str(tmp_path))
    spec = load_model(SAMPLE)
    first = derive(spec)
    second = derive(spec)
    assert not first.from_cache and second.from_cache
    assert second.ode == first.ode == closed.ode
    assert second.theta0 == first.theta0


def test_sample_yaw_is_the_decoupled_one(closed):
    """The spec's yaw is the member of the U_c family with no linear in-plane -> out-of-plane load."""
    from autocable.model.calibration import decoupled_angles
    from autocable.model.galerkin import aero_scales
    from autocable.model.modes import linear_modes
    from autocable.model.shapes import ClosedFormIntegrator
    spec, st = closed.spec, closed.statics
    modes = linear_modes(st)
    K, nu = aero_scales(spec.aero, spec.cable, st)
    beta, theta0 = decoupled_angles(spec.aero, st, modes, ClosedFormIntegrator(modes.shapes), K, nu,
                                    spec.cable.damping_ratio)
    assert spec.aero.yaw_deg == pytest.approx(beta, abs=1e-6)
    assert math.degrees(closed.theta0) == pytest.approx(theta0, abs=1e-4)
    c = closed.ode.coefficients()
    assert c["zeta11"] == pytest.approx(-2 * spec.cable.damping_ratio * closed.ode.omega1, rel=1e-6)
    assert abs(c.get("xi12", 0.0)) < 1e-8


@pytest.mark.slow
def test_literal_eq12_convention_gives_subcritical_galloping(closed):
    """Why the sample spec reads the coefficient curves the other way ("mirrored"): with eq. (12) as
    printed, every member of the U_c family (zeta11 = -2 xi_s omega1) at beta = -90, -60, ..., 90 deg
    has zeta8 < 0 (subcritical galloping, against Fig. 3); with the mirrored sense the sample's
    zeta8 > 0 and eq. (25)'s branch exists above U = 1. Not every beta of the literal sense is subcritical: see
    tests/test_calibration.py::test_literal_sense_can_gallop_supercritically (beta = 15 deg)."""
    from autocable.model.aero import expand_load, linear_load
    from autocable.model.galerkin import aero_scales, linear_aero_matrix
    from autocable.model.modes import linear_modes
    from autocable.model.shapes import ClosedFormIntegrator
    from scipy.optimize import brentq
    spec, st = closed.spec, closed.statics
    modes = linear_modes(st)
    I = ClosedFormIntegrator(modes.shapes)
    K, nu = aero_scales(spec.aero, spec.cable, st)
    target = -2 * spec.cable.damping_ratio * modes.omega1
    i11, i14 = I(("phi1", "phi1")), I(("phi1", "phi1", "phi1", "phi1"))
    found = 0
    for beta_deg in range(-90, 91, 30):
        beta = math.radians(beta_deg)

        def zeta11(th):
            lin = linear_load(spec.aero.lift, spec.aero.drag, st.alpha, beta, th, "eq12")
            return linear_aero_matrix(I, K, nu, st.m_star, lin)[(1, 2)] - target

        grid = np.radians(np.arange(-89.0, 89.1, 1.0))
        vals = [zeta11(t) for t in grid]
        for t0, t1, f0, f1 in zip(grid[:-1], grid[1:], vals[:-1], vals[1:]):
            if f0 * f1 < 0:
                th = brentq(zeta11, t0, t1)
                exp = expand_load(spec.aero.lift, spec.aero.drag, st.alpha, beta, th, "eq12")
                zeta8 = -K * nu**3 * exp.b2[(0, 3, 0)] * i14 / (st.m_star * i11)
                assert zeta8 < 0, (beta_deg, math.degrees(th))
                found += 1
    assert found >= 5
    assert closed.spec.aero.angle_convention == "mirrored"      # frame indifferent (docs/model.md, M11)
    assert closed.ode.coefficients()["zeta8"] > 0


def test_calibration_is_invertible(closed):
    """Given Theta0, calibrating the yaw gives back the spec's yaw; the Theta0 scan found two valid
    roots (-13.88 and 67.25 deg; 69.12 with the legacy sense, whose out-of-plane terms differ) and
    kept the smaller."""
    from dataclasses import replace
    spec = closed.spec
    other = replace(spec, aero=replace(spec.aero, yaw_deg=None,
                                       rivulet_angle_deg=math.degrees(closed.theta0)))
    d = derive(other, use_cache=False)
    assert d.calibrated == "yaw_deg"
    assert math.degrees(d.beta) == pytest.approx(spec.aero.yaw_deg, abs=1e-8)
    roots = sorted(r for r, why in closed.calibration_roots if not why)
    assert roots == pytest.approx([-13.8794, 67.2494], abs=1e-3)       # regression pins
    assert math.degrees(closed.theta0) == pytest.approx(roots[0], abs=1e-9)


# ------------------------------------------------------------------------------------------------
# Independent checks of eq. (21)'s structural coefficients: derived here by hand from eq. (19) with
# the corrections the model follows (the Irvine term of docs/model.md, M3; the twist, slaved through
# eq. (19)_3 with (1 + chi), enters eqs. (19)_1,2 only through the aerodynamic loads), with the mode
# shapes written out here from Irvine's equation, not taken from autocable.model.modes.
#
# At eta = 0 without loads, eqs. (19)_1,2 with the Irvine term are
#     m* v_tt = tau v'' + (v'' + delta) e,    m* w_tt = tau w'' + w'' e,
#     e(t) = int_0^1 (v'^2 / 2 + w'^2 / 2 - delta v) ds   (the dynamic axial strain),
# m* = pi^2 tau. With v = q1 phi1, w = q2 phi2, phi2 = sin(pi s), Galerkin projection gives
#     m* M1 q1'' + tau I1 q1 + (I1 q1 - delta P1) e = 0,   m* M2 q2'' + tau I2 q2 + I2 q2 e = 0,
#     e = I1 q1^2 / 2 + I2 q2^2 / 2 - delta P1 q1,
# Mk = int phik^2, Ik = int phik'^2, P1 = int phi1. Divided by m* Mk (eq. 21's normalisation):
#     omega1^2 = (tau I1 + delta^2 P1^2) / (m* M1),  k31 = -3 delta P1 I1 / (2 m* M1),
#     k51 = -delta P1 I2 / (2 m* M1),  k4 = I1^2 / (2 m* M1),  k7 = I1 I2 / (2 m* M1),
#     h41 = -delta P1 I2 / (m* M2),  h5 = I1 I2 / (2 m* M2),  h31 = I2^2 / (2 m* M2) = pi^2 / (4 tau).
# They derive from the potential V = (m* / 2)(tau I1 q1^2 + ...) + e^2 / 2, hence the reciprocity
# relations k7 M1 = h5 M2 and 2 k51 M1 = h41 M2 (and, with the support motion, 2 k52 M1 = h42 M2).
# ------------------------------------------------------------------------------------------------
def _hand_modes(spec_path):
    """delta, tau, and (M1, I1, P1, M2, I2) of phi1 = (cos(b (s - 1/2)) - cos(b/2)) / (1 - cos(b/2))
    (Irvine's symmetric mode, unit maximum, b from tan(b/2) = b/2 - (4 / lambda^2)(b/2)^3) and
    phi2 = sin(pi s), from the model file's numbers (Sect. 2.1 statics)."""
    import tomllib

    from scipy.integrate import quad
    from scipy.optimize import brentq

    cable = tomllib.loads(Path(spec_path).read_text())["cable"]
    a = math.radians(cable["chord_slope_deg"])
    H, l = cable["horizontal_tension_N"], cable["length_m"]
    delta = cable["mass_per_length_kg_m"] * cable["gravity_m_s2"] * math.cos(a) ** 2 / H * l
    tau = H / math.cos(a) / cable["axial_stiffness_N"]
    lam2 = delta ** 2 / tau
    x = brentq(lambda x: math.cos(x) * (x - 4 * x ** 3 / lam2) - math.sin(x), math.pi / 2 * (1 + 1e-15),
               3 * math.pi / 2 * (1 - 1e-15), xtol=1e-15, rtol=1e-15)
    b = 2 * x
    norm = 1 - math.cos(b / 2)

    def integral(fn):
        return quad(fn, 0.0, 1.0, epsabs=1e-14, epsrel=1e-13, limit=200)[0]

    M1 = integral(lambda s: ((math.cos(b * (s - 0.5)) - math.cos(b / 2)) / norm) ** 2)
    I1 = integral(lambda s: (b * math.sin(b * (s - 0.5)) / norm) ** 2)
    P1 = integral(lambda s: (math.cos(b * (s - 0.5)) - math.cos(b / 2)) / norm)
    return delta, tau, (M1, I1, P1, 0.5, math.pi ** 2 / 2)


def _hand_coefficients(delta, tau, integrals):
    M1, I1, P1, M2, I2 = integrals
    ms = math.pi ** 2 * tau
    return {"omega1^2": (tau * I1 + delta ** 2 * P1 ** 2) / (ms * M1),
            "k31": -1.5 * delta * P1 * I1 / (ms * M1), "k51": -0.5 * delta * P1 * I2 / (ms * M1),
            "k4": 0.5 * I1 ** 2 / (ms * M1), "k7": 0.5 * I1 * I2 / (ms * M1),
            "h41": -delta * P1 * I2 / (ms * M2), "h5": 0.5 * I1 * I2 / (ms * M2),
            "h31": 0.5 * I2 ** 2 / (ms * M2)}


def _named(ode):
    return {t.name: t.coefficient for t in ode.terms if t.name}


@pytest.mark.parametrize("which", ["closed", "quad"])
def test_structural_coefficients_derived_by_hand_from_eq19(which, request):
    """Every structural term of eq. (21) at eta = 0 against the hand derivation above (Irvine's
    mode shape, quadrature of its integrals here): 1e-12 relative, for both integrators."""
    ode = request.getfixturevalue(which).ode
    hand = _hand_coefficients(*_hand_modes(SAMPLE))
    got = _named(ode)
    assert ode.omega1 ** 2 == pytest.approx(hand.pop("omega1^2"), rel=1e-12)
    for name, value in hand.items():
        assert got[name] == pytest.approx(value, rel=1e-12 if which == "closed" else 1e-8), name
    # Nothing else structural and unforced: eq. (21)'s conservative part is exactly these.
    structural = {t.name for t in ode.terms if t.origin == "structural" and t.forcing == (0, 0, 0)}
    assert structural == set(hand)


def test_reciprocity_of_the_structural_terms(closed):
    """The structural terms derive from a potential, so the cross terms of the two equations are
    related through the modal masses M1 = int phi1^2 (computed here), M2 = int sin^2(pi s) = 1/2:
    k7 M1 = h5 M2 (from q1^2 q2^2 in V), 2 k51 M1 = h41 M2 (from q1 q2^2), and for the support
    motion's parametric terms 2 k52 M1 = h42 M2 (from eta f q1 q2^2)."""
    c = _named(closed.ode)
    _, _, (M1, _, _, M2, _) = _hand_modes(SAMPLE)
    assert M2 / M1 == pytest.approx(1.000568855, rel=1e-9)    # not 1: the relations see M1 != M2
    assert c["k7"] * M1 == pytest.approx(c["h5"] * M2, rel=1e-12)
    assert 2 * c["k51"] * M1 == pytest.approx(c["h41"] * M2, rel=1e-12)
    assert 2 * c["k52"] * M1 == pytest.approx(c["h42"] * M2, rel=1e-12)


def test_taut_string_limit(tmp_path):
    """delta -> 0 (gravity 1e-3 of the sample's: delta = 1.3e-5, lambda^2 = 1e-7): the in-plane mode
    becomes sin(pi s) and eq. (21) the taut string's, whose cubic coefficients are known in closed
    form: k4 = k7 = h5 = h31 = pi^2 / (4 tau) (uniform stretching e = pi^2 (q1^2 + q2^2) / 4), and
    omega1 -> 1; the quadratic ones vanish like delta: k31 -> -3 delta / (pi tau),
    k51 -> -delta / (pi tau), h41 -> -2 delta / (pi tau) (P1 -> 2 / pi, I1 -> pi^2 / 2).
    The corrections are O(lambda^2) = 1e-7 relative."""
    text = SAMPLE.read_text()
    assert "gravity_m_s2 = 9.81 " in text
    taut = tmp_path / "taut.toml"
    taut.write_text(text.replace("gravity_m_s2 = 9.81 ", "gravity_m_s2 = 0.00981 "))
    d = derive(load_model(taut), integrator="closed-form", use_cache=False)
    delta, tau = d.statics.delta, d.statics.tau
    assert delta == pytest.approx(_hand_modes(taut)[0], rel=1e-13) and delta < 2e-5
    c = _named(d.ode)
    string = math.pi ** 2 / (4 * tau)
    for name in ("k4", "k7", "h5", "h31"):
        assert c[name] == pytest.approx(string, rel=1e-6), name
    assert d.ode.omega1 == pytest.approx(1.0, abs=1e-7)
    assert c["k31"] == pytest.approx(-3 * delta / (math.pi * tau), rel=1e-6)
    assert c["k51"] == pytest.approx(-delta / (math.pi * tau), rel=1e-6)
    assert c["h41"] == pytest.approx(-2 * delta / (math.pi * tau), rel=1e-6)


def test_energy_of_the_conservative_part_is_conserved(closed):
    """U = 0, eta = 0, no damping: eq. (21) reduces to its structural terms, which derive from
    V = M1 (omega1^2 q1^2 / 2 + k31 q1^3 / 3 + k51 q1 q2^2 + k4 q1^4 / 4 + k7 q1^2 q2^2 / 2)
        + M2 (omega2^2 q2^2 / 2 + h31 q2^4 / 4)
    (the reciprocity relations make dV/dq2 = M2 x eq. (21)_2's terms). Integrated by the eq. (21)
    integrator at rtol = 1e-11 over 50 periods from q = (0.01, 0.008) (cubic terms ~10 % of the
    linear ones), E = sum Mk qk'^2 / 2 + V stays constant to 1e-8 relative (measured 7.7e-11); the
    same check with the sign of k51 flipped in eq. (21)_1 alone (a broken reciprocity) drifts by
    far more (measured 2.2e-2)."""
    import dataclasses

    from autocable.methods.integration.ode21 import Ode21Integrator
    from autocable.model.equations import TwoModeODE
    from autocable.model.symbolic import parameter_values

    ode = closed.ode
    _, _, (M1, _, _, M2, _) = _hand_modes(SAMPLE)
    keep = tuple(t for t in ode.terms if t.forcing == (0, 0, 0) and t.origin in ("structural", "linear"))
    assert len(keep) == 9

    def energy(c, y):
        q1, q2, p1, p2 = y.T
        V = (M1 * (ode.omega1 ** 2 * q1 ** 2 / 2 + c["k31"] * q1 ** 3 / 3 + c["k51"] * q1 * q2 ** 2
                   + c["k4"] * q1 ** 4 / 4 + c["k7"] * q1 ** 2 * q2 ** 2 / 2)
             + M2 * (ode.omega2 ** 2 * q2 ** 2 / 2 + c["h31"] * q2 ** 4 / 4))
        return M1 * p1 ** 2 / 2 + M2 * p2 ** 2 / 2 + V

    def drift(terms):
        cons = TwoModeODE(terms=terms, omega1=ode.omega1, omega2=ode.omega2, xi_s=0.0)
        integ = Ode21Integrator(cons, engine="scipy", rtol=1e-11, atol=1e-15)
        _, y = integ.run((0.01, 0.008, 0.0, 0.0), 0.0, 50 * 2 * math.pi, 0.05,
                         parameter_values(0.0, 0.0, ode.omega1))
        E = energy(_named(ode), y)
        return float(np.max(np.abs(E - E[0])) / E[0]), y

    err, y = drift(keep)
    assert np.max(np.abs(y[:, 1])) > 0.007                     # both modes stay excited
    assert err < 1e-8, err
    broken = tuple(dataclasses.replace(t, coefficient=-t.coefficient) if t.name == "k51" else t
                   for t in keep)
    assert drift(broken)[0] > 1e3 * err
