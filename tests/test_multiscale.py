"""The Multiple Scales engine (Sect. 4, eqs. 22-24) against closed forms and direct integration.

Closed forms use the peak amplitude a (docs/model.md, C1): q = a cos(Omega t + Phi) + ...
"""
from __future__ import annotations

import json
from fractions import Fraction

import numpy as np
import pytest
import sympy as sp
from scipy.integrate import solve_ivp
from scipy.optimize import brentq, root

from autocable.model.ame import AmplitudeEquations
from autocable.model.equations import Term, TwoModeODE
from autocable.model.multiscale import (MultipleScalesError, OscillatorSystem, OscillatorTerm,
                                        default_ordering, derive, from_two_mode_ode)

mu, alpha, w0, F, Om = sp.symbols("mu alpha w0 F Omega", real=True)


def duffing_system(w=w0, damping=mu, cubic=alpha, force=F):
    """q'' + 2 mu q' + w0^2 q + alpha q^3 = F cos(Omega t); F cos = -(-F/Omega) * eta f' at eta = 1."""
    return OscillatorSystem(omegas=(w,), terms=(
        OscillatorTerm(1, (0,), (1,), coefficient=2 * damping, origin="damping", label="2mu q'"),
        OscillatorTerm(1, (3,), (0,), coefficient=cubic, label="alpha q^3"),
        OscillatorTerm(1, (0,), (0,), forcing=(0, 1, 0), coefficient=-force / Om, origin="inertia",
                       label="force"),
    ))


def first_harmonic(sol_fun, Omega, T, n=128):
    """(2/n) sum q(t_j) e^{-i Omega t_j} over one period: equals r + i s for q = r cos - s sin."""
    t = np.arange(n) * T / n
    q = sol_fun(t)
    return 2.0 * np.mean(q * np.exp(-1j * Omega * t[None, :]), axis=1)


def newton(rhs, y, p, tol=1e-15, maxiter=50):
    """An equilibrium of the Cartesian AME by Newton's method on its analytic Jacobian."""
    y = np.array(y, dtype=float)
    for _ in range(maxiter):
        step = np.linalg.solve(rhs.jacobian(y, p), rhs(y, p))
        y -= step
        if np.max(abs(step)) < tol * max(1.0, np.max(abs(y))):
            return y
    raise AssertionError(f"Newton did not converge from {y}")


def periodic_orbit(rhs, x0, T):
    """Fixed point of the period map (shooting on solve_ivp), for a stable or unstable hyperbolic orbit."""
    def period_map(x):
        return solve_ivp(rhs, (0.0, T), x, method="DOP853", rtol=1e-12, atol=1e-14).y[:, -1]

    res = root(lambda x: period_map(x) - x, x0, method="hybr", tol=1e-13)
    # hybr may stop with "not making good progress" when the residual is already at the
    # integrator's round-off; what matters is that the orbit closes, so that is what is asserted.
    closure = np.linalg.norm(period_map(res.x) - res.x) / np.linalg.norm(res.x)
    assert res.success or closure < 1e-10, (res.message, closure)
    sol = solve_ivp(rhs, (0.0, T), res.x, method="DOP853", rtol=1e-12, atol=1e-14, dense_output=True)
    return res.x, sol.sol


# -- Duffing ----------------------------------------------------------------------------------------
def test_duffing_symbolic_expanded_is_textbook():
    ame = derive(duffing_system(), omega="expanded")
    s = ame.symbols()
    A, Ab, eta, sig1 = s["A_1"], s["Abar_1"], s["eta"], s["sigma_1"]
    (F1,) = ame.complex_expressions()
    expected = sp.I * sig1 * A - mu * A + 3 * sp.I * alpha / (2 * w0) * A**2 * Ab - sp.I * F * eta / (4 * w0)
    assert sp.expand(F1 - expected) == 0
    # Backbone (eta = mu = 0): a Phi' = 0 gives omega = Omega = w0 - sigma_1 = w0 + 3 alpha a^2 / (8 w0).
    p = ame.polar_expressions()
    a = s["a_1"]
    sol = sp.solve(sp.Eq(p[1].subs({eta: 0, mu: 0}), 0), sig1)
    assert len(sol) == 1 and sp.simplify((w0 - sol[0]) - (w0 + 3 * alpha * a**2 / (8 * w0))) == 0
    assert all(ame.checks.values())


def test_duffing_symbolic_exact_omega():
    ame = derive(duffing_system())
    s = ame.symbols()
    A, Ab, eta, sig1, O = s["A_1"], s["Abar_1"], s["eta"], s["sigma_1"], s["Omega"]
    (F1,) = ame.complex_expressions()
    # omega^2 - Omega^2 = 2 Omega sigma_1 + sigma_1^2 kept exactly; every 1/omega is 1/Omega.
    expected = (sp.I * (2 * O * sig1 + sig1**2) / (2 * O) * A - mu * A
                + 3 * sp.I * alpha / (2 * O) * A**2 * Ab - sp.I * F * eta / (4 * O))
    assert sp.expand(F1 - expected) == 0
    # With omega_1 = Omega + sigma_1 the backbone is Omega^2 = w0^2 + 3 alpha a^2 / 4 (same to the order kept).
    p = ame.polar_expressions()[1].subs({eta: 0, mu: 0}).subs(sig1, w0 - O)
    assert sp.simplify(p.subs(O, sp.sqrt(w0**2 + 3 * alpha * s["a_1"]**2 / 4))) == 0


