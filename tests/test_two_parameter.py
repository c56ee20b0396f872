"""Two-parameter curves (autocable.methods.continuation.continue_folds / continue_hopf) against
closed forms, the independent checks at every point, and a scene with a curve run.

* The forced Duffing slow flow (the system of test_continuation, forcing amplitude f now a
  parameter): the fold curve in (sigma, f) is the discriminant of the frequency response,
  f^2 = A (mu^2 + s^2) with 3 s^2 - 2 sigma s + mu^2 = 0, s = sigma - kappa A, A = a^2; its two
  branches meet at the cusp sigma = sqrt(3) mu, f^2 = 8 mu^3 / (3 sqrt(3) kappa), A = 2 mu / (sqrt(3) kappa).
* The Brusselator: Hopf points on b = 1 + a^2 with omega = a, at the equilibrium (a, b/a).
* The Bogdanov-Takens normal form x' = y, y' = b1 + b2 y + x^2 - x y: folds on b1 = 0, Hopf points
  on b1 = -b2^2 (b2 < 0); both curves meet at the BT point b1 = b2 = 0, where the Hopf curve ends
  (beyond it the pair is real: neutral saddles).
* The Bautin normal form: Hopf points on b1 = 0, l1 = b2 (up to a positive factor): GH at b2 = 0.
* runs/folds_sigma_eta.toml: the folds of the cable's mono-modal branch I in (sigma, eta), with
  the cusp below which the resonance is single-valued.
"""
from __future__ import annotations

import csv
import math

import numpy as np
import pytest
import sympy as sp

from autocable.methods.continuation import (ContinuationSettings, EquilibriumProblem, StartError, System,
                                            continue_equilibria, continue_folds, continue_hopf)
from autocable.results import read_results
from autocable.scene.runner import load_scene, run_scene
from autocable.spec import SpecError
from conftest import REPO, SAMPLE

MODEL = SAMPLE
FOLDS_SCENE = REPO / "runs" / "folds_sigma_eta.toml"


def fd_jacobian(system: System, x, p, h=1e-7) -> np.ndarray:
    """Central differences of f (independent of the sympy Jacobian the engine uses)."""
    x = np.asarray(x, float)
    cols = []
    for e in np.eye(len(x)):
        step = h * max(1.0, np.max(np.abs(x)))
        cols.append((system.f(x + step * e, p) - system.f(x - step * e, p)) / (2 * step))
    return np.column_stack(cols)


def params_at(branch, system, i) -> np.ndarray:
    return np.array([branch[name][i] for name in system.parameter_names])


def crossings(branch, p1: str, p2: str, value: float) -> np.ndarray:
    """The values of p1 where the curve crosses p2 = value (linear interpolation between points)."""
    a, b = np.asarray(branch[p1]), np.asarray(branch[p2]) - value
    idx = np.nonzero(np.sign(b[:-1]) * np.sign(b[1:]) < 0)[0]
    return np.array([a[i] + (a[i + 1] - a[i]) * b[i] / (b[i] - b[i + 1]) for i in idx])


def assert_folds_checked(branch, system, tol=1e-6):
    """det J = 0 at every point: the engine's own check and an independent FD Jacobian."""
    assert branch.kind == "fold" and branch.info["check_failure_count"] == 0
    assert np.all(branch["check_residual"] <= 1e-8)
    for i in range(len(branch)):
        sv = np.linalg.svd(fd_jacobian(system, branch.states[i], params_at(branch, system, i)), compute_uv=False)
        assert sv[-1] <= tol * sv[0], (i, sv)


def assert_hopf_checked(branch, system, tol=1e-6, skip=()):
    """A pair of eigenvalues on the imaginary axis at every point (FD Jacobian)."""
    assert branch.kind == "hopf" and branch.info["check_failure_count"] == 0
    for i in range(len(branch)):
        if i in skip:
            continue
        assert branch["check_residual"][i] <= 1e-8
        J = fd_jacobian(system, branch.states[i], params_at(branch, system, i))
        ev = np.linalg.eigvals(J)
        pair = ev[np.abs(ev.imag) > 1e-9 * np.linalg.norm(J)]
        assert pair.size >= 2, (i, ev)
        assert np.min(np.abs(pair.real)) <= tol * np.linalg.norm(J), (i, ev)


