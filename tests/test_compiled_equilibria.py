"""The compiled equilibrium engine (``engine="compiled"``) against the PyCont engine and closed forms.

* The C kernel's F, J_x, J_p equal the sympy ones; its Hopf test function equals
  `bialternate`'s determinant; its Routh count of unstable eigenvalues equals numpy's on random
  matrices (n = 2, 4) whenever it decides, and it declines (-1) on a matrix with a pair on the
  imaginary axis.
* The first runs of the Fig. 6, 7 and 10 scenes (runs/fig06.toml, ...): the same special points
  (BP, LP, H) as PyCont's engine (parameter to 1e-8, a1 to 1e-8 relative). The first runs of the
  Fig. 5a and Fig. 6 scenes (runs/fig05a.toml, runs/fig06.toml): stability at every
  returned point equal to numpy's eigenvalues of the exact Jacobian and to the kernel's count,
  every point on the PyCont branch within the step tolerance (max_step^2 in chart units), both
  branches ending exactly on the range.
* Branch switching at Fig. 6's first branch point: the same special points on the new branch.
* The Duffing slow flow: folds against the closed form to 1e-5, the middle branch unstable; the
  Hopf normal form: H, omega and l1 against the closed form.
* A closed branch (the unit circle): its folds, stability, the closed end; the point budget.
* A right-hand side C cannot compile, or a missing compiler: a one-line `KernelBuildError`.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
import sympy as sp

from autocable.codegen.ckernel import KernelBuildError, compiled_kernel
from autocable.methods.continuation import (ContinuationSettings, EquilibriumProblem, System, ame_system,
                                            auto_state_scale, bialternate, continue_equilibria,
                                            switch_branch)
from autocable.methods.continuation.chart import _Chart
from conftest import REPO

ROOT = REPO


def first_run_problem(scene_file: str):
    """The problem and settings of a scene's first run, built as `run_scene` builds them."""
    from autocable.model.ame_cache import derive_ame
    from autocable.model.derive import derive
    from autocable.scene.runner import load_scene

    from conftest import load_legacy_scene       # the numbers were measured on it
    scene = load_legacy_scene(ROOT / "runs" / scene_file)
    run = scene.runs[0]
    assert run.start.kind == "trivial" and run.parameter == "sigma"
    ame = derive_ame(derive(scene.model)).ame
    values = {"sigma": 0.0, "U": 0.0, "eta": 0.0, **scene.fixed, **run.fixed}
    values[run.parameter] = run.range[0]
    system = ame_system(ame, scene.ame, wind=values["U"] != 0.0)
    problem = EquilibriumProblem(system, run.parameter, values, run.range,
                                 state_scale=auto_state_scale(system, values))
    return problem, ContinuationSettings(**run.steps), run.name, run.directions


@pytest.fixture(scope="module", params=["fig05a.toml", "fig06.toml"])
def both_engines(request):
    problem, settings, name, directions = first_run_problem(request.param)
    pyc = continue_equilibria(problem, settings, name=name, directions=directions)
    comp = continue_equilibria(problem, settings, name=name, directions=directions, engine="compiled")
    return request.param, problem, settings, pyc, comp


#: The special points of each scene's first branch (types in order along it): Fig. 6's two
#: pitchforks of branch I, Fig. 7's two folds of the resonance curve with wind, Fig. 10's Hopf
#: point and fold. Fig. 5a's first branch has none (the shared fixture's other case).
SPECIAL_TYPES = {"fig06.toml": ["BP", "BP"], "fig07.toml": ["LP", "LP"], "fig10.toml": ["H", "LP"]}


@pytest.fixture(scope="module", params=sorted(SPECIAL_TYPES))
def engines_with_special_points(request):
    problem, settings, name, directions = first_run_problem(request.param)
    pyc = continue_equilibria(problem, settings, name=name, directions=directions)
    comp = continue_equilibria(problem, settings, name=name, directions=directions, engine="compiled")
    return request.param, problem, settings, pyc, comp


