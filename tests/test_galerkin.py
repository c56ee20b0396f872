"""Eq. (21): the Galerkin table, computed two independent ways, and its physics checks."""
import math
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from autocable.model import aero as aero_mod
from autocable.model.derive import derive
from autocable.spec import load_model

SAMPLE = Path(__file__).resolve().parents[1] / "models" / "luongo_zulli_2012.toml"


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
    (m0,) = closed.ode.find(1, (0, 0, 0, 0), (0, 0, 1))
    # m0 = -int(phi1 vhat)/int(phi1^2) on the paper's right-hand side
    assert m0.name == "m0" and m0.appendix_value > 0


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


def test_literal_eq12_convention_gives_subcritical_galloping(closed):
    """Why the sample spec reverses the sense of phi: with eq. (12) as printed, every member of the
    U_c family (zeta11 = -2 xi_s omega1) at beta = -90, -60, ..., 90 deg has zeta8 < 0 (subcritical
    galloping, against Fig. 3); with the reversed sense the sample's zeta8 > 0 and eq. (25)'s branch
    exists above U = 1. Not every beta of the literal sense is subcritical: see
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
    assert closed.spec.aero.angle_convention == "reversed"
    assert closed.ode.coefficients()["zeta8"] > 0


def test_calibration_is_invertible(closed):
    """Given Theta0, calibrating the yaw gives back the spec's yaw; the Theta0 scan found two valid
    roots (-13.88 and 69.12 deg, as the spec says) and kept the smaller."""
    from dataclasses import replace
    spec = closed.spec
    other = replace(spec, aero=replace(spec.aero, yaw_deg=None,
                                       rivulet_angle_deg=math.degrees(closed.theta0)))
    d = derive(other, use_cache=False)
    assert d.calibrated == "yaw_deg"
    assert math.degrees(d.beta) == pytest.approx(spec.aero.yaw_deg, abs=1e-8)
    roots = sorted(r for r, why in closed.calibration_roots if not why)
    assert roots == pytest.approx([-13.8794, 69.1193], abs=1e-3)
    assert math.degrees(closed.theta0) == pytest.approx(roots[0], abs=1e-9)