# --------------------------------------------------------------------------------------------
# Duffing slow flow: z' = (-mu + i (sigma - kappa |z|^2)) z - i f
MU, KAPPA = 0.1, 1.0
SIGMA_CUSP = math.sqrt(3) * MU
F_CUSP = math.sqrt(8 * MU**3 / (3 * math.sqrt(3) * KAPPA))
A_CUSP = math.sqrt(2 * MU / (math.sqrt(3) * KAPPA))


def duffing() -> System:
    u, v, s, f = sp.symbols("u v sigma f")
    w = s - KAPPA * (u * u + v * v)
    return System("duffing_slow_2p", ("u", "v"), (-MU * u - w * v, -MU * v + w * u - f),
                  {"sigma": -1.0, "f": 0.2}, (("a1", ("u", "v")),))


def fold_forcing(sigma: float) -> list[float]:
    """The closed-form fold curve: the forcing amplitudes f at which the frequency response
    folds at detuning sigma (zero, one or two of them)."""
    disc = sigma * sigma - 3 * MU * MU
    disc = 0.0 if -1e-12 < disc < 0 else disc                  # the cusp itself, to round-off
    out = []
    if disc >= 0:
        for sign in (1, -1):
            s = (sigma + sign * math.sqrt(disc)) / 3
            A = (sigma - s) / KAPPA
            if A > 0:
                out.append(math.sqrt(A * (MU**2 + s * s)))
    return out


@pytest.fixture(scope="module")
def duffing_folds():
    system = duffing()
    problem = EquilibriumProblem(system, "sigma", {"sigma": -1.0, "f": 0.2}, (-1.0, 6.0))
    settings = ContinuationSettings(max_step=4e-2, curve_max_step=5e-2)
    eq = continue_equilibria(problem, settings, name="I", directions="forward")
    return system, eq, continue_folds(eq, "LP1", "f", (0.0, 0.3))


@pytest.mark.slow
def test_fold_curve_is_the_duffing_discriminant_and_reaches_the_cusp(duffing_folds):
    system, eq, folds = duffing_folds
    b = folds.branch
    assert b.parameter == "sigma" and b.parameter2 == "f" and len(b) > 30
    worst = 0.0
    for sigma, f in zip(b["sigma"], b["f"]):
        cf = fold_forcing(sigma)
        assert cf, sigma
        worst = max(worst, min(abs(f - c) for c in cf))
    assert worst < 1e-6
    # the state: A = a^2 solves the fold condition 3 s^2 - 2 sigma s + mu^2 = 0, s = sigma - kappa A
    A = b["a1"] ** 2
    s = b["sigma"] - KAPPA * A
    assert np.max(np.abs(3 * s * s - 2 * b["sigma"] * s + MU**2)) < 1e-6
    # one curve through both folds of the f = 0.2 branch, and both ends at a range
    cross = np.sort(crossings(b, "sigma", "f", 0.2))
    folds = sorted(s_.value for s_ in eq.branch.of_type("LP"))
    assert len(cross) == 1 and len(folds) == 2              # the other fold is the start point itself
    assert min(abs(cross[0] - v) for v in folds) < 2e-2 and np.min(np.abs(b["f"] - 0.2)) < 1e-12
    assert sorted(e.reason for e in b.ends) == ["range", "range"]
    k = b.info["start_index"]                                # "forward": increasing f at the start
    assert b["f"][k] == pytest.approx(0.2, abs=1e-12) and b["f"][k + 1] > 0.2 > b["f"][k - 1]
    # the cusp, where the two fold branches meet
    cps = b.of_type("CP")
    assert len(cps) == 1 and not b.of_type("BT") and not b.of_type("ZH")
    cp = cps[0]
    assert cp.origin == "autocable" and cp.converged and cp.confirmed_by_pycont
    assert cp.value == pytest.approx(SIGMA_CUSP, abs=1e-4)
    assert cp.extra["value2"] == pytest.approx(F_CUSP, abs=1e-4)
    assert cp.parameters["f"] == cp.extra["value2"] and cp.a1 == pytest.approx(A_CUSP, abs=1e-4)
    print(f"Duffing fold curve: worst |f - f_closed| = {worst:.2e}; cusp error "
          f"({abs(cp.value - SIGMA_CUSP):.1e}, {abs(cp.extra['value2'] - F_CUSP):.1e})")


