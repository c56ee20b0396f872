"""Statics, quasi-static shape (eqs. 15-16), modes (eqs. 19-20) and slaved twist."""
import math

import numpy as np
import pytest

from autocable.model.modes import irvine_root, linear_modes, ritz_omega1
from autocable.model.statics import cable_statics, quasi_static_coefficients_si
from autocable.spec import load_model
from conftest import SAMPLE



@pytest.fixture(scope="module")
def spec():
    return load_model(SAMPLE)


@pytest.fixture(scope="module")
def st(spec):
    return cable_statics(spec.cable)


@pytest.fixture(scope="module")
def modes(st):
    return linear_modes(st)


def test_omega1_matches_paper_and_irvine(modes, st):
    assert modes.omega2 == 1.0
    assert modes.omega1 == pytest.approx(1.004, abs=3e-4)
    # Irvine's transcendental equation holds at the root ...
    x = modes.b / 2
    assert math.tan(x) == pytest.approx(x - 4 / st.lambda2 * x**3, rel=1e-9)
    # ... and an independent Rayleigh-Ritz sine series converges to it.
    assert ritz_omega1(st, 400) == pytest.approx(modes.omega1, rel=1e-9)


def test_printed_EA_gives_omega1_near_one(spec):
    """docs/model.md, M1: with EA = 29.7e6 N the in-plane frequency is 1.00006, not 1.004."""
    from dataclasses import replace
    st = cable_statics(replace(spec.cable, axial_stiffness_N=29.7e6))
    assert linear_modes(st).omega1 == pytest.approx(1.00006, abs=2e-5)


def test_irvine_limits():
    assert irvine_root(1e-8) == pytest.approx(math.pi, rel=1e-6)
    # lambda^2 = 4 pi^2 is the cross-over: the symmetric root is b = 2 pi.
    assert irvine_root(4 * math.pi**2) == pytest.approx(2 * math.pi, rel=1e-9)


def test_quasi_static_shape_solves_eq15(spec, st):
    s = np.linspace(0, 1, 11)
    vhat = st.C1 * s**2 + st.C2 * s
    assert vhat[0] == 0.0
    assert vhat[-1] == pytest.approx(math.cos(st.alpha), abs=1e-14)
    residual = st.delta * math.sin(st.alpha) - st.delta**2 * (st.C1 / 3 + st.C2 / 2) + st.tau * 2 * st.C1
    assert abs(residual) < 1e-15
    # Eq. (16) with the corrected C2 (12 H^3 cos(alpha)) is the same shape in metres.
    C1, C2 = quasi_static_coefficients_si(spec.cable)
    l = spec.cable.length_m
    assert C1 * l * l == pytest.approx(st.C1, rel=1e-12)
    assert C2 * l == pytest.approx(st.C2, rel=1e-12)
    assert C1 * l * l + C2 * l == pytest.approx(math.cos(st.alpha), rel=1e-12)


def test_printed_C2_violates_boundary_condition(spec):
    """docs/model.md, M2: as printed, v-hat(l) is ~1 instead of cos(alpha).

    Exactly, v-hat(l) = (EA m^2 g^2 l^2 c^6 + 12 H^3) / (EA m^2 g^2 l^2 c^5 + 12 H^3), c = cos(alpha),
    which is 1 up to the (small) first terms: 0.9985 for the sample cable, against cos(alpha) = 0.817.
    """
    C1, C2 = quasi_static_coefficients_si(spec.cable, printed=True)
    l = spec.cable.length_m
    c = math.cos(math.radians(spec.cable.chord_slope_deg))
    EA, m, g, H = (spec.cable.axial_stiffness_N, spec.cable.mass_per_length_kg_m,
                   spec.cable.gravity_m_s2, spec.cable.horizontal_tension_N)
    exact = (EA * m**2 * g**2 * l**2 * c**6 + 12 * H**3) / (EA * m**2 * g**2 * l**2 * c**5 + 12 * H**3)
    assert C1 * l * l + C2 * l == pytest.approx(exact, rel=1e-12)
    assert C1 * l * l + C2 * l == pytest.approx(1.0, abs=2e-3)


def _d(f, s, h=1e-4):
    return (f(s + h) - f(s - h)) / (2 * h)


def _dd(f, s, h=1e-4):
    return (f(s + h) - 2 * f(s) + f(s - h)) / h**2


def test_in_plane_mode_eigen_equation(modes, st):
    sh = modes.shapes
    s = np.linspace(0.05, 0.95, 19)
    phi = sh["phi1"].evaluate
    integral = sh["phi1"].exp.integral()
    # tau phi'' - delta^2 int phi + m* omega1^2 phi = 0 (analytic second derivative)
    res = st.tau * sh["phi1_dd"].evaluate(s) - st.delta**2 * integral + st.m_star * modes.omega1**2 * phi(s)
    assert np.max(np.abs(res)) < 1e-14
    assert phi(0.0) == pytest.approx(0.0, abs=1e-14) and phi(1.0) == pytest.approx(0.0, abs=1e-14)
    assert phi(0.5) == pytest.approx(1.0, abs=1e-14)
    assert np.max(phi(np.linspace(0, 1, 1001))) == pytest.approx(1.0, abs=1e-12)
    # the analytic derivative agrees with finite differences of the mode itself
    assert np.allclose(_dd(phi, s), sh["phi1_dd"].evaluate(s), rtol=1e-5, atol=1e-5)


def test_out_of_plane_mode_and_twist(modes, st):
    sh = modes.shapes
    w, th = sh["phi2"].evaluate, sh["theta2"].evaluate
    s = np.linspace(0.02, 0.98, 25)
    # twist equation chi th'' - delta^2 th + (1 + chi) delta w'' = 0 (docs/model.md, M4: 1 + chi)
    B, C, k = modes.twist_B, modes.twist_C, modes.twist_k
    th_dd = -B * math.pi**2 * np.sin(math.pi * s) + C * k * k * np.cosh(k * (s - 0.5))
    assert np.allclose(_dd(th, s), th_dd, rtol=1e-4, atol=1e-4)
    res = st.chi * th_dd - st.delta**2 * th(s) + (1 + st.chi) * st.delta * sh["phi2_dd"].evaluate(s)
    scale = st.chi * np.max(np.abs(th_dd))
    assert np.max(np.abs(res)) < 1e-12 * scale
    # natural boundary conditions th' + delta w' = 0 at both ends
    for end in (1e-9, 1 - 1e-9):
        assert _d(th, end, 1e-6) + st.delta * sh["phi2_d"].evaluate(end) == pytest.approx(0.0, abs=1e-5)
    # global balance of twisting moments: delta^2 int th = delta [w']_0^1 = -2 pi delta
    assert sh["theta2"].exp.integral() == pytest.approx(-2 * math.pi / st.delta, rel=1e-12)
    assert w(0.5) == 1.0
    # out-of-plane eigen-equation tau w'' + m* omega2^2 w = 0 with omega2 = 1, w(0) = w(1) = 0
    res = st.tau * sh["phi2_dd"].evaluate(s) + st.m_star * modes.omega2**2 * w(s)
    assert np.max(np.abs(res)) < 1e-15
    assert abs(w(0.0)) < 1e-15 and abs(w(1.0)) < 1e-15
