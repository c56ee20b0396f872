"""The angle senses of eq. (12) against two properties every quasi-steady load must have, each a test
that could fail (docs/model.md, U4 and the errata):

* frame indifference: turning the relative wind and the section together about the cable axis turns
  the load with them (the load in the turned section is unchanged). Eq. (12) as printed
  ("eq12") and the coefficient curves read the other way ("mirrored") have it; the legacy
  "reversed" reading, which flips the wind angle and not the twist, does not;
* homogeneity: the load is homogeneous of degree 2 in the wind speed and the velocities together, so
  every aerodynamic term of eq. (21) with n velocity factors (q1', q2', eta f') carries U^(2 - n).

And the structural relation between the two senses that share the in-plane terms: "mirrored" differs
from "reversed" only in the sign of the twist in phi, so every aerodynamic term of eq. (21) with
q2^a (the twist is slaved to q2) changes by (-1)^a and nothing else changes.
"""
import math
import warnings

import numpy as np
import pytest

from conftest import SAMPLE
from autocable.model.aero import (FRAME_INDIFFERENT, LEGACY_SENSES, expand_load_jet, frame_residual,
                                  section_load)

LIFT = (-0.48, 0.84, 4.69, 0.86)     # the sample's A_k, B_k (eq. 13)
DRAG = (1.25, -0.65, -0.08, 6.81)
ALPHA, BETA, THETA0 = math.radians(-35.2), math.radians(-6.569711), math.radians(-13.879)
SENSES = ("eq12", "mirrored", "reversed")
AXES = ("reference", "twisted")


def _samples(n=200, seed=1):
    """Relative winds around the static one (U* = 1) and twists of up to 0.3 rad."""
    rng = np.random.default_rng(seed)
    V2 = math.sin(ALPHA) * math.sin(BETA) + 0.3 * rng.standard_normal(n)
    V3 = math.cos(ALPHA) + 0.3 * rng.standard_normal(n)
    theta = 0.3 * rng.standard_normal(n)
    return V2, V3, theta


@pytest.mark.parametrize("axes", AXES)
@pytest.mark.parametrize("sense", SENSES)
def test_exact_load_frame_indifference(sense, axes):
    """A 3 deg turn of wind and section: round-off for eq12 and mirrored, order one for reversed."""
    V2, V3, theta = _samples()
    r = frame_residual(LIFT, DRAG, THETA0, V2, V3, theta, math.radians(3.0), sense, axes)
    if sense in FRAME_INDIFFERENT:
        assert r < 1e-12, f"{sense}/{axes}: residual {r:.3g} for a 3 deg turn"
    else:
        assert sense in LEGACY_SENSES
        # phi moves by 2 d = 6 deg; the lift slope A1 = 0.84 alone changes the load by ~0.09.
        assert r > 0.05, f"{sense}/{axes}: residual {r:.3g}, expected the frame dependence"


def test_reversed_residual_grows_linearly_with_the_turn():
    """The legacy sense's error is of first order in the turn (phi moves by 2 d): not round-off."""
    V2, V3, theta = _samples()
    r1 = frame_residual(LIFT, DRAG, THETA0, V2, V3, theta, 1e-3, "reversed")
    r2 = frame_residual(LIFT, DRAG, THETA0, V2, V3, theta, 2e-3, "reversed")
    assert r2 / r1 == pytest.approx(2.0, rel=0.02)
    assert r1 > 1e-4


def _cubic_load(sense, axes):
    """The cubic expansion of eq. (14) about the static state at U* = 1, as a function of the
    relative wind and the twist: vdot = V2_0 - V2, wdot = V3_0 - V3."""
    exp = expand_load_jet(LIFT, DRAG, ALPHA, BETA, THETA0, sense, axes)
    V20, V30 = math.sin(ALPHA) * math.sin(BETA), math.cos(ALPHA)
    z2, z3 = section_load(LIFT, DRAG, THETA0, V20, V30, 0.0, sense, axes)

    def load(V2, V3, th):
        vd, wd = V20 - np.asarray(V2), V30 - np.asarray(V3)
        th = np.asarray(th, dtype=float)
        b2 = z2 + sum(c * th**a * vd**b * wd**cc for (a, b, cc), c in exp.b2.items())
        b3 = z3 + sum(c * th**a * vd**b * wd**cc for (a, b, cc), c in exp.b3.items())
        return b2, b3
    return load