@pytest.mark.slow
def test_fold_curve_checks_hold_at_every_point(duffing_folds):
    system, _, folds = duffing_folds
    assert_folds_checked(folds.branch, system)
    # det J column: zero to round-off against the size of J (|J| ~ 1 here)
    assert np.max(np.abs(folds.branch["det_J"])) < 1e-10
    # the outer eigenvalue stays negative (mu > 0): every fold happens on a stable branch
    assert folds.branch.stable.all()


def test_curve_start_errors():
    system = duffing()
    problem = EquilibriumProblem(system, "sigma", {"sigma": -1.0, "f": 0.2}, (-1.0, 6.0))
    eq = continue_equilibria(problem, ContinuationSettings(max_step=4e-2), name="I", directions="forward")
    with pytest.raises(ValueError, match="LP point"):
        continue_hopf(eq, "LP1", "f", (0.0, 0.3))
    with pytest.raises(ValueError, match="differ"):
        continue_folds(eq, "LP1", "sigma", (0.0, 0.3))
    with pytest.raises(StartError, match="outside the range"):
        continue_folds(eq, "LP1", "f", (0.3, 0.5))


# --------------------------------------------------------------------------------------------
@pytest.mark.slow
def test_brusselator_hopf_curve_is_b_equals_one_plus_a_squared():
    x, y, a, b = sp.symbols("x y a b")
    system = System("brusselator", ("x", "y"), (a - (b + 1) * x + x * x * y, b * x - x * x * y),
                    {"a": 1.0, "b": 1.0}, (("a1", ("x", "y")),))
    problem = EquilibriumProblem(system, "b", {"a": 1.0, "b": 1.0}, (1.0, 4.0))
    eq = continue_equilibria(problem, ContinuationSettings(), [1.0, 1.0], name="E", directions="forward")
    assert eq.special("H1").value == pytest.approx(2.0, abs=1e-10)
    hopf = continue_hopf(eq, "H1", "a", (0.6, 1.6), ContinuationSettings(curve_step=0.05, curve_max_step=0.2))
    B = hopf.branch
    assert B.kind == "hopf" and B.parameter2 == "a" and len(B) > 8
    assert sorted(e.reason for e in B.ends) == ["range", "range"]
    assert B["a"].min() == pytest.approx(0.6) and B["a"].max() == pytest.approx(1.6)
    err = np.max(np.abs(B["b"] - 1 - B["a"] ** 2))
    assert err < 1e-6
    assert np.max(np.abs(B["omega"] - B["a"])) < 1e-6                 # the Hopf frequency, omega = a
    assert np.max(np.abs(B["x"] - B["a"])) < 1e-6 and np.max(np.abs(B["y"] - B["b"] / B["a"])) < 1e-6
    assert_hopf_checked(B, system)
    # the Brusselator's Hopf points are all supercritical: no GH of autocable's; a label only
    # PyCont gives is kept but marked unconfirmed
    assert not [s for s in B.special_points if s.origin == "autocable"]
    for s in B.special_points:
        assert s.origin == "pycont" and not s.converged and "not confirmed" in s.message
    print(f"Brusselator Hopf curve: max |b - 1 - a^2| = {err:.2e} over {len(B)} points")


# --------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def bogdanov_takens():
    x, y, b1, b2 = sp.symbols("x y b1 b2")
    return System("bt_normal_form", ("x", "y"), (y, b1 + b2 * y + x * x - x * y),
                  {"b1": -1.0, "b2": -1.0}, (("a1", ("x", "y")),))


@pytest.mark.slow
def test_hopf_curve_ends_at_the_bogdanov_takens_point(bogdanov_takens):
    system = bogdanov_takens
    problem = EquilibriumProblem(system, "b2", {"b1": -1.0, "b2": -2.0}, (-2.0, 1.0))
    eq = continue_equilibria(problem, ContinuationSettings(), [-1.0, 0.0], name="E")
    hopf = continue_hopf(eq, "H1", "b1", (-1.5, 0.5), ContinuationSettings(curve_step=0.02, curve_max_step=0.1))
    B = hopf.branch
    assert np.max(np.abs(B["b1"] + B["b2"] ** 2)) < 1e-6
    ends = {e.side: e for e in B.ends}
    assert ends["backward"].reason == "range" and ends["forward"].reason == "neutral_saddle"
    bt = B.of_type("BT")
    assert len(bt) == 1 and bt[0].origin == "autocable" and bt[0].converged
    assert abs(bt[0].value) < 1e-8 and abs(bt[0].extra["value2"]) < 1e-8
    assert bt[0].index == len(B) - 1
    # every point but the BT end has its pair on the imaginary axis
    assert_hopf_checked(B, system, skip=(len(B) - 1,))


