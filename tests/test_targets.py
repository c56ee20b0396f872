"""The targets of Sect. 5 as data: the file, its validation, and each kind of decision on
a small case with a known answer."""
from __future__ import annotations

import math
from pathlib import Path

import pytest

from autocable.model.equations import Term, TwoModeODE
from autocable.paper import targets as tg
from autocable.paper.report import SceneData

TARGETS = Path("models/luongo_zulli_2012.targets.toml")


def test_the_paper_targets_file():
    """Every statement report.md checks (48), the three printed numbers and the screen's targets."""
    ts = tg.load_targets(TARGETS)
    kinds = [t.kind for t in ts]
    assert kinds.count("statement") == 48
    assert {t.id: t.value for t in ts if t.kind == "number"} == {"U_c": 1.0, "omega1": 1.004, "rho": -0.004}
    screen = {t.id for t in ts if t.kind == "screen"}
    assert {"supercritical", "onset_21", "bounded_fig08", "bounded_fig10", "a2_ratio_ame"} <= screen
    scenes = {t.scene for t in ts if t.kind == "statement"}
    assert scenes == {"fig03", "fig04a", "fig04b", "fig04c", "fig05a", "fig05b", "fig06", "fig07", "fig08",
                      "fig09", "fig10", "fig11"}


@pytest.mark.parametrize("text,field", [
    ('[[number]]\nid = "x"\nsays = "s"\nquantity = "omega9"\nvalue = 1.0\ntolerance = 0.1\n', "number[0].quantity"),
    ('[[screen]]\nid = "x"\nsays = "s"\nquantity = "zeta8"\nop = "=="\nthreshold = 0.0\n', "screen[0].op"),
    ('[[screen]]\nid = "x"\nsays = "s"\nquantity = "bounded_fraction"\nop = ">"\nthreshold = 0.5\n', "screen[0].points"),
    ('[[number]]\nid = "x"\nsays = "s"\nquantity = "rho"\nvalue = "a"\ntolerance = 0.1\n', "number[0].value"),
    ('[[statement]]\nid = "x"\nscene = "fig03"\nsays = "s"\nquantity = "q"\n', "statement[0].threshold"),
    ('[[statment]]\nid = "x"\n', "statment"),
    ('[[statement]]\nid = "x"\nscene = "fig03"\nsays = "s"\nquantity = "q"\nthreshold = "t"\nsource = "printed"\n',
     "statement[0].source"),
    ('[[number]]\nid = "x"\nsays = "s"\nquantity = "rho"\nvalue = 1.0\ntolerance = 0.1\n'
     '[[number]]\nid = "x"\nsays = "s"\nquantity = "rho"\nvalue = 1.0\ntolerance = 0.1\n', "number[1].id"),
])
def test_bad_targets_file_is_one_line(tmp_path, text, field):
    path = tmp_path / "t.toml"
    path.write_text(text)
    with pytest.raises(tg.TargetsError) as err:
        tg.load_targets(path)
    msg = str(err.value)
    assert "\n" not in msg and str(path) in msg and field in msg


def test_missing_targets_file_is_one_line(tmp_path):
    with pytest.raises(tg.TargetsError) as err:
        tg.load_targets(tmp_path / "none.toml")
    assert "no such file" in str(err.value) and "\n" not in str(err.value)


def test_number_and_screen_decisions():
    num = tg.Target(id="omega1", kind="number", says="", quantity="omega1", value=1.004, tolerance=5e-4)
    assert tg.decide_number(num, 1.0040053).shown == "yes"
    assert tg.decide_number(num, 1.00006).shown == "no"         # the printed EA's omega1 (docs/model.md, M1)
    assert tg.decide_number(num, math.nan).shown == "no"
    scr = tg.Target(id="s", kind="screen", says="", quantity="zeta8", op=">", threshold=0.0)
    assert tg.decide_screen(scr, 9.4).shown == "yes"
    assert tg.decide_screen(scr, -0.3).shown == "no"
    assert tg.decide_screen(scr, 0.0).shown == "no"
    assert tg.decide_screen(scr, math.nan).shown == "no"


def _galloping_ode(c: float, xi: float = 0.004, omega1: float = 1.004, out_of_plane: float = 0.0):
    """q1'' + (2 xi omega1 - c U) q1' + omega1^2 q1 = 0, q2'' + (2 xi - out_of_plane U) q2' + q2 = 0:
    the trivial solution loses stability at U = 2 xi omega1 / c (in plane) or 2 xi / out_of_plane."""
    terms = (Term(1, (1, 0, 0, 0), (0, 0, 0), 0, omega1**2, "linear"),
             Term(1, (0, 0, 1, 0), (0, 0, 0), 0, 2 * xi * omega1, "damping"),
             Term(1, (0, 0, 1, 0), (0, 0, 0), 1, -c, "aerodynamic", "zeta11"),
             Term(2, (0, 1, 0, 0), (0, 0, 0), 0, 1.0, "linear"),
             Term(2, (0, 0, 0, 1), (0, 0, 0), 0, 2 * xi, "damping"),
             Term(2, (0, 0, 0, 1), (0, 0, 0), 1, -out_of_plane, "aerodynamic", "xi21"))
    return TwoModeODE(terms=terms, omega1=omega1, omega2=1.0, xi_s=xi)