@pytest.mark.slow
def test_same_special_points_as_pycont(engines_with_special_points):
    """Every special point of the PyCont engine is found by the compiled engine and vice versa,
    at the same parameter (1e-8, the test-function tolerance) and a1 (1e-8 relative)."""
    scene, problem, settings, pyc, comp = engines_with_special_points
    a, b = pyc.branch.special_points, comp.branch.special_points
    assert [s.type for s in a] == SPECIAL_TYPES[scene]            # never an empty comparison
    assert [s.type for s in b] == SPECIAL_TYPES[scene]
    assert [s.label for s in a] == [s.label for s in b]
    for sa, sb in zip(a, b):
        assert sb.value == pytest.approx(sa.value, abs=1e-8)
        assert sb.a1 == pytest.approx(sa.a1, rel=1e-8)
        assert sb.converged and sb.origin == "autocable" and sb.confirmed_by_pycont is None


def test_stability_is_numpys_at_every_point_and_the_kernels_count(both_engines):
    scene, problem, settings, pyc, comp = both_engines
    b = comp.branch
    system = problem.system
    kernel = compiled_kernel(system)
    counts = np.array(b.info["kernel_unstable_counts"])
    assert len(counts) == len(b) and b.info["kernel_stability_disagreements"] == 0
    decided = 0
    for i in range(len(b)):
        p = np.array([b[n][i] for n in system.parameter_names])
        J = system.jac(b.states[i], p)
        ev = np.linalg.eigvals(J)
        n_unstable = int(np.sum(ev.real > 0))
        assert bool(b.stable[i]) == (n_unstable == 0), (scene, i, ev)
        if counts[i] >= 0:
            assert counts[i] == n_unstable, (scene, i, ev)
            assert kernel.unstable_count(J) == counts[i]
            decided += 1
    assert decided >= len(b) - 2          # undecided only next to a bifurcation point
    if scene == "fig06.toml":             # unstable exactly between the two branch points
        bp1, bp2 = (s.value for s in b.of_type("BP"))
        s = b["sigma"]
        assert not np.any(b.stable[(s > bp1 + 1e-6) & (s < bp2 - 1e-6)])
        assert np.all(b.stable[(s < bp1 - 1e-6) | (s > bp2 + 1e-6)])
    else:
        assert np.all(b.stable)


def test_points_lie_on_the_pycont_branch(both_engines):
    scene, problem, settings, pyc, comp = both_engines
    chart = _Chart.of(problem)
    Yp = np.array([chart.to_chart(x, v) for x, v in zip(pyc.branch.states, pyc.branch.values)])
    Yc = np.array([chart.to_chart(x, v) for x, v in zip(comp.branch.states, comp.branch.values)])
    # Distance of every compiled point to PyCont's polyline (chords between its points).
    a, d = Yp[:-1], np.diff(Yp, axis=0)
    worst = 0.0
    for Y in Yc:
        s = np.clip(np.einsum("ij,ij->i", Y - a, d) / np.einsum("ij,ij->i", d, d), 0.0, 1.0)
        worst = max(worst, float(np.min(np.linalg.norm(a + s[:, None] * d - Y, axis=1))))
        assert np.max(np.abs(chart.F(Y))) < 1e-10
    assert worst <= settings.max_step ** 2
    assert abs(len(comp.branch) - len(pyc.branch)) <= 0.1 * len(pyc.branch)
    for ea, eb in zip(pyc.branch.ends, comp.branch.ends):
        assert eb.reason == ea.reason == "range"
        assert eb.value == pytest.approx(ea.value, abs=1e-12)


