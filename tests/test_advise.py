"""`autocable advise`: the lightest rung of the method ladder a scene needs, with its evidence.

Fig. 5a (U = 0, eta = 8.2e-5): the out-of-plane mode is never excited (a2 = 0 on every branch of
the 2-dof AME and in eq. 21), the 1-dof and 2-dof branches coincide, and the AME matches eq. (21)
within ~1.1e-3 (its O(eta^2) error, docs/ame_vs_ode21.md): the 1-dof AME suffices at 2 %.
Fig. 6 (eta = 1.4e-3): the mono-modal branch has two pitchfork points (sigma ~ -0.026, +0.023,
Sect. 5: "bi-modal motions (III-V) arising from pitchfork bifurcation points"), the bi-modal
branches reach a2 ~ 0.6 max a1, and between the pitchforks the A2 = 0 reduction calls stable what
the 2-dof AME finds unstable: the 1-dof AME is refused.
"""
from __future__ import annotations

import json

import pytest

from autocable.studies.advise import advice_report, choose_ame
from autocable.cli import main
from autocable.studies import ladder as R
from conftest import REPO

ROOT = REPO
RUNS = ROOT / "runs"


@pytest.fixture(scope="module")
def tools():
    return R.Tools(ROOT / "models" / "luongo_zulli_2012.toml")


def test_fig05a_needs_only_the_one_dof_ame(tools):
    adv = choose_ame(RUNS / "fig05a.toml", 0.02, tools=tools)
    e = adv.evidence
    assert (adv.rung, adv.ame) == ("1dof", "1dof"), adv.reasons
    assert e["a2_over_a1_2dof"] < 1e-9 and e["a2_over_a1_eq21_probes"] < 1e-9
    assert e["branch_points_on_mono_modal"] == [] and e["sigma_1dof_stable_2dof_unstable"] == []
    assert e["max_rel_a1_1dof_vs_2dof"] < 1e-3          # interpolation at max_step 0.01 only
    # the AME's own error against eq. (21): 1.08e-3 at sigma = -0.05 (docs/ame_vs_ode21.md)
    assert 5e-4 < e["max_err_1dof_vs_eq21"] < 2e-3
    assert e["probes"][0]["err_1dof"] == pytest.approx(1.08e-3, rel=0.05)
    assert "1-dof AME (A2 = 0) suffices" in advice_report(adv)


def test_fig06_refuses_the_one_dof_ame(tools):
    adv = choose_ame(RUNS / "fig06.toml", 0.02, tools=tools)
    e = adv.evidence
    assert adv.rung != "1dof" and adv.ame == "2dof", adv.reasons
    bps = sorted(b["sigma"] for b in e["branch_points_on_mono_modal"])
    assert len(bps) == 2 and bps[0] == pytest.approx(-0.026, abs=2e-3) and bps[1] == pytest.approx(0.023, abs=2e-3)
    assert e["a2_over_a1_2dof"] > 0.3
    stab = e["sigma_1dof_stable_2dof_unstable"]
    assert len(stab) >= 10 and bps[0] <= min(stab) and max(stab) <= bps[1]
    # eq. (21) itself is bi-modal at resonance: a2 / a1 ~ 0.64 at sigma = 0
    assert e["a2_over_a1_eq21_probes"] > 0.3
    # and the AME errs by more than the tolerance against it (26 % at sigma = -0.05)
    assert adv.rung == "ode21" and e["probes"][0]["err_2dof"] == pytest.approx(0.265, abs=0.01)
    assert any("bi-modal" in r for r in adv.reasons)


def test_cli_advise(capsys):
    assert main(["advise", str(RUNS / "fig05a.toml"), "--tol", "0.02", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["rung"] == "1dof" and out["evidence"]["max_err_1dof_vs_eq21"] < 0.02
    assert main(["advise", str(RUNS / "fig05a.toml"), "--tol", "2"]) == 2
    assert "--tol" in capsys.readouterr().err


def test_advise_names_the_load_and_curve_rungs_a_motion_needs():
    """The ladder's new rungs: a probe whose cubic load errs beyond the bound asks for the exact load,
    one whose phi leaves the curves' range asks for curves that hold there; none asks for nothing."""
    from autocable.model.aero import CUBIC_RTOL
    from autocable.studies.advise import _load_reasons
    quiet = {"phi_swept_deg": 3.0, "twist_max_deg": 2.0, "cubic_load_error": 1e-4, "beyond_curves": [],
             "beyond_cubic": []}
    assert _load_reasons(quiet) == []
    loud = dict(quiet, cubic_load_error=2 * CUBIC_RTOL, beyond_cubic=[0.01], phi_swept_deg=80.0,
                beyond_curves=[0.01, 0.02])
    reasons = _load_reasons(loud)
    assert len(reasons) == 2
    assert 'aero.load = "exact"' in reasons[0] and "+0.0100" in reasons[0]
    assert "valid range" in reasons[1] and "+-80 deg" in reasons[1]


@pytest.mark.slow
def test_advise_measures_the_probes_validity():
    """Fig. 7's probes (U* = 0.7, small responses): measured, inside the curves' range, no load rung."""
    from autocable.studies.advise import choose_ame
    advice = choose_ame(REPO / "runs" / "fig07.toml", tools=None)
    v = advice.evidence["validity"]
    assert 0.0 < v["phi_swept_deg"] < 15.0 and v["beyond_curves"] == [] and v["beyond_cubic"] == []
    assert not any("aero.load" in r for r in advice.reasons)
