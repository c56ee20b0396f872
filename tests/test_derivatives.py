"""autocable.model.derivatives: the same expressions as sympy's ``diff``, faster.

The claim the module makes is equality as sympy expressions (so the text lambdify and the C printer
write, and every number computed from it, is unchanged). It is checked here on every entry of the
sample's Cartesian AME (24) Jacobians J_x, J_p and the second and third derivative tensors of the
first Lyapunov coefficient, wind and no wind, 2-dof and the A2 = 0 reduction; on the C integrator's
eq. (21) field with its time-dependent forcing; and on expressions outside the fast rules (a
symbol in an exponent, functions), which go to sympy itself."""
import time

import pytest
import sympy as sp

from autocable.methods.continuation.system import ame_system
from autocable.model import derivatives as D


@pytest.fixture(scope="module", params=[("2dof", True), ("2dof", False), ("1dof", True)],
                ids=["2dof-wind", "2dof-no-wind", "1dof-wind"])
def system(request, sample_ame):
    dof, wind = request.param
    return ame_system(sample_ame, dof, wind=wind, use_cache=False)


def test_jacobians_equal_sympys_expression_by_expression(system):
    xs = [sp.Symbol(v) for v in system.variables]
    ps = [sp.Symbol(p) for p in system.parameter_names]
    rhs = [sp.sympify(e) for e in system.rhs]
    sp.core.cache.clear_cache()
    t0 = time.perf_counter()
    J_ref, Jp_ref = sp.Matrix(rhs).jacobian(xs), sp.Matrix(rhs).jacobian(ps)
    t_ref = time.perf_counter() - t0
    sp.core.cache.clear_cache()
    t0 = time.perf_counter()
    memo: dict = {}
    J, Jp = D.jacobian(rhs, xs, memo), D.jacobian(rhs, ps, memo)
    t_fast = time.perf_counter() - t0
    assert J.shape == J_ref.shape and Jp.shape == Jp_ref.shape
    for a, b in zip(list(J) + list(Jp), list(J_ref) + list(Jp_ref)):
        assert a == b
        assert sp.srepr(a) == sp.srepr(b)      # the same tree, so the same printed text
    # not a timing assertion (benchmarks hold those): the information for a failing run
    print(f"{system.name}: sympy {t_ref:.2f} s, derivatives {t_fast:.2f} s")


@pytest.mark.slow
def test_lyapunov_tensors_equal_sympys(system):
    xs = [sp.Symbol(v) for v in system.variables]
    rhs = [sp.sympify(e) for e in system.rhs]
    d2_ref = sp.derive_by_array(sp.derive_by_array(rhs, xs), xs)
    d3_ref = sp.derive_by_array(d2_ref, xs).tolist()
    memo: dict = {}
    d2 = D.derive_by_array(D.derive_by_array(rhs, xs, memo), xs, memo)
    d3 = D.derive_by_array(d2, xs, memo)
    assert d2 == d2_ref.tolist()
    assert d3 == d3_ref


@pytest.mark.slow
def test_numeric_functions_print_the_same_text(system):
    """What lambda_cache stores: lambdify's text from the fast derivatives is sympy's, character
    for character (so cached functions of earlier versions stay valid and no number moves)."""
    import inspect

    from autocable.methods.lambda_cache import _expression
    xs = [sp.Symbol(v) for v in system.variables]
    ps = [sp.Symbol(p) for p in system.parameter_names]
    rhs = [sp.sympify(e) for e in system.rhs]
    ref = {"jac": sp.Matrix(rhs).jacobian(xs), "jac_p": sp.Matrix(rhs).jacobian(ps)}
    for kind, expr in ref.items():
        a = inspect.getsource(sp.lambdify((xs, ps), _expression(kind, rhs, xs, ps), modules="numpy", cse=True))
        b = inspect.getsource(sp.lambdify((xs, ps), expr, modules="numpy", cse=True))
        assert _dummies_in_order(a) == _dummies_in_order(b), kind


def _dummies_in_order(text: str) -> str:
    """lambdify's argument Dummies are numbered by a process-wide counter: renumber them in order
    of appearance (the only difference two identical expressions' texts may have)."""
    import re
    seen: dict = {}
    return re.sub(r"_Dummy_\d+", lambda m: seen.setdefault(m.group(0), f"_Dummy_{len(seen)}"), text)


def test_the_forced_field_of_eq21_and_rules_sympy_keeps():
    """The C integrator's field has sin/cos of the forcing phase and the time symbol; functions and
    a symbol in an exponent go to sympy's diff, and the result is still sympy's."""
    q1, q2, t, Om, a, b = sp.symbols("q1 q2 t Omega a b")
    exprs = [
        -a * q1 - 0.3 * q1**3 + 0.01 * q1 * q2**2 * sp.cos(Om * t) + b * sp.sin(q2) / (1 + q1**2),
        q1**q2 + sp.exp(a * q1) * q2 - sp.sqrt(q1**2 + q2**2) + 2.5 * q2 / (a + 1.0000000000001),
        sp.Integer(3), q1, (q1 + q2) ** 3 * a**-2,
    ]
    memo: dict = {}
    for e in exprs:
        for x in (q1, q2, t, a):
            got = D.diff(e, x, memo)
            assert got == sp.diff(e, x), (e, x)
    # a closed form: d/dx of the Duffing backbone's cubic x^3 is 3 x^2, d2 is 6 x
    x = sp.Symbol("x")
    assert D.diff(x**3, x) == 3 * x**2
    assert D.derive_by_array(D.derive_by_array([x**3], [x]), [x]) == [[[6 * x]]]


def test_the_c_kernel_source_is_sympys(monkeypatch):
    """The compiled kernel's C text from the fast derivatives equals, character for character, the
    text with sympy's own Jacobians (on a small field with every kind of term the AME has: 1/(a
    polynomial in a parameter), parameter powers, cubic state terms)."""
    from autocable.codegen import ckernel
    r1, s1, sig, U = sp.symbols("r1 s1 sigma U")
    rhs = [-0.02 * r1 + 1.5 * U**2 * s1 / (sig + 1.004) - 0.7 * s1 * (r1**2 + s1**2) / (sig**3 + 3.01 * sig + 1.0),
           0.3 * U * r1 * s1**2 / (sig + 1.004) + sig * r1 - 2.0 * r1**3]
    fast = ckernel.kernel_source(("r1", "s1"), ("sigma", "U"), rhs)
    monkeypatch.setattr(ckernel.derivatives, "jacobian",
                        lambda exprs, xs, memo=None: sp.Matrix(list(exprs)).jacobian(xs))
    slow = ckernel.kernel_source(("r1", "s1"), ("sigma", "U"), rhs)
    assert fast == slow
    assert fast.count("out[") >= 2 + 4 + 4      # F, J_x and J_p were all written
