"""Chart regions by structure (`regions.a2_slaved`): "bi-modal" is an equilibrium whose a2 is not
slaved to a1 (a solution of the out-of-plane equations of its own, born at a branch point), not a
threshold on a2 / a1. On a cable whose wind coupling forces a2 ~ 0.1 a1 on the ordinary forced
response the old threshold (a2 > 1 % of a1) called every point bi-modal; the sample's bi-modal
branches of Fig. 6 are still found."""
import math

import numpy as np
import pytest

import autocable as ac
from autocable.methods.integration.shooting import ShootingSolver
from autocable.methods.regions import a2_slaved, classify_point


@pytest.fixture(scope="module")
def wind_system(stay190):
    return ac.ame_system(ac.derive_ame(stay190).ame, "2dof", wind=True)


#: Points of the 190 m stay below its onset (U* < 1), with support motion: the forced response.
COUPLED = [(0.5, 8.2e-5, -0.03), (0.8, 4.1e-4, 0.0), (0.95, 4.1e-4, -0.03), (0.95, 8.2e-5, 0.0)]


@pytest.mark.parametrize("U,eta,sigma", COUPLED)
def test_coupled_forced_response_is_not_bi_modal(wind_system, U, eta, sigma):
    """Every start settles on one equilibrium with a2 between 5 % and 20 % of a1 (the old rule's
    "bi-modal"), and it is classed mono-modal or the small forced response: its a2 is the a2
    equations' response to a1 (`a2_slaved`), and the a2 equations are forced (g = G(0) != 0)."""
    cls, rows = classify_point(wind_system, {"U": U, "eta": eta, "sigma": sigma})
    assert "bi-modal" not in cls and "diverged" not in cls, cls
    for r in rows:
        assert 0.05 < r["a2"] / r["a1"] < 0.2           # the old rule (a2 > 1e-2 a1) said bi-modal


def test_coupled_response_is_one_branch_by_eq21(stay190):
    """Independent route, eq. (21) itself: a slaved a2 is unique, so starts with the out-of-plane
    seed q2 = +1e-6 and -1e-6 reach the same orbit (U* = 0.8, eta* = 4.1e-4, sigma = 0; a2 / a1 ~
    0.1), where on a bi-modal motion they reach mirror orbits (`test_sample_bimodal_mirror_orbits`)."""
    solver = ShootingSolver(stay190.ode)
    plus = solver.steady(0.8, 4.1e-4, 0.0, (0.0, 0.0, 1e-6, 0.0))
    minus = solver.steady(0.8, 4.1e-4, 0.0, (0.0, 0.0, -1e-6, 0.0))
    assert plus.response == minus.response == "period-1"
    assert 0.05 < plus.a2 / plus.a1 < 0.2
    assert np.max(np.abs(np.subtract(plus.state0, minus.state0))) < 1e-8 * plus.a1


def test_sample_bimodal_mirror_orbits(derivation):
    """The contrast of the test above: on the sample's bi-modal motion (Fig. 6, U = 0, sigma = 0)
    the two seeds reach mirror orbits (q2 -> -q2), two distinct solutions."""
    solver = ShootingSolver(derivation.ode)
    plus = solver.steady(0.0, 1.4e-3, 0.0, (0.0, 0.0, 1e-6, 0.0))
    minus = solver.steady(0.0, 1.4e-3, 0.0, (0.0, 0.0, -1e-6, 0.0))
    assert plus.response == minus.response == "period-1" and plus.a2 > 1e-3
    mirror = np.array([1.0, -1.0, 1.0, -1.0]) * np.asarray(minus.state0)
    assert np.max(np.abs(plus.state0 - mirror)) < 1e-8 * plus.a1
    assert np.max(np.abs(np.subtract(plus.state0, minus.state0))) > 0.1 * plus.a2