def duffing_response(w, m, a3, f, Omega):
    """Closed-form frequency response of the exact-Omega AME: a^2 [(nu + 3 a3 a^2/(8 Omega))^2 + m^2]
    = (f/(2 Omega))^2, nu = (w^2 - Omega^2)/(2 Omega); returns the real positive amplitudes a."""
    nu, kap, P = (w**2 - Omega**2) / (2 * Omega), 3 * a3 / (8 * Omega), f / (2 * Omega)
    x = np.roots([kap**2, 2 * nu * kap, nu**2 + m**2, -P**2])
    x = np.real(x[(abs(x.imag) < 1e-9 * abs(x)) & (x.real > 0)])
    return np.sort(np.sqrt(x))


@pytest.mark.parametrize("sigma", [-0.3, -0.05, 0.0, 0.1, 0.35, 0.6, 0.9])
def test_duffing_equilibria_match_frequency_response(sigma):
    ame = derive(duffing_system())
    vals = {"mu": 0.02, "alpha": 0.8, "w0": 1.3, "F": 0.05}
    rhs = ame.cartesian_rhs(vals)
    p = ame.control(eta=1.0, U=0.0, sigma=sigma, values=vals)
    Omega = p[-1]
    amps = duffing_response(1.3, 0.02, 0.8, 0.05, Omega)
    assert len(amps) in (1, 3)
    for a in amps:
        # Phase from the polar form: sin Phi = -2 mu Omega a / f, cos Phi = 2 Omega a (nu + 3 alpha a^2/(8 Omega)) / f.
        nu = (1.3**2 - Omega**2) / (2 * Omega)
        phi = np.arctan2(-2 * 0.02 * Omega * a / 0.05, 2 * Omega * a * (nu + 3 * 0.8 * a**2 / (8 * Omega)) / 0.05)
        y0 = a * np.array([np.cos(phi), np.sin(phi)])
        assert np.max(abs(rhs(y0, p))) < 1e-12
        y = newton(rhs, y0 * (1 + 1e-3), p)
        assert abs(ame.amplitudes(y)[0] - a) < 1e-10


def test_duffing_against_direct_integration_error_order():
    """Along the MSM scaling (mu ~ eps^2, Omega - w0 ~ eps^2, F ~ eps^3) the relative error of r + i s
    (amplitude and phase) must fall as eps^2."""
    w, a3, mu_h, sig_h, F_h = 1.0, 1.0, 0.5, 0.3, 1.0
    ame = derive(duffing_system())
    eps_list = [0.4, 0.2, 0.1]
    errors = []
    for eps in eps_list:
        vals = {"mu": mu_h * eps**2, "alpha": a3, "w0": w, "F": F_h * eps**3}
        p = ame.control(eta=1.0, sigma=sig_h * eps**2, values=vals)
        rhs = ame.cartesian_rhs(vals)
        amps = duffing_response(w, vals["mu"], a3, vals["F"], p[-1])
        assert len(amps) == 1
        y = newton(rhs, [amps[0], 0.0], p)
        assert abs(ame.amplitudes(y)[0] - amps[0]) < 1e-10 * amps[0]
        Omega, T = p[-1], 2 * np.pi / p[-1]
        q0, qd0 = ame.reconstruct(y, 0.0, p, values=vals)

        def ode(t, x, m=vals["mu"], f=vals["F"]):
            return [x[1], -2 * m * x[1] - w**2 * x[0] - a3 * x[0]**3 + f * np.cos(Omega * t)]

        x, fun = periodic_orbit(ode, [q0[0, 0], qd0[0, 0]], T)
        c = first_harmonic(lambda t: fun(t)[:1], Omega, T)[0]
        errors.append(abs(c - complex(y[0], y[1])) / abs(c))
    order = np.polyfit(np.log(eps_list), np.log(errors), 1)[0]
    assert errors[-1] < 2e-3
    assert 1.7 < order < 2.3, (errors, order)


# -- quadratic, parametric and velocity terms against direct integration (q2 matters here) -----------
def test_quadratic_parametric_against_direct_integration_and_reconstruction():
    """q'' + 2 mu q' + w^2 q + a2 q^2 + a3 q^3 + b q q'^2 + c q q' + k eta f q + m eta f'' = 0.
    The AME amplitude error falls as eps^2 (relative), the first-order reconstruction error of q(t)
    as eps (relative) and the second-order one as eps^2."""
    w = 1.0
    syms = sp.symbols("mu a2 a3 b c k m", real=True)
    m_, a2, a3, b, c, k, m = syms
    system = OscillatorSystem(omegas=(w,), terms=(
        OscillatorTerm(1, (0,), (1,), coefficient=2 * m_, origin="damping"),
        OscillatorTerm(1, (2,), (0,), coefficient=a2), OscillatorTerm(1, (3,), (0,), coefficient=a3),
        OscillatorTerm(1, (1,), (2,), coefficient=b), OscillatorTerm(1, (1,), (1,), coefficient=c),
        OscillatorTerm(1, (1,), (0,), forcing=(1, 0, 0), coefficient=k),
        OscillatorTerm(1, (0,), (0,), forcing=(0, 0, 1), coefficient=m, origin="inertia"),
    ))
    ame = derive(system)
    assert [e.order for e in ame.ordering.entries] == [3, 2, 3, 3, 2, 2, 3]
    hat = dict(mu=0.4, a2=0.6, a3=0.5, b=0.3, c=-0.4, k=0.7, m=0.8, sigma=0.2, eta=1.0)
    eps_list = [0.2, 0.1, 0.05]
    err_amp, err_q1, err_q2 = [], [], []
    for eps in eps_list:
        vals = dict(mu=hat["mu"] * eps**2, a2=hat["a2"], a3=hat["a3"], b=hat["b"], c=hat["c"], k=hat["k"],
                    m=hat["m"] * eps**2)
        eta = hat["eta"] * eps
        p = ame.control(eta=eta, sigma=hat["sigma"] * eps**2, values=vals)
        rhs = ame.cartesian_rhs(vals)
        # The AME is nearly homogeneous in eps: its stable node is close to eps * (-1.12, 0.16).
        y = newton(rhs, [-1.12 * eps, 0.16 * eps], p)
        assert np.all(np.real(np.linalg.eigvals(rhs.jacobian(y, p))) < 0)
        assert np.max(abs(rhs(y, p))) < 1e-14
        Omega, T = p[-1], 2 * np.pi / p[-1]

        def ode(t, x):
            q, v = x
            f, fdd = np.sin(Omega * t), -Omega**2 * np.sin(Omega * t)
            acc = (2 * vals["mu"] * v + w**2 * q + vals["a2"] * q**2 + vals["a3"] * q**3 + vals["b"] * q * v**2
                   + vals["c"] * q * v + vals["k"] * eta * f * q + vals["m"] * eta * fdd)
            return [v, -acc]

        q0, qd0 = ame.reconstruct(y, 0.0, p, values=vals)
        x, fun = periodic_orbit(ode, [q0[0, 0], qd0[0, 0]], T)
        c1 = first_harmonic(lambda t: fun(t)[:1], Omega, T)[0]
        err_amp.append(abs(c1 - complex(*y)) / abs(c1))
        t = np.linspace(0.0, T, 201)
        q_num = fun(t)[0]
        scale = np.max(abs(q_num))
        err_q1.append(np.max(abs(ame.reconstruct(y, t, p, order=1, values=vals)[0][0] - q_num)) / scale)
        err_q2.append(np.max(abs(ame.reconstruct(y, t, p, order=2, values=vals)[0][0] - q_num)) / scale)
    fit = lambda e: np.polyfit(np.log(eps_list), np.log(e), 1)[0]  # noqa: E731
    assert 1.7 < fit(err_amp) < 2.3, err_amp
    assert 0.8 < fit(err_q1) < 1.2, err_q1
    assert 1.7 < fit(err_q2) < 2.3, err_q2
    assert err_q2[-1] < 0.2 * err_q1[-1]