def test_onset_speed_closed_form():
    """The onset of eq. (21) at eta = 0 where zeta11 U cancels the structural damping 2 xi omega1
    (uncoupled modes: the mono-modal and the two-mode onsets coincide)."""
    ode = _galloping_ode(c=2 * 0.004 * 1.004 / 1.25)
    U, mode = tg.onset_speed(ode)
    assert U == pytest.approx(1.25, abs=1e-10) and mode == "in-plane"
    nums = tg.ode_numbers(ode)
    assert nums["U_onset"] == pytest.approx(1.25, abs=1e-10)
    assert nums["rho"] == pytest.approx(-0.004, abs=1e-15)
    assert tg.onset_error_21(ode) == pytest.approx(0.25, abs=1e-10)
    # an out-of-plane onset first: eq. (21)'s onset is not the in-plane galloping of Fig. 3, while
    # the mono-modal onset of eq. (25) (A2 = 0) is still 2 xi omega1 / c
    other = _galloping_ode(c=2 * 0.004 * 1.004 / 1.25, out_of_plane=2 * 0.004 / 0.8)
    assert tg.onset_speed(other)[1] == "out-of-plane"
    assert tg.onset_speed(other)[0] == pytest.approx(0.8, abs=1e-10)
    assert math.isnan(tg.onset_error_21(other))
    assert tg.mono_modal_onset(other) == pytest.approx(1.25, abs=1e-12)


def _scene(name: str, a2_over_a1: float) -> SceneData:
    rows = [{"branch": "I", "kind": "equilibrium", "sigma": str(s), "U": "0", "eta": "8.2e-5",
             "a1": str(a1), "a2": str(a1 * a2_over_a1), "stable": "1"}
            for s, a1 in ((-0.02, 1e-4), (0.0, 3e-4), (0.02, 1e-4))]
    run = {"branches": [{"name": "I", "kind": "equilibrium", "parameter": "sigma", "ends": []}],
           "provenance": {"title": name, "omega1": 1.004005, "omega2": 1.0}}
    return SceneData(name=name, folder=Path("."), status="ok", run=run, rows=rows)


def test_statement_decided_by_the_report_code():
    """A statement is decided by the report's own code: Fig. 5a's "mono-modal only" is yes for a
    planar branch and no when a2 is half of a1; a statement the code does not produce is "no"."""
    ts = tg.load_targets(TARGETS)
    planar = {"fig05a": _scene("fig05a", 0.0)}
    v = {x.id: x for x in tg.decide_statements(ts, planar)}
    assert v["fig05a.mono"].shown == "yes"
    assert v["fig05a.forced"].shown == "yes"
    assert v["fig06.a2_triggered"].shown == "no" and "not run" in v["fig06.a2_triggered"].evidence
    spatial = {"fig05a": _scene("fig05a", 0.5)}
    assert {x.id: x for x in tg.decide_statements(ts, spatial)}["fig05a.mono"].shown == "no"
    # the report's table for that scene and the targets' verdict come from the same call
    feats = tg.scene_statements(spatial["fig05a"], spatial)
    assert [f for f in feats if f[0].startswith("in-plane mono-modal")][0][1] == "no"
    nums = tg.scene_numbers(planar)
    assert nums["omega1"] == 1.004005 and math.isnan(nums["U_onset"])


def _with_hopf(d: SceneData, sigmas) -> SceneData:
    d.specials = [{"branch": "I", "type": "H", "label": f"H{k + 1}", "parameter": "sigma", "sigma": str(s),
                   "origin": "autocable", "a1": "3e-4", "a2": "0"} for k, s in enumerate(sigmas)]
    return d


@pytest.mark.parametrize("ref_hopf", [(), (0.01,)])
@pytest.mark.parametrize("wind_hopf", [(), (-0.01,), (-0.01, 0.02)])
def test_hopf_moved_never_exceeds_its_no_wind_ceiling(ref_hopf, wind_hopf):
    """"Wind moves the Hopf points" is at best "partly" when the no-wind scene has no Hopf point,
    whatever the wind scene shows (the calibration's ceiling rests on this)."""
    from autocable.paper.report import _hopf_moved, hopf_moved_ceiling
    order = {"no": 0, "partly": 1, "yes": 2}
    ref = _with_hopf(_scene("fig05b", 0.0), ref_hopf)
    wind = _with_hopf(_scene("fig07", 0.1), wind_hopf)
    shown = _hopf_moved(wind, ref)[1]
    best = hopf_moved_ceiling(ref)
    assert best == ("yes" if ref_hopf else "partly")
    assert order[shown] <= order[best]
    if ref_hopf and wind_hopf:
        assert shown == "yes"          # the ceiling is reached: it is not a bound that cannot be met
    assert hopf_moved_ceiling(None) == "no"


