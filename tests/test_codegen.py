"""autocable.codegen.pydstool and cache: the emitter, the Jacobian, builds keyed by content,
PyCont on a system with known answers, and fast integration checked against closed forms."""
from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
import sympy
from scipy.integrate import solve_ivp

from autocable.codegen import compat, pydstool
from autocable import _store as cache
from autocable.codegen.pydstool import TIME, VectorField
from conftest import REPO

x, y, z, v = sympy.symbols("x y z v")


# --------------------------------------------------------------------------------------------
# (a) the printer

def _zoo():
    """Expressions that exercise every printing rule (powers both signs, rationals, functions)."""
    a, b = sympy.symbols("a b")
    return [
        x**3 - y / (2 * x**2) + sympy.Rational(1, 3) * z,
        (x + y)**2 * (x - z) - 7 * x**5 * y**2 + sympy.Rational(-5, 7),
        1 / (1 + x**2 + y**2)**3 - a * x * y * z / (b + z**2),
        sympy.sin(2 * x) * sympy.exp(-y**2) + sympy.cos(z)**3 - sympy.sqrt(1 + x**2),
        -x**2 * y**3 + 1e-5 * z - sympy.pi * x / 3 + a**2 / b**3,
        sympy.atan(x / (1 + y**2)) + sympy.tanh(z) * sympy.log(2 + x**2) + y * x**-1,
    ]


def _eval_text(text: str, values: dict) -> float:
    """Evaluate emitted text as Python (PyDSTool's other target) with C-like math functions."""
    names = {n: getattr(math, n) for n in ("sin", "cos", "tan", "asin", "acos", "atan", "atan2",
                                           "sinh", "cosh", "tanh", "exp", "log", "sqrt")}
    return eval(text, {"__builtins__": {}}, {**names, **values})  # noqa: S307 - test-only


def test_printer_never_emits_powers_and_round_trips():
    rng = np.random.default_rng(7)
    a, b = sympy.symbols("a b")
    syms = (x, y, z, a, b)
    for expr in _zoo():
        text = pydstool.pydstool_str(expr)
        assert "**" not in text and "^" not in text and "pow" not in text, text
        reference = sympy.lambdify(syms, expr, "math")
        for _ in range(50):
            point = rng.uniform(0.2, 1.7, size=5) * rng.choice([-1, 1], size=5)
            point[4] = abs(point[4])  # b > 0 keeps b + z**2 away from zero
            want = reference(*point)
            got = _eval_text(text, dict(zip(("x", "y", "z", "a", "b"), point)))
            assert got == pytest.approx(want, rel=1e-13, abs=1e-13 * (1 + abs(want))), text


def test_printer_writes_floats_exactly_and_never_integer_division():
    assert pydstool.pydstool_str(x / 2) == "x/2.0"
    assert pydstool.pydstool_str(sympy.Rational(1, 2) * x + 1) == "1.0 + x/2.0"
    third = pydstool.pydstool_str(sympy.Float(1 / 3) * x)
    assert float(third.split("*")[0]) == 1 / 3  # repr: round-trip exact
    assert pydstool.pydstool_str(x**-2) == "(1.0/(x*x))"


@pytest.mark.parametrize("bad", [x**sympy.Rational(3, 2), x**y, sympy.Float("inf") * x,
                                 sympy.gamma(x), sympy.I * x, sympy.Abs(x)])
def test_printer_rejects_what_it_cannot_write(bad):
    with pytest.raises(ValueError, match="cannot write"):
        pydstool.pydstool_str(bad)


