"""The onset of galloping of eq. (21) (`autocable.model.onset`, `autocable.model.hopf`): the speed
against an independent route (the Hurwitz determinant of the characteristic polynomial), the first
Lyapunov coefficient against closed forms, and the criticality and the post-critical amplitude
against direct integration of eq. (21) on two cables, one of each kind."""
import math

import numpy as np
import pytest

from autocable.model.hopf import first_lyapunov
from autocable.model.onset import (first_onset_U, hopf_point, one_mode, one_mode_warnings, stability,
                                   with_damping)
from autocable.model.units import units_of

#: A 190 m stay (D = 0.19 m, 88 kg/m, T = 4.4 MN, 0.1 % damping, U_c = 10 m/s, yaw 30 deg, the
#: paper's lift and drag fits; chord slope, EA, EI, GJ made up for a 91-strand stay): with this
#: rivulet angle (the root of the U_c calibration with the "reversed" sense) its galloping onset is
#: in-plane and super-critical, while the one-mode coefficients say zeta8 < 0 (sub-critical) and
#: zeta11 > 0 (no in-plane galloping): the case of the issue that asked for `autocable onset`.
STAY_190 = """name = "stay190_40"
[cable]
length_m = 190.0
chord_slope_deg = -40.0
horizontal_tension_N = 3370558.0
mass_per_length_kg_m = 88.0
diameter_m = 0.19
axial_stiffness_N = 2.66e9
bending_stiffness_Nm2 = 13700.0
torsional_stiffness_Nm2 = 1030.0
damping_ratio = 0.001
[aero]
air_density_kg_m3 = 1.25
rivulet_diameter_ratio = 0.1
lift = [-0.48, 0.84, 4.69, 0.86]
drag = [1.25, -0.65, -0.08, 6.81]
critical_wind_speed_m_s = 10.0
angle_convention = "reversed"
yaw_deg = 30.0
rivulet_angle_deg = -31.886261
"""


@pytest.fixture(scope="module")
def stay190_40(tmp_path_factory):
    import warnings
    from autocable.model.derive import derive
    path = tmp_path_factory.mktemp("stay") / "stay190_40.toml"
    path.write_text(STAY_190)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return derive(path)


def _hurwitz(A):
    """Delta_3 = a1 a2 a3 - a3^2 - a1^2 a4 of det(lambda I - A) = lambda^4 + a1 lambda^3 + ... + a4,
    the coefficients by Faddeev-LeVerrier (traces, no eigenvalues): zero where a pair of roots
    crosses the imaginary axis."""
    n = len(A)
    M, c = np.zeros((n, n)), [1.0]
    for k in range(1, n + 1):
        M = A @ M + c[-1] * np.eye(n)
        c.append(-np.trace(A @ M) / k)
    a1, a2, a3, a4 = c[1:]
    return a1 * a2 * a3 - a3 ** 2 - a1 ** 2 * a4


@pytest.mark.parametrize("which", ["sample", "stay190_40"])
def test_onset_speed_equals_the_hurwitz_route(which, derivation, stay190_40):
    from scipy.optimize import brentq
    d = derivation if which == "sample" else stay190_40
    first = stability(d.ode).first
    assert first is not None and first.lyapunov is not None
    Uc = first.U_star
    h = lambda U: _hurwitz(d.ode.linear_matrix(U))
    lo, hi = 0.97 * Uc, 1.03 * Uc
    assert h(lo) * h(hi) < 0
    U_h = brentq(h, lo, hi, xtol=1e-14, rtol=1e-15)
    assert U_h == pytest.approx(Uc, rel=1e-6)
    assert first_onset_U(d.ode) == pytest.approx(Uc, rel=1e-10)
    # the frequency is the imaginary part at the crossing: sqrt(a3/a1) of the quartic at U_h
    A = d.ode.linear_matrix(U_h)
    n, M, c = 4, np.zeros((4, 4)), [1.0]
    for k in range(1, n + 1):
        M = A @ M + c[-1] * np.eye(n)
        c.append(-np.trace(A @ M) / k)
    assert first.frequency == pytest.approx(math.sqrt(c[3] / c[1]), rel=1e-6)