def two_dof_family(eps: float) -> TwoModeODE:
    """A 2-dof eq. (21)-like system scaled as the default ordering assumes: damping, detunings, linear
    aerodynamic terms and resonant forcing ~ eps^2; quadratic/cubic structural and cubic aerodynamic
    terms ~ 1. The quadratic aerodynamic term is scaled eps^2 (not the eps of the default ordering):
    at eps it would enter the AME at fourth order and make the error O(eps), not O(eps^2)."""
    e2 = eps**2
    w1, w2 = 1.0 + 0.1 * e2, 1.0
    S, A, I = "structural", "aerodynamic", "inertia"
    spec = [(1, (1, 0, 0, 0), (0, 0, 0), 0, w1**2, "linear"), (2, (0, 1, 0, 0), (0, 0, 0), 0, w2**2, "linear"),
            (1, (0, 0, 1, 0), (0, 0, 0), 0, 0.3 * e2, "damping"), (2, (0, 0, 0, 1), (0, 0, 0), 0, 0.4 * e2, "damping"),
            (1, (3, 0, 0, 0), (0, 0, 0), 0, 0.5, S), (1, (1, 2, 0, 0), (0, 0, 0), 0, 0.4, S),
            (1, (2, 0, 0, 0), (0, 0, 0), 0, 0.3, S), (1, (0, 2, 0, 0), (0, 0, 0), 0, -0.2, S),
            (1, (0, 1, 1, 0), (0, 0, 0), 0, 0.3, S), (1, (1, 0, 0, 0), (1, 0, 0), 0, 0.5, S),
            (1, (0, 0, 0, 0), (0, 0, 1), 0, 0.8 * e2, I),
            (1, (0, 0, 1, 0), (0, 0, 0), 1, -0.2 * e2, A), (1, (0, 0, 3, 0), (0, 0, 0), -1, 0.3, A),
            (1, (0, 0, 2, 0), (0, 1, 0), -1, 0.2, A),
            (2, (0, 3, 0, 0), (0, 0, 0), 0, 0.5, S), (2, (2, 1, 0, 0), (0, 0, 0), 0, 0.4, S),
            (2, (1, 1, 0, 0), (0, 0, 0), 0, 0.3, S), (2, (0, 1, 0, 1), (0, 0, 0), 0, -0.25, S),
            (2, (0, 1, 0, 0), (1, 0, 0), 0, 0.6, S), (2, (0, 0, 0, 1), (0, 1, 0), 0, 0.2, S),
            (2, (0, 0, 0, 0), (0, 0, 1), 0, 0.5 * e2, I), (2, (0, 0, 1, 1), (0, 0, 0), -1, 0.2 * e2, A),
            (2, (0, 0, 1, 0), (0, 0, 0), 1, 0.1 * e2, A)]
    return TwoModeODE(terms=tuple(Term(*t) for t in spec), omega1=w1, omega2=w2, xi_s=0.0)


