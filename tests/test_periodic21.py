"""Periodic orbits of eq. (21): Floquet multipliers (floquet21) and their continuation (periodic21)."""
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from autocable.methods.floquet21 import (Variational21, floquet_multipliers, multipliers_of,
                                         shoot_period1)
from autocable.methods.integration import Ode21Integrator
from autocable.model.derive import derive
from autocable.model.equations import Term, TwoModeODE
from autocable.spec import load_model

SAMPLE = Path(__file__).resolve().parents[1] / "models" / "luongo_zulli_2012.toml"


def linear_ode(w1=1.02, w2=0.97, xi1=0.03, xi2=0.011, m=0.7) -> TwoModeODE:
    """q_k'' + 2 xi_k w_k q_k' + w_k^2 q_k = m eta f'' (k = 1) / 0 (k = 2): a closed-form test."""
    terms = (Term(1, (1, 0, 0, 0), (0, 0, 0), 0, w1**2, "linear"),
             Term(1, (0, 0, 1, 0), (0, 0, 0), 0, 2 * xi1 * w1, "damping"),
             Term(1, (0, 0, 0, 0), (0, 0, 1), 0, -m, "inertia"),
             Term(2, (0, 1, 0, 0), (0, 0, 0), 0, w2**2, "linear"),
             Term(2, (0, 0, 0, 1), (0, 0, 0), 0, 2 * xi2 * w2, "damping"))
    return TwoModeODE(terms=terms, omega1=w1, omega2=w2, xi_s=xi1)


@pytest.fixture(scope="module")
def sample():
    return derive(load_model(SAMPLE))


@pytest.fixture(scope="module")
def variational(sample):
    return Variational21(sample.ode)


def test_linear_oscillator_multipliers_are_exp_of_eigenvalues():
    """Linear: the monodromy is exp(A T) exactly, so mu = exp(T lambda(A)); the closed-form
    steady response q1 = Re(Q e^{i Omega t}) is a fixed point of the period map."""
    ode = linear_ode()
    sigma, eta, m = 0.013, 1e-3, 0.7
    Om = ode.omega1 + sigma
    w1, xi1 = 1.02, 0.03
    # q1'' + 2 xi w q1' + w^2 q1 = -m eta Om^2 sin(Om t): q1 = Im(Q e^{i Om t})
    Q = -m * eta * Om**2 / (w1**2 - Om**2 + 2j * xi1 * w1 * Om)
    state0 = (Q.imag, 0.0, (1j * Om * Q).imag, 0.0)
    fl = floquet_multipliers(ode, 0.0, eta, sigma, state0)
    T = 2 * math.pi / Om
    expected = multipliers_of(np.diag(np.exp(T * np.linalg.eigvals(ode.linear_matrix(0.0)))))
    assert np.max(np.abs(fl.multipliers - expected)) < 1e-9
    assert fl.period == pytest.approx(T, rel=1e-15)
    assert fl.residual < 1e-9
    assert fl.stable and fl.max_modulus == pytest.approx(math.exp(-0.011 * 0.97 * T), rel=1e-9)


def test_sample_model_period1_response_is_stable_and_damped(sample, variational):
    """Fig. 5a point (U = 0, eta = 8.2e-5, sigma = 0): the period-1 response reached by integration
    is a fixed point of the period map, it is stable, and its multipliers are the linear damping
    exp(T lambda(A)) up to the nonlinear correction.

    Tolerances: (i) Liouville, exact: prod mu = exp(int_0^T tr J dt) (to 1e-8 relative, the
    quadrature and integration error); (ii) rigorous: with B(t) = J(t) - A along the orbit,
    beta = int_0^T |B| dt and K = cond(V) of A's eigenvectors, variation of constants and Gronwall
    give |Phi(T) - e^{AT}| <= K^2 beta e^{K beta}, and Bauer-Fike adds a factor K; (iii) the
    correction is the nonlinear one: it falls like eta^2 (a1^2) when eta is divided by 10."""
    ode = sample.ode
    eta, sigma = 8.2e-5, 0.0
    r = Ode21Integrator(ode).simulate(0.0, eta, sigma)
    assert r.steady and r.periodic
    fl = floquet_multipliers(sample, 0.0, eta, sigma, r.final_state, system=variational)
    assert fl.residual < 1e-7
    assert fl.stable and fl.max_modulus < 0.99

    Om = ode.omega1 + sigma
    T = fl.period
    p = variational.parameters(0.0, eta, Om)
    sol = solve_ivp(lambda t, y: variational.rhs(t, y, p), (0, T), r.final_state, method="DOP853",
                    rtol=1e-11, atol=1e-16, dense_output=True)
    ts = np.linspace(0.0, T, 2001)
    jac = [variational.jacobian(t, sol.sol(t), p) for t in ts]
    liouville = math.exp(np.trapz([np.trace(J) for J in jac], ts))
    assert np.prod(fl.multipliers).real == pytest.approx(liouville, rel=1e-8)

    A = ode.linear_matrix(0.0)
    lam, V = np.linalg.eig(A)
    K = np.linalg.cond(V)
    beta = np.trapz([np.linalg.norm(J - A, 2) for J in jac], ts)
    bound = K**3 * beta * math.exp(K * beta)
    linear = np.exp(T * lam)

    def deviation(mu):
        return max(min(abs(m - ml) for ml in linear) for m in mu)

    dev = deviation(fl.multipliers)
    assert dev < bound
    assert np.abs(fl.multipliers) == pytest.approx(math.exp(-ode.xi_s * T), abs=bound)

    small = shoot_period1(variational, 0.0, eta / 10, Om, np.asarray(r.final_state) / 10)
    assert small.converged
    ratio = dev / deviation(multipliers_of(small.monodromy))
    assert 50 < ratio < 400     # O(eta^2) = 100, with O(eta^3) and splitting corrections