@pytest.mark.parametrize("axes", AXES)
@pytest.mark.parametrize("sense", SENSES)
def test_cubic_expansion_frame_indifference_order(sense, axes):
    """The cubic load of eq. (14) inherits the property to its own order: for the consistent senses
    the residual of a turn d at perturbations of size h ~ d is O(h^4) (halving h divides it by ~16);
    for reversed it is O(h) (halving divides it by ~2)."""
    load = _cubic_load(sense, axes)
    rng = np.random.default_rng(7)
    u = rng.standard_normal((3, 50))
    V20, V30 = math.sin(ALPHA) * math.sin(BETA), math.cos(ALPHA)
    res = []
    for h in (0.02, 0.01):
        res.append(frame_residual(LIFT, DRAG, THETA0, V20 + h * u[0], V30 + h * u[1], h * u[2], h,
                                  sense, axes, load=load))
    ratio = res[0] / res[1]
    if sense in FRAME_INDIFFERENT:
        assert 12.0 < ratio < 20.0, f"{sense}/{axes}: residuals {res}, ratio {ratio:.2f} (order 4: 16)"
        assert res[0] < 1e-4     # vs > 1e-3 for the legacy sense at the same h
    else:
        assert 1.8 < ratio < 2.2, f"{sense}/{axes}: residuals {res}, ratio {ratio:.2f} (order 1: 2)"
        assert res[0] > 1e-3


def _readings_odes():
    from autocable.paper.calibration import Readings, candidate_spec, fast_ode
    from autocable.spec import load_model
    spec = load_model(SAMPLE)
    out = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for sense in SENSES:
            for axes in AXES:
                for ends in ("natural", "restrained"):
                    r = Readings(ends, axes, sense, "diameter", 1.25)
                    out[(sense, axes, ends)] = fast_ode(candidate_spec(spec, r, -6.569711, -13.879))
    return out


@pytest.fixture(scope="module")
def readings_odes():
    return _readings_odes()


def test_every_aerodynamic_term_is_homogeneous_of_degree_two(readings_odes, derivation):
    """Every aerodynamic term of eq. (21), in every reading and in the sample's derivation (sympy
    route): U^(2 - n) with n the velocity factors q1', q2', eta f'; no support acceleration f''."""
    checked = 0
    for key, ode in list(readings_odes.items()) + [("sample", derivation.ode)]:
        for t in ode.terms:
            if t.origin != "aerodynamic":
                continue
            n = t.powers[2] + t.powers[3] + t.forcing[1]
            assert t.u_power == 2 - n, f"{key}: {t.label} carries U^{t.u_power}, expected U^{2 - n}"
            assert t.forcing[2] == 0, f"{key}: {t.label} has the support acceleration in a wind term"
            checked += 1
    assert checked > 40 * (len(readings_odes) + 1)     # every ODE has dozens of wind terms


def test_homogeneity_of_the_derived_load_numerically(derivation):
    """The aerodynamic part of eq. (21)'s accelerations at (lambda U, q, lambda q', lambda eta f')
    equals lambda^2 times that at (U, q, q', eta f'): an evaluation, not the bookkeeping above."""
    ode = derivation.ode
    rng = np.random.default_rng(3)

    def aero_acc(U, state, eta, f, fdot):
        acc = np.zeros(2)
        for t in ode.terms:
            if t.origin != "aerodynamic":
                continue
            m = t.factor(U, eta, f, fdot, 0.0)
            for x, p in zip(state, t.powers):
                m *= x ** p
            acc[t.equation - 1] += m
        return acc

    for _ in range(5):
        q1, q2, v1, v2 = 1e-3 * rng.standard_normal(4)
        f, fdot = rng.standard_normal(2)
        base = aero_acc(1.1, (q1, q2, v1, v2), 1e-3, f, fdot)
        lam = 1.7
        scaled = aero_acc(1.1 * lam, (q1, q2, lam * v1, lam * v2), 1e-3, f, lam * fdot)
        # eta f' scales as a velocity, eta f (a displacement) does not: scale fdot alone
        np.testing.assert_allclose(scaled, lam**2 * base, rtol=1e-10, atol=1e-14 * np.max(np.abs(base)))


def test_mirrored_is_reversed_with_the_twist_flipped(readings_odes):
    """mirrored and reversed differ only by the sign of theta in phi: on the reference axes every
    aerodynamic term with q2^a changes by (-1)^a (the twist is slaved to q2), every other term is
    the same. (On the twisted axes the projection turns by +theta in both, so no such relation.)"""
    for axes in ("reference",):
        for ends in ("natural", "restrained"):
            m = {(t.equation, t.powers, t.forcing, t.u_power, t.origin): t.coefficient
                 for t in readings_odes[("mirrored", axes, ends)].terms}
            r = {(t.equation, t.powers, t.forcing, t.u_power, t.origin): t.coefficient
                 for t in readings_odes[("reversed", axes, ends)].terms}
            flipped = 0
            for key in set(m) | set(r):
                cm, cr = m.get(key, 0.0), r.get(key, 0.0)
                sign = (-1) ** key[1][1] if key[4] == "aerodynamic" else 1
                scale = max(abs(cm), abs(cr), 1e-300)
                assert abs(cm - sign * cr) <= 1e-9 * scale, (axes, ends, key, cm, cr)
                flipped += sign < 0 and abs(cr) > 0
            assert flipped > 5