@pytest.mark.slow
def test_two_dof_internal_resonance_against_direct_integration():
    """Both modes excited (1:1 internal and external resonance, U = 1): the AME equilibrium (r_k + i s_k)
    matches the first harmonics of the periodic orbit of eq. (21) with a relative error ~ eps^2."""
    eps_list = [0.2, 0.1, 0.05]
    errors = []
    for eps in eps_list:
        ode = two_dof_family(eps)
        ame = derive(ode)
        rhs = ame.cartesian_rhs()
        p = ame.control(eta=eps, U=1.0, sigma=0.15 * eps**2)
        y = newton(rhs, eps * np.array([-1.15, -0.78, -0.80, 0.02]), p)
        assert np.all(np.real(np.linalg.eigvals(rhs.jacobian(y, p))) < 0)
        assert np.all(ame.amplitudes(y) > 0.5 * eps)
        Omega, T = p[-1], 2 * np.pi / p[-1]

        def eq21(t, x):
            f = np.sin(Omega * t)
            return np.r_[x[2:], ode.accelerations(x, 1.0, eps, f, Omega * np.cos(Omega * t), -Omega**2 * f)]

        q0, qd0 = ame.reconstruct(y, 0.0, p)
        _, fun = periodic_orbit(eq21, np.r_[q0[:, 0], qd0[:, 0]], T)
        c = first_harmonic(lambda t: fun(t)[:2], Omega, T, n=64)
        errors.append(np.max(abs(c - (y[0::2] + 1j * y[1::2]))) / np.max(abs(c)))
    order = np.polyfit(np.log(eps_list), np.log(errors), 1)[0]
    assert errors[-1] < 2e-3 and 1.7 < order < 2.3, (errors, order)


def test_quadratic_cubic_backbone():
    """q'' + w0^2 q + a2 q^2 + a3 q^3 = 0: omega = w0 + (9 a3 w0^2 - 10 a2^2) a^2 / (24 w0^3)."""
    a2, a3 = sp.symbols("a2 a3", real=True)
    ame = derive(OscillatorSystem(omegas=(w0,), terms=(OscillatorTerm(1, (2,), (0,), coefficient=a2),
                                                       OscillatorTerm(1, (3,), (0,), coefficient=a3))),
                 omega="expanded")
    s = ame.symbols()
    p = ame.polar_expressions()
    assert p[0] == 0
    sig = sp.solve(p[1], s["sigma_1"])[0]
    assert sp.simplify(-sig - (9 * a3 * w0**2 - 10 * a2**2) * s["a_1"]**2 / (24 * w0**3)) == 0
    # q2 = a2 [A^2 e^{2i Omega t}/3 + c.c. - 2 A Abar] / w0^2 (Nayfeh & Mook), as data.
    rows = {(r.harmonic, r.state): r.coefficient for r in ame.second_order_rows}
    assert rows == {(2, (2, 0)): (Fraction(1, 3), 0), (-2, (0, 2)): (Fraction(1, 3), 0),
                    (0, (1, 1)): (Fraction(-2), 0)}


# -- self-excited oscillators -----------------------------------------------------------------------
def test_van_der_pol_limit_cycle():
    """q'' - mu (1 - q^2) q' + q = 0: a' = mu a (1 - a^2/4) / 2, limit cycle a = 2."""
    ame = derive(OscillatorSystem(omegas=(1,), terms=(
        OscillatorTerm(1, (0,), (1,), coefficient=-mu), OscillatorTerm(1, (2,), (1,), coefficient=mu))))
    s = ame.symbols()
    a = s["a_1"]
    assert sp.expand(ame.polar_expressions()[0] - (mu * a / 2 - mu * a**3 / 8)) == 0
    rhs = ame.cartesian_rhs({"mu": 0.1})
    p = ame.control()
    r = brentq(lambda r: rhs([r, 0.0], p)[0], 1.0, 3.0, xtol=1e-15)
    assert abs(r - 2.0) < 1e-12


@pytest.mark.parametrize("w", [1.0, 1.7])
def test_rayleigh_limit_cycle(w):
    """Rayleigh q'' + w^2 q = mu (q' - q'^3 / 3): peak velocity 2, i.e. a = 2 / w."""
    ame = derive(OscillatorSystem(omegas=(w,), terms=(
        OscillatorTerm(1, (0,), (1,), coefficient=-mu), OscillatorTerm(1, (0,), (3,), coefficient=mu / 3))))
    rhs = ame.cartesian_rhs({"mu": 0.05})
    p = ame.control()
    r = brentq(lambda r: rhs([r, 0.0], p)[0], 0.5 / w, 4.0 / w, xtol=1e-15)
    assert abs(r - 2.0 / w) < 1e-12 * (2.0 / w)


def test_galloping_closed_form_model_m5():
    """q'' + (2 xi w + z11 U) q' + w^2 q + (z8/U) q'^3 = 0 (Sect. 5, docs/model.md, M5):
    a = 2 sqrt(-(2 xi w + z11 U) U) / sqrt(3 z8 w^2) at sigma = 0 (Omega = w)."""
    xi, w, z11, z8 = sp.symbols("xi w z11 z8", real=True)
    U = sp.Symbol("U", real=True)
    system = OscillatorSystem(omegas=(w,), terms=(
        OscillatorTerm(1, (0,), (1,), coefficient=2 * xi * w, origin="damping"),
        OscillatorTerm(1, (0,), (1,), coefficient=z11 * U, origin="aerodynamic"),
        OscillatorTerm(1, (0,), (3,), coefficient=z8 / U, origin="aerodynamic")))
    ame = derive(system)
    s = ame.symbols()
    a = s["a_1"]
    p1 = ame.polar_expressions()[0].subs(s["Omega"], w)
    a2 = sp.solve(sp.expand(p1 / a), a**2)
    closed = 4 * (-(2 * xi * w + z11 * s["U"]) * s["U"]) / (3 * z8 * w**2)
    assert len(a2) == 1 and sp.simplify(a2[0] - closed) == 0
    vals = {"xi": 0.004, "w": 1.004, "z11": -2 * 0.004 * 1.004, "z8": 0.37}
    rhs = ame.cartesian_rhs(vals)
    for Uv in (1.05, 1.3, 2.0):
        p = ame.control(U=Uv, values=vals)
        expect = 2 * np.sqrt(-(2 * 0.004 * 1.004 + vals["z11"] * Uv) * Uv) / np.sqrt(3 * 0.37 * 1.004**2)
        r = brentq(lambda r: rhs([r, 0.0], p)[0], 0.5 * expect, 2 * expect, xtol=1e-16, rtol=1e-15)
        assert abs(r - expect) < 1e-12 * expect
    # No wind, no aerodynamic term: at U = 0 only the structural damping remains (no 1/U blow-up).
    p0 = ame.control(U=0.0, values=vals)
    assert np.allclose(rhs([0.3, 0.1], p0), -0.004 * 1.004 * np.array([0.3, 0.1]), rtol=1e-14, atol=0)