@pytest.mark.parametrize("both_engines", ["fig06.toml"], indirect=True)   # Fig. 5a's branch I has no BP
def test_switching_at_the_first_branch_point_agrees(both_engines):
    """The bi-modal branch through Fig. 6's BP1, a closed curve back to BP1 that crosses a2 = 0 at
    a second branch point (where the island II of the scene starts): the same special points,
    points and ends with both engines. (The second BP falls close to a computed point of the
    compiled branch: `_sharpen_branch_point` is what finds it there.)"""
    scene, problem, settings, pyc, comp = both_engines
    a = switch_branch(pyc, "BP1")
    b = switch_branch(comp, "BP1", engine="compiled")
    assert [s.label for s in a.branch.special_points] == [s.label for s in b.branch.special_points] \
        == ["BP0", "BP1"]
    for sa, sb in zip(a.branch.special_points, b.branch.special_points):
        assert sb.value == pytest.approx(sa.value, abs=1e-8)
        assert sb.a1 == pytest.approx(sa.a1, rel=1e-8)
        assert abs(sb.a2) < 1e-10 and sb.converged
    assert b.branch.special("BP0").value == pytest.approx(a.branch.special("BP0").value, abs=1e-8)
    assert [e.reason for e in b.branch.ends] == [e.reason for e in a.branch.ends] == ["closed", "closed"]
    assert b.branch.info["kernel_stability_disagreements"] == 0
    chart = _Chart.of(problem.at(sigma=a.problem.values["sigma"]))
    Ya = np.array([chart.to_chart(x, v) for x, v in zip(a.branch.states, a.branch.values)])
    Yb = np.array([chart.to_chart(x, v) for x, v in zip(b.branch.states, b.branch.values)])
    gap = max(float(np.min(np.linalg.norm(Ya - Y, axis=1))) for Y in Yb)
    assert gap <= settings.max_step
    assert abs(len(Yb) - len(Ya)) <= 0.1 * len(Ya)
    assert np.max(b.branch["a2"]) == pytest.approx(np.max(a.branch["a2"]), rel=1e-3)


# --------------------------------------------------------------------------------------------
# Duffing slow flow (as in test_continuation): z' = (-mu + i(sigma - kappa |z|^2)) z - i f.
MU_D, KAPPA, F_D = 0.1, 1.0, 0.2


def duffing() -> System:
    u, v, s = sp.symbols("u v sigma")
    w = s - KAPPA * (u * u + v * v)
    return System("duffing_compiled", ("u", "v"), (-MU_D * u - w * v, -MU_D * v + w * u - F_D),
                  {"sigma": -1.0}, (("a1", ("u", "v")),))


def duffing_folds():
    roots = np.roots([4 * KAPPA**2 * MU_D**2, -4 * KAPPA**2 * F_D**2, 0.0, 0.0, F_D**4])
    A = np.sort(roots[(np.abs(roots.imag) < 1e-12) & (roots.real > 0)].real)
    return [(KAPPA * a + F_D**2 / (2 * KAPPA * a * a), math.sqrt(a)) for a in A]


def test_duffing_folds_with_the_compiled_engine():
    system = duffing()
    problem = EquilibriumProblem(system, "sigma", {"sigma": -1.0}, (-1.0, 6.0))
    r = continue_equilibria(problem, ContinuationSettings(max_step=4e-2), name="I", directions="forward",
                            engine="compiled")
    b = r.branch
    folds = sorted(b.of_type("LP"), key=lambda s: s.value)
    assert len(folds) == 2 and not b.of_type("H") and not b.of_type("BP")
    for sp_, (sigma_f, a_f) in zip(folds, duffing_folds()):
        assert sp_.value == pytest.approx(sigma_f, abs=1e-5)
        assert sp_.a1 == pytest.approx(a_f, abs=1e-5)
        assert sp_.converged
    A = b["a1"] ** 2
    dG = MU_D**2 + (b["sigma"] - KAPPA * A) ** 2 - 2 * KAPPA * A * (b["sigma"] - KAPPA * A)
    assert (dG < -1e-6).sum() >= 5
    assert not np.any(b.stable[dG < -1e-6]) and np.all(b.stable[dG > 1e-6])
    G = A * (MU_D**2 + (b["sigma"] - KAPPA * A) ** 2) - F_D**2
    assert np.max(np.abs(G)) < 1e-12
    assert b.ends[-1].reason == "range" and b.ends[-1].value == pytest.approx(6.0, abs=1e-12)