def test_lyapunov_of_the_rayleigh_oscillator():
    """x'' + x = mu x' - k x'^3: averaging gives the cycle a^2 = 4 mu / (3 k), so with
    d Re lambda / d mu = 1/2 the slope d(a^2)/d mu is 4 / (3k); super-critical (l1 < 0)."""
    k = 0.7
    A = np.array([[0.0, 1.0], [-1.0, 0.0]])
    hp = first_lyapunov(A, lambda u, v: np.zeros(2, complex),
                        lambda u, v, w: np.array([0.0, -6 * k * u[1] * v[1] * w[1]]))
    assert hp.l1 < 0
    assert hp.amplitude_slopes(0.5)[0] == pytest.approx(4 / (3 * k), rel=1e-12)
    # x'' + x = mu x' - k x^2 x' (van der Pol type): a^2 = 4 mu / k
    hp = first_lyapunov(A, lambda u, v: np.zeros(2, complex),
                        lambda u, v, w: np.array([0.0, -2 * k * (u[0] * v[0] * w[1] + u[0] * v[1] * w[0]
                                                                 + u[1] * v[0] * w[0])]))
    assert hp.amplitude_slopes(0.5)[0] == pytest.approx(4 / k, rel=1e-12)


@pytest.mark.slow
def test_lyapunov_is_invariant_under_a_quadratic_change_of_coordinates():
    """The Hopf normal form x' = -w y + s x r^2, y' = w x + s y r^2 (Re c1 = 2 s with |q| = 1, so
    l1 = 2 s / w), rewritten in coordinates x = y + Q(y) with Q quadratic: the new field has quadratic
    terms and other cubic ones, and the same l1 (the B-terms of Kuznetsov's formula must cancel
    what the change of coordinates put in)."""
    import sympy as sp
    w, s = 1.3, -0.4
    y1, y2, e = sp.symbols("y1 y2 e")
    Y = sp.Matrix([y1, y2])
    Q = sp.Matrix([0.7 * y1 ** 2 - 0.3 * y1 * y2, 0.5 * y2 ** 2 + 0.9 * y1 ** 2 + 0.2 * y1 * y2])
    X = Y + Q

    def F(x):
        r2 = x[0] ** 2 + x[1] ** 2
        return sp.Matrix([-w * x[1] + s * x[0] * r2, w * x[0] + s * x[1] * r2])

    DQ = Q.jacobian(Y)
    inv = sp.eye(2) - DQ + DQ * DQ           # (I + DQ)^-1 to the order the cubic terms need
    G = (inv * F(X)).subs({y1: e * y1, y2: e * y2})
    G = sp.Matrix([sp.expand(sp.series(g, e, 0, 4).removeO()).subs(e, 1) for g in G])
    z = {y1: 0, y2: 0}
    A = np.array([[float(sp.diff(g, v).subs(z)) for v in (y1, y2)] for g in G])
    H = [[[float(sp.diff(g, a, b).subs(z)) for b in (y1, y2)] for a in (y1, y2)] for g in G]
    T = [[[[float(sp.diff(g, a, b, c).subs(z)) for c in (y1, y2)] for b in (y1, y2)] for a in (y1, y2)]
         for g in G]
    H, T = np.array(H), np.array(T)
    assert np.abs(H).max() > 0.5          # the new field does have quadratic terms
    B = lambda u, v: np.einsum("iab,a,b->i", H, u, v)
    C = lambda u, v, x: np.einsum("iabc,a,b,c->i", T, u, v, x)
    hp = first_lyapunov(A, B, C)
    assert hp.omega == pytest.approx(w, rel=1e-12)
    assert hp.l1 == pytest.approx(2 * s / w, rel=1e-9)


def _envelope_end(d, U, a0, t_end):
    from autocable.methods.integration.ode21 import Ode21Integrator
    integ = Ode21Integrator(d.ode, engine="compiled")
    t, a1, a2, msg = integ.envelope(U, 0.0, 0.0, (a0, 0.0, 0.0, 0.0), t_end, Omega=d.ode.omega1)
    return a1, msg


