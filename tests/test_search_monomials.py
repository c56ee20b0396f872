"""The search's batched evaluation of the AME as a polynomial in the state (`monomials.Monomials`)
against the lambdified functions it replaces (`System.f_many`, `jac_many`), and the searches of the
figure scenes with either: the same equilibria (stated tolerances below)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from autocable.methods.continuation import System, ame_system
from autocable.methods.continuation.search import Monomials, find_equilibria
from autocable.methods.continuation.system import auto_state_scale
from autocable.model.ame_cache import derive_ame
from autocable.model.derive import derive
from autocable.spec import load_model

MODEL = Path(__file__).resolve().parents[1] / "models" / "luongo_zulli_2012.toml"


@pytest.fixture(scope="module")
def systems():
    d = derive(load_model(MODEL))
    return {order: ame_system(derive_ame(d, ordering=order).ame, "2dof", wind=True)
            for order in ("natural", "paper")}


# (ordering, fixed values, search values of the continued parameter): Fig. 4a's search (natural
# ordering, in U) and Fig. 10's (paper ordering, in sigma), as in runs/fig04a.toml, runs/fig10.toml
CASES = [("natural", {"sigma": 0.01, "eta": 1.6e-4}, "U", (0.85, 0.95, 1.05)),
         ("paper", {"U": 1.3, "eta": 1.4e-3}, "sigma", (-0.04, 0.0, 0.04))]


@pytest.mark.parametrize("order, fixed, name, values", CASES)
@pytest.mark.slow
def test_monomials_equal_the_lambdified_field_and_jacobian(systems, order, fixed, name, values):
    system = systems[order]
    m = Monomials.of(system)
    assert m is not None and m.E.shape == (35, 4)          # every cubic monomial of (r1, s1, r2, s2)
    X = np.random.default_rng(1).normal(size=(300, 4)) * 5e-3
    for v in values:
        p = system.parameter_vector({**fixed, name: v})
        F0, F1 = system.f_many(X, p), m.f_many(X, p)
        J0, J1 = system.jac_many(X, p), m.jac_many(X, p)
        assert np.max(np.abs(F1 - F0)) <= 1e-12 * np.max(np.abs(F0))
        assert np.max(np.abs(J1 - J0)) <= 1e-12 * np.max(np.abs(J0))


@pytest.mark.parametrize("order, fixed, name, values", CASES)
@pytest.mark.slow
def test_monomial_derivative_tensors_equal_sympys(systems, order, fixed, name, values):
    """`System.hessian` / `third` (from the monomials since they are exact for a polynomial field)
    against sympy's second and third derivatives of the same AME, lambdified: equal to 1e-12 of
    the largest entry at random states (the order of the sums differs), and the first Lyapunov
    coefficient (Kuznetsov's eq. 3.20) at a state where J has a complex pair to 1e-10."""
    from autocable.methods.continuation.events import first_lyapunov
    system = systems[order]
    assert Monomials.of(system) is not None
    f2, f3 = system._numeric_function("d2"), system._numeric_function("d3")
    n = system.dimension
    rng = np.random.default_rng(2)
    for v in values:
        p = system.parameter_vector({**fixed, name: v})
        for x in rng.normal(size=(5, n)) * 5e-3:
            H0 = np.broadcast_to(np.array(f2(x, p), dtype=float), (n,) * 3).transpose(2, 1, 0)
            T0 = np.broadcast_to(np.array(f3(x, p), dtype=float), (n,) * 4).transpose(3, 2, 1, 0)
            H1, T1 = system.hessian(x, p), system.third(x, p)
            assert np.max(np.abs(H1 - H0)) <= 1e-12 * np.max(np.abs(H0))
            assert np.max(np.abs(T1 - T0)) <= 1e-12 * np.max(np.abs(T0))
    # l1 either way at a state with a complex pair of J (a Hopf point needs its real part zero;
    # the formula needs only the pair)
    p = system.parameter_vector({**fixed, name: values[1]})
    for x in rng.normal(size=(20, n)) * 5e-3:
        ev = np.linalg.eigvals(system.jac(x, p))
        if np.any(np.abs(ev.imag) > 1e-9):
            break
    else:
        pytest.fail("no state with a complex pair")
    l1_mono = first_lyapunov(system, x, p)[0]
    system.__dict__["_higher"] = (
        lambda x, p: np.broadcast_to(np.array(f2(x, p), dtype=float), (n,) * 3).transpose(2, 1, 0),
        lambda x, p: np.broadcast_to(np.array(f3(x, p), dtype=float), (n,) * 4).transpose(3, 2, 1, 0))
    try:
        l1_sympy = first_lyapunov(system, x, p)[0]
    finally:
        del system.__dict__["_higher"]
    assert l1_mono == pytest.approx(l1_sympy, rel=1e-10)


@pytest.mark.parametrize("order, fixed, name, values", CASES)
@pytest.mark.slow
def test_the_search_finds_the_same_equilibria_either_way(systems, order, fixed, name, values):
    system = systems[order]
    m = Monomials.of(system)
    for v in values:
        vals = {**fixed, name: v}
        scale = 0.005 if order == "natural" else auto_state_scale(system, vals)
        fast = find_equilibria(system, vals, scale=scale)
        system.__dict__["_search_monomials"] = False      # the lambdified path
        try:
            slow = find_equilibria(system, vals, scale=scale)
        finally:
            system.__dict__["_search_monomials"] = m
        assert len(fast) == len(slow) >= 1
        for a, b in zip(fast, slow):
            assert a.stable == b.stable
            x = np.asarray(b.state)
            assert np.linalg.norm(np.asarray(a.state) - x) <= 1e-10 * (np.linalg.norm(x) + scale)


def test_a_field_that_is_not_polynomial_in_the_state_keeps_the_lambdified_path():
    x, p = sp.symbols("x y"), sp.Symbol("k")
    system = System("pendulum", ("x", "y"), [x[1], -p * sp.sin(x[0])], (("k", 1.0),), (("a", ("x",)),))
    assert Monomials.of(system) is None
    found = find_equilibria(system, {"k": 1.0}, scale=1.0, max_amplitude=10.0)
    assert any(abs(e.state[0]) < 1e-12 and abs(e.state[1]) < 1e-12 for e in found)


def test_the_polynomial_form_is_cached_like_the_other_numeric_functions(tmp_path, monkeypatch):
    from autocable.methods import lambda_cache as L
    monkeypatch.setenv("AUTOCABLE_CACHE", str(tmp_path))
    x, y, s = sp.symbols("x y s")
    rhs = [s * x - sp.Rational(3, 8) * x * (x**2 + y**2) + 0.25 / s, -s * y + sp.Float("0.123456789012345") * x * y]
    fresh = L.numeric_function("poly", ("x", "y"), ("s",), rhs, use_cache=False)
    first = L.numeric_function("poly", ("x", "y"), ("s",), rhs)
    monkeypatch.setattr(L, "_expression", lambda *a: pytest.fail("cache hit re-derived the function"))
    second = L.numeric_function("poly", ("x", "y"), ("s",), rhs)
    assert len(list((tmp_path / "lambdas").glob("poly-*.py"))) == 1
    for got in (first, second):
        C, E = got(np.zeros(2), np.array([0.7]))
        C0, E0 = fresh(np.zeros(2), np.array([0.7]))
        assert E == E0 and np.allclose(np.array(C, float), np.array(C0, float), rtol=1e-15, atol=0)
    # F(x) = sum_m C[i][m] x^E[m] at a state: the closed form above
    C, E = (np.array(a, float) for a in first(np.zeros(2), np.array([0.7])))
    xv = np.array([0.3, -0.2])
    F = C @ np.prod(xv[None, :] ** E, axis=1)
    want = [0.7 * 0.3 - 3 / 8 * 0.3 * (0.09 + 0.04) + 0.25 / 0.7, 0.7 * 0.2 + 0.123456789012345 * 0.3 * -0.2]
    np.testing.assert_allclose(F, want, rtol=1e-14)
