"""Exit status means what it says: invalid numbers are refused as input (2), a physical divergence
is a result (0, strict JSON with ``"status": "diverged"`` and null amplitudes), a numerical failure
or a spent budget is a failure (3) that keeps what was computed before."""
from __future__ import annotations

import csv
import json
import math
import os
import re

import numpy as np
import pytest

from autocable.cli import main
from autocable.errors import BudgetExceeded, ComputationError
from conftest import SAMPLE, two_run_scene

#: Fig. 10's carets: above U_c eq. (21) grows past |q| = 0.1 (tests/test_compiled_integration.py).
#: Diverging with the legacy-sense sample (conftest.legacy_sample); the sample stays bounded there.
DIVERGING = ["--U", "1.3", "--eta", "1.4e-3", "--sigma", "0.03"]


def strict_json(text: str):
    """json.loads that refuses NaN and Infinity (what a strict parser does)."""
    def refuse(name):
        raise ValueError(f"not JSON: {name}")
    return json.loads(text, parse_constant=refuse)


def run_cli(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


# -- bad numbers are input errors, one line naming the option -----------------------------------
@pytest.mark.parametrize("args, option", [
    (["--U", "0.7", "--eta", "nan", "--sigma", "0.01", "--json"], "--eta"),
    (["--U", "nan", "--json"], "--U"),
    (["--U", "inf", "--json"], "--U"),
    (["--U", "-0.1"], "--U"),
    (["--q0", "nan", "0", "1e-6", "0", "--json"], "--q0"),
    (["--q0", "0", "0", "5", "0"], "--q0"),
    (["--method", "ame", "--eta", "nan", "--json"], "--eta"),
    (["--sigma", "1e9", "--json"], "--sigma"),
    (["--max-time", "-5", "--json"], "--max-time"),
    (["--max-time", "inf"], "--max-time"),
    (["--max-time", "1e12"], "--max-time"),
    (["--modes", "0"], "--modes"),
    (["--csv", ""], "--csv"),
])
def test_simulate_refuses_invalid_numbers(capsys, args, option):
    code, out, err = run_cli(capsys, "simulate", SAMPLE, *args)
    assert code == 2 and out == ""
    line, = err.strip().splitlines()
    assert f": {option}: " in line and "Traceback" not in line
    # the message says what is accepted: a range or "finite"
    assert re.search(r"[\[(][-+\d.e]+, [-+\d.e]+\]", line) or "finite" in line or "empty" in line, line


@pytest.mark.parametrize("argv, option", [
    (["run", "SCENE", "--out", ""], "--out"),
    (["chart", "SCENE", "--out", ""], "--out"),
    (["bench", "derive", "--repeats", "-1"], "--repeats"),
    (["bench", "derive", "--out", " "], "--out"),
    (["sweep", "SWEEP", "--out", "o", "--workers", "-1"], "--workers"),
    (["sweep", "SWEEP", "--out", "o", "--chunk", "0"], "--chunk"),
    (["calibrate", "MODEL", "TARGETS", "--out", "o", "--workers", "-1"], "--workers"),
    (["calibrate", "MODEL", "TARGETS", "--out", "o", "--bound-margin", "-1"], "--bound-margin"),
    (["calibrate", "MODEL", "TARGETS", "--out", "o", "--bound-minutes", "nan"], "--bound-minutes"),
    (["failure-map", "--out", ""], "--out"),
])
def test_other_commands_refuse_bad_options_before_any_work(capsys, tmp_path, monkeypatch, argv, option):
    """Nothing is read or written: the option is refused first (an empty --out used to write to ./out)."""
    monkeypatch.chdir(tmp_path)
    code, out, err = run_cli(capsys, *argv)
    assert code == 2
    line, = err.strip().splitlines()
    assert f": {option}: " in line
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("argv, option", [
    (["figures", "--out", ""], "--out"),
    (["figures", "--out", "o", "--timeout", "nan"], "--timeout"),
])
def test_figures_refuses_bad_options(capsys, tmp_path, monkeypatch, argv, option):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr("os.environ", dict(os.environ))    # `figures` sets thread counts there
    code, _, err = run_cli(capsys, *argv)
    assert code == 2 and f": {option}: " in err.strip()
    assert list(tmp_path.iterdir()) == []


# -- a divergence is a result: exit 0, strict JSON, status, nulls ---------------------------------
def test_divergence_is_a_result_in_strict_json(capsys, legacy_sample):
    code, out, err = run_cli(capsys, "simulate", legacy_sample, *DIVERGING, "--json", "--quiet")
    assert code == 0
    r = strict_json(out)
    assert r["status"] == "diverged" and r["a1"] is None and r["a2"] is None
    assert r["a1_max"] is None and r["steady"] is False
    assert "|q_k| > 0.1" in r["message"]


def test_steady_result_has_status(capsys):
    """U = 0: the linear forced response, status "steady", finite numbers."""
    code, out, _ = run_cli(capsys, "simulate", SAMPLE, "--eta", "8.2e-6", "--sigma", "0.02", "--json",
                           "--quiet")
    r = strict_json(out)
    assert code == 0 and r["status"] == "steady" and r["a1"] > 0


def test_not_steady_status_when_time_runs_out(capsys):
    code, out, _ = run_cli(capsys, "simulate", SAMPLE, "--eta", "8.2e-5", "--sigma", "0.02",
                           "--max-time", "50", "--json", "--quiet")
    r = strict_json(out)
    assert code == 0 and r["status"] == "not_steady" and r["t_end"] == pytest.approx(50, abs=0.2)


def test_csv_of_a_diverging_response_keeps_the_rows(capsys, legacy_sample, tmp_path):
    """--csv on a divergence writes the history up to it (every row inside |q| <= 0.1, the last
    within one sample interval of t_end) and still prints the result."""
    path = tmp_path / "h.csv"
    code, out, _ = run_cli(capsys, "simulate", legacy_sample, *DIVERGING, "--json", "--quiet", "--csv", path)
    assert code == 0
    r = strict_json(out)
    assert r["status"] == "diverged"
    with path.open() as fh:
        rows = list(csv.reader(fh))
    assert rows[0] == ["t", "q1", "q2", "q1dot", "q2dot"]
    data = np.array(rows[1:], dtype=float)
    assert len(data) > 1000 and np.all(np.isfinite(data))
    assert np.all(np.diff(data[:, 0]) > 0)
    assert np.max(np.abs(data[:, 1:3])) <= 0.1
    dt = 2 * math.pi / r["Omega"] / 64
    assert r["t_end"] - dt <= data[-1, 0] <= r["t_end"]


def test_csv_of_an_immediate_divergence_is_the_header(capsys, legacy_sample, tmp_path):
    """Diverging within the first sample interval: the csv holds the start row or only the header
    (not the old "not enough values to unpack"), the result is printed."""
    path = tmp_path / "h.csv"
    code, out, _ = run_cli(capsys, "simulate", legacy_sample, *DIVERGING, "--q0", "0.099", "0.09", "0.099", "0.09",
                           "--json", "--quiet", "--csv", path)
    assert code == 0 and strict_json(out)["status"] == "diverged"
    lines = path.read_text().splitlines()
    assert lines[0] == "t,q1,q2,q1dot,q2dot" and len(lines) <= 3


# -- a numerical failure is exit 3 with the reason ---------------------------------------------------
def test_integrator_failure_at_a_bounded_state_is_exit_3(capsys, monkeypatch):
    """PyDSTool failing while the compiled engine finds the response bounded is not a divergence."""
    from autocable.codegen import pydstool
    from autocable.codegen.compat import PyDSToolError

    def broken(*args, **kwargs):
        raise PyDSToolError("integrating failed: step size too small")
    monkeypatch.setattr(pydstool, "integrate", broken)
    code, out, err = run_cli(capsys, "simulate", SAMPLE, "--eta", "8.2e-5", "--sigma", "0.02", "--json",
                             "--quiet")
    assert code == 3 and out == ""
    line, = err.strip().splitlines()
    assert "stayed bounded" in line and "step size too small" in line


def test_compiled_step_budget_is_a_failure_not_a_divergence(derivation, monkeypatch):
    from autocable.methods.integration.ode21 import Ode21Integrator
    monkeypatch.setattr(Ode21Integrator, "_budget", staticmethod(lambda t0, t1, n: 10))
    with pytest.raises(ComputationError, match="integration steps"):
        Ode21Integrator(derivation.ode, engine="compiled").simulate(0.0, 8.2e-5, 0.02)


def test_non_finite_parameters_in_the_library_are_failures(derivation, sample_ame):
    """The library does not call a NaN a divergence either: as the CLI, it refuses it before any
    work, naming the argument (`ArgumentError`; was a `ComputationError` from
    the integration)."""
    from autocable.methods.integration.ame import AmeIntegrator
    from autocable.methods.integration.ode21 import Ode21Integrator
    from autocable.methods.integration.shooting import ShootingSolver
    from autocable.model.premises import ArgumentError
    with pytest.raises(ArgumentError, match="^Ode21Integrator.simulate: eta: expected a finite number"):
        Ode21Integrator(derivation.ode, engine="compiled").simulate(0.7, math.nan, 0.01)
    with pytest.raises(ArgumentError, match="^AmeIntegrator.simulate: eta: expected a finite number"):
        AmeIntegrator(sample_ame, method="DOP853").simulate(0.7, math.nan, 0.01)
    with pytest.raises(ArgumentError, match="^ShootingSolver.steady: eta: expected a finite number"):
        ShootingSolver(derivation.ode).steady(0.7, math.nan, 0.01)


def test_ame_integration_has_a_budget(sample_ame):
    from autocable.methods.integration.ame import AmeIntegrator
    with pytest.raises(BudgetExceeded, match="budget of 10 right-hand side evaluations"):
        AmeIntegrator(sample_ame).simulate(0.0, 8.2e-5, 0.02, max_evaluations=10)


# -- budgets: a start that would integrate without end stops, the other runs are kept --------------
def _scene(tmp_path, second_start: str, steps: str = "") -> str:
    path = tmp_path / "budget.toml"
    path.write_text(two_run_scene(second_start, f'{steps}\n[plot]\nx = "sigma"\ny = ["a1"]', title="budget"))
    return str(path)


def test_settle_budget_keeps_the_other_runs_and_exits_3(capsys, tmp_path):
    scene = _scene(tmp_path, "{ integrate = [5e-4, 0.0] }", "steps = { settle_evaluations = 5 }")
    out = tmp_path / "out"
    code, _, err = run_cli(capsys, "run", scene, "--out", out, "--no-plot", "--resolution", "coarse", "--quiet")
    assert code == 3
    line, = err.strip().splitlines()
    assert "run II failed" in line and "budget of 5 right-hand side evaluations" in line
    assert "settle_evaluations" in line
    with (out / "branches.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    assert {r["branch"] for r in rows} == {"I"} and len(rows) > 50
    run = json.loads((out / "run.json").read_text())
    assert list(run["provenance"]["failed_runs"]) == ["II"]


def test_same_scene_within_budget_exits_0(capsys, tmp_path):
    scene = _scene(tmp_path, "{ integrate = [5e-4, 0.0] }")
    code, _, err = run_cli(capsys, "run", scene, "--out", tmp_path / "out", "--no-plot", "--resolution",
                           "coarse", "--quiet")
    assert code == 0, err
    run = json.loads((tmp_path / "out" / "run.json").read_text())
    assert run["provenance"]["failed_runs"] == {}


def test_start_far_outside_the_model_is_refused_at_load(capsys, tmp_path):
    scene = _scene(tmp_path, "{ integrate = [1e6, 0.0] }")
    code, _, err = run_cli(capsys, "run", scene, "--out", tmp_path / "out", "--quiet")
    assert code == 2
    line, = err.strip().splitlines()
    assert "run[1].start.integrate" in line and "[-0.1, 0.1]" in line
    assert not (tmp_path / "out" / "branches.csv").exists()


def test_settle_and_orbit_budgets_raise(sample_ame):
    from autocable.methods.continuation import ame_system, periodic_orbit, settle
    system = ame_system(sample_ame, "2dof", wind=False)
    values = {"sigma": 0.0, "U": 0.0, "eta": 1.4e-3}
    y0 = np.array([3e-3, 0.0, 3e-3, 0.0])
    with pytest.raises(BudgetExceeded, match="budget of 10 right-hand side evaluations"):
        settle(system, values, y0, scale=1e-3, evaluations=10)
    with pytest.raises(BudgetExceeded, match="more than 3 steps"):
        periodic_orbit(system, values, y0, scale=1e-3, max_steps=3)


def test_a_failed_follow_up_branch_keeps_the_scene(capsys, tmp_path, monkeypatch):
    """A numerical failure while switching branches at a pitchfork (Fig. 6, compiled engine,
    coarse) loses that follow-up branch only (and the runs that start on it): run I and its cycles
    are computed and written, run.json lists the failed follow-ups and the folder is published as
    "failed", exit 3 (a failed follow-up ended the whole scene before)."""
    from conftest import RUNS
    from autocable.methods import continuation as C

    def failing(source, label, *args, **kwargs):
        raise ComputationError(f"the corrector did not converge at {label} (provoked)")

    monkeypatch.setattr(C, "switch_branch", failing)
    out = tmp_path / "out"
    code, _, err = run_cli(capsys, "run", RUNS / "fig06.toml", "--out", out, "--no-plot", "--quiet",
                           "--resolution", "coarse", "--engine", "compiled")
    assert code == 3
    assert "failed" in err and "provoked" in err
    run = json.loads((out / "run.json").read_text())
    assert run["status"] == "failed"
    failed = run["provenance"]["failed_runs"]
    switched = {name for name in failed if re.fullmatch(r"I-BP\d+", name)}
    assert switched == {"I-BP1", "I-BP2"}, failed
    # run II starts on I-BP1's branch: skipped with the reason, not attempted
    assert set(failed) - switched == {"II"} and "I-BP1, which failed" in failed["II"]
    with (out / "branches.csv").open() as fh:
        names = {r["branch"] for r in csv.DictReader(fh)}
    assert "I" in names and not names & set(failed)