@pytest.fixture(scope="module")
def fig06(derivation):
    """Fig. 6 (U = 0, eta* = 1.4e-3) by continuation on the compiled kernel: branch I and the
    bi-modal branches switched at its pitchforks (as in the README's example)."""
    system = ac.ame_system(ac.derive_ame(derivation).ame, "2dof", wind=False)
    values = {"U": 0.0, "eta": 1.4e-3, "sigma": -0.05}
    problem = ac.EquilibriumProblem(system, "sigma", values, (-0.05, 0.05),
                                    state_scale=ac.auto_state_scale(system, values))
    settings = ac.ContinuationSettings(max_step=0.02)
    I = ac.continue_equilibria(problem, settings, name="I", engine="compiled")
    bi = [ac.switch_branch(I, bp, settings, name=f"I-{bp.label}", engine="compiled")
          for bp in I.branch.special_points if bp.type == "BP"]
    return system, I, bi


def _states(result):
    b = result.branch
    return [np.array([b[v][k] for v in ("r1", "s1", "r2", "s2")]) for k in range(len(b["sigma"]))], b["sigma"]


def test_fig06_bimodal_branches_are_not_slaved(fig06):
    """Every point of branch I (mono-modal) is slaved; every point of the branches born at its
    pitchforks is not, except the ones at the pitchforks themselves (where the two branches meet:
    there a2 -> 0 on both); so the structural rule finds the bi-modal branches of Fig. 6."""
    system, I, bi = fig06
    assert len(bi) == 2
    for x, s in zip(*_states(I)):
        assert a2_slaved(system, x, system.parameter_vector({"U": 0.0, "eta": 1.4e-3, "sigma": s}))
    bps = [bp.parameters["sigma"] for bp in I.branch.special_points if bp.type == "BP"]
    for b in bi:
        xs, ss = _states(b)
        a2max = max(math.hypot(x[2], x[3]) for x in xs)
        assert a2max > 1e-3
        for x, s in zip(xs, ss):
            if math.hypot(x[2], x[3]) < 1e-2 * a2max:         # at a pitchfork: the branches meet
                continue
            assert a2_slaved(system, x, system.parameter_vector({"U": 0.0, "eta": 1.4e-3, "sigma": s})) is False


@pytest.mark.parametrize("sigma", [-0.03, -0.02, -0.01, 0.0, 0.02])
def test_fig06_chart_classes_unchanged_on_the_symmetric_sample(fig06, sigma):
    """Without wind nothing forces the a2 equations (a2 = 0 exactly on mono-modal responses, 1e-45
    and below after integration), so the old threshold was right there: the structural rule gives
    the same classes along Fig. 6's line, bi-modal at sigma = -0.02 (a2 / a1 ~ 5) and nowhere else
    of these points."""
    system, _, _ = fig06
    cls, rows = classify_point(system, {"U": 0.0, "eta": 1.4e-3, "sigma": sigma})
    old = any(r["a2"] > 1e-2 * r["a1"] for r in rows)
    assert ("bi-modal" in cls) == old and old == (sigma == -0.02)


@pytest.mark.parametrize("which,U,eta,sigma,flags", [
    ("stay190", 0.8, 4.1e-4, 0.0, (0, 0)),         # coupled forced response, a2 ~ 0.1 a1: slaved
    ("sample", 0.0, 8.2e-5, 0.0, (0, 0)),          # Fig. 5a: mono-modal
    ("sample", 0.0, 1e-3, -0.005, (1, 1)),         # between Figs. 5b and 6: on a bi-modal branch
    # Fig. 6 itself: eq. (21)'s bi-modal orbit (a1, a2) = (3.3e-3, 4.1e-3) is farther from the AME's
    # (1.4e-3, 7.6e-3) than the study's NEAR (the AME's known error at this eta*): undecided
    ("sample", 0.0, 1.4e-3, -0.02, (-1, 1))])
@pytest.mark.slow
def test_sweep_points_carry_the_structural_flag(stay190, derivation, which, U, eta, sigma, flags):
    """A sweep's period-1 point records ``bimodal`` by structure (the AME equilibrium it lies on,
    `a2_slaved`; -1 where the AME has none near it) for eq. (21) by shooting and for the AME; the
    chart draws it from there."""
    from autocable.methods.integration.ode21 import DEFAULT_Q0
    from autocable.studies import sweep as sw
    model = (stay190 if which == "stay190" else derivation).spec
    for method, flag in zip(("shooting", "ame"), flags):
        rec = sw.compute_point(model, method, U, eta, sigma, DEFAULT_Q0, 60000.0)
        assert rec["response"] == "period-1", (method, rec["message"])
        assert rec["bimodal"] == flag, method