# -- parametric resonance ----------------------------------------------------------------------------
def test_mathieu_tongue():
    """q'' + w0^2 q + p eta^2 f^2 q = 0, f = sin(Omega t): f^2 = (1 - cos 2 Omega t)/2, so this is Mathieu
    with mean stiffness w0^2 + p eta^2/2 and modulation (p eta^2/2) cos 2 Omega t. First tongue, to the
    order kept: |Omega^2 - w0^2 - p eta^2/2| < p eta^2/4, growth rate sqrt(k^2 - d^2)/(2 Omega)."""
    pp = sp.Symbol("p", real=True)
    ame = derive(OscillatorSystem(omegas=(w0,), terms=(
        OscillatorTerm(1, (1,), (0,), forcing=(2, 0, 0), coefficient=pp),)))
    s = ame.symbols()
    A, Ab, eta, O, sig = s["A_1"], s["Abar_1"], s["eta"], s["Omega"], s["sigma_1"]
    (F1,) = ame.complex_expressions()
    expected = sp.I * ((2 * O * sig + sig**2 + pp * eta**2 / 2) * A - pp * eta**2 / 4 * Ab) / (2 * O)
    assert sp.expand(F1 - expected) == 0

    vals = {"w0": 1.0, "p": 0.8}
    rhs = ame.cartesian_rhs(vals)
    eta_v = 0.25

    def det(sg):   # det J(0) = (detuning^2 - modulation^2) / (2 Omega)^2: zero on the tongue boundaries
        return np.linalg.det(rhs.jacobian([0.0, 0.0], ame.control(eta=eta_v, sigma=sg, values=vals)))

    pe2 = 0.8 * eta_v**2
    lo, hi = np.sqrt(1 + pe2 / 4) - 1, np.sqrt(1 + 3 * pe2 / 4) - 1
    mid = 0.5 * (lo + hi)
    assert abs(brentq(det, lo - 0.01, mid, xtol=1e-15) - lo) < 1e-10
    assert abs(brentq(det, mid, hi + 0.01, xtol=1e-15) - hi) < 1e-10

    # Against Floquet theory of the exact equation at the tongue centre: relative error O(p eta^2).
    errs = []
    for ev in (0.3, 0.15):
        pe2 = 0.8 * ev**2
        Omega = np.sqrt(1 + pe2 / 2)
        p = ame.control(eta=ev, sigma=Omega - 1.0, values=vals)
        lam = np.max(np.real(np.linalg.eigvals(rhs.jacobian([0.0, 0.0], p))))
        assert abs(lam - pe2 / 4 / (2 * Omega)) < 1e-14
        T = np.pi / Omega
        M = np.column_stack([solve_ivp(lambda t, x: [x[1], -(1 + 0.8 * ev**2 * np.sin(Omega * t)**2) * x[0]],
                                       (0, T), e0, method="DOP853", rtol=1e-12, atol=1e-14).y[:, -1]
                             for e0 in ([1.0, 0.0], [0.0, 1.0])])
        lam_floquet = np.log(np.max(abs(np.linalg.eigvals(M)))) / T
        errs.append(abs(lam - lam_floquet) / lam_floquet)
    assert errs[0] < 0.05 and errs[1] < 0.5 * errs[0]