def test_compiled_right_hand_side_matches_sympy():
    """The emitted text, compiled by PyDSTool's C target, evaluates like sympy (1e-13 relative)."""
    a, b = sympy.symbols("a b")
    zoo = _zoo()
    vf = VectorField("printer_zoo", ("x", "y", "z"), [zoo[1] + zoo[4], zoo[2] + zoo[5], zoo[0] + zoo[3]],
                     {"a": 0.7, "b": 1.3})
    gen = pydstool.make_ode_generator(vf, "Dopri").pydstool
    fs = [sympy.lambdify((x, y, z, a, b), e, "math") for e in vf.rhs]
    rng = np.random.default_rng(3)
    for _ in range(20):
        point = rng.uniform(0.2, 1.7, size=3) * rng.choice([-1, 1], size=3)
        got = np.asarray(gen.Rhs(0.0, dict(zip(vf.variables, point))))  # PyDSTool order x, y, z
        want = np.array([f(*point, 0.7, 1.3) for f in fs])
        np.testing.assert_allclose(got, want, rtol=1e-13, atol=1e-13)


# --------------------------------------------------------------------------------------------
# (b) the Jacobian

def _mixed_case_field():
    """Variable order z, b, A: PyDSTool's order (A, b, z) differs, uppercase sorting first."""
    A, b, k = sympy.symbols("A b k")
    return VectorField("jac_order", ("z", "b", "A"),
                       {"z": b * A + k * z**2, "b": sympy.sin(z) - A**3, "A": z * b / (1 + A**2)},
                       {"k": 0.7})


def test_jacobian_matches_finite_differences():
    vf = _mixed_case_field()
    syms = [sympy.Symbol(n) for n in vf.variables]
    f = sympy.lambdify([syms], [e.subs("k", 0.7) for e in vf.rhs], "numpy")
    jac = sympy.lambdify([syms], pydstool.jacobian_matrix(vf).subs("k", 0.7), "numpy")
    point = np.array([0.3, -0.4, 1.3])
    h = 1e-6
    fd = np.column_stack([(np.asarray(f(point + h * e)) - np.asarray(f(point - h * e))) / (2 * h)
                          for e in np.eye(3)])
    np.testing.assert_allclose(np.asarray(jac(point), dtype=float), fd, rtol=1e-8, atol=1e-9)


def test_jacobian_spec_is_in_pydstool_order_and_compiled_correctly():
    vf = _mixed_case_field()
    args, text = pydstool.jacobian_spec(vf)
    assert args == ["t", "A", "b", "z"]
    assert "**" not in text
    gen = pydstool.make_ode_generator(vf, "Dopri").pydstool
    assert list(gen.funcspec.vars) == ["A", "b", "z"]
    point = {"z": 0.3, "b": -0.4, "A": 1.3}
    want = pydstool.jacobian_matrix(vf, ["A", "b", "z"]).subs({**point, "k": 0.7})
    np.testing.assert_allclose(np.asarray(gen.Jacobian(0.0, point)), np.array(want, dtype=float),
                               rtol=1e-14, atol=1e-14)


def test_one_dimensional_jacobian_is_a_bare_expression():
    vf = VectorField("oned", ("x",), [-x**3], {})
    assert pydstool.jacobian_spec(vf) == (["t", "x"], "-(3.0*(x*x))")


# --------------------------------------------------------------------------------------------
# (c) PyCont on the Hopf normal form

W, A3, B3, MU0 = 2.0, -0.5, 0.3, 0.3137