def test_settle_with_the_compiled_engine_lands_on_the_closed_form_response():
    """Integrating the Duffing slow flow from rest below resonance settles on the one response
    there: |z|^2 = A solves A (mu^2 + (sigma - kappa A)^2) = f^2; both engines agree."""
    from autocable.methods.continuation.equilibria import settle
    system = duffing()
    x = {e: settle(system, {"sigma": -1.0}, [0.0, 0.0], engine=e) for e in ("pycont", "compiled")}
    A = float(x["compiled"] @ x["compiled"])
    assert A * (MU_D**2 + (-1.0 - KAPPA * A) ** 2) == pytest.approx(F_D**2, rel=1e-10)
    np.testing.assert_allclose(x["compiled"], x["pycont"], rtol=0, atol=1e-12)


def test_hopf_normal_form_with_the_compiled_engine():
    """x' = mu x - w y + a x r^2, y' = w x + mu y + a y r^2: H at mu = 0 with omega = w and
    Kuznetsov's l1 = 2a/w (closed form, as in test_continuation); the origin stable for mu < 0."""
    w_h, a_h = 2.0, -1.0
    x, y, mu = sp.symbols("x y mu")
    r2 = x * x + y * y
    system = System("hopf_nf_compiled", ("x", "y"), (mu * x - w_h * y + a_h * x * r2, w_h * x + mu * y + a_h * y * r2),
                    {"mu": -0.2}, (("a1", ("x", "y")),))
    problem = EquilibriumProblem(system, "mu", {"mu": -0.2}, (-0.2, 0.3))
    b = continue_equilibria(problem, ContinuationSettings(), name="EQ", engine="compiled").branch
    assert [s.label for s in b.special_points] == ["H1"]
    h = b.special("H1")
    assert abs(h.value) < 1e-10 and h.converged and h.confirmed_by_pycont is None
    assert h.extra["omega"] == pytest.approx(w_h, rel=1e-12)
    assert h.extra["l1"] == pytest.approx(2 * a_h / w_h, rel=1e-10)
    away = np.abs(b["mu"]) > 1e-12
    assert np.all(b.stable[away] == (b["mu"][away] < 0))
    counts = np.array(b.info["kernel_unstable_counts"])
    assert np.all(counts[away & (b["mu"] < 0)] == 0) and np.all(counts[away & (b["mu"] > 0)] == 2)
    assert [e.reason for e in b.ends] == ["range", "range"]
    assert b["mu"][0] == pytest.approx(-0.2, abs=1e-12) and b["mu"][-1] == pytest.approx(0.3, abs=1e-12)


def test_closed_curve_folds_and_point_budget():
    """x' = x^2 + p^2 - 1: the branch is the unit circle, folds at p = -1 and p = 1 (x = 0); the
    kernel goes round and stops where it started; with 30 points it stops at the budget."""
    x, p = sp.symbols("x p")
    system = System("circle_compiled", ("x",), (x * x + p * p - 1,), {"p": 0.0}, (("a1", ("x",)),))
    problem = EquilibriumProblem(system, "p", {"p": 0.0}, (-2.0, 2.0))
    b = continue_equilibria(problem, ContinuationSettings(), [1.0], engine="compiled").branch
    assert [e.reason for e in b.ends] == ["closed", "closed"]
    assert np.max(np.abs(b["x"] ** 2 + b["p"] ** 2 - 1)) < 1e-12
    folds = sorted(b.of_type("LP"), key=lambda s_: s_.value)
    assert [f.value for f in folds] == pytest.approx([-1.0, 1.0], abs=1e-10)
    assert all(abs(f.state[0]) < 1e-5 and f.converged for f in folds)
    away = np.abs(b["x"]) > 1e-6                      # f_x = 2x: stable on the lower half-circle
    assert np.all(b.stable[away] == (b["x"][away] < 0))
    short = continue_equilibria(problem, ContinuationSettings(max_points=30), [1.0], directions="forward",
                                engine="compiled").branch
    assert short.ends[-1].reason == "max_points" and len(short) == 30
    assert "raise max_points" in short.ends[-1].message