@pytest.mark.slow
def test_fold_curve_passes_the_bogdanov_takens_point(bogdanov_takens):
    system = bogdanov_takens
    problem = EquilibriumProblem(system, "b1", {"b1": -1.0, "b2": -0.5}, (-1.0, 0.5))
    eq = continue_equilibria(problem, ContinuationSettings(), [-1.0, 0.0], name="E")
    assert eq.special("LP1").value == pytest.approx(0.0, abs=1e-10)
    folds = continue_folds(eq, "LP1", "b2", (-1.0, 1.0), ContinuationSettings(curve_max_step=0.1))
    F = folds.branch
    assert np.max(np.abs(F["b1"])) < 1e-6 and np.max(np.abs(F["x"])) < 1e-6
    assert F["b2"].min() == pytest.approx(-1.0) and F["b2"].max() == pytest.approx(1.0)
    bt = F.of_type("BT")
    assert len(bt) == 1 and bt[0].origin == "autocable" and bt[0].converged
    assert abs(bt[0].extra["value2"]) < 1e-8
    assert_folds_checked(F, system)


@pytest.mark.slow
def test_generalized_hopf_point_of_the_bautin_normal_form():
    x, y, b1, b2 = sp.symbols("x y b1 b2")
    r2 = x * x + y * y
    system = System("bautin_normal_form", ("x", "y"),
                    (b1 * x - y + b2 * x * r2 - x * r2 * r2, x + b1 * y + b2 * y * r2 - y * r2 * r2),
                    {"b1": -0.5, "b2": -0.5}, (("a1", ("x", "y")),))
    problem = EquilibriumProblem(system, "b1", {"b1": -0.5, "b2": -0.5}, (-0.5, 0.5))
    eq = continue_equilibria(problem, ContinuationSettings(), name="E")
    hopf = continue_hopf(eq, "H1", "b2", (-0.5, 0.7), ContinuationSettings(curve_max_step=0.1))
    B = hopf.branch
    assert np.max(np.abs(B["b1"])) < 1e-8
    gh = [s for s in B.of_type("GH") if s.origin == "autocable"]
    assert len(gh) == 1 and gh[0].converged and abs(gh[0].extra["value2"]) < 1e-6
    assert_hopf_checked(B, system)


# --------------------------------------------------------------------------------------------
# the cable: folds of branch I in (sigma, eta)
@pytest.fixture(scope="module")
def folds_scene(tmp_path_factory):
    out = tmp_path_factory.mktemp("folds")
    return run_scene(load_scene(FOLDS_SCENE), out), out


@pytest.mark.slow
def test_fold_curve_scene_runs_end_to_end(folds_scene):
    res, out = folds_scene
    for name in ("branches.csv", "special_points.csv", "run.json", "folds_sigma_eta.png",
                 "folds_sigma_eta_plane.png", "folds_sigma_eta_plane.pdf"):
        assert (out / name).stat().st_size > 0, name
    I, F = res.branch("I"), res.branch("F")
    assert [s.label for s in I.of_type("LP")] == ["LP1", "LP2"]
    assert F.kind == "fold" and F.parameter == "sigma" and F.parameter2 == "eta"
    assert F.info["check_failure_count"] == 0 and F.info["started_from"] == "I:LP2"
    # the curve passes through both folds of I (eta = 1.4e-3) and has the cusp below them
    cross = crossings(F, "sigma", "eta", 1.4e-3)
    assert np.min(np.abs(F["eta"] - 1.4e-3)) < 1e-15              # the start, I:LP2
    assert len(cross) == 1 and abs(cross[0] - I.special("LP1").value) < 1e-2
    cp = F.of_type("CP")
    assert len(cp) == 1 and cp[0].origin == "autocable" and cp[0].converged
    assert 0.0 < cp[0].extra["value2"] < 1.4e-3 and cp[0].value < I.special("LP2").value
    assert np.all(F["U"] == 0.0)
    # the rows of the fold curve in branches.csv: both parameters as columns
    with open(out / "branches.csv", newline="") as fh:
        rows = [r for r in csv.DictReader(fh) if r["branch"] == "F"]
    assert len(rows) == len(F) and all(r["kind"] == "fold" and r["parameter2"] == "eta" for r in rows)
    np.testing.assert_array_equal([float(r["eta"]) for r in rows], F["eta"])
    back = read_results(out).branch("F")
    assert back.kind == "fold" and back.parameter2 == "eta"
    np.testing.assert_array_equal(back["check_residual"], F["check_residual"])
    # the independent check on the AME itself (the 1-dof Cartesian system of the scene)
    from autocable.methods.continuation import ame_system
    from autocable.model.ame_cache import derive_ame
    from autocable.model.derive import derive
    system = ame_system(derive_ame(derive(MODEL)).ame, "1dof", wind=False)
    assert_folds_checked(F, system)


