"""Compiled code once per structure, the numeric coefficients as run-time data
(`autocable.codegen.coefficients`, used by the C kernel, the DOP853 integrator and the search's
polynomial form).

* The template: its weights put back give the right-hand side (to 1e-15 relative at random
  points); every right-hand side of the AME (24)'s structure, whatever its numbers, gives the same
  template (the sample's wind AME with its coefficients redrawn at random, which reorders sympy's
  sums); a changed structure gives another.
* Two systems of one structure with different coefficients share one build (one compile in a
  fresh cache: one library folder, the second load compiles nothing) and each evaluates its own
  coefficients: F and J of the C kernel and the integrator against sympy's evaluation of that
  system's own right-hand side (1e-12 relative), the compiled engine's folds of two Duffing slow
  flows against their closed forms (1e-5), on the compiled engine and on PyCont (its generator
  built once, the numbers PyDSTool parameters), the search's polynomial form against the
  lambdified field (1e-12); a change of structure is a second build.
"""
from __future__ import annotations

import math
import random

import numpy as np
import pytest
import sympy as sp

from autocable.codegen import cintegrate, ckernel
from autocable.codegen.coefficients import coefficient_template
from autocable.methods.continuation import ContinuationSettings, EquilibriumProblem, System, continue_equilibria
from conftest import SAMPLE


@pytest.fixture(scope="module")
def ame():
    from autocable.model.ame_cache import derive_ame
    from autocable.model.derive import derive
    from autocable.spec import load_model
    return derive_ame(derive(load_model(SAMPLE))).ame


def redrawn(rhs, seed: int):
    """``rhs`` with every distinct Float value replaced by another (equal values stay equal): the
    same structure, other numbers."""
    rng = random.Random(seed)
    values = sorted({float(f) for e in rhs for f in e.atoms(sp.Float)})
    new = {v: v * rng.uniform(0.5, 1.5) for v in values}
    return tuple(e.xreplace({f: sp.Float(new[float(f)], 17) for f in e.atoms(sp.Float)}) for e in rhs)


def _evaluate(rhs, names, point):
    return np.array(sp.lambdify([sp.Symbol(n) for n in names], list(rhs), modules="mpmath")(*point), float)


@pytest.mark.slow
def test_the_template_restores_the_rhs_and_is_the_same_for_every_coefficient(ame):
    from autocable.methods.continuation import ame_system
    system = ame_system(ame, "2dof", wind=True)
    t = coefficient_template(system.rhs)
    assert len(t.weights) > 100 and all(n.startswith("ac_k") for n in t.weight_names)
    names = system.variables + system.parameter_names
    restored = t.restore()
    rng = np.random.default_rng(3)
    for _ in range(3):
        point = list(rng.uniform(-0.05, 0.05, 4)) + [0.02, 0.9, 1e-3]
        a, b = _evaluate(system.rhs, names, point), _evaluate(restored, names, point)
        assert np.max(np.abs(a - b)) <= 1e-15 * np.max(np.abs(a))
    keys = {coefficient_template(redrawn(system.rhs, seed)).key for seed in range(5)}
    assert keys == {t.key}
    # another structure: one term more, or one term less
    x = sp.Symbol("r1")
    assert coefficient_template((system.rhs[0] + sp.Float(0.25) * x**2,) + system.rhs[1:]).key != t.key
    assert coefficient_template(system.rhs[1:]).key != t.key


def _fresh(monkeypatch, tmp_path):
    monkeypatch.setenv("AUTOCABLE_CACHE", str(tmp_path))
    ckernel._kernel_for.cache_clear()
    cintegrate._integrator_for.cache_clear()