def test_kernel_functions_equal_sympys_and_numpys():
    rng = np.random.default_rng(7)
    system = duffing()
    u, v, s, c = sp.symbols("u v s c")
    four = System("four_compiled", ("u", "v", "s", "c"),
                  (-u + v * s - c**3, u * c - 2 * v + s, u * v * s - c + sp.sin(u), s * s - u * c - v),
                  {"mu": 0.3}, ())
    for sysm in (system, four):
        k = compiled_kernel(sysm)
        n = sysm.dimension
        for _ in range(5):
            x, p = rng.normal(size=n), rng.normal(size=len(sysm.parameters))
            np.testing.assert_allclose(k.f(x, p), sysm.f(x, p), rtol=1e-13, atol=1e-14)
            np.testing.assert_allclose(k.jac(x, p), sysm.jac(x, p), rtol=1e-13, atol=1e-14)
            np.testing.assert_allclose(k.jac_p(x, p), sysm.jac_p(x, p), rtol=1e-13, atol=1e-14)
        decided = 0
        for _ in range(300):
            J = rng.normal(size=(n, n))
            hopf = np.linalg.det(bialternate(J))
            assert k.hopf_test(J) == pytest.approx(hopf, rel=1e-10, abs=1e-12)
            c_ = k.unstable_count(J)
            if c_ >= 0:
                assert c_ == int(np.sum(np.linalg.eigvals(J).real > 0))
                decided += 1
        assert decided >= 295
        # A pair on the imaginary axis (rotation block) and the rest stable: undecided.
        R = -np.eye(n)
        R[:2, :2] = [[0.0, 1.0], [-1.0, 0.0]]
        assert k.unstable_count(R) == -1
        assert k.unstable_count(np.zeros((n, n))) == -1


def test_a_kernel_that_does_not_compile_is_a_one_line_error(tmp_path, monkeypatch):
    monkeypatch.setenv("AUTOCABLE_CACHE", str(tmp_path))
    u, v = sp.symbols("u v")
    bad = System("not_c", ("u", "v"), (sp.Function("mystery")(u), -v), {"k": 1.0}, ())
    with pytest.raises(KernelBuildError) as exc:
        compiled_kernel(bad)
    msg = str(exc.value)
    assert "\n" not in msg and "not_c" in msg and "mystery" in msg and "engine='pycont'" in msg
    assert not list(tmp_path.rglob("*.so"))
    with pytest.raises(KernelBuildError) as exc:           # a compiler that fails
        compiled_kernel(duffing(), cc="false")
    assert "\n" not in str(exc.value) and "false failed" in str(exc.value)
    with pytest.raises(KernelBuildError) as exc:
        compiled_kernel(duffing(), cc="no-such-compiler-here")
    assert "\n" not in str(exc.value) and "not found" in str(exc.value)
    problem = EquilibriumProblem(bad, "k", {"k": 1.0}, (0.0, 2.0))
    with pytest.raises(ValueError, match="engine must be one of"):
        continue_equilibria(problem, engine="fortran")


def _four() -> System:
    u, v, s, c = sp.symbols("u v s c")
    return System("four_compiled", ("u", "v", "s", "c"),
                  (-u + v * s - c**3, u * c - 2 * v + s, u * v * s - c + sp.sin(u), s * s - u * c - v),
                  {"mu": 0.3}, ())