def _hopf_field():
    r"""Hopf normal form in Cartesian coordinates plus quadratic terms, Hopf point at mu = MU0.

        x' = (mu - mu0) x - w y + (a x - b y)(x^2 + y^2) + x^2
        y' = w x + (mu - mu0) y + (a y + b x)(x^2 + y^2) + x^2

    The origin is an equilibrium for every mu, with eigenvalues (mu - mu0) +- i w: a Hopf point
    at mu = mu0, frequency w. Known first Lyapunov coefficient (closed form): for a planar system
    x' = -w y + f, y' = w x + g, Guckenheimer & Holmes (1983), eq. (3.4.11), give the cubic
    coefficient of the radial normal form r' = (mu - mu0) r + a_GH r^3,

        a_GH = (f_xxx + f_xyy + g_xxy + g_yyy)/16
               + (f_xy (f_xx + f_yy) - g_xy (g_xx + g_yy) - f_xx g_xx + f_yy g_yy)/(16 w).

    Here the cubic part gives (6a + 2a + 2a + 6a)/16 = a and f = g = x^2 gives -(2*2)/(16 w), so
    a_GH = a - 1/(4 w) = -0.625 (supercritical).

    What PyCont reports: its `firstlyapunov` (PyCont/misc.py) returns
    l1 = 1/2 Re <p, C(q,q,q̄) + B(q̄,(2iwI-A)^-1 B(q,q)) - 2 B(q, A^-1 B(q,q̄))> with |q| = 1 and
    <p,q> = 1. That is Kuznetsov's (Elements of Applied Bifurcation Theory, 3rd ed., eq. 3.20)
    invariant formula *without* its 1/w factor: l1_PyCont = w * l1_Kuznetsov = Re c1(0).
    With |q| = 1 the complex coordinate z on the centre manifold is (x + iy)/sqrt(2), so
    |z|^2 = r^2/2 and Re c1 = 2 a_GH. Hence l1_PyCont = 2 a - 1/(2 w) = -1.25, and
    l1_Kuznetsov = (2 a - 1/(2 w))/w = -0.625. The test checks PyCont against the closed form and
    against an independent evaluation of Kuznetsov's formula with exact sympy derivatives.
    The same a_GH fixes the amplitude of the cycles born at the Hopf point: r^2 = (mu - mu0)/(-a_GH).
    """
    mu = sympy.Symbol("mu")
    r2 = x * x + y * y
    rhs = {"x": (mu - MU0) * x - W * y + A3 * x * r2 - B3 * y * r2 + x * x,
           "y": W * x + (mu - MU0) * y + A3 * y * r2 + B3 * x * r2 + x * x}
    return VectorField("hopf_normal_form", ("x", "y"), rhs, {"mu": 0.0})


def _kuznetsov_l1(vf: VectorField, point: dict) -> float:
    """Kuznetsov's l1 (eq. 3.20, with 1/w) from exact derivatives, independent of PyCont."""
    syms = [sympy.Symbol(n) for n in vf.variables]
    f = sympy.Matrix([e.subs("mu", point["mu"]) for e in vf.rhs])
    at = {s: point[s.name] for s in syms}
    n = len(syms)
    A = np.array(f.jacobian(syms).subs(at), dtype=float)
    B = np.array([[[float(sympy.diff(f[i], syms[j], syms[k]).subs(at)) for k in range(n)]
                   for j in range(n)] for i in range(n)])
    C = np.array([[[[float(sympy.diff(f[i], syms[j], syms[k], syms[m]).subs(at)) for m in range(n)]
                    for k in range(n)] for j in range(n)] for i in range(n)])
    evals, right = np.linalg.eig(A)
    i = int(np.argmax(evals.imag))
    w = evals[i].imag
    q = right[:, i] / np.linalg.norm(right[:, i])
    evals_t, left = np.linalg.eig(A.T)
    p = left[:, int(np.argmin(abs(evals_t + 1j * w)))]
    p = p / np.conj(np.vdot(p, q))  # <p, q> = conj(p) . q = 1
    Bf = lambda u, s: np.einsum("ijk,j,k->i", B, u, s)  # noqa: E731
    Cf = lambda u, s, t: np.einsum("ijkm,j,k,m->i", C, u, s, t)  # noqa: E731
    g = (Cf(q, q, q.conj()) - 2 * Bf(q, np.linalg.solve(A, Bf(q, q.conj())))
         + Bf(q.conj(), np.linalg.solve(2j * w * np.eye(n) - A, Bf(q, q))))
    return float(np.real(np.vdot(p, g)) / (2 * w))


@pytest.fixture(scope="module")
def hopf_system():
    vf = _hopf_field()
    cont = pydstool.continuation_system(vf, "Dopri", ics={"x": 0.0, "y": 0.0}, auto=True)
    dst = compat.import_pydstool()
    with compat.quiet():
        cont.newCurve(dst.args(name="EQ1", type="EP-C", freepars=["mu"], StepSize=1e-2,
                               MaxStepSize=5e-2, MinStepSize=1e-6, MaxNumPoints=30,
                               LocBifPoints=["H"], SaveEigen=True, verbosity=0,
                               FuncTol=1e-10, VarTol=1e-10, TestTol=1e-10))
        cont["EQ1"].forward()
    return vf, cont