# -- a synthetic eq. (21) table -------------------------------------------------------------------------
_S, _A, _I = "structural", "aerodynamic", "inertia"
#: (equation, (q1, q2, q1', q2'), (eta f, eta f', eta f''), U power, origin): the monomials of
#: Appendix A, eqs. (26)-(27), in the order printed, plus extra structural ones (EXTRA).
EQ21 = [
    (1, (0, 0, 1, 0), (0, 0, 0), 1, _A), (1, (0, 0, 1, 0), (0, 2, 0), -1, _A), (1, (0, 0, 1, 0), (0, 1, 0), 0, _A),
    (1, (1, 0, 0, 0), (1, 0, 0), 0, _S), (1, (1, 0, 0, 0), (2, 0, 0), 0, _S),
    (1, (0, 1, 0, 0), (0, 0, 0), 2, _A), (1, (0, 1, 0, 0), (0, 2, 0), 0, _S), (1, (0, 1, 0, 0), (0, 1, 0), 1, _A),
    (1, (0, 0, 0, 1), (0, 1, 0), 0, _A), (1, (0, 0, 0, 1), (0, 0, 0), 1, _A), (1, (0, 0, 0, 1), (0, 2, 0), -1, _A),
    (1, (2, 0, 0, 0), (0, 0, 0), 0, _S), (1, (2, 0, 0, 0), (1, 0, 0), 0, _S),
    (1, (0, 2, 0, 0), (0, 0, 0), 0, _S), (1, (0, 2, 0, 0), (1, 0, 0), 0, _S), (1, (0, 2, 0, 0), (0, 0, 0), 2, _A),
    (1, (0, 2, 0, 0), (0, 1, 0), 1, _A),
    (1, (3, 0, 0, 0), (0, 0, 0), 0, _S), (1, (0, 3, 0, 0), (0, 0, 0), 2, _A), (1, (1, 2, 0, 0), (0, 0, 0), 0, _S),
    (1, (0, 0, 2, 0), (0, 1, 0), -1, _A), (1, (0, 0, 2, 0), (0, 0, 0), 0, _A),
    (1, (0, 0, 1, 1), (0, 0, 0), 0, _A), (1, (0, 0, 1, 1), (0, 1, 0), -1, _A),
    (1, (0, 0, 0, 2), (0, 0, 0), 0, _A), (1, (0, 0, 0, 2), (0, 0, 0), -1, _A),
    (1, (0, 1, 1, 0), (0, 1, 0), 0, _A), (1, (0, 1, 1, 0), (0, 0, 0), 1, _A),
    (1, (0, 1, 0, 1), (0, 0, 0), 1, _A), (1, (0, 1, 0, 1), (0, 1, 0), 0, _A),
    (1, (0, 0, 3, 0), (0, 0, 0), -1, _A), (1, (0, 0, 0, 3), (0, 0, 0), -1, _A),
    (1, (0, 1, 2, 0), (0, 0, 0), 0, _A), (1, (0, 2, 1, 0), (0, 0, 0), 1, _A), (1, (0, 1, 0, 2), (0, 0, 0), 0, _A),
    (1, (0, 2, 0, 1), (0, 0, 0), 0, _A), (1, (0, 1, 1, 1), (0, 0, 0), 0, _A), (1, (0, 0, 2, 1), (0, 0, 0), -1, _A),
    (1, (0, 0, 0, 0), (2, 0, 0), 0, _S), (1, (0, 0, 0, 0), (3, 0, 0), 0, _S), (1, (0, 0, 0, 0), (0, 1, 0), 1, _A),
    (1, (0, 0, 0, 0), (0, 3, 0), -1, _A), (1, (0, 0, 0, 0), (0, 0, 1), 0, _I),
    (2, (0, 0, 1, 0), (0, 1, 0), 0, _A), (2, (0, 0, 1, 0), (0, 0, 0), 1, _A), (2, (0, 0, 1, 0), (0, 2, 0), -1, _A),
    (2, (0, 0, 0, 1), (0, 0, 0), 1, _A), (2, (0, 0, 0, 1), (0, 1, 0), 0, _A), (2, (0, 0, 0, 1), (0, 2, 0), -1, _A),
    (2, (0, 1, 0, 0), (1, 0, 0), 0, _S), (2, (0, 1, 0, 0), (2, 0, 0), 0, _S), (2, (0, 1, 0, 0), (0, 1, 0), 1, _A),
    (2, (0, 1, 0, 0), (0, 0, 0), 2, _A), (2, (0, 1, 0, 0), (0, 2, 0), 0, _S),
    (2, (0, 2, 0, 0), (0, 0, 0), 2, _A), (2, (0, 2, 0, 0), (0, 1, 0), 1, _A),
    (2, (1, 1, 0, 0), (0, 0, 0), 0, _S), (2, (1, 1, 0, 0), (1, 0, 0), 0, _S),
    (2, (0, 3, 0, 0), (0, 0, 0), 0, _S), (2, (0, 3, 0, 0), (0, 0, 0), 2, _A), (2, (2, 1, 0, 0), (0, 0, 0), 0, _S),
    (2, (0, 0, 2, 0), (0, 0, 0), 0, _A), (2, (0, 0, 2, 0), (0, 1, 0), -1, _A),
    (2, (0, 0, 0, 2), (0, 0, 0), 0, _A), (2, (0, 0, 0, 2), (0, 1, 0), -1, _A),
    (2, (0, 1, 1, 0), (0, 0, 0), 1, _A), (2, (0, 1, 1, 0), (0, 1, 0), 0, _A),
    (2, (0, 1, 0, 1), (0, 1, 0), 0, _A), (2, (0, 1, 0, 1), (0, 0, 0), 1, _A),
    (2, (0, 0, 1, 1), (0, 0, 0), 0, _A), (2, (0, 0, 1, 1), (0, 1, 0), -1, _A),
    (2, (0, 2, 0, 1), (0, 0, 0), 1, _A), (2, (0, 1, 1, 1), (0, 0, 0), 0, _A), (2, (0, 2, 1, 0), (0, 0, 0), 1, _A),
    (2, (0, 1, 2, 0), (0, 0, 0), 0, _A), (2, (0, 0, 3, 0), (0, 0, 0), -1, _A), (2, (0, 0, 2, 1), (0, 0, 0), -1, _A),
    (2, (0, 1, 0, 2), (0, 0, 0), 0, _A), (2, (0, 0, 1, 2), (0, 0, 0), -1, _A), (2, (0, 0, 0, 3), (0, 0, 0), -1, _A),
    (2, (0, 0, 0, 0), (0, 2, 0), 0, _A), (2, (0, 0, 0, 0), (0, 1, 0), 1, _A), (2, (0, 0, 0, 0), (0, 3, 0), -1, _A),
]
EXTRA = [
    (1, (1, 1, 0, 0), (0, 0, 0), 0, _S), (1, (2, 1, 0, 0), (0, 0, 0), 0, _S), (1, (1, 0, 1, 0), (0, 0, 0), 0, _S),
    (1, (1, 0, 0, 0), (0, 1, 0), 0, _S), (1, (0, 0, 1, 0), (1, 0, 0), 0, _S), (1, (1, 0, 0, 0), (1, 1, 0), 0, _S),
    (2, (2, 0, 0, 0), (0, 0, 0), 0, _S), (2, (1, 2, 0, 0), (0, 0, 0), 0, _S), (2, (3, 0, 0, 0), (0, 0, 0), 0, _S),
    (2, (0, 1, 0, 0), (0, 0, 1), 0, _I), (2, (0, 0, 0, 1), (1, 0, 0), 0, _S), (2, (0, 1, 0, 1), (0, 0, 0), 0, _S),
    (1, (0, 0, 0, 0), (0, 0, 0), 0, _S),
]