def _sorted_eig(ev) -> np.ndarray:
    return -np.sort(-np.asarray(ev))          # decreasing real part, then imaginary part


def test_kernel_eigenvalues_equal_closed_forms_and_numpys():
    """The kernel's eigenvalues (balancing, Hessenberg, double-shift QR in C): against closed forms
    (V diag(lambda) V^-1 with known real and complex-pair lambda, 1e-12 of |lambda|max), against
    numpy's LAPACK on random and badly scaled (graded) matrices (1e-12 relative to ||J||), sorted
    as the branch keeps them; a triangular and the zero matrix exactly."""
    rng = np.random.default_rng(11)
    for sysm in (duffing(), _four()):
        k = compiled_kernel(sysm)
        n = sysm.dimension
        for _ in range(50):                   # closed form: prescribed eigenvalues
            lam = list(rng.normal(size=n - 2)) + [complex(rng.normal(), abs(rng.normal()) + 0.1)]
            lam = lam + [np.conj(lam[-1])]
            D = np.zeros((n, n))
            for i, l_ in enumerate(lam[:-2]):
                D[i, i] = l_.real if isinstance(l_, complex) else l_
            a, b = lam[-2].real, lam[-2].imag
            D[n - 2:, n - 2:] = [[a, b], [-b, a]]
            V = np.eye(n) + 0.3 * rng.normal(size=(n, n))
            J = V @ D @ np.linalg.inv(V)
            want = _sorted_eig(np.array(lam, complex))
            np.testing.assert_allclose(k.eigenvalues(J), want, rtol=0, atol=1e-12 * np.max(np.abs(want)))
        for scale in (1.0, 1e-6, 1e6):
            for _ in range(100):
                J = scale * rng.normal(size=(n, n))
                G = np.diag(10.0 ** rng.uniform(-4, 4, size=n))
                for M in (J, G @ J @ np.linalg.inv(G)):
                    ev = k.eigenvalues(M)
                    ref = _sorted_eig(np.linalg.eigvals(M))
                    np.testing.assert_allclose(ev, ref, rtol=0, atol=1e-12 * np.linalg.norm(J) + 1e-300)
        T = np.triu(rng.normal(size=(n, n)))
        np.testing.assert_allclose(k.eigenvalues(T), _sorted_eig(np.diag(T)), rtol=0, atol=1e-14)
        assert np.all(k.eigenvalues(np.zeros((n, n))) == 0)
        T.setflags(write=False)               # a read-only array is passed by its address too
        np.testing.assert_allclose(k.eigenvalues(T), _sorted_eig(np.diag(T)), rtol=0, atol=1e-14)
        J = rng.normal(size=(n, n))
        J[0, 0] = np.nan                      # no eigenvalues: NaN, never a hang
        assert np.all(np.isnan(k.eigenvalues(J)))


def test_sign_changes_skip_zeros_and_non_finite_values():
    """`chart._sign_changes` (the segments the analysis locates in): the index before each change
    of sign between consecutive nonzero finite values; zeros, NaN and inf are skipped."""
    from autocable.methods.continuation.chart import _sign_changes
    assert _sign_changes([]) == [] and _sign_changes([1.0]) == []
    assert _sign_changes([1.0, 2.0, -1.0, -3.0, 4.0]) == [1, 3]
    assert _sign_changes([1.0, 0.0, 0.0, -1.0]) == [0]               # a zero at a point counts once
    assert _sign_changes([-1.0, np.nan, np.inf, 2.0, 0.0, 5.0]) == [0]
    assert _sign_changes([0.0, -2.0, 0.0, 3.0, -np.inf, -1e-300]) == [1, 3]
    assert all(isinstance(i, int) for i in _sign_changes([1.0, -1.0]))