@pytest.mark.slow
def test_pycont_finds_hopf_point_and_first_lyapunov_coefficient(hopf_system):
    vf, cont = hopf_system
    hopf = cont["EQ1"].getSpecialPoint("H1")
    assert hopf is not None, "PyCont found no Hopf point"
    data = hopf.labels["H"]["data"]
    assert hopf["mu"] == pytest.approx(MU0, abs=1e-6)
    assert abs(hopf["x"]) < 1e-8 and abs(hopf["y"]) < 1e-8
    assert data.w == pytest.approx(W, rel=1e-8)
    closed_form = 2 * A3 - 1 / (2 * W)  # = Re c1 = w * l1_Kuznetsov, see _hopf_field
    assert data.l1 == pytest.approx(closed_form, rel=1e-4)
    kuznetsov = _kuznetsov_l1(vf, {"x": 0.0, "y": 0.0, "mu": MU0})
    assert kuznetsov == pytest.approx((2 * A3 - 1 / (2 * W)) / W, rel=1e-10)
    assert data.l1 == pytest.approx(W * kuznetsov, rel=1e-4)


@pytest.mark.slow
def test_pycont_cycles_from_hopf_follow_the_normal_form(hopf_system, tmp_path, monkeypatch):
    """LC-C from H1: period 2 pi / w, amplitude sqrt((mu - mu0)/(-a_GH)); CWD stays empty."""
    vf, cont = hopf_system
    monkeypatch.chdir(tmp_path)
    dst = compat.import_pydstool()
    with compat.pydstool_session("continuing cycles", pydstool.pydstool_cache_dir()):
        cont.newCurve(dst.args(name="LC1", type="LC-C", initpoint="EQ1:H1", freepars=["mu"],
                               StepSize=2e-3, MaxStepSize=1e-2, MaxNumPoints=12, NumIntervals=30,
                               NumCollocation=4, SolutionMeasures="all", verbosity=0))
        cont["LC1"].forward()
    a_gh = A3 - 1 / (4 * W)
    checked = 0
    for point in cont["LC1"].sol:
        dmu = point["mu"] - MU0
        if dmu < 1e-4:
            continue
        half_range = (point["x_max"] - point["x_min"]) / 2  # cancels the O(r^2) mean shift
        assert half_range == pytest.approx(math.sqrt(dmu / -a_gh), rel=2e-3)
        assert point["_T"] == pytest.approx(2 * math.pi / W, rel=1e-4)
        checked += 1
    assert checked >= 5
    assert list(tmp_path.iterdir()) == []


def test_continuation_rejects_time_dependent_fields():
    vf = VectorField("forced_1d", ("x",), [-x + sympy.sin(TIME)], {})
    with pytest.raises(ValueError, match="autonomous"):
        pydstool.continuation_system(vf)


# --------------------------------------------------------------------------------------------
# (d) builds keyed by content

_DECAY_SCRIPT = textwrap.dedent("""
    import json, sys
    import sympy
    from autocable.codegen import compat, pydstool
    compat.import_pydstool()
    x, k = sympy.symbols("x k")
    vf = pydstool.VectorField("decay", ("x",), [-float(sys.argv[1]) * k * x], {"k": 1.0})
    gen = pydstool.make_ode_generator(vf, "Dopri", algparams={"rtol": 1e-10, "atol": 1e-12})
    t, states = pydstool.integrate(gen, [1.0], None, 0.0, 1.0, 0.5)
    print(json.dumps({"name": gen.name, "reused": gen.reused,
                      "x1": float(states[-1, 0])}))
""")


def _decay(rate: float) -> VectorField:
    k = sympy.Symbol("k")
    return VectorField("decay", ("x",), [-rate * k * x], {"k": 1.0})