@pytest.mark.parametrize("body, field, words", [
    ('kind = "curve"\nstart = "I:LP1"\nparameter = "sigma"\nrange = [-0.2, 0.3]\nparameter2 = "eta"\n'
     'range2 = [0, 3e-3]\nparameter3 = "U"\n', "run[1].parameter3", "unknown key"),
    # (a branch point starts a curve of pitchforks since the stability charts: a cycle's PD does not)
    ('kind = "curve"\nstart = "I:PD1"\nparameter = "sigma"\nrange = [-0.2, 0.3]\nparameter2 = "eta"\n'
     'range2 = [0, 3e-3]\n', "run[1].start", "a fold, a Hopf point or a branch point"),
    ('kind = "curve"\nstart = "I:LP1"\nparameter = "sigma"\nrange = [-0.2, 0.3]\nrange2 = [0, 3e-3]\n',
     "run[1].parameter2", "missing"),
    ('kind = "curve"\nstart = "I:LP1"\nparameter = "sigma"\nrange = [-0.2, 0.3]\nparameter2 = "sigma"\n'
     'range2 = [0, 3e-3]\n', "run[1].parameter2", "other than"),
    ('kind = "curve"\nstart = "I:H1"\nparameter = "sigma"\nrange = [-0.2, 0.3]\nparameter2 = "eta"\n'
     'range2 = [3e-3, 0]\n', "run[1].range2", "lo < hi"),
    ('kind = "curve"\nstart = "I:LP1"\nparameter = "sigma"\nrange = [-0.2, 0.3]\nparameter2 = "eta"\n'
     'range2 = [0, 3e-3]\nat = 0.0\n', "run[1].at", "not allowed"),
    ('parameter = "sigma"\nrange = [-0.2, 0.3]\nparameter2 = "eta"\n', "run[1].parameter2", "curve"),
])
def test_curve_schema_errors_are_one_line(tmp_path, body, field, words):
    path = tmp_path / "bad.toml"
    path.write_text(f'model = "{MODEL}"\n[[run]]\nname = "I"\nparameter = "sigma"\nrange = [-0.2, 0.3]\n'
                    f'[[run]]\nname = "F"\n' + body)
    with pytest.raises(SpecError) as err:
        load_scene(path)
    text = str(err.value)
    assert "\n" not in text and text.startswith(str(path))
    assert err.value.field == field and words in text


def test_curve_range_must_hold_the_start_point(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text(f'model = "{MODEL}"\n' 'ame = "1dof"\n[fixed]\neta = 1.4e-3\n'
                    '[[run]]\nname = "I"\nparameter = "sigma"\nrange = [-0.2, 0.3]\n'
                    '[[run]]\nname = "F"\nkind = "curve"\nstart = "I:LP2"\nparameter = "sigma"\n'
                    'range = [-0.2, 0.3]\nparameter2 = "eta"\nrange2 = [2e-3, 3e-3]\n')
    with pytest.raises(SpecError) as err:
        run_scene(load_scene(path), tmp_path / "out", plot=False)
    assert err.value.field == "run[1].range2" and "outside" in str(err.value) and "\n" not in str(err.value)