@pytest.mark.parametrize("which", ["sample", "stay190_40"])
def test_criticality_agrees_with_direct_integration(which, derivation, stay190_40):
    """Just below the onset (U* = 0.99 U_cr) hysteresis is present iff the onset is sub-critical: a
    start at 1.5 times the unstable cycle's amplitude (from the normal form) grows and one at 0.6
    times decays; for a super-critical onset a start at 5e-3 (a displacement of l/200 at mid-span)
    decays as one at 1e-4 does."""
    d = derivation if which == "sample" else stay190_40
    first = stability(d.ode).first
    Uc, slope = first.U_star, first.amplitude_slopes[0]
    U = 0.99 * Uc
    small, _ = _envelope_end(d, U, 1e-4, 3e4)
    assert small[-1] < 0.5 * small[0]
    if first.criticality == "subcritical":
        assert slope < 0
        a_u = math.sqrt(slope * (U - Uc))          # the unstable cycle
        below, _ = _envelope_end(d, U, 0.6 * a_u, 8e4)
        above, msg = _envelope_end(d, U, 1.5 * a_u, 8e4)
        assert below[-1] < 0.5 * below[0]
        assert above.max() > 1.3 * above[0] or "diverges" in msg
    else:
        assert slope > 0
        big, msg = _envelope_end(d, U, 5e-3, 8e4)
        assert "diverges" not in msg and big[-1] < 0.2 * big[0]
    expected = {"sample": None, "stay190_40": "supercritical"}[which]
    if expected:
        assert first.criticality == expected


def test_post_critical_amplitude_matches_the_normal_form(stay190_40):
    """Above a super-critical onset (U* = 1.02 U_cr) the cycle of eq. (21), reached from below and
    from above, has a1^2 = slope (U - U_cr) to within 5 % in a1 (the normal form's leading order)."""
    first = stability(stay190_40.ode).first
    Uc, slope = first.U_star, first.amplitude_slopes[0]
    U = 1.02 * Uc
    a_pred = math.sqrt(slope * (U - Uc))
    for start in (0.5 * a_pred, 2 * a_pred):
        a1, msg = _envelope_end(stay190_40, U, start, 2.5e5)
        assert "bounded" in msg
        assert a1[-1] == pytest.approx(a_pred, rel=0.05)
        assert abs(a1[-1] - a1[-200]) < 1e-3 * a1[-1]          # settled


def test_one_mode_coefficients_mislead_on_the_190_m_stay(stay190_40):
    """The issue's reading: zeta8 < 0 and zeta11 > 0 say "no in-plane galloping, and sub-critical
    if any"; eq. (21) gallops in-plane and super-critically, and the warnings say both."""
    om = one_mode(stay190_40.ode)
    assert om["zeta8"] < 0 and om["zeta11"] > 0
    result = stability(stay190_40.ode)
    first = result.first
    assert first.mechanism == "in-plane galloping" and first.criticality == "supercritical"
    text = " ".join(one_mode_warnings(stay190_40.ode, result, units_of(stay190_40.spec, stay190_40.statics)))
    assert "zeta11" in text and "zeta8" in text and "supercritical" in text