def test_c_locator_equals_the_python_one():
    """`CKernel.locate` (chart._locate with equilibrium_analysis's test functions, in C) lands
    where `chart._locate` with the test functions written here in numpy (the SVD tangent, det
    [DF; chord], det 2J(.)I) lands, to 1e-12 in chart units, for each special point of Fig. 6's
    branch I (BP), the Duffing folds (LP) and the Hopf normal form (H)."""
    from autocable.methods.continuation.chart import _locate, _tangent
    from autocable.methods.continuation.compiled_equilibria import _KernelChart
    from autocable.methods.continuation.events import _hopf_test

    def tau(kind, chart, ref):
        if kind == "LP":
            return lambda Y: float(np.sign(_tangent(chart.DF(Y)) @ ref) * _tangent(chart.DF(Y))[-1])
        if kind == "BP":
            return lambda Y: float(np.linalg.det(np.vstack([chart.DF(Y), ref / np.linalg.norm(ref)])))
        return lambda Y: _hopf_test(chart.system.jac(*chart.to_phys(Y)))

    w_h, a_h = 2.0, -1.0
    x, y, mu = sp.symbols("x y mu")
    r2 = x * x + y * y
    hopf = System("hopf_nf_compiled", ("x", "y"), (mu * x - w_h * y + a_h * x * r2, w_h * x + mu * y + a_h * y * r2),
                  {"mu": -0.2}, (("a1", ("x", "y")),))
    fig6, settings, _, _ = first_run_problem("fig06.toml")
    cases = [(fig6, settings, "BP"),
             (EquilibriumProblem(duffing(), "sigma", {"sigma": -1.0}, (-1.0, 6.0)),
              ContinuationSettings(max_step=4e-2), "LP"),
             (EquilibriumProblem(hopf, "mu", {"mu": -0.2}, (-0.2, 0.3)), ContinuationSettings(), "H")]
    for problem, settings, kind in cases:
        b = continue_equilibria(problem, settings, engine="compiled").branch
        chart = _KernelChart.around(_Chart.of(problem), compiled_kernel(problem.system))
        Ys = [chart.to_chart(x_, v_) for x_, v_ in zip(b.states, b.values)]
        found = 0
        for sp_ in b.of_type(kind):
            # The bracket the analysis used is on the branch next to the point; take the steps
            # around it, wide enough that Brent iterates (not only the zero the kernel put there).
            i = sp_.index
            for Ya, Yb in ((Ys[max(i - 1, 0)], Ys[min(i + 1, len(Ys) - 1)]),
                           (Ys[max(i - 2, 0)], Ys[min(i + 2, len(Ys) - 1)])):
                Yc, okc = chart.locate_test(kind, Ya, Yb, settings.newton_tol)
                Yp, okp = _locate(chart, Ya, Yb, tau(kind, chart, Yb - Ya), settings.newton_tol)
                assert okc == okp
                np.testing.assert_allclose(Yc, Yp, rtol=0, atol=1e-12)
                found += okc
        assert found >= 2, kind


def test_pitchfork_on_a_trivial_branch_where_the_whole_jacobian_vanishes():
    """x' = x (p - x^2) continued on x = 0 from p = -0.5: at the pitchfork p = 0 both J_x = p and
    J_p = x are exactly zero, so [J_x, J_p] has rank 0 (Fig. 3's galloping onset on the 1-dof
    amplitude equation is such a point). It is a BP with rank test 0, found without a 0/0
    (RuntimeWarning turned into an error here)."""
    import warnings
    x, p = sp.symbols("x p")
    system = System("pitchfork_zero", ("x",), (x * (p - x * x),), {"p": -0.5}, (("a1", ("x",)),))
    problem = EquilibriumProblem(system, "p", {"p": -0.5}, (-0.5, 0.5))
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        b = continue_equilibria(problem, ContinuationSettings(), [0.0], engine="compiled").branch
    bps = b.of_type("BP")
    assert len(bps) == 1 and bps[0].value == pytest.approx(0.0, abs=1e-10)
    assert np.max(np.abs(b["x"])) == 0.0
    assert bps[0].extra["rank_test"] == 0.0
