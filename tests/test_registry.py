"""The method ladder (autocable.studies.ladder): records, one interface, and each rung's error
against a closed form at its declared order; the quick work-precision bench.

Closed forms used (U = 0, the linear limit eta -> 0 of eq. 21 and of the AME):

* eq. (21): q1'' + d q1' + k q1 + sum_c c eta f^(c) = 0 with f = sin(Omega t), the forced linear
  oscillator; its steady state q1 = X sin(Omega t) + Y cos(Omega t) solves a 2x2 linear system. The
  terms left out (parametric eta f q1 ~ 320 eta q1, quadratic q1^2) change q1 by a relative
  O(320 eta / omega1^2) = 3e-10 at eta = 1e-12: far below the integration errors measured.
* AME (24), 1-dof: at eta -> 0 the slow flow is linear in (r1, s1), y' = J y + g, whose equilibrium
  is y* = -J^{-1} g (cubic terms change it by a relative O(a^2) ~ 1e-24).
"""
from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest

from autocable.studies.work_precision import compare, crossings
from autocable.cli import main
from autocable.studies import ladder as R
from autocable.model.symbolic import parameter_values
from conftest import REPO, SAMPLE

ROOT = REPO
RUNS = ROOT / "runs"


@pytest.fixture(scope="module")
def tools():
    return R.Tools(SAMPLE)


def test_records_are_frozen_and_consistent():
    methods = R.available_methods()
    assert {"ame-1dof", "ame-2dof", "ame-sweep", "ode21-sweep"} <= set(methods)
    for m in methods.values():
        names = {k.name for k in m.knobs}
        assert m.order_knob is None or m.order_knob in names, m.name
        assert (m.order is None) == (m.order_knob is None), m.name
        for knobs in m.ladder:
            assert set(knobs) <= names, (m.name, dict(knobs))
        with pytest.raises(dataclasses.FrozenInstanceError):
            m.name = "x"


def test_settings_come_from_the_scene_files():
    s6 = R.setting_from_scene(RUNS / "fig06.toml")
    assert (s6.scene, s6.U, s6.eta, s6.sigma_range) == ("fig06", 0.0, 1.4e-3, (-0.05, 0.05))
    s9 = R.setting_from_scene(RUNS / "fig09.toml")
    assert (s9.U, s9.eta) == (0.7, 1.4e-3)


def test_run_rejects_unknown_knobs_and_methods(tools):
    st = R.setting_from_scene(RUNS / "fig05a.toml")
    with pytest.raises(ValueError, match="unknown knobs"):
        R.run("ame-1dof", st, {"rtol": 1e-6}, tools)
    with pytest.raises(ValueError, match="unknown method"):
        R.run("ame-3dof", st, {}, tools)


def _linear_eq21(ode, eta, sigma):
    """(X, Y) of the steady q1 = X sin + Y cos of the linear forced eq. (21) at U = 0."""
    def c(powers, forcing):
        return sum(t.coefficient for t in ode.equation(1)
                   if t.powers == powers and t.forcing == forcing and (t.u_power or 0) == 0)
    Om = ode.omega1 + sigma
    k, d = c((1, 0, 0, 0), (0, 0, 0)), c((0, 0, 1, 0), (0, 0, 0))
    # forcing moved to the right-hand side: -c (eta f, eta f', eta f'') = eta (A sin + B cos)
    A = -c((0, 0, 0, 0), (1, 0, 0)) + Om ** 2 * c((0, 0, 0, 0), (0, 0, 1))
    B = -Om * c((0, 0, 0, 0), (0, 1, 0))
    X, Y = np.linalg.solve([[k - Om ** 2, -d * Om], [d * Om, k - Om ** 2]], [A * eta, B * eta])
    return Om, X, Y


