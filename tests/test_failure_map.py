"""The failure map: the quick map runs end to end through the command, the AME is
exact in the linear limit, a known blow-up of eq. (21) is classified as such, and the 2 % statement
is computed from the grid.

Linear limit. At eta -> 0 and U = 0 the forced response is linear, a1 = O(eta), and the exact-Omega
AME reproduces the linear forced response of eq. (21) exactly; the first terms it misses are relative
O(eta^2) (tests/test_ame_vs_ode21.py derives the order): the parametric term eta f q1 of eq. (21)
(coefficient ~320) acts on the amplitude at Omega only at second order, (320 eta / omega1^2)^2
~ 1e-7 at eta = 1e-6, and the integrators' and the amplitude extraction's accuracy is ~1e-7 too.
The error is asserted below 1e-6, ten times that expected 1e-7 (measured 0.8e-7 to 4e-7 over
sigma = -0.02, 0, 0.02).
"""
from __future__ import annotations

import copy
import math
import re

import pytest

from autocable.cli import main
from autocable.studies.failure_map import Tools, map_point, point_class, region_statement
from conftest import SAMPLE



@pytest.fixture(scope="module")
def quick_map(tmp_path_factory):
    out = tmp_path_factory.mktemp("failure_map")
    assert main(["failure-map", "--out", str(out), "--quick", "--quiet", "--model", str(SAMPLE)]) == 0
    return out


@pytest.mark.slow
def test_quick_map_writes_report_and_figures(quick_map):
    md = (quick_map / "failure_map.md").read_text()
    for k in (1, 2):
        png = quick_map / f"failure_map_{k}.png"
        assert png.stat().st_size > 10_000
        assert f"failure_map_{k}.png" in md
    assert "## The region where the 2-dof AME is within 2 %" in md
    # One table row per grid point of each plane: 2 rows x 3 sigmas.
    for value in ("1e-06", "0.00041", "0.7"):
        assert len(re.findall(rf"^\| {value} \| [+-]0\.0[02]00 \|", md, flags=re.M)) == 3
    # The continuation rows: both no-wind rows ran to the end of the range; wind rows skipped (quick).
    assert re.search(r"^\| 1e-06 \| \d+ \| range \| \+0\.0200 \|", md, flags=re.M)
    assert re.search(r"^\| 0\.7 \| 0 \| not_run \|", md, flags=re.M)


@pytest.mark.slow
def test_linear_limit_error_below_1e6(quick_map):
    md = (quick_map / "failure_map.md").read_text()
    rows = [line.split("|") for line in md.splitlines() if re.match(r"\| 1e-06 \| [+-]0\.0", line)]
    assert len(rows) == 3
    for cells in rows:
        assert cells[3].strip() == "same"
        assert float(cells[6]) < 1e-6            # relative a1 error, AME against eq. (21)
        assert cells[8].strip() == "agree"       # Floquet of (21) and AME eigenvalues: both stable
        assert float(cells[9]) < 1.0             # max |mu|


@pytest.fixture(scope="module")
def tools():
    return Tools.build(SAMPLE)


def test_linear_limit_floquet_matches_ame_eigenvalue(tools):
    """Cross-check of (b) where both are exact: at eta -> 0, U = 0 eq. (21) is two damped linear
    oscillators q_k'' + 2 xi_s omega_k q_k' + omega_k^2 q_k = forcing, whose multipliers have moduli
    exp(-xi_s omega_k T) exactly; the AME's equilibrium has the eigenvalues -xi_s omega_k +- i sigma_k.
    The least damped is the out-of-plane mode (omega2 < omega1: rho < 0). So log(max |mu|) / T
    (integrated variational equations) equals max Re(lambda) (analytic AME Jacobian) equals
    -c2 / 2, c2 the damping coefficient of eq. (21)_2, up to the O(eta^2) parametric corrections
    (~1e-12) and the integration's 1e-10."""
    ode = tools.derivation.ode
    (damping,) = [t for t in ode.find(2, (0, 0, 0, 1)) if t.origin == "damping"]
    decay = damping.coefficient / 2
    assert ode.omega2 < ode.omega1 and decay == pytest.approx(ode.xi_s * ode.omega2, rel=1e-6)
    row = map_point(tools, 0.0, 1e-6, 0.0)
    st = row["stability"]
    T = 2 * math.pi / ode.omega1             # sigma = 0: Omega = omega1
    assert st["verdict"] == "agree" and st["stable21"] and st["ame_stable"]
    assert math.log(st["max_modulus"]) / T == pytest.approx(-decay, rel=1e-7)
    assert st["ame_max_real"] == pytest.approx(-decay, rel=1e-7)
    assert row["rel_a1"] < 1e-6