def synthetic_ode(seed=0, omega1=1.004, omega2=1.0, xi=0.004, keep=lambda spec: True) -> TwoModeODE:
    rng = np.random.default_rng(seed)
    terms = [Term(1, (1, 0, 0, 0), (0, 0, 0), 0, omega1**2, "linear", "omega1^2"),
             Term(2, (0, 1, 0, 0), (0, 0, 0), 0, omega2**2, "linear", "omega2^2"),
             Term(1, (0, 0, 1, 0), (0, 0, 0), 0, 2 * xi * omega1, "damping", "2 xi omega1"),
             Term(2, (0, 0, 0, 1), (0, 0, 0), 0, 2 * xi * omega2, "damping", "2 xi omega2")]
    for spec in EQ21 + EXTRA:
        c = float(rng.uniform(-1, 1))
        if keep(spec):
            terms.append(Term(spec[0], spec[1], spec[2], spec[3], c, spec[4]))
    return TwoModeODE(terms=tuple(terms), omega1=omega1, omega2=omega2, xi_s=xi)


@pytest.fixture(scope="module")
def synthetic():
    ode = synthetic_ode()
    return ode, derive(ode)


def test_synthetic_table_derivation_and_cache(synthetic):
    """A 100-term table derives with all checks passing and survives a JSON round trip (the
    derivation and reload times are targets of `autocable bench ame-vs-ode`, not asserted here)."""
    ode, ame = synthetic
    assert len(ode.terms) == 100
    assert all(ame.checks.values()) and len(ame.checks) == 5
    text = json.dumps(ame.to_dict())
    back = AmplitudeEquations.from_dict(json.loads(text))
    back.cartesian_rhs()
    assert back == ame
    assert back.cartesian_rows == ame.cartesian_rows and back.polar_rows == ame.polar_rows
    assert ame.provenance["ode_hash"] == ode.content_hash()


def test_default_ordering_rules(synthetic):
    ode, ame = synthetic
    ordering = default_ordering(ode)
    assert ordering == ame.ordering
    by_label = {e.label: e for e in ordering.entries}
    assert "omega1^2" not in by_label                         # stiffness: Omega^2 + detuning, not an entry
    assert by_label["2 xi omega1"].order == 3                  # structural damping O(eps^2)
    assert by_label["eq1:q1dot*U"].order == 3                  # linear aero x eps^2
    assert by_label["eq1:q1dot^2"].order == 3                  # quadratic aero x eps
    assert by_label["eq1:q1dot^3/U"].order == 3                # cubic aero x 1: saturates galloping
    assert by_label["eq1:eta*fddot"].order == 3                # resonant external forcing
    assert by_label["eq1:q1^2"].order == 2 and by_label["eq1:q1*eta*f"].order == 2
    assert by_label["eq1:eta^2*f^2"].order == 2 and by_label["eq1:eta^3*f^3"].order == 3
    assert by_label["eq1:1"].order == 3                        # a constant load (enters q3 only)
    effects = dict(zip((e.label for e in ordering.entries), ame.effects))
    assert effects["eq1:q1dot^2"].startswith("order 3: no resonant part")
    assert effects["eq1:q1dot^2*eta*fdot/U"] == "order 3: direct"
    assert effects["eq1:q1^2"].startswith("order 2: via q2")


def test_ordering_override_and_checks():
    ode = synthetic_ode(keep=lambda s: s[3] == 0 and s[4] != _A)
    base = derive(ode)
    # A quadratic aerodynamic term moved to second order now feeds q2 and changes the AME.
    ode2 = synthetic_ode(keep=lambda s: (s[3] == 0 and s[4] != _A) or s[:4] == (1, (0, 0, 2, 0), (0, 0, 0), 0))
    o2 = default_ordering(ode2)
    assert derive(ode2).complex_rows == base.complex_rows   # quadratic aero at order 3: no effect
    moved = derive(ode2, o2.override({"eq1:q1dot^2": 2}))
    assert moved.complex_rows != base.complex_rows
    assert moved.ordering.as_dict()["eq1:q1dot^2"] == 2
    # Dropping a term by label.
    dropped = derive(ode, default_ordering(ode).override({"eq1:q1^3": None}))
    assert dropped.effects[[e.label for e in dropped.ordering.entries].index("eq1:q1^3")] == "dropped"
    with pytest.raises(ValueError):
        default_ordering(ode).override({"eq1:q1^3": 2})       # cubic cannot start at eps^2
    with pytest.raises(KeyError):
        default_ordering(ode).override({"no such term": 3})
    # A resonant (odd) term at second order: dA/dT1 != 0, the derivation refuses.
    bad = default_ordering(ode).override({"eq1:eta*fddot": 2})
    with pytest.raises(MultipleScalesError, match="dA/dT1"):
        derive(ode, bad)
    with pytest.raises(MultipleScalesError, match="ordering was not made"):
        derive(ode2, default_ordering(ode))


def test_adapter_checks_stiffness():
    ode = synthetic_ode()
    wrong = TwoModeODE(terms=ode.terms, omega1=1.01, omega2=1.0, xi_s=0.004)
    with pytest.raises(MultipleScalesError, match="omega1"):
        from_two_mode_ode(wrong)
    system = from_two_mode_ode(ode)
    assert system.omegas == (1.004, 1.0) and len(system.terms) == len(ode.terms) - 2