def test_ode21_integration_error_is_order_one_in_rtol(tools):
    """ode21-sweep declares error ~ rtol^1: DOP853 with per-step error control is tolerance-
    proportional (global error ~ rtol for a stable linear problem over a fixed time). Started on the
    closed-form steady state and integrated 50 forcing periods, the max error of q1 relative to the
    amplitude is measured 5.6 rtol for rtol in [1e-10, 1e-7] (above 1e-6 the step is capped by the
    integrator's max_step = 1 and the error stays ~7e-6)."""
    ode = tools.derivation.ode
    eta, sigma = 1e-12, 0.02
    Om, X, Y = _linear_eq21(ode, eta, sigma)
    amp = math.hypot(X, Y)
    T = 2 * math.pi / Om
    rtols = np.array([1e-7, 1e-8, 1e-9, 1e-10])
    errors = []
    for rtol in rtols:
        integ = tools.ode21(1e-10).with_tolerances(float(rtol), 1e-3 * float(rtol) * amp)
        t, ys = integ.run((Y, 0.0, Om * X, 0.0), 0.0, 50 * T, T / 64, parameter_values(0.0, eta, Om))
        errors.append(np.max(np.abs(ys[:, 0] - (X * np.sin(Om * t) + Y * np.cos(Om * t)))) / amp)
    order = np.polyfit(np.log(rtols), np.log(errors), 1)[0]
    m = R.method("ode21-sweep")
    assert m.order == 1.0 and m.order_knob == "rtol"
    assert abs(order - m.order) < 0.2, (errors, order)
    assert all(e < 30 * r for e, r in zip(errors, rtols)), errors
    assert errors[-1] > 1e-3 * rtols[-1]          # resolved, not at the linear limit's floor


@pytest.mark.slow
def test_continuation_error_is_order_two_in_the_step(tools):
    """ame-1dof declares points exact (Newton) and an O(h^2) read-out between them (linear
    interpolation of a smooth curve, h the pseudo-arclength step). Against the closed-form linear
    equilibrium y* = -J^{-1} g at 201 sigma values, max_step 0.04 -> 0.02 -> 0.01 gives errors
    4.6e-3, 1.15e-3, 2.8e-4 (measured): order 2.0. PyCont's EP-C and the compiled engine agree."""
    st = R.Setting("linear", "U = 0, eta = 1e-9", SAMPLE, 0.0, 1e-9, (-0.05, 0.05))
    system = tools.system("1dof", False)
    grid = np.linspace(-0.05, 0.05, 201)

    def exact(s):
        p = system.parameter_vector({"sigma": s, "U": 0.0, "eta": 1e-9})
        x0 = np.zeros(system.dimension)
        return system.amplitude_values(-np.linalg.solve(system.jac(x0, p), system.f(x0, p)))[0]

    ex = np.array([exact(s) for s in grid])

    def error(h, engine="compiled"):
        r = R.run("ame-1dof", st, {"max_step": h, "engine": engine}, tools)
        return max(min(abs(c[0] - e) / e for c in crossings(r, s)) for s, e in zip(grid, ex))

    steps = np.array([0.04, 0.02, 0.01])
    errors = [error(h) for h in steps]
    order = np.polyfit(np.log(steps), np.log(errors), 1)[0]
    assert abs(order - R.method("ame-1dof").order) < 0.3, (errors, order)
    assert error(0.04, "pycont") == pytest.approx(errors[0], rel=0.05)


def test_ame_error_against_eq21_is_order_two_in_eta(tools):
    """The AME rungs' model error (docs/ame_vs_ode21.md; tests/test_ame_vs_ode21.py derives it):
    relative O(eta^2) at fixed sigma. Through the registry: the 2-dof diagram at sigma = -0.05 (its
    first, exact point) against eq. (21) at eta = 8.2e-5 x (1, 1/2, 1/4); measured order 1.99."""
    integ = tools.ode21(1e-10)
    etas = 8.2e-5 * np.array([1.0, 0.5, 0.25])
    errors = []
    for eta in etas:
        st = R.Setting("eta", "", SAMPLE, 0.0, float(eta), (-0.05, 0.05))
        r = R.run("ame-2dof", st, {"max_step": 0.05, "engine": "compiled"}, tools)
        o = integ.simulate(0.0, float(eta), -0.05)
        (a1, _, _, _), = crossings(r, -0.05)
        errors.append(abs(a1 - o.a1) / o.a1)
    order = np.polyfit(np.log(etas), np.log(errors), 1)[0]
    assert 1.7 < order < 2.3, (errors, order)