@pytest.mark.parametrize("which", ["sample", "stay190_40"])
def test_decoupled_onset_is_the_closed_form_for_every_damping(which, derivation, stay190_40):
    """Eq. (21) with its linear cross terms removed (each mode's own terms kept): the in-plane block
    q1'' + (2 xi omega1 + zeta11 U) q1' + omega1^2 q1 loses stability at U* = -2 xi omega1 / zeta11,
    the out-of-plane one q2'' + (2 xi + xi21 U) q2' + (1 + h14 U^2) q2 at -2 xi / xi21 (when the
    coefficient is negative), so the first onset is the smaller, at any damping `with_damping` sets."""
    from dataclasses import replace
    d = derivation if which == "sample" else stay190_40
    own = tuple(t for t in d.ode.terms
                if not (t.eta_power == 0 and sum(t.powers) == 1 and t.powers.index(1) % 2 != t.equation - 1))
    ode0 = replace(d.ode, terms=own)

    def coefficient(k, powers):
        return sum(t.coefficient for t in ode0.find(k, powers, u_power=1) if t.origin == "aerodynamic")

    z11, x21 = coefficient(1, (0, 0, 1, 0)), coefficient(2, (0, 0, 0, 1))
    assert not ode0.find(1, (1, 0, 0, 0), u_power=2)          # no in-plane wind stiffness
    for xi in (0.002, 0.004, 0.008):
        ode = with_damping(ode0, xi)
        roots = [U for U in (-2 * xi * ode.omega1 / z11 if z11 < 0 else math.inf,
                             -2 * xi * ode.omega2 / x21 if x21 < 0 else math.inf) if U <= 5.0]
        expected = min(roots, default=math.inf)
        got = first_onset_U(ode)
        if math.isfinite(expected):
            assert got == pytest.approx(expected, rel=1e-9)
        else:
            assert got == math.inf


def test_hopf_point_frequency_is_the_critical_eigenvalue(stay190_40):
    first = stability(stay190_40.ode).first
    hp = hopf_point(stay190_40.ode, first.U_star)
    lam = np.linalg.eigvals(stay190_40.ode.linear_matrix(first.U_star))
    assert min(abs(lam - 1j * hp.omega)) < 1e-9


def test_the_pencil_is_the_linear_matrix(derivation, stay190_40):
    from autocable.model.onset import LinearPencil
    for d in (derivation, stay190_40):
        pencil = LinearPencil(d.ode)
        U = np.array([0.0, 0.37, 1.0, 2.9])
        for Ui, M in zip(U, pencil.matrices(U)):
            assert np.allclose(M, d.ode.linear_matrix(Ui), rtol=1e-14, atol=1e-16)


@pytest.mark.parametrize("which", ["sample", "stay190_40"])
def test_the_matrix_is_the_calibrations(which, derivation, stay190_40):
    """Two routes to the trivial state's linear matrix: the calibration's (first-order load
    coefficients projected directly, `calibration._linear_matrix`) and eq. (21)'s term table (the
    cubic load expanded, then projected) that the onset scans: equal to round-off at every U*."""
    from autocable.model.aero import linear_load
    from autocable.model.calibration import _linear_matrix
    from autocable.model.galerkin import aero_scales, linear_aero_matrix
    from autocable.model.modes import linear_modes
    from autocable.model.shapes import ClosedFormIntegrator
    d = derivation if which == "sample" else stay190_40
    spec, st = d.spec, d.statics
    modes = linear_modes(st, spec.cable.twist_ends)
    K, nu = aero_scales(spec.aero, spec.cable, st)
    lin = linear_load(spec.aero.lift, spec.aero.drag, st.alpha, d.beta, d.theta0, spec.aero.angle_convention,
                      spec.aero.load_axes)
    al = linear_aero_matrix(ClosedFormIntegrator(modes.shapes), K, nu, st.m_star, lin)
    for U in (0.3, 1.0, 2.2):
        A = _linear_matrix(modes.omega1, modes.omega2, d.ode.xi_s, al, U)
        assert np.allclose(A, d.ode.linear_matrix(U), rtol=1e-10, atol=1e-13)


def test_matrix_derivative_and_growth_slope_by_differences(stay190_40):
    """d A / d U* term by term against a central difference of the matrix (exact for its U and U^2
    terms), and d Re lambda / d U* at the onset against a difference of the eigenvalue."""
    from autocable.model.onset import matrix_derivative
    ode = stay190_40.ode
    first = stability(ode).first
    U, h = first.U_star, 1e-5
    fd = (ode.linear_matrix(U + h) - ode.linear_matrix(U - h)) / (2 * h)
    assert np.allclose(matrix_derivative(ode, U), fd, rtol=1e-7, atol=1e-12)
    lam = [np.max(np.linalg.eigvals(ode.linear_matrix(u)).real) for u in (U - h, U + h)]
    assert first.growth_slope == pytest.approx((lam[1] - lam[0]) / (2 * h), rel=1e-5)