@pytest.mark.slow
def test_changed_equations_get_a_fresh_build_and_identical_ones_reuse_it(tmp_path, monkeypatch):
    """Same base name, different equations: different module, different numbers, no stale reuse.

    Runs on an empty cache (so the builds are real) from an empty working directory, which must
    stay empty. A second process then loads the library without compiling.
    """
    cache_dir, work = tmp_path / "cache.with.dots", tmp_path / "work"
    work.mkdir()
    monkeypatch.setenv("AUTOCABLE_CACHE", str(cache_dir))
    monkeypatch.chdir(work)
    algparams = {"rtol": 1e-10, "atol": 1e-12}

    slow = pydstool.make_ode_generator(_decay(1.0), "Dopri", algparams=algparams)
    fast = pydstool.make_ode_generator(_decay(3.0), "Dopri", algparams=algparams)
    assert slow.name.startswith("decay_") and fast.name.startswith("decay_")
    assert slow.name != fast.name
    assert not slow.reused and not fast.reused
    x_slow = pydstool.integrate(slow, [1.0], None, 0.0, 1.0, 0.5)[1][-1, 0]
    x_fast = pydstool.integrate(fast, [1.0], None, 0.0, 1.0, 0.5)[1][-1, 0]
    assert x_slow == pytest.approx(math.exp(-1.0), rel=1e-8)
    assert x_fast == pytest.approx(math.exp(-3.0), rel=1e-8)

    again = pydstool.make_ode_generator(_decay(1.0), "Dopri", algparams=algparams)
    assert again.name == slow.name and again.reused
    assert pydstool.integrate(again, [1.0], None, 0.0, 1.0, 0.5)[1][-1, 0] == pytest.approx(x_slow, rel=1e-12)

    env = {**os.environ, "AUTOCABLE_CACHE": str(cache_dir),
           "PYTHONPATH": os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")])}
    for rate, expected_name, expected_x in ((1.0, slow.name, math.exp(-1.0)), (3.0, fast.name, math.exp(-3.0))):
        done = subprocess.run([sys.executable, "-c", _DECAY_SCRIPT, str(rate)], cwd=work, env=env,
                              capture_output=True, text=True, timeout=120)
        assert done.returncode == 0, done.stderr[-2000:]
        assert done.stderr == ""
        report = json.loads(done.stdout)
        assert report["name"] == expected_name
        assert report["reused"] is True  # loading, not compiling (load time: `autocable bench derive`)
        assert report["x1"] == pytest.approx(expected_x, rel=1e-8)
    # The constructed generators were kept for later processes (those above unpickled them); a
    # damaged file fails its sha256 check, costs only the FuncSpec parsing again, and is replaced
    # (one stderr line says so).
    kept = {p.name for p in cache_dir.rglob("*.generator.pickle")}
    assert kept == {f"dop853_{slow.name}_vf.generator.pickle", f"dop853_{fast.name}_vf.generator.pickle"}
    damaged = next(cache_dir.rglob(f"dop853_{slow.name}_vf.generator.pickle"))
    damaged.write_bytes(b"not a pickle")
    done = subprocess.run([sys.executable, "-c", _DECAY_SCRIPT, "1.0"], cwd=work, env=env,
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stderr == f"autocable: cache: pickled generator {damaged.name} failed its check, rebuilt\n"
    assert json.loads(done.stdout)["x1"] == pytest.approx(math.exp(-1.0), rel=1e-8)
    assert damaged.read_bytes() != b"not a pickle"
    assert list(work.iterdir()) == []


def test_model_name_ignores_parameter_values_but_not_names_or_equations():
    k, c = sympy.symbols("k c")
    base = VectorField("m", ("x",), [-k * x], {"k": 1.0})
    assert pydstool.model_name(base) == pydstool.model_name(VectorField("m", ("x",), [-k * x], {"k": 5.0}))
    assert pydstool.model_name(base) != pydstool.model_name(VectorField("m", ("x",), [-c * x], {"c": 1.0}))
    assert pydstool.model_name(base) != pydstool.model_name(VectorField("m", ("x",), [-k * x * x], {"k": 1.0}))
    assert pydstool.model_name(base) != pydstool.model_name(VectorField("n", ("x",), [-k * x], {"k": 1.0}))
    assert len(pydstool.model_name(base)) == len("m_") + cache.HASH_CHARS


# --------------------------------------------------------------------------------------------
# (e) integration against closed forms and scipy

K, C, F, OMEGA = 4.0, 0.1, 1.0, 1.5


@pytest.fixture(scope="module")
def oscillator():
    """x'' + C x' + K x = F cos(OMEGA t), as a first-order system (x, v)."""
    k, c, f, om = sympy.symbols("k c F Omega")
    vf = VectorField("forced_linear", ("x", "v"), {"x": v, "v": -k * x - c * v + f * sympy.cos(om * TIME)},
                     {"k": K, "c": C, "F": F, "Omega": OMEGA})
    return pydstool.make_ode_generator(vf, "Dopri", algparams={"rtol": 1e-10, "atol": 1e-12})


def _steady_state(t):
    """Closed form: x = Re(Z e^{i OMEGA t}), Z = F / (K - OMEGA^2 + i C OMEGA)."""
    Z = F / complex(K - OMEGA**2, C * OMEGA)
    phase = np.exp(1j * OMEGA * np.asarray(t))
    return np.column_stack([(Z * phase).real, (1j * OMEGA * Z * phase).real])


def test_forced_oscillator_stays_on_its_closed_form_steady_state(oscillator):
    t, states = pydstool.integrate(oscillator, _steady_state(0.0)[0], None, 0.0, 200.0, 0.05)
    assert t[0] == 0.0 and t[-1] == pytest.approx(200.0, abs=1e-12) and len(t) == 4001
    np.testing.assert_allclose(np.diff(t), 0.05, rtol=0, atol=1e-12)
    assert states.shape == (4001, 2)  # columns in the field's order: x, v
    np.testing.assert_allclose(states, _steady_state(t), rtol=0, atol=1e-8)


def test_chunked_integration_uses_absolute_time_and_matches_scipy(oscillator):
    start = [1.0, 0.0]  # off the steady state: a transient, so chunk hand-over matters
    t_all, x_all = pydstool.integrate(oscillator, start, None, 0.0, 60.0, 0.1)
    t_a, x_a = pydstool.integrate(oscillator, start, None, 0.0, 30.0, 0.1)
    t_b, x_b = pydstool.integrate(oscillator, x_a[-1], None, 30.0, 60.0, 0.1)
    np.testing.assert_allclose(t_b, t_all[300:], atol=1e-12)
    np.testing.assert_allclose(x_b, x_all[300:], rtol=0, atol=5e-8)  # a restart changes the steps

    def rhs(t, s):
        return [s[1], -K * s[0] - C * s[1] + F * math.cos(OMEGA * t)]

    ref = solve_ivp(rhs, (0.0, 60.0), start, method="DOP853", rtol=1e-10, atol=1e-12, t_eval=t_all)
    np.testing.assert_allclose(x_all, ref.y.T, rtol=0, atol=1e-8)


def test_sample_grid_ends_exactly_at_t1(oscillator):
    t, states = pydstool.integrate(oscillator, [1.0, 0.0], None, 0.0, 0.3, 0.1)  # 3*0.1 > 0.3
    assert t.tolist() == [0.0, 0.1, 0.2, 0.3]
    t, _ = pydstool.integrate(oscillator, [1.0, 0.0], None, 0.0, 0.35, 0.1)  # t1 off the grid
    assert t[-1] == pytest.approx(0.3) and len(t) == 4


def test_parameters_can_change_between_runs_without_rebuilding(oscillator):
    stiff = pydstool.integrate(oscillator, [1.0, 0.0], {"k": 9.0, "F": 0.0, "c": 0.0}, 0.0, 1.0, 0.5)[1]
    np.testing.assert_allclose(stiff[:, 0], np.cos(3.0 * np.array([0.0, 0.5, 1.0])), atol=1e-9)
    with pytest.raises(ValueError, match="no parameters"):
        pydstool.integrate(oscillator, [1.0, 0.0], {"nope": 1.0}, 0.0, 1.0, 0.5)


def test_per_call_tolerances_apply_and_do_not_stick(oscillator):
    exact = _steady_state([0.0, 20.0])
    loose = pydstool.integrate(oscillator, exact[0], None, 0.0, 20.0, 20.0,
                               algparams={"rtol": 1e-4, "atol": 1e-6})[1]
    tight = pydstool.integrate(oscillator, exact[0], None, 0.0, 20.0, 20.0)[1]
    assert 1e-7 < abs(loose[-1, 0] - exact[1, 0]) < 1e-2
    assert abs(tight[-1, 0] - exact[1, 0]) < 1e-9
    with pytest.raises(ValueError, match="unknown Dopri algparams"):
        pydstool.integrate(oscillator, exact[0], None, 0.0, 1.0, 0.5, algparams={"bogus": 1})


def test_vode_generator_agrees_with_dopri(oscillator):
    vode = pydstool.make_ode_generator(oscillator.field, "Vode", algparams={"rtol": 1e-10, "atol": 1e-12})
    t, xs = pydstool.integrate(vode, [1.0, 0.0], None, 0.0, 5.0, 0.5)
    _, xd = pydstool.integrate(oscillator, [1.0, 0.0], None, 0.0, 5.0, 0.5)
    np.testing.assert_allclose(xs, xd, rtol=0, atol=1e-7)


# --------------------------------------------------------------------------------------------
# VectorField validation and the cache helpers

@pytest.mark.parametrize("kwargs, message", [
    (dict(variables=("t",), rhs=[sympy.Symbol("t")]), "not usable"),
    (dict(variables=("x",), rhs=[x * sympy.Symbol("k")]), "undeclared"),
    (dict(variables=("x", "y"), rhs=[x]), "right-hand sides"),
    (dict(variables=("x",), rhs=[sympy.Function("g")(x)]), "auxiliary"),
])
def test_vector_field_validation(kwargs, message):
    with pytest.raises(ValueError, match=message):
        VectorField("bad", **kwargs)


def test_auxiliary_functions_are_inlined_for_the_jacobian():
    g = sympy.Function("g")
    vf = VectorField("aux", ("x", "y"), [g(x, y), -x], {}, {"g": (("a", "b"), sympy.Symbol("a") * sympy.Symbol("b")**2)})
    assert pydstool.jacobian_matrix(vf)[0, :] == sympy.Matrix([[y**2, 2 * x * y]])
    assert pydstool.pydstool_args(vf)["fnspecs"]["g"] == (["a", "b"], "a*(b*b)")


def test_cache_root_and_content_hash(monkeypatch, tmp_path):
    monkeypatch.setenv("AUTOCABLE_CACHE", str(tmp_path / "c"))
    assert cache.cache_root() == (tmp_path / "c").resolve()
    monkeypatch.delenv("AUTOCABLE_CACHE")
    assert cache.cache_root() == (Path.home() / ".cache" / "autocable").resolve()
    h = cache.content_hash({"b": [1, 2.5], "a": "x"})
    assert h == cache.content_hash({"a": "x", "b": [1, 2.5]}) and len(h) == 12
    assert all(ch in "0123456789abcdef" for ch in h)
    assert h != cache.content_hash({"a": "x", "b": [1, 2.5000000000000004]})
    assert cache.content_hash("text") == "982d9e3eb996"  # sha256("text"), stable across runs
    with pytest.raises(TypeError):
        cache.content_hash({"a": object()})


def test_atomic_writes_and_read_json(tmp_path):
    target = tmp_path / "sub" / "data.json"
    cache.atomic_write_json(target, {"b": 1, "a": [1.5, "x"]})
    assert cache.read_json(target) == {"a": [1.5, "x"], "b": 1}
    cache.atomic_write_text(target, "{not json")
    assert cache.read_json(target) is None
    assert cache.read_json(tmp_path / "missing.json") is None
    assert sorted(p.name for p in target.parent.iterdir()) == ["data.json"]  # no temp files left