@pytest.mark.slow
def test_quick_bench_writes_records_and_chart(tmp_path, tools):
    """`autocable bench --out DIR --quick` (Fig. 5a): every record scored against the eq. (21)
    reference. Measured: ode21-sweep ~2e-6 (the reference differs in rtol only), ame-2dof ~1.7e-3 at
    max_step 0.02: the AME's O(eta^2) model error plus the O(h^2) linear-interpolation read-out of
    the branch at the reference sigma values (`work_precision.crossings`).

    The expected error is computed here: the model error is the same comparison read from a branch
    with max_step 0.001 (interpolation 400x smaller than at 0.02; it is 1.08e-3, at sigma = -0.05).
    The branch starts at sigma = -0.05, where there is no interpolation, so the 0.02 rung's error is
    at least the model error; the interpolation adds at most (0.02 / 0.05)^2 of the 0.05 rung's
    whole error, with a margin of 1.5 for the adaptive steps not all being max_step."""
    assert main(["bench", "--out", str(tmp_path), "--quick", "--quiet"]) == 0
    data = json.loads((tmp_path / "bench.json").read_text())
    assert (tmp_path / "work_precision.png").stat().st_size > 10_000
    assert "fig05a" in (tmp_path / "work_precision.md").read_text()
    recs = {(r["method"], json.dumps(r["setting"], sort_keys=True)): r for r in data["records"]}
    for r in data["records"]:
        for key in ("scene", "method", "setting", "error", "seconds", "build_seconds", "found", "missed"):
            assert key in r
        assert r["scene"] == "fig05a" and r["seconds"] is not None, r["message"]
        assert r["missed"] == 0 and r["found"] == r["compared"] > 0, r
    sweep = recs[("ode21-sweep", json.dumps({"points": 11, "rtol": 1e-6}))]
    assert sweep["error"] < 1e-3
    coarse = recs[("ame-2dof", json.dumps({"engine": "compiled", "max_step": 0.05}, sort_keys=True))]
    fine = recs[("ame-2dof", json.dumps({"engine": "compiled", "max_step": 0.02}, sort_keys=True))]
    assert fine["error"] <= coarse["error"]
    ref_points = data["references"]["fig05a"]["points"]
    finest = R.run("ame-2dof", R.setting_from_scene(RUNS / "fig05a.toml"),
                   {"engine": "compiled", "max_step": 0.001}, tools)
    model = max(min(R._distance(c[0], c[1], p["a1"], p["a2"]) for c in crossings(finest, p["sigma"]))
                for p in ref_points)
    assert model * (1 - 1e-6) <= fine["error"] <= model + 1.5 * (0.02 / 0.05) ** 2 * coarse["error"]
    assert data["summary"]["fig05a"]["ratio_sweep_over_ame"]


def test_compare_counts_missed_responses():
    """A diagram that has nothing at the reference sigma values misses them all."""
    def result(values, a1, branch, ok):
        n = len(values)
        return R.MethodResult("x", "s", {}, np.array(values), np.array(a1), np.zeros(n), np.ones(n, bool),
                              tuple(branch), (), 0.0, 0.0, "", ok=np.array(ok))
    ref = result([0.0, 0.1], [1.0, 2.0], ["up", "up"], [True, True])
    far = result([0.5, 0.6], [1.0, 1.0], ["I", "I"], [True, True])
    c = compare(far, ref)
    assert (c["found"], c["missed"], c["error"]) == (0, 2, None)
    near = result([0.0, 0.1], [1.01, 2.4], ["I", "I"], [True, True])
    c = compare(near, ref)
    assert c["found"] == 1 and c["missed"] == 1 and c["error"] == pytest.approx(0.2)


def test_cli_bench_without_subcommand_needs_out(capsys):
    assert main(["bench"]) == 2
    assert "--out" in capsys.readouterr().err