def test_reversed_warns_and_mirrored_does_not(tmp_path):
    """The legacy sense is readable, with a warning that says why; the consistent ones are quiet."""
    from autocable.model.premises import PremiseWarning, check_model
    from autocable.spec import load_model
    text = SAMPLE.read_text()
    for sense, warns in (("reversed", True), ("mirrored", False), ("eq12", False)):
        p = tmp_path / f"{sense}.toml"
        p.write_text(text.replace('angle_convention = "mirrored"', f'angle_convention = "{sense}"')
                     .replace('angle_convention = "reversed"', f'angle_convention = "{sense}"'))
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            check_model(load_model(p))
        said = [str(w.message) for w in caught if issubclass(w.category, PremiseWarning)
                and "frame indifferent" in str(w.message)]
        assert bool(said) == warns, (sense, said)
        if warns:
            assert "angle_convention" in said[0] and "mirrored" in said[0]


def test_errata_terms_of_appendix_a(readings_odes):
    """docs/model.md, M8-M10: the terms the printed Appendix A gets wrong or lacks exist in the derived
    eq. (21) with the powers of U that homogeneity gives, and are not zero; the in-plane equation has
    its q1' wind damping (eq. 11 with v-dot, M8); the mean drag B0 enters the out-of-plane wind
    damping (eq. 13 from k = 0, M9)."""
    from dataclasses import replace

    from autocable.paper.calibration import Readings, candidate_spec, fast_ode
    from autocable.spec import load_model
    ode = readings_odes[("mirrored", "reference", "natural")]

    def coeff(eq, powers, forcing=(0, 0, 0), origin="aerodynamic"):
        got = [t for t in ode.terms if t.equation == eq and t.powers == powers and t.forcing == forcing
               and t.origin == origin]
        assert len(got) == 1, (eq, powers, forcing, got)
        return got[0]

    scale = max(abs(t.coefficient) for t in ode.terms if t.origin == "aerodynamic")
    for eq, powers, forcing, u in ((1, (0, 2, 0, 1), (0, 0, 0), 1),     # zeta15 q2^2 q2' U
                                   (1, (0, 0, 0, 2), (0, 1, 0), -1),    # zeta22-bar eta f' q2'^2 / U
                                   (1, (0, 0, 1, 2), (0, 0, 0), -1),    # q1' q2'^2 / U
                                   (1, (0, 0, 0, 0), (0, 2, 0), 0),     # eta^2 f'^2 forcing
                                   (1, (0, 0, 1, 0), (0, 0, 0), 1),     # zeta11 U q1' (M8)
                                   (2, (0, 0, 0, 1), (0, 0, 0), 1)):    # xi11 U q2'
        t = coeff(eq, powers, forcing)
        assert t.u_power == u, t.label
        assert abs(t.coefficient) > 1e-9 * scale, t.label
    spec = load_model(SAMPLE)
    r = Readings("natural", "reference", "mirrored", "diameter", 1.25)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        no_b0 = candidate_spec(replace(spec, aero=replace(spec.aero, drag=(0.0,) + spec.aero.drag[1:])),
                               r, -6.569711, -13.879)
        damped = coeff(2, (0, 0, 0, 1)).coefficient
        undamped = [t.coefficient for t in fast_ode(no_b0).terms if t.equation == 2
                    and t.powers == (0, 0, 0, 1) and t.origin == "aerodynamic"]
    assert abs(damped - undamped[0]) > 0.1 * abs(damped)


def test_mirrored_reading_decisions_on_the_sample(tmp_path):
    """The consistent sense at the sample's yaw decides the in-plane targets as the legacy one does,
    for the reason the structure gives (same in-plane terms): the same calibrated Theta0 (to the
    root finder's tolerance), the same zeta8 > 0 (super-critical galloping of eq. 25, the screen's
    "supercritical" target yes) and the same onset of eq. (21) at U* = 1 (xi12 = 0 at this yaw, so
    the flipped k21 cannot move it); and out of plane the cubic wind stiffness h32 flips sign, from
    softening to hardening."""
    from autocable.model.derive import derive
    from autocable.paper import targets as tg
    ts = {t.id: t for t in tg.load_targets(SAMPLE.with_suffix("").with_suffix(".targets.toml"))}
    text = SAMPLE.read_text()
    got = {}
    for sense in ("mirrored", "reversed"):
        p = tmp_path / f"{sense}.toml"
        p.write_text(text.replace('angle_convention = "mirrored"', f'angle_convention = "{sense}"')
                     .replace('angle_convention = "reversed"', f'angle_convention = "{sense}"'))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            d = derive(p)
        c = d.ode.coefficients()
        got[sense] = (math.degrees(d.theta0), c["zeta8"], c["h32"],
                      tg.decide_screen(ts["supercritical"], c["zeta8"]).shown,
                      tg.decide_screen(ts["onset_21"], tg.onset_error_21(d.ode)).shown)
    m, r = got["mirrored"], got["reversed"]
    assert m[0] == pytest.approx(r[0], abs=1e-6) and m[0] == pytest.approx(-13.879, abs=1e-3)
    assert m[1] == pytest.approx(r[1], rel=1e-8) and m[1] > 0
    assert m[3] == r[3] == "yes" and m[4] == r[4] == "yes"
    assert m[2] == pytest.approx(-r[2], rel=1e-8) and m[2] > 0