def test_invariance_of_A2_zero_and_coupling():
    # Every term of equation 2 contains q2 or q2': A2 = 0 is invariant, F_2(A_1, 0) = 0.
    ode = synthetic_ode(keep=lambda s: s[0] == 1 or s[1][1] or s[1][3])
    ame = derive(ode)
    assert all(r.state[1] or r.state[3] for r in ame.complex_rows if r.equation == 1)
    rng = np.random.default_rng(3)
    p = ame.control(eta=0.01, U=1.2, sigma=0.02)
    for _ in range(5):
        A1 = complex(*rng.normal(size=2))
        assert ame.complex_rhs([A1, 0.0], p)[1] == 0.0
    # With the full table (e.g. Gamma_{2,1} q1', Gamma_{2,17} q1'^3, Gamma_{2,22}) mode 2 is driven.
    full = derive(synthetic_ode())
    assert any(not (r.state[1] or r.state[3]) for r in full.complex_rows if r.equation == 1)
    assert abs(full.complex_rhs([0.3 + 0.1j, 0.0], p)[1]) > 1e-6


def test_forms_agree_at_random_points(synthetic):
    _, ame = synthetic
    s = ame.symbols()
    cplx = ame.complex_expressions()
    polar = ame.polar_expressions()
    cart = ame.cartesian_expressions()
    pn = ["eta", "U", "sigma_1", "sigma_2", "Omega"]
    args = [s[x] for x in pn]
    f_c = sp.lambdify([s["A_1"], s["A_2"], s["Abar_1"], s["Abar_2"], *args], cplx, "numpy")
    f_p = sp.lambdify([s["a_1"], s["a_2"], s["Phi_1"], s["Phi_2"], *args], polar, "numpy")
    f_g = sp.lambdify([s["r_1"], s["s_1"], s["r_2"], s["s_2"], *args], cart, "numpy")
    rhs = ame.cartesian_rhs()
    rng = np.random.default_rng(7)
    for _ in range(20):
        a = rng.uniform(0.01, 0.5, 2)
        phi = rng.uniform(-np.pi, np.pi, 2)
        p = ame.control(eta=rng.uniform(0, 0.02), U=rng.uniform(0.2, 2), sigma=rng.uniform(-0.05, 0.05))
        A = a / 2 * np.exp(1j * phi)
        Fc = np.array(f_c(*A, *np.conj(A), *p))
        assert np.allclose(Fc, ame.complex_rhs(A, p), rtol=1e-12, atol=1e-15)
        P = np.array(f_p(*a, *phi, *p))
        lhs = P[:2] + 1j * P[2:]
        assert np.max(abs(lhs - 2 * np.exp(-1j * phi) * Fc)) < 1e-12 * np.max(abs(Fc))
        y = np.array([2 * A[0].real, 2 * A[0].imag, 2 * A[1].real, 2 * A[1].imag])
        G = np.array(f_g(*y, *p))
        assert np.max(abs(G[0::2] + 1j * G[1::2] - 2 * Fc)) < 1e-12 * np.max(abs(Fc))
        assert np.max(abs(rhs(y, p) - G)) < 1e-12 * np.max(abs(G))
        # Jacobian against central differences.
        h = 1e-6
        Jfd = np.column_stack([(rhs(y + h * e, p) - rhs(y - h * e, p)) / (2 * h) for e in np.eye(4)])
        assert np.allclose(rhs.jacobian(y, p), Jfd, rtol=1e-6, atol=1e-8)


def test_no_wind_drops_aerodynamic_rows():
    ode = synthetic_ode()
    ame = derive(ode)
    no_aero = derive(TwoModeODE(terms=tuple(t for t in ode.terms if t.origin != "aerodynamic"),
                                omega1=ode.omega1, omega2=ode.omega2, xi_s=ode.xi_s))
    y = np.array([0.1, -0.2, 0.05, 0.3])
    p = ame.control(eta=0.01, U=0.0, sigma=0.01)
    assert np.all(np.isfinite(ame.cartesian_rhs()(y, p)))
    assert np.allclose(ame.cartesian_rhs()(y, p), no_aero.cartesian_rhs()(y, p), rtol=1e-13, atol=1e-16)
    assert len(ame.cartesian_expressions(include_aero=False)[0].free_symbols & {ame.symbols()["U"]}) == 0


def test_one_dof_reduction(synthetic):
    _, ame = synthetic
    one = ame.one_dof()
    assert one.n_modes == 1 and one.modes == (1,)
    assert one.param_names[:4] == ("eta", "U", "sigma_1", "Omega")
    rng = np.random.default_rng(11)
    for _ in range(5):
        A1 = complex(*rng.normal(scale=0.2, size=2))
        p = ame.control(eta=0.01, U=1.3, sigma=rng.uniform(-0.05, 0.05))
        p1 = one.control(eta=0.01, U=1.3, sigma=p[2] * -1)
        assert np.allclose(one.complex_rhs([A1], p1)[0], ame.complex_rhs([A1, 0.0], p)[0], rtol=1e-13)
        y = np.array([2 * A1.real, 2 * A1.imag])
        assert np.allclose(one.cartesian_rhs()(y, p1), ame.cartesian_rhs()(np.r_[y, 0, 0], p)[:2], rtol=1e-12)
    assert AmplitudeEquations.from_dict(json.loads(json.dumps(one.to_dict()))) == one


def test_control_relations(synthetic):
    _, ame = synthetic
    p = ame.control(eta=1e-3, U=0.7, sigma=-0.042)
    eta, U, s1, s2, Omega = p
    assert np.isclose(Omega, 1.004 - 0.042) and np.isclose(s1, 0.042)     # sigma = -sigma_1
    assert np.isclose(s2 - s1, 1.0 - 1.004)                               # rho = omega2 - omega1
    assert np.isclose(ame.control(sigma=0.01, rho=-0.01)[3] - ame.control(sigma=0.01, rho=-0.01)[2], -0.01)
    rel = ame.detuning_relations()
    s = ame.symbols()
    assert rel[s["sigma_1"]] == -s["sigma"] and rel[s["sigma_2"]] == s["rho"] - s["sigma"]