def test_known_divergence_is_diverged_21(legacy_sample):
    """U = 1.3, eta = 1.4e-3, sigma = 0 (Fig. 10's setting): eq. (21) of the legacy-sense sample
    (conftest.legacy_sample) blows up in finite time while the AME stays bounded: "diverged-21",
    and the AME is unchecked there."""
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        legacy = Tools.build(legacy_sample)
    row = map_point(legacy, 1.3, 1.4e-3, 0.0)
    assert row["status"] == "diverged-21"
    assert row["diverged_at"] is not None and row["a1_ode21"] is None
    assert row["a1_ame"] is not None and 0 < row["a1_ame"] < 0.1
    assert point_class(row, 0.02) == "unchecked"


def _fake(rows_by_value, sigmas, axis="eta", fixed=None):
    """A map with given (status, rel_a1) per sigma per row value."""
    rows = []
    for v, cells in rows_by_value.items():
        for s, (status, rel) in zip(sigmas, cells):
            rows.append({axis: v, "sigma": s, "status": status, "rel_a1": rel})
    return {"planes": [{"name": "p", "axis": axis, "fixed": fixed or {"U": 0.0}, "sigmas": list(sigmas),
                        "values": list(rows_by_value), "rows": rows}]}


def test_statement_is_computed_from_the_grid():
    sig = [-0.02, -0.01, 0.0, 0.01, 0.02]
    ok, bad = ("same-branch", 1e-3), ("same-branch", 0.05)
    grid = _fake({1e-4: [ok] * 5, 4e-4: [bad, bad, ok, ok, ok], 1e-3: [ok, ("no-ame-branch", None), bad,
                                                                       ok, ok]}, sig)
    line, total = region_statement(grid, 0.02)
    assert "within 2 % at every sigma for eta <= 0.0001" in line
    assert "for eta = 0.0004: within 2 % only at sigma in [+0, +0.02]; not within 2 % at sigma in " \
           "[-0.02, -0.01]" in line
    assert "for eta = 0.001: within 2 % only at sigma = -0.02 and sigma in [+0.01, +0.02]; " \
           "not within 2 % at sigma in [-0.01, +0]" in line
    # Change one grid point: the statement follows.
    changed = copy.deepcopy(grid)
    for r in changed["planes"][0]["rows"]:
        if r["eta"] == 4e-4:
            r["rel_a1"] = 1e-3
    line2, total2 = region_statement(changed, 0.02)
    assert "within 2 % at every sigma for eta <= 0.0004" in line2 and line2 != line
    assert total == "Over all 15 distinct grid points: within 2 % at 11, not within 2 % at 4, unchecked " \
                    "(eq. (21) diverges) at 0."
    assert "within 2 % at 13, not within 2 % at 2," in total2
    # The smallest eta fails somewhere: no prefix of the rows is within everywhere.
    worse = copy.deepcopy(grid)
    worse["planes"][0]["rows"][0]["rel_a1"] = 0.03
    line4, _ = region_statement(worse, 0.02)
    assert "no row of the grid is within 2 % at every sigma" in line4
    assert "for eta = 0.0001: within 2 % only at sigma in [-0.01, +0.02]; not within 2 % at sigma = -0.02" in line4
    # A looser tolerance moves the boundary too.
    line3, _ = region_statement(grid, 0.06)
    assert "for eta <= 0.0004" in line3


def test_statement_marks_divergence_as_unchecked():
    sig = [-0.01, 0.0, 0.01]
    grid = _fake({0.7: [("same-branch", 1e-3)] * 3, 1.3: [("diverged-21", None)] * 3}, sig, axis="U",
                 fixed={"eta": 4.1e-4})
    line, total = region_statement(grid, 0.02)
    assert "within 2 % at every sigma for U <= 0.7" in line
    assert "for U = 1.3: within 2 % at no sigma; eq. (21) diverges at sigma in [-0.01, +0.01], so the " \
           "AME is unchecked there" in line


def _numbers_in_the_text(monkeypatch):
    """PyCont's EP-C generator built with the right-hand side's numbers printed in its text
    (`System.scaled_field` without its coefficients as parameters)."""
    from autocable.methods.continuation.system import System
    monkeypatch.setattr(System, "scaled_field", lambda self, coefficients_as_parameters=False: self._scaled_field)


