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