def test_no_wind_ceiling_caps_the_no_wind_statements():
    """Statements of a no-wind scene keep that scene's verdict for every candidate; "wind moves the
    Hopf points" against a no-wind scene without Hopf points is capped at "partly"."""
    from autocable.paper.calibration import no_wind_ceiling
    ts = tg.load_targets(TARGETS)
    scenes = {"fig05a": _scene("fig05a", 0.5), "fig05b": _scene("fig05b", 0.0)}
    capped = {c["id"]: c for c in no_wind_ceiling(ts, scenes)}
    # fig05a with a2 = a1/2 is not mono-modal: capped at its own verdict "no"
    assert capped["fig05a.mono"]["best"] == "no" and "no-wind scene fig05a" in capped["fig05a.mono"]["why"]
    assert "fig05b.mono" not in capped                           # "yes" is no cap
    assert capped["fig07.hopf_moved"]["best"] == "partly" and capped["fig08.hopf_moved"]["best"] == "partly"
    assert "fig09.hopf_moved" not in capped                      # fig06 not run: nothing known
    scenes["fig05b"] = _with_hopf(scenes["fig05b"], (0.01,))
    assert "fig07.hopf_moved" not in {c["id"] for c in no_wind_ceiling(ts, scenes)}


def _fig03_scene(galloping_a1) -> SceneData:
    """Fig. 3 with the trivial solution below and above U = 1 and a run "galloping" over [1.05, 1.3]
    whose amplitudes are ``galloping_a1(U)``; stability as eq. (25) with a super-critical branch."""
    rows, branches = [], []
    for name, us, stable in (("trivial", (0.5, 0.8, 0.99), "1"), ("trivial-above", (1.01, 1.2, 1.3), "0")):
        rows += [{"branch": name, "kind": "equilibrium", "U": str(u), "sigma": "0", "eta": "0", "a1": "0",
                  "a2": "0", "stable": stable} for u in us]
        branches.append({"name": name, "kind": "equilibrium", "parameter": "U", "ends": []})
    rows += [{"branch": "galloping", "kind": "equilibrium", "U": str(u), "sigma": "0", "eta": "0",
              "a1": repr(galloping_a1(u)), "a2": "0", "stable": "1"} for u in (1.05, 1.1, 1.2, 1.3)]
    branches.append({"name": "galloping", "kind": "equilibrium", "parameter": "U", "ends": []})
    run = {"branches": branches, "provenance": {"title": "fig03", "omega1": 1.004, "omega2": 1.0}}
    return SceneData(name="fig03", folder=Path("."), status="ok", run=run, rows=rows)


def test_fig03_galloping_and_trivial_decided_with_and_without_a_galloping_branch():
    """Eq. (25): a1^2 / U = c (U - 1) is the super-critical branch born at U = 1: both statements
    "yes". A galloping run that settled on rest (a1 ~ 1e-95, the model's onset above the run's
    start) is the trivial solution: galloping "no" (it used to be a "partly" with a fit through
    round-off), and the trivial statement is still decided from every trivial branch (it used to be
    missing, hence "no")."""
    ts = tg.load_targets(TARGETS)
    good = {x.id: x for x in tg.decide_statements(ts, {"fig03": _fig03_scene(lambda u: math.sqrt(0.01 * u * (u - 1)))})}
    assert good["fig03.galloping"].shown == "yes" and "U = 1.000000" in good["fig03.galloping"].evidence
    assert good["fig03.trivial"].shown == "yes"
    rest = {x.id: x for x in tg.decide_statements(ts, {"fig03": _fig03_scene(lambda u: 1e-95)})}
    assert rest["fig03.galloping"].shown == "no"
    assert rest["fig03.galloping"].evidence.startswith("no non-trivial equilibrium branch")
    # the settled-on-rest run is stable above U = 1 in this example: rest is then not "unstable above"
    assert rest["fig03.trivial"].shown == "partly" and "3 of 3 trivial points stable below" in rest["fig03.trivial"].evidence


def test_statements_decided_beyond_the_cubic_expansion():
    """A statement is listed as decided beyond the cubic load's bound exactly when its scene's
    run.json records points past the bound; a scene within it, or without the record, is not listed."""
    ts = tg.load_targets(TARGETS)
    past = _scene("fig05a", 0.0)
    past.run["provenance"]["model_validity"] = {"points_beyond_bound": 3, "points": 40, "cubic_rtol": 0.1,
                                                "largest_cubic_error": 0.4}
    within = _scene("fig05b", 0.0)
    within.run["provenance"]["model_validity"] = {"points_beyond_bound": 0, "points": 40, "cubic_rtol": 0.1,
                                                  "largest_cubic_error": 0.02}
    got = tg.beyond_expansion(ts, {"fig05a": past, "fig05b": within, "fig06": _scene("fig06", 0.0)})
    fig05a = sorted(t.id for t in ts if t.kind == "statement" and t.scene == "fig05a")
    assert sorted(got) == fig05a and fig05a
    assert got[fig05a[0]]["points_beyond_bound"] == 3 and got[fig05a[0]]["largest_cubic_error"] == 0.4
