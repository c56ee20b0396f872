"""The cached numeric functions of a `System` (`autocable.methods.lambda_cache`) are the functions
sympy.lambdify makes, whether built fresh or read back from the cache folder."""
import numpy as np
import pytest
import sympy as sp

from autocable.methods import lambda_cache as L


def _rhs():
    # A small AME-like field with Floats that must survive the round trip exactly (srepr key).
    x, y, s, e = sp.symbols("x y sigma eta")
    return ["x", "y"], ["sigma", "eta"], [
        sp.Float("0.123456789012345") * x + s * y - sp.Rational(3, 8) * x * (x**2 + y**2) + e * sp.cos(y),
        -s * x - 0.004 * y + sp.Rational(1, 3) * y * (x**2 + y**2) + e * sp.sin(x) * x,
    ]


@pytest.mark.parametrize("kind", L.KINDS)
def test_cached_function_equals_fresh_lambdify_and_the_second_call_reads_the_file(kind, tmp_path, monkeypatch):
    monkeypatch.setenv("AUTOCABLE_CACHE", str(tmp_path))
    variables, parameters, rhs = _rhs()
    fresh = L.numeric_function(kind, variables, parameters, rhs, use_cache=False)
    assert not (tmp_path / "lambdas").exists()
    first = L.numeric_function(kind, variables, parameters, rhs)
    files = sorted((tmp_path / "lambdas").glob(f"{kind}-*.py"))
    assert len(files) == 1
    # A hit must not differentiate again: make any sympy derivative fail while reading it back.
    monkeypatch.setattr(L, "_expression", lambda *a: pytest.fail("cache hit re-derived the function"))
    second = L.numeric_function(kind, variables, parameters, rhs)
    assert second.__code__.co_filename == str(files[0])
    rng = np.random.default_rng(5)
    for _ in range(5):
        x, p = rng.normal(size=2), rng.normal(size=2)
        want = np.array(fresh(x, p), dtype=float)
        for got in (first(x, p), second(x, p)):
            np.testing.assert_allclose(np.array(got, dtype=float), want, rtol=1e-15, atol=0)


def test_a_changed_coefficient_gets_its_own_cached_function(tmp_path, monkeypatch):
    monkeypatch.setenv("AUTOCABLE_CACHE", str(tmp_path))
    variables, parameters, rhs = _rhs()
    changed = [rhs[0], rhs[1].subs(sp.Float(0.004), sp.Float(0.0040000001))]
    assert L.rhs_key(changed) != L.rhs_key(rhs)
    a = L.numeric_function("f", variables, parameters, rhs)
    b = L.numeric_function("f", variables, parameters, changed)
    assert len(list((tmp_path / "lambdas").glob("f-*.py"))) == 2
    x, p = np.array([0.3, -0.2]), np.array([0.1, 0.0])
    assert float(np.asarray(a(x, p))[1, 0] - np.asarray(b(x, p))[1, 0]) == pytest.approx(1e-10 * -0.2, rel=1e-6)


def test_unknown_kind_is_refused():
    with pytest.raises(ValueError, match="unknown numeric function 'hessian'"):
        L.numeric_function("hessian", ["x"], [], [sp.Symbol("x")])


# --------------------------------------------------------------------------------------------
# The Cartesian AME (24) as a System, kept as srepr text (autocable.methods.continuation.system.ame_system).
def _ame():
    from pathlib import Path

    from autocable.model.ame_cache import derive_ame
    from autocable.model.derive import derive
    from autocable.spec import load_model
    return derive_ame(derive(load_model(Path(__file__).resolve().parents[1] / "models"
                                         / "luongo_zulli_2012.toml"))).ame


@pytest.mark.parametrize("dof, wind", [("2dof", True), ("2dof", False), ("1dof", True)])
def test_ame_system_read_back_from_the_cache_is_the_system_sympy_builds(dof, wind, tmp_path, monkeypatch):
    from autocable.methods.continuation import system as S
    from autocable.model.ame import AmplitudeEquations

    ame = _ame()       # derived with the usual cache; the systems go to an empty one
    monkeypatch.setenv("AUTOCABLE_CACHE", str(tmp_path))
    fresh = S.ame_system(ame, dof, wind=wind, use_cache=False)
    assert not (tmp_path / "systems").exists()
    first = S.ame_system(ame, dof, wind=wind)
    files = list((tmp_path / "systems").glob("ame-system-*.json"))
    assert len(files) == 1
    # A hit must not build the expressions from the rows again.
    monkeypatch.setattr(AmplitudeEquations, "cartesian_expressions",
                        lambda *a, **k: pytest.fail("cache hit rebuilt the AME expressions"))
    second = S.ame_system(ame, dof, wind=wind)
    for got in (first, second):
        assert got.variables == fresh.variables and got.parameters == fresh.parameters
        assert got.amplitudes == fresh.amplitudes and got.name == fresh.name
        assert [sp.srepr(e) for e in got.rhs] == [sp.srepr(e) for e in fresh.rhs]   # exact, every Float
    # The key the hit carries without printing the expressions is the one printing them gives.
    assert second._rhs_key == L.rhs_key(fresh.rhs)
    x = np.array([1e-3, -2e-3, 5e-4, 3e-4][: fresh.dimension])
    p = fresh.parameter_vector({"sigma": 0.01, "U": 0.7 if wind else 0.0, "eta": 4.1e-4})
    np.testing.assert_array_equal(second.f(x, p), fresh.f(x, p))
    np.testing.assert_array_equal(second.jac(x, p), fresh.jac(x, p))


def test_ame_system_cache_is_per_reduction_and_a_damaged_file_is_rebuilt(tmp_path, monkeypatch):
    from autocable.methods.continuation import system as S

    ame = _ame()
    monkeypatch.setenv("AUTOCABLE_CACHE", str(tmp_path))
    for dof, wind in (("2dof", True), ("2dof", False), ("1dof", True), ("1dof", False)):
        S.ame_system(ame, dof, wind=wind)
    files = sorted((tmp_path / "systems").glob("ame-system-*.json"))
    assert len(files) == 4
    fresh = S.ame_system(ame, "2dof", wind=True, use_cache=False)
    target = next(f for f in files if len(f.read_text()) == max(len(g.read_text()) for g in files))
    for damage in ('{"format": 1, "rhs": ["Add(Symbol(\'r1\'), "]}',   # unparsable text
                   '{"format": 1, "rhs": ["__import__(\'os\')"]}',     # no builtins in the namespace
                   "not json"):
        target.write_text(damage)
        got = S.ame_system(ame, "2dof", wind=True)
        assert [sp.srepr(e) for e in got.rhs] == [sp.srepr(e) for e in fresh.rhs]
        assert '"rhs"' in target.read_text() and "Symbol('r1')" in target.read_text()   # written again