@pytest.mark.slow
def test_two_ames_of_one_structure_share_one_kernel_and_keep_their_coefficients(ame, monkeypatch, tmp_path):
    from autocable.methods.continuation import ame_system
    _fresh(monkeypatch, tmp_path)
    a = ame_system(ame, "2dof", wind=False)
    b = System("other_model", a.variables, redrawn(a.rhs, 7), dict(a.parameters), a.amplitudes)
    ka = ckernel.compiled_kernel(a)
    ckernel._kernel_for.cache_clear()              # the second from the disk cache, as in another process
    kb = ckernel.compiled_kernel(b)
    assert dict(ka.timings)["compile_s"] > 0 and dict(kb.timings)["compile_s"] == 0.0
    assert ka.path == kb.path and len(list((tmp_path / "ckernel").iterdir())) == 1
    names = a.variables + a.parameter_names
    x, p = np.array([0.01, -0.02, 0.015, 0.005]), np.array([0.02, 0.0, 1e-3])
    for system, k in ((a, ka), (b, kb)):
        F = _evaluate(system.rhs, names, list(x) + list(p))
        J = _evaluate(sp.Matrix(system.rhs).jacobian(sp.symbols(system.variables)), names, list(x) + list(p))
        assert np.max(np.abs(k.f(x, p) - F)) <= 1e-12 * np.max(np.abs(F))
        assert np.max(np.abs(k.jac(x, p) - J.reshape(4, 4))) <= 1e-12 * np.max(np.abs(J))
    assert np.max(np.abs(ka.f(x, p) - kb.f(x, p))) > 1e-3 * np.max(np.abs(ka.f(x, p)))
    # a change of structure (a term more) is a second build
    c = System("third", a.variables, (a.rhs[0] + sp.Float(0.5) * sp.Symbol("r1") ** 3,) + a.rhs[1:],
               dict(a.parameters), a.amplitudes)
    kc = ckernel.compiled_kernel(c)
    assert dict(kc.timings)["compile_s"] > 0 and kc.path != ka.path
    assert len(list((tmp_path / "ckernel").iterdir())) == 2


@pytest.mark.slow
def test_two_ames_of_one_structure_share_one_integrator(ame, monkeypatch, tmp_path):
    from autocable.methods.continuation import ame_system
    _fresh(monkeypatch, tmp_path)
    a = ame_system(ame, "2dof", wind=False)
    rhs_b = redrawn(a.rhs, 11)
    ia = cintegrate.compiled_integrator("model_a", a.variables, a.parameter_names, a.rhs, None)
    cintegrate._integrator_for.cache_clear()
    ib = cintegrate.compiled_integrator("model_b", a.variables, a.parameter_names, rhs_b, None)
    assert dict(ia.timings)["compile_s"] > 0 and dict(ib.timings)["compile_s"] == 0.0
    assert ia.path == ib.path and len(list((tmp_path / "cintegrate").iterdir())) == 1
    names = a.variables + a.parameter_names
    x, p = np.array([0.01, -0.02, 0.015, 0.005]), np.array([-0.01, 0.0, 1.4e-3])
    for rhs, ci in ((a.rhs, ia), (rhs_b, ib)):
        F = _evaluate(rhs, names, list(x) + list(p))
        J = _evaluate(sp.Matrix(rhs).jacobian(sp.symbols(a.variables)), names, list(x) + list(p))
        assert np.max(np.abs(ci.rhs(0.0, x, p) - F)) <= 1e-12 * np.max(np.abs(F))
        assert np.max(np.abs(ci.jac(0.0, x, p) - J.reshape(4, 4))) <= 1e-12 * np.max(np.abs(J))
        # and a run: the state after 50 time units against scipy's DOP853 at tight tolerances
        from scipy.integrate import solve_ivp
        f = sp.lambdify([sp.symbols(a.variables), sp.symbols(a.parameter_names)], list(rhs), modules="numpy")
        ref = solve_ivp(lambda t, y: f(y, p), (0.0, 50.0), x, rtol=1e-12, atol=1e-15, method="DOP853")
        run = ci.run(x, np.array([0.0, 50.0]), p, rtol=1e-12, atol=1e-15)
        assert run.ok and np.max(np.abs(run.y[-1] - ref.y[:, -1])) <= 1e-9 * np.max(np.abs(ref.y[:, -1]))


MU_D, F_D = 0.1, 0.2