@pytest.mark.slow
def test_pycont_row_passes_the_pitchfork_pycont_cannot_locate(tools, monkeypatch):
    """The map's PyCont row at U = 0, eta = 8e-4 (`continuation_row`, forward from sigma = -0.05 with
    max_step 5e-2) stopped at sigma = 5.06e-4 with "PyCont failed: IndexError: list index out of
    range": PyCont detected the second pitchfork of the mono-modal branch (the other end of the
    bi-modal wedge of docs/charts.md's U = 0 chart), its fsolve "located" it where the smallest
    eigenvalue of [J_x, J_p; v] is 2e-4, and its BP processing indexed the empty list of eigenvalues
    below 5e-5. Now the row runs to the end of the range and both pitchforks are located by
    autocable's test functions; the second agrees with the compiled engine (its own kernel and
    test functions, no PyCont) to 1e-9 in sigma, and the branch says which point PyCont could not
    locate."""
    import numpy as np
    from autocable.methods.continuation import (ContinuationSettings, EquilibriumProblem, auto_state_scale,
                                                continue_equilibria)
    from autocable.studies.failure_map import continuation_row

    row = continuation_row(tools, 0.0, 8e-4, (-0.05, 0.05))
    assert (row["end_reason"], row["stalled"]) == ("range", False), row["message"]
    assert row["end_sigma"] == pytest.approx(0.05, abs=1e-12)
    bps = [s["sigma"] for s in row["special"] if s["type"] == "BP"]
    # the compiled engine over the same row
    system = tools.system("2dof", False)
    values = {"sigma": -0.05, "U": 0.0, "eta": 8e-4}
    problem = EquilibriumProblem(system, "sigma", values, (-0.05, 0.05),
                                 state_scale=auto_state_scale(system, values))
    settings = ContinuationSettings(step=1e-2, max_step=5e-2, max_points=400)
    ref = continue_equilibria(problem, settings, np.zeros(system.dimension), directions="forward",
                              engine="compiled").branch
    ref_bps = [s.value for s in ref.special_points if s.type == "BP"]
    assert len(ref_bps) == 2 and ref_bps[1] == pytest.approx(1.43e-3, abs=2e-5)
    assert bps == pytest.approx(ref_bps, abs=1e-9)
    # PyCont's failure to locate that pitchfork reproduces with its generator compiled with the
    # model's numbers in the text (as when the row was measured); with the numbers as PyDSTool
    # parameters (the default since, one generator per structure) its fsolve lands elsewhere
    _numbers_in_the_text(monkeypatch)
    res = continue_equilibria(problem, settings, np.zeros(system.dimension), directions="forward")
    [unlocated] = res.branch.info["pycont_unlocated"]
    assert unlocated["type"] == "BP" and unlocated["sigma"][0] < ref_bps[1] < unlocated["sigma"][1]
    bp2 = [s for s in res.branch.special_points if s.type == "BP"][1]
    assert not bp2.confirmed_by_pycont and "could not locate it" in bp2.message


def test_pycont_location_failure_past_the_limit_is_named(tools, monkeypatch):
    """With no unlocated point allowed (MAX_UNLOCATED = 0), the same row ends at that pitchfork with
    a named failure that says what PyCont could not do and what to use instead, not PyCont's
    IndexError."""
    import numpy as np
    from autocable.methods.continuation import (ContinuationSettings, EquilibriumProblem, auto_state_scale,
                                                continue_equilibria, pycont_driver)

    monkeypatch.setattr(pycont_driver, "MAX_UNLOCATED", 0)
    _numbers_in_the_text(monkeypatch)           # where PyCont's location fails (above)
    system = tools.system("2dof", False)
    values = {"sigma": -0.05, "U": 0.0, "eta": 8e-4}
    problem = EquilibriumProblem(system, "sigma", values, (-0.05, 0.05),
                                 state_scale=auto_state_scale(system, values))
    settings = ContinuationSettings(step=1e-2, max_step=5e-2, max_points=400)
    res = continue_equilibria(problem, settings, np.zeros(system.dimension), directions="forward")
    fwd = [e for e in res.branch.ends if e.side == "forward"][0]
    assert fwd.reason == "error" and fwd.value < 1.43e-3
    assert fwd.message.startswith("PyCont detected a BP point just beyond sigma = ")
    assert "could not locate it" in fwd.message and 'engine = "compiled"' in fwd.message
    assert "IndexError" not in fwd.message
