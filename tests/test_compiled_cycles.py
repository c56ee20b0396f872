"""The compiled cycle engine (`continue_cycles(..., engine="compiled")`, autocable's collocation on
the C kernel) against closed forms, against autocable's variational integration and against
PyCont's LC-C (AUTO).

* The Hopf normal form x' = mu x - y - x r^2, y' = x + mu y - y r^2: cycles r = sqrt(mu), period
  2 pi, Floquet multipliers 1 and exp(-4 pi mu); the period error falls as ntst^-8 (Gauss
  collocation with ncol = 4 is superconvergent, order 2 ncol).
* Special points and ends against closed forms: the fold of cycles of r' = mu r + r^3 - r^5 at
  mu = -1/4 (to 1e-12: the step ends on it), the period blow-up (T = 2 pi / (1 - mu)) and range
  ends; the period doubling of Rossler's cycle at c = 2.8324450 (PyCont's value, 1e-8).
* Fig. 10's Hopf point H1 (U = 1.3, eta = 1.4e-3, 2-dof AME) and Fig. 4a's (1-dof AME): the
  compiled branch equals PyCont's point by point (the same step rule, AUTO's): parameter to 1e-8
  relative, period (interpolated in the parameter) to 1e-8, multiplier moduli to 1e-6, a1_max
  and a2_max to 1e-5 and 3e-5 of the branch's largest value (PyCont's extremes are the largest of
  ~560 samples of a cycle: their sampling error, which the compiled engine's refined extremes do
  not have, is that size), the same stability at every cycle (the Hopf point itself, a degenerate
  cycle with a multiplier pair on the unit circle, excepted), the same end.
* A Neimark-Sacker point of cycles (a complex pair of multipliers leaving the unit circle) at
  its closed-form parameter value (1e-10), with the stability change it causes.
* The collocation monodromy equals autocable's definition (`cycles._monodromy`, the variational
  equations integrated over one period) to 1e-7, and one period integrated from a compiled cycle
  closes to 1e-7 of its size.
* A label that is not a Hopf point: a one-line error.
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
import sympy as sp
from scipy.interpolate import CubicSpline

from autocable.methods.continuation import (ContinuationSettings, EquilibriumProblem, System, ame_system,
                                            auto_state_scale, continue_cycles, continue_equilibria)
from autocable.methods.continuation.cycles import _monodromy
from conftest import REPO

ROOT = REPO
x, y, mu = sp.symbols("x y mu")


# --------------------------------------------------------------------------------------------
def normal_form_cycles(ntst: int, max_points: int = 30):
    r2 = x * x + y * y
    system = System("hopf_nf_unit", ("x", "y"), (mu * x - y - x * r2, x + mu * y - y * r2), {"mu": -0.2},
                    (("a1", ("x", "y")),))
    problem = EquilibriumProblem(system, "mu", {"mu": -0.2}, (-0.2, 0.3))
    settings = ContinuationSettings(cycle_step=5e-3, cycle_max_step=5e-2, cycle_max_points=max_points,
                                    ntst=ntst, ncol=4)
    eq = continue_equilibria(problem, settings, name="EQ", engine="compiled")
    return eq, continue_cycles(eq, "H1", settings, engine="compiled")


def test_normal_form_cycles_radius_period_and_multipliers():
    _, res = normal_form_cycles(ntst=20)
    c = res.branch
    assert c.kind == "cycle" and len(c) == 30 and c.ends[0].reason == "max_points"
    assert c.info["engine"] == "compiled"
    assert c.stable[1:].all() and not c.special_points
    for i in range(1, len(c)):
        m = c["mu"][i]
        assert m > 0
        r = math.sqrt(m)
        assert c["a1_max"][i] == pytest.approx(r, rel=1e-8)
        assert c["a1_min"][i] == pytest.approx(r, rel=1e-8)
        assert c["period"][i] == pytest.approx(2 * math.pi, rel=1e-10)
        mults = np.sort(np.abs(c.eigenvalues[i]))
        assert mults[0] == pytest.approx(math.exp(-4 * math.pi * m), rel=1e-9)
        assert mults[1] == pytest.approx(1.0, abs=1e-10)
    assert c["mu"][-1] > 0.03                      # 30 cycles reach mu = 0.039


def test_normal_form_period_converges_with_order_2_ncol():
    errs = {}
    for ntst in (3, 6):
        _, res = normal_form_cycles(ntst=ntst, max_points=6)
        errs[ntst] = abs(res.branch["period"][-1] - 2 * math.pi)
    order = math.log(errs[3] / errs[6], 2)
    assert 7.5 < order < 8.5, (errs, order)


def test_fold_of_cycles_is_put_on_the_branch():
    """r' = mu r + r^3 - r^5, theta' = 1: a subcritical Hopf point at mu = 0, unstable cycles
    r^2 = (1 - sqrt(1 + 4 mu)) / 2 back to the fold (LPC) at mu = -1/4, r^2 = 1/2, stable cycles
    r^2 = (1 + sqrt(1 + 4 mu)) / 2 beyond; non-trivial multiplier exp(2 pi (mu + 3 r^2 - 5 r^4))."""
    r2 = x * x + y * y
    system = System("hopf_lpc", ("x", "y"), (mu * x - y + x * (r2 - r2 ** 2), x + mu * y + y * (r2 - r2 ** 2)),
                    {"mu": 0.2}, (("a1", ("x", "y")),))
    problem = EquilibriumProblem(system, "mu", {"mu": 0.2}, (-0.5, 0.3))
    settings = ContinuationSettings(cycle_step=1e-2, cycle_max_step=5e-2, cycle_max_points=200, ntst=20)
    eq = continue_equilibria(problem, settings, name="EQ", engine="compiled")
    c = continue_cycles(eq, "H1", settings, engine="compiled").branch
    assert [e.reason for e in c.ends] == ["range"] and 0.25 < c["mu"][-1] <= 0.3
    lpc, = c.special_points
    assert lpc.type == "LPC" and lpc.confirmed_by_pycont is None
    assert lpc.value == pytest.approx(-0.25, abs=1e-12)
    assert lpc.a1 == pytest.approx(math.sqrt(0.5), rel=1e-8)
    i = lpc.index
    assert not c.stable[1:i + 1].any() and c.stable[i + 2:].all()
    for k in range(1, len(c)):
        r2k = c["a1_max"][k] ** 2
        want = math.exp(2 * math.pi * (c["mu"][k] + 3 * r2k - 5 * r2k ** 2))
        got = np.abs(c.eigenvalues[k])
        assert np.min(np.abs(got - want)) < 1e-6 * max(want, 1.0), k   # r from a1_max (~1e-8)


def test_cycles_from_an_integrated_orbit_both_ways():
    """No Hopf point needed: the stable cycle of the normal form reached by integration at mu = 0.2
    (`periodic_orbit`: radius sqrt(0.2), period 2 pi), then continued down and up in mu. Every
    cycle on both arms is r = sqrt(mu), period 2 pi, multipliers 1 and exp(-4 pi mu); the forward
    arm ends at the range, the backward one at its point budget; the records run from the backward
    end to the forward end through the start."""
    from autocable.methods.continuation import continue_cycles_from_orbit, periodic_orbit

    r2 = x * x + y * y
    system = System("hopf_nf_orbit", ("x", "y"), (mu * x - y - x * r2, x + mu * y - y * r2), {"mu": 0.2},
                    (("a1", ("x", "y")),))
    t, X, T = periodic_orbit(system, {"mu": 0.2}, [0.05, 0.0], scale=0.5)
    assert T == pytest.approx(2 * math.pi, rel=1e-8)
    assert np.hypot(X[:, 0], X[:, 1]) == pytest.approx(math.sqrt(0.2), rel=1e-7)
    assert t[-1] - t[0] < T <= t[-1] - t[0] + 2 * (t[1] - t[0])
    problem = EquilibriumProblem(system, "mu", {"mu": 0.2}, (-0.2, 0.3), state_scale=0.5)
    settings = ContinuationSettings(cycle_step=1e-2, cycle_max_step=5e-2, cycle_max_points=40, ntst=20)
    c = continue_cycles_from_orbit(problem, settings, t, X, T, name="NF").branch
    assert c.kind == "cycle" and c.info["from"] == "orbit" and c.info["engine"] == "compiled"
    assert [(e.side, e.reason) for e in c.ends] == [("backward", "max_points"), ("forward", "range")]
    i0 = c.info["start_index"]
    assert i0 == 39 and c["mu"][i0] == pytest.approx(0.2, abs=1e-14)
    assert np.all(np.diff(c["mu"]) > 0) and c["mu"][0] < 0.1 and 0.29 < c["mu"][-1] <= 0.3
    assert c.stable.all() and not c.special_points
    for k in range(len(c)):
        m = c["mu"][k]
        assert c["a1_max"][k] == pytest.approx(math.sqrt(m), rel=1e-8)
        assert c["a1_min"][k] == pytest.approx(math.sqrt(m), rel=1e-8)
        assert c["period"][k] == pytest.approx(2 * math.pi, rel=1e-10)
        mults = np.sort(np.abs(c.eigenvalues[k]))
        assert mults[0] == pytest.approx(math.exp(-4 * math.pi * m), rel=1e-9)
        assert mults[1] == pytest.approx(1.0, abs=1e-10)
    one_way = continue_cycles_from_orbit(problem, settings, t, X, T, directions="forward").branch
    assert [e.side for e in one_way.ends] == ["forward"] and one_way.info["start_index"] == 0
    np.testing.assert_allclose(one_way["mu"], c["mu"][i0:], rtol=0, atol=1e-14)


def test_periodic_orbit_says_what_it_found_instead():
    from autocable.methods.continuation import StartError, periodic_orbit

    r2 = x * x + y * y
    system = System("hopf_nf_orbit", ("x", "y"), (mu * x - y - x * r2, x + mu * y - y * r2), {"mu": 0.2},
                    (("a1", ("x", "y")),))
    with pytest.raises(StartError, match="settled on an equilibrium"):
        periodic_orbit(system, {"mu": -0.2}, [0.05, 0.0], scale=0.5)
    grow = System("hopf_grow", ("x", "y"), (mu * x - y + x * r2, x + mu * y + y * r2), {"mu": 0.2},
                  (("a1", ("x", "y")),))
    with pytest.raises(StartError, match="diverges"):
        periodic_orbit(grow, {"mu": 0.2}, [0.05, 0.0], scale=0.5)
    # A weakly damped focus about (1, 0) (swing decaying by exp(-2 pi 1e-4) per turn, return times
    # exactly 2 pi): an equilibrium, not a periodic orbit.
    focus = System("weak_focus", ("x", "y"), (-mu * (x - 1) - y, (x - 1) - mu * y), {"mu": 1e-4},
                   (("a1", ("x", "y")),))
    with pytest.raises(StartError, match="equilibrium"):
        periodic_orbit(focus, {"mu": 1e-4}, [1.01, 0.0], scale=1.0)


@pytest.mark.parametrize("ratio, reason", [(3.0, "period_blowup"), (20.0, "range")])
def test_period_blowup_and_range_ends(ratio, reason):
    """r' = mu r - r^3, theta' = 1 - r^2: cycles r^2 = mu of period 2 pi / (1 - mu), multiplier
    exp(-2 mu T). With max_period_ratio = 3 the branch ends before mu = 2/3 (T = 3 x 2 pi)."""
    r2 = x * x + y * y
    w = 1 - r2
    system = System("hopf_slow", ("x", "y"), (mu * x - w * y - x * r2, w * x + mu * y - y * r2), {"mu": -0.2},
                    (("a1", ("x", "y")),))
    problem = EquilibriumProblem(system, "mu", {"mu": -0.2}, (-0.2, 0.9))
    settings = ContinuationSettings(cycle_step=1e-2, cycle_max_step=5e-2, cycle_max_points=300, ntst=30,
                                    max_period_ratio=ratio)
    eq = continue_equilibria(problem, settings, name="EQ", engine="compiled")
    c = continue_cycles(eq, "H1", settings, engine="compiled").branch
    assert [e.reason for e in c.ends] == [reason]
    last = c["mu"][-1]
    assert (0.6 < last < 2 / 3) if reason == "period_blowup" else (0.85 < last <= 0.9)
    for k in range(1, len(c)):
        m = c["mu"][k]
        T = 2 * math.pi / (1 - m)
        assert c["period"][k] == pytest.approx(T, rel=1e-8)
        assert c["a1_max"][k] == pytest.approx(math.sqrt(m), rel=1e-7)
        assert np.min(np.abs(c.eigenvalues[k])) == pytest.approx(math.exp(-2 * m * T), rel=1e-7, abs=1e-12)


def test_neimark_sacker_point_is_put_on_the_branch():
    """A Hopf normal form in (x, y) beside a linear rotation in (u, v) whose growth rate is mu - 0.1:
    the cycles r = sqrt(mu) of (x, y) have the multipliers 1, exp(-4 pi mu) and the complex pair
    exp(2 pi (mu - 0.1 +- 0.3 i)), which leaves the unit circle at mu = 0.1 exactly: a
    Neimark-Sacker point (NS), stable cycles before it, unstable after."""
    u, v = sp.symbols("u v")
    r2 = x * x + y * y
    system = System("ns_test", ("x", "y", "u", "v"),
                    (mu * x - y - x * r2, x + mu * y - y * r2, (mu - 0.1) * u - 0.3 * v, 0.3 * u + (mu - 0.1) * v),
                    {"mu": -0.2}, (("a1", ("x", "y")), ("a2", ("u", "v"))))
    problem = EquilibriumProblem(system, "mu", {"mu": -0.2}, (-0.2, 0.3))
    settings = ContinuationSettings(cycle_step=1e-2, cycle_max_step=5e-2, cycle_max_points=200, ntst=20)
    eq = continue_equilibria(problem, settings, name="EQ", engine="compiled")
    assert [h.value for h in eq.branch.of_type("H")] == pytest.approx([0.0, 0.1], abs=1e-10)
    c = continue_cycles(eq, "H1", settings, engine="compiled").branch
    assert [e.reason for e in c.ends] == ["range"]
    ns, = c.special_points
    assert ns.type == "NS" and ns.confirmed_by_pycont is None
    assert ns.value == pytest.approx(0.1, abs=1e-10)
    assert ns.a1 == pytest.approx(math.sqrt(0.1), rel=1e-8)
    i = ns.index
    assert c.stable[1:i + 1].all() and not c.stable[i + 2:].any()
    for k in range(1, len(c)):
        m = c["mu"][k]
        pair = np.exp(2 * math.pi * (m - 0.1 + 0.3j))
        got = c.eigenvalues[k]
        assert np.min(np.abs(got - pair)) < 1e-8 and np.min(np.abs(got - np.conj(pair))) < 1e-8, k
        assert np.min(np.abs(got - math.exp(-4 * math.pi * m))) < 1e-8, k


def test_multiplier_collisions_are_not_bifurcations_of_cycles():
    """Fig. 10's branch P near its fold of cycles (measured multipliers): a real multiplier below -1
    that comes back inside while meeting another negative one (the count of reals below -1 drops by
    one: a PD, if coarsely resolved), the double multiplier +1 of the fold split by round-off into
    1 +- 9e-7 i (not an NS), two reals below -1 meeting into a complex pair outside (not a PD, not an
    NS), and a genuine complex pair leaving the circle (NS)."""
    from autocable.methods.continuation.events import _genuine_crossing
    one = [1.0 + 0j]
    before_pd2 = one + [-1.05, -0.30, 0.05]
    after_pd2 = one + [-0.4956 + 0.1783j, -0.4956 - 0.1783j, 0.0456]
    assert _genuine_crossing("PD", before_pd2, after_pd2)
    near_fold = one + [0.9990, -0.0605 + 0.0857j, -0.0605 - 0.0857j]
    at_fold = [1.000000002 + 9.4e-7j, 1.000000002 - 9.4e-7j, -0.0605 + 0.0857j, -0.0605 - 0.0857j]
    assert not _genuine_crossing("NS", near_fold, at_fold)
    two_reals = one + [-1.3, -1.2, 0.1]
    merged = one + [-1.25 + 0.05j, -1.25 - 0.05j, 0.1]
    assert not _genuine_crossing("PD", two_reals, merged) and not _genuine_crossing("NS", two_reals, merged)
    inside = one + [0.2, 0.99 * np.exp(0.6j * math.pi), 0.99 * np.exp(-0.6j * math.pi)]
    outside = one + [0.2, 1.01 * np.exp(0.6j * math.pi), 1.01 * np.exp(-0.6j * math.pi)]
    assert _genuine_crossing("NS", inside, outside) and _genuine_crossing("NS", outside, inside)


def test_period_doubling_of_the_rossler_cycle():
    """Rossler's system (a = b = 0.2) in c: the cycle from the Hopf point at c = 0.4 doubles its
    period at c = 2.8324450 (PyCont's LC-C on the same settings, measured: 2.832445027549823, the
    same 234 cycles, the same range end). The step ends on the crossing: a cycle there has a
    multiplier at -1. Stable before, unstable after."""
    xs = sp.symbols("x y z")
    a, b, c = sp.symbols("a b c")
    X, Y, Z = xs
    system = System("rossler", ("x", "y", "z"), (-Y - Z, X + a * Y, b + Z * (X - c)),
                    {"a": 0.2, "b": 0.2, "c": 0.5}, (("a1", ("x", "y")),))
    problem = EquilibriumProblem(system, "c", {"a": 0.2, "b": 0.2, "c": 0.5}, (0.3, 4.0))
    settings = ContinuationSettings(step=1e-2, max_step=5e-2, cycle_step=0.1, cycle_max_step=0.5,
                                    cycle_max_points=300, ntst=40)
    eq = continue_equilibria(problem, settings, [0.1, -0.5, 0.5], name="EQ", engine="compiled")
    assert eq.branch.special("H1").value == pytest.approx(0.4, abs=1e-10)
    cyc = continue_cycles(eq, "H1", settings, engine="compiled").branch
    assert [e.reason for e in cyc.ends] == ["range"] and len(cyc) == 234
    pd, = cyc.special_points
    assert pd.type == "PD" and pd.value == pytest.approx(2.832445027549823, rel=1e-8)
    dist = np.min(np.abs(np.asarray(cyc.eigenvalues) + 1.0), axis=1)
    on = int(np.argmin(dist))
    assert dist[on] < 1e-7 and abs(cyc["c"][on] - pd.value) < 1e-9
    assert pd.index in (on - 1, on)
    # The cycle on the crossing itself has |mu| = 1 to round-off: its flag is not asserted.
    assert cyc.stable[1:on].all() and not cyc.stable[on + 1:].any()


# --------------------------------------------------------------------------------------------
def scene_hopf(scene_file: str):
    """The first run of a scene (equilibria, compiled) and its settings, built as `run_scene` does."""
    from autocable.model.ame_cache import derive_ame
    from autocable.model.derive import derive
    from autocable.scene.runner import _settings, load_scene

    from conftest import load_legacy_scene       # the numbers were measured on it
    scene = load_legacy_scene(ROOT / "runs" / scene_file)
    run = scene.runs[0]
    ame = derive_ame(derive(scene.model), ordering=scene.ordering).ame
    values = {"sigma": 0.0, "U": 0.0, "eta": 0.0, **scene.fixed, **run.fixed}
    values[run.parameter] = run.range[0]
    system = ame_system(ame, scene.ame, wind=True)
    scale = scene.state_scale or auto_state_scale(system, values)
    problem = EquilibriumProblem(system, run.parameter, values, run.range, state_scale=scale)
    settings = _settings(run, "full")
    settings = replace(settings, cycle_max_points=30)   # the test's budget; the scene's are 60, 40
    eq = continue_equilibria(problem, settings, name=run.name, engine="compiled")
    return eq, settings


@pytest.fixture(scope="module", params=["fig10.toml", "fig04a.toml"])
def both_cycle_engines(request):
    eq, settings = scene_hopf(request.param)
    assert [h.label for h in eq.branch.of_type("H")] == ["H1"]
    pyc = continue_cycles(eq, "H1", settings, engine="pycont")
    comp = continue_cycles(eq, "H1", settings, engine="compiled")
    return request.param, eq, pyc, comp


@pytest.mark.slow
def test_compiled_cycles_equal_pycont_lc_c(both_cycle_engines):
    scene, eq, pyc, comp = both_cycle_engines
    a, b = pyc.branch, comp.branch
    par = a.parameter
    assert [e.reason for e in a.ends] == [e.reason for e in b.ends] == ["max_points"]
    assert len(a) == len(b) == 30
    span = eq.problem.span
    np.testing.assert_allclose(b[par], a[par], rtol=0, atol=1e-8 * span)
    # Interpolated in the parameter (cubic through the compiled cycles), at PyCont's cycles.
    order = np.argsort(b[par][1:]) + 1
    xs = b[par][order]
    assert np.all(np.diff(xs) > 0)
    inner = slice(2, len(a) - 1)
    for key, tol in (("period", 1e-8), ("a1_max", 1e-5), ("a2_max", 3e-5)):
        if np.all(np.isnan(a[key])):
            assert np.all(np.isnan(b[key]))              # the 1-dof AME has no a2
            continue
        got = CubicSpline(xs, b[key][order])(a[par][inner])
        scale = np.max(np.abs(a[key]))
        assert np.max(np.abs(got - a[key][inner])) <= tol * scale, (scene, key)
    ma = np.sort(np.abs(a.eigenvalues), axis=1)
    mb = np.sort(np.abs(b.eigenvalues), axis=1)
    assert np.max(np.abs(ma - mb)[1:]) < 1e-6
    # The Hopf point (row 0) has a multiplier pair on the unit circle: its flag is round-off.
    assert np.array_equal(a.stable[1:], b.stable[1:])
    assert [s.label for s in a.special_points] == [s.label for s in b.special_points]


@pytest.mark.slow
def test_collocation_monodromy_is_the_variational_one(both_cycle_engines):
    scene, eq, _, comp = both_cycle_engines
    b = comp.branch
    system = eq.problem.system
    for i in (5, len(b) - 1):
        p = np.array([b[name][i] for name in system.parameter_names])
        Phi, xT, dense = _monodromy(system, b.states[i], p, b["period"][i], 1e-11)
        size = np.max(np.ptp(dense, axis=0))
        assert np.linalg.norm(xT - b.states[i]) <= 1e-7 * size, scene
        want = np.sort_complex(np.linalg.eigvals(Phi))
        got = np.sort_complex(np.asarray(b.eigenvalues[i]))
        assert np.max(np.abs(want - got)) < 1e-7, (scene, want, got)


@pytest.mark.slow
def test_batched_chart_equals_the_pointwise_chart(both_cycle_engines):
    from autocable.codegen.ckernel import compiled_kernel
    _, eq, _, _ = both_cycle_engines
    system = eq.problem.system
    kernel = compiled_kernel(system)
    rng = np.random.default_rng(3)
    cfg = np.concatenate([system.parameter_vector(eq.problem.values), [0, 0.01, 0.1]])
    Y = rng.normal(size=(7, system.dimension + 1))
    f, df = kernel.chart_batch(cfg, Y)
    for q in range(len(Y)):
        f1, df1 = kernel.both(cfg, Y[q])
        assert np.array_equal(f[q], f1) and np.array_equal(df[q], df1)


# --------------------------------------------------------------------------------------------
def test_a_label_that_is_not_a_hopf_point_is_one_line():
    eq, _ = normal_form_cycles(ntst=4, max_points=3)
    with pytest.raises(KeyError) as exc:
        continue_cycles(eq, "H7", engine="compiled")
    assert "no special point 'H7'" in str(exc.value) and "\n" not in str(exc.value)
    lp = replace(eq.branch.special("H1"), type="LP", label="LP1")
    with pytest.raises(ValueError, match=r"^EQ:LP1 is a LP point, not a Hopf point$"):
        continue_cycles(eq, lp, engine="compiled")
    with pytest.raises(ValueError, match="engine must be one of"):
        continue_cycles(eq, "H1", engine="auto")