def duffing(kappa: float, name: str) -> System:
    u, v, s = sp.symbols("u v sigma")
    w = s - sp.Float(kappa) * (u * u + v * v)
    return System(name, ("u", "v"), (-sp.Float(MU_D) * u - w * v, -sp.Float(MU_D) * v + w * u - sp.Float(F_D)),
                  {"sigma": -1.0}, (("a1", ("u", "v")),))


def duffing_folds(kappa: float):
    roots = np.roots([4 * kappa**2 * MU_D**2, -4 * kappa**2 * F_D**2, 0.0, 0.0, F_D**4])
    A = np.sort(roots[(np.abs(roots.imag) < 1e-12) & (roots.real > 0)].real)
    return [(kappa * a + F_D**2 / (2 * kappa * a * a), math.sqrt(a)) for a in A]


def _one_build(engine: str, cache) -> int:
    if engine == "compiled":
        return len(list((cache / "ckernel").iterdir()))
    return len(list((cache / "pydstool").glob("dop853_temp/_dop853_duffing_pycont_*.so")))


@pytest.mark.parametrize("engine, name", [
    ("compiled", lambda kappa: f"duffing_{kappa}"),    # the kernel is keyed by structure, not by name
    ("pycont", lambda kappa: "duffing_pycont"),        # PyDSTool names its build: one name, one build
])
@pytest.mark.slow
def test_each_duffing_finds_its_own_folds_with_one_build(monkeypatch, tmp_path, engine, name):
    """Two Duffing slow flows of one structure with different coefficients: one build (the C
    kernel; PyCont's EP-C generator with the numbers as PyDSTool parameters), and each finds its
    own closed-form folds."""
    _fresh(monkeypatch, tmp_path)
    for kappa in (1.0, 0.7):
        system = duffing(kappa, name(kappa))
        problem = EquilibriumProblem(system, "sigma", {"sigma": -1.0}, (-1.0, 6.0))
        r = continue_equilibria(problem, ContinuationSettings(max_step=4e-2), name="I", directions="forward",
                                engine=engine)
        folds = sorted(r.branch.of_type("LP"), key=lambda s: s.value)
        assert len(folds) == 2
        for sp_, (sigma_f, a_f) in zip(folds, duffing_folds(kappa)):
            assert sp_.value == pytest.approx(sigma_f, abs=1e-5)
            assert sp_.a1 == pytest.approx(a_f, abs=1e-5)
    assert _one_build(engine, tmp_path) == 1


def test_the_search_polynomial_form_is_generated_once_per_structure(ame, monkeypatch, tmp_path):
    from autocable.methods.continuation import ame_system
    from autocable.methods.continuation.search import Monomials
    _fresh(monkeypatch, tmp_path)
    a = ame_system(ame, "2dof", wind=False)
    b = System("other_model", a.variables, redrawn(a.rhs, 5), dict(a.parameters), a.amplitudes)
    X = np.random.default_rng(2).normal(size=(50, 4)) * 5e-3
    p = a.parameter_vector({"sigma": 0.01, "eta": 1.4e-3})
    for system in (a, b):
        m = Monomials(system)
        F0, F1 = system.f_many(X, p), m.f_many(X, p)
        J0, J1 = system.jac_many(X, p), m.jac_many(X, p)
        assert np.max(np.abs(F1 - F0)) <= 1e-12 * np.max(np.abs(F0))
        assert np.max(np.abs(J1 - J0)) <= 1e-12 * np.max(np.abs(J0))
    assert len(list((tmp_path / "lambdas").glob("poly-*.py"))) == 1


def test_a_symbol_with_the_weights_prefix_is_refused_every_time():
    """A right-hand side that already uses a weight's name cannot be templated (its symbol and a
    weight would be one); the refusal holds on a second call too (the template cache does not
    keep failures)."""
    from autocable.codegen.coefficients import WEIGHT_PREFIX, coefficient_template
    rhs = [sp.Symbol(f"{WEIGHT_PREFIX}0") * 2.5 + sp.Symbol("x")]
    for _ in range(2):
        with pytest.raises(ValueError, match="reserved for compiled coefficients"):
            coefficient_template(rhs)
