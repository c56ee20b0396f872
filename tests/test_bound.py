"""The bound stage of `autocable calibrate` (autocable.paper.bound): an upper bound on the
statements each candidate can show, from its wind scenes run one at a time, and the goal it is
measured against (the targets file's [goal])."""
from __future__ import annotations

import json
from pathlib import Path

import pytest

from autocable.paper import bound as bd
from autocable.paper import targets as tg
from autocable.spec import load_model

SAMPLE = "models/luongo_zulli_2012.toml"
TARGETS = "models/luongo_zulli_2012.targets.toml"
GOAL = tg.Goal(40, 0.8, ("fig08", "fig10"))


# ------------------------------------------------------------------------------------------------
# the goal as data
# ------------------------------------------------------------------------------------------------
def test_the_papers_goal_is_read_from_the_targets_file():
    assert tg.load_goal(TARGETS) == GOAL
    assert len(tg.load_targets(TARGETS)) == 58          # the [goal] table is not a target


@pytest.mark.parametrize("table, field", [
    ({"statements_yes": -1, "boxes_share": 0.8, "boxes_scenes": ["fig08"]}, "goal.statements_yes"),
    ({"statements_yes": 40, "boxes_share": 1.5, "boxes_scenes": ["fig08"]}, "goal.boxes_share"),
    ({"statements_yes": 40, "boxes_share": 0.8, "boxes_scenes": "fig08"}, "goal.boxes_scenes"),
    ({"statements_yes": 40, "boxes_share": 0.8}, "goal.boxes_scenes"),
    ({"statements_yes": 40, "boxes_share": 0.8, "boxes_scenes": [], "share": 1}, "goal.share"),
])
def test_a_bad_goal_is_one_line_naming_the_file_and_field(tmp_path, table, field):
    path = tmp_path / "bad.targets.toml"
    body = "\n".join(f"{k} = {json.dumps(v)}" for k, v in table.items())
    head, tail = Path(TARGETS).read_text().split("[goal]")
    path.write_text(head + "[goal]\n" + body + "\n\n[[statement]]" + tail.split("[[statement]]", 1)[1])
    with pytest.raises(tg.TargetsError) as err:
        tg.load_goal(path)
    msg = str(err.value)
    assert "\n" not in msg and "bad.targets.toml" in msg and field in msg


# ------------------------------------------------------------------------------------------------
# the bound, on cases with a known answer
# ------------------------------------------------------------------------------------------------
IDS = ["fig03.galloping", "fig03.boxes", "fig09.homoclinic", "fig08.boxes", "fig09.a2_small", "fig06.island_ii",
       "fig11.same_motion", "fig10.periodic_p"]


def test_the_statements_the_paper_does_not_print_are_read_from_the_targets_file():
    """The targets file marks Fig. 11's eq. (21) statements as autocable's checks (the paper's
    Fig. 11 shows the AME alone) and the P statements as beyond Sect. 5; with Fig. 3's boxes (a
    measurement limit) these are exactly the statements the bound never uses."""
    unused = bd.not_used_to_prune(tg.load_targets(TARGETS))
    assert sorted(unused) == ["fig03.boxes", "fig08.periodic_p", "fig10.periodic_p", "fig11.envelope21",
                              "fig11.same_motion"]
    assert unused["fig11.same_motion"] == tg.SOURCES["check"] and unused["fig10.periodic_p"] == tg.SOURCES["beyond"]


def test_bound_counts_undecided_as_yes_and_only_usable_decisions_lower_it():
    capped = {"fig06.island_ii"}
    unused = bd.not_used_to_prune(tg.load_targets(TARGETS))
    # nothing decided: every statement but the capped one may still be yes
    assert bd.bound_of({}, IDS, capped, unused) == (7, [])
    v = {"fig03.galloping": {"shown": "partly"}, "fig03.boxes": {"shown": "partly"},
         "fig09.homoclinic": {"shown": "no"}, "fig08.boxes": {"shown": "yes"}, "fig09.a2_small": {"shown": "no"},
         "fig06.island_ii": {"shown": "partly"}, "fig11.same_motion": {"shown": "no"},
         "fig10.periodic_p": {"shown": "no"}}
    # never used: fig03.boxes (a measurement limit), Fig. 11's eq. (21) check and P (not printed);
    # the capped one is out of the count
    assert bd.bound_of(v, IDS, capped, unused) == (4, ["fig03.galloping", "fig09.homoclinic", "fig09.a2_small"])
    # with nothing marked unused, every decided "not yes" lowers it
    assert bd.bound_of(v, IDS, capped, {}) == (1, ["fig03.galloping", "fig03.boxes", "fig09.homoclinic",
                                                   "fig09.a2_small", "fig11.same_motion", "fig10.periodic_p"])
    # a dropped orbit run: the cycle statement of that scene no longer lowers the bound
    assert bd.bound_of(v, IDS, capped, {}, dropped=["fig10: run[2] (no periodic orbit)"])[0] == 2
    # a failed scene: none of its statements does
    assert bd.bound_of(v, IDS, capped, unused, failed={"fig09"}) == (6, ["fig03.galloping"])


def test_the_orbit_runs_a_bound_need_not_pay_for(tmp_path):
    """Figs. 8 and 10 start their cycle branch P from an integrated orbit; it decides periodic_p
    only, which the targets file marks beyond Sect. 5: the bound stage drops that run."""
    from autocable.paper import calibration as cal
    from autocable.spec import read_toml
    for n in ("fig08", "fig10"):
        copy = tmp_path / f"{n}.toml"
        copy.write_text((Path("runs") / f"{n}.toml").read_text())
        ks = bd.orbit_runs(copy)
        names = [r["name"] for r in read_toml(copy)[0]["run"]]
        assert [names[k] for k in ks] == ["P"]
        assert cal._drop_run(copy, ks[0]) and bd.orbit_runs(copy) == []
        assert [r["name"] for r in read_toml(copy)[0]["run"]] == [x for x in names if x != "P"]
    assert bd.orbit_runs(Path("runs") / "fig03.toml") == []


def test_boxes_short_of_the_goal_share():
    box = {"points": 22, "within": 0, "at_rest": 0}
    assert bd.boxes_short({"fig08": dict(box, within=22)}, GOAL) is None          # fig10 not run yet
    # 36 of 44 is 81.8 %: enough; 35 of 44 is 79.5 %: short; at rest in both counts as agreement
    assert bd.boxes_short({"fig08": dict(box, within=22), "fig10": dict(box, within=14)}, GOAL) is False
    assert bd.boxes_short({"fig08": dict(box, within=22), "fig10": dict(box, within=13)}, GOAL) is True
    assert bd.boxes_short({"fig08": dict(box, within=20, at_rest=2), "fig10": dict(box, within=14)}, GOAL) is False


# ------------------------------------------------------------------------------------------------
# the stage, end to end on two candidates and one wind scene
# ------------------------------------------------------------------------------------------------
@pytest.mark.slow
def test_bound_stage_stops_resumes_and_agrees_with_the_report(tmp_path):
    """Two candidates (the sample's readings at two yaws), the wind scene fig03 only, goal 46 of 48:
    the bound is 46 less the fig03 and no-wind statements the report's code decides other than yes
    (fig03.boxes and the capped ones excepted), and such a statement stops the candidate. A rerun
    reads every record (counted); a candidate whose record was lost reuses its finished scene folder
    (no scene run, counted)."""
    from autocable.paper import calibration as cal
    from autocable.paper.figures import run_figures
    from autocable.paper.report import load_scene_data
    root = Path.cwd()
    runs = root / "runs"
    targets = tg.load_targets(TARGETS)
    ref = tmp_path / "ref"
    outs = run_figures([runs / f"{n}.toml" for n in bd.NO_WIND], ref, jobs=2)
    assert all(o.status == "ok" for o in outs)
    spec = load_model(SAMPLE)
    cands = []
    for beta in (0.0, 5.0):
        r = cal.Readings("restrained", "reference", "reversed", "diameter", 1.25)
        roots, _ = cal.theta0_roots(cal.candidate_spec(spec, r, beta, None))
        cands.append({"readings": cal.asdict(r), "yaw_deg": beta, "rivulet_angle_deg": min(roots, key=abs),
                      "ordering": "paper", "verdicts": {}})
    capped = {"fig06.island_ii", "fig06.boxes"}
    says = []
    strict = tg.Goal(46, 0.8, ("fig08", "fig10"))
    # a spent time budget: nothing started, both reported not bounded with the no-wind bound, nothing stored
    none = bd.run_bound(Path(SAMPLE).resolve(), targets, strict, cands, [], tmp_path / "a", runs, ref, capped, 2,
                        says.append, order=("fig03",), minutes=0.0)
    assert [r["status"] for r in none] == [bd.NOT_BOUNDED] * 2 and all(r["scenes_run"] == [] for r in none)
    assert not list((tmp_path / "a").rglob("bound.json")) and "time budget of 0 min is spent" in says[-1]
    assert bd.summary(none, strict)["not_bounded"] == [r["name"] for r in none]
    recs = bd.run_bound(Path(SAMPLE).resolve(), targets, strict, cands, [], tmp_path / "a", runs, ref, capped, 2,
                        says.append, order=("fig03",))
    assert len(recs) == 2 and says[0].startswith("bound: 2 candidate models")
    assert all(r["bound"] <= n["bound"] for r, n in zip(sorted(recs, key=lambda r: r["name"]),
                                                         sorted(none, key=lambda r: r["name"])))
    for r in recs:
        # fig03.galloping and fig03.trivial are decided; the bound can only go down from 46
        folder = tmp_path / "a" / "bound" / r["name"]
        data = {"fig03": load_scene_data(folder / "out" / "fig03")}
        data.update({n: load_scene_data(ref / n) for n in bd.NO_WIND})
        ver = {v.id: v.shown for v in tg.decide_statements(targets, data) if v.id.split(".")[0] in ("fig03",) + bd.NO_WIND}
        not_yes = [k for k, s in ver.items() if s != "yes" and k not in capped
                   and k not in bd.not_used_to_prune(targets)]
        assert r["bound"] == 46 - len(not_yes) and sorted(r["lowered_by"]) == sorted(not_yes)
        assert r["status"] == ("stopped: statements" if not_yes else "every scene run")
        assert r["scenes_run"] == ["fig03"] and r["computed_scenes"] == 1
        # fig03's overlay decides fig03.boxes only, which never lowers a bound: not run
        assert "[overlay]" not in (folder / "runs" / "fig03.toml").read_text()
        assert any(d.startswith("fig03: overlay (not run") for d in r["dropped_runs"])
        assert not (folder / "out" / "fig03" / "overlay.csv").exists()
    # a rerun reads the records: nothing computed
    again = bd.run_bound(Path(SAMPLE).resolve(), targets, strict, cands, [], tmp_path / "a", runs, ref, capped, 2,
                         says.append, order=("fig03",))
    assert [r["bound"] for r in again] == [r["bound"] for r in recs]
    assert says[-1].endswith("2 already on disk, 0 to bound (0 of them stored under another rule: decided "
                             "again, their finished scenes reused); goal 46 statements, boxes >= 80% of fig08, fig10")
    # a record made under another rule (here: a stamp that is not this rule's) is decided again
    # from its finished scene folder, with no scene rerun
    other = tmp_path / "a" / "bound" / recs[1]["name"] / "bound.json"
    stale = json.loads(other.read_text())
    assert stale["rule"] == bd.rule_of([t.id for t in targets if t.kind == "statement"], capped,
                                       bd.not_used_to_prune(targets), strict)
    other.write_text(json.dumps(dict(stale, rule="another", bound=0)))
    bd.run_bound(Path(SAMPLE).resolve(), targets, strict, cands, [], tmp_path / "a", runs, ref, capped, 2,
                 says.append, order=("fig03",))
    header = next(m for m in reversed(says) if m.startswith("bound: "))
    assert "1 already on disk, 1 to bound (1 of them stored under another rule" in header
    fresh = json.loads(other.read_text())
    assert fresh["computed_scenes"] == 0 and fresh["bound"] == recs[1]["bound"] and fresh["rule"] == stale["rule"]
    # the scene time is the scene's own record (run.json), the same whether computed or reused
    assert fresh["scene_s"] > 0 and fresh["scene_s"] == stale["scene_s"]
    # a margin is part of the rule: with a margin larger than the goal no statement stops a candidate,
    # so both run every scene of the order (here fig03, reused: nothing computed) with the same bounds
    wide = bd.run_bound(Path(SAMPLE).resolve(), targets, strict, cands, [], tmp_path / "a", runs, ref, capped, 2,
                        says.append, order=("fig03",), margin=47)
    assert "2 to bound (2 of them stored under another rule" in next(m for m in reversed(says) if m.startswith("bound: "))
    assert sorted((r["bound"], r["status"], r["computed_scenes"]) for r in wide) == sorted(
        (r["bound"], "every scene run", 0) for r in recs)
    # a lost record: the candidate is bounded again from its finished scene folder, no scene rerun
    lost = tmp_path / "a" / "bound" / recs[0]["name"] / "bound.json"
    lost.unlink()
    third = bd.run_bound(Path(SAMPLE).resolve(), targets, strict, cands, [], tmp_path / "a", runs, ref, capped, 2,
                         says.append, order=("fig03",))
    redone = json.loads(lost.read_text())
    assert redone["computed_scenes"] == 0 and redone["bound"] == recs[0]["bound"]
    assert len(third) == 2


def test_bound_refuses_a_targets_file_with_scenes_it_does_not_run(tmp_path):
    """A statement of a scene the stage neither runs nor takes from the no-wind reference: one line
    naming the targets file and the field, before any work (no traceback from the scheduler)."""
    from autocable.paper import calibration as cal
    bad = tmp_path / "other.targets.toml"
    bad.write_text(Path(TARGETS).read_text().replace('scene = "fig11"', 'scene = "fig12"', 1))
    assert bd.unknown_scenes(tg.load_targets(bad)) == ["fig12"]
    with pytest.raises(tg.TargetsError) as err:
        cal.calibrate(SAMPLE, bad, tmp_path / "out", bound=True, quiet=True)
    msg = str(err.value)
    assert "\n" not in msg and "other.targets.toml" in msg and "statement.scene" in msg and "fig12" in msg


def test_the_markdown_says_what_the_conclusion_rests_on():
    """Four records with a known answer (goal 40): without s1, model A (39, lowered by s1) would
    reach the goal, so one model rests on s1; without s2 none does (B drops to 39 only, C is short
    of its boxes whatever its statements). The screen's table counts the models each lowered."""
    def rec(name, b, lowered, status="stopped: statements", short=None, screen=()):
        return {"name": name, "readings": {"twist_ends": "natural", "load_axes": "reference",
                                           "angle_convention": "reversed", "load_length": "diameter"},
                "bound": b, "status": status, "lowered_by": list(lowered), "scenes_run": ["fig03"],
                "boxes_good": 0, "boxes_points": 0, "boxes_short": short, "reaches_goal": False,
                "wall_s": 1.0, "scene_s": 2.0, "computed_scenes": 1, "screen_not_met": list(screen)}
    records = [rec("A", 39, ["s1"], screen=["U_c"]), rec("B", 38, ["s1", "s2"], screen=["U_c", "supercritical"]),
               rec("C", 39, ["s2"], "stopped: boxes", True), rec("D", 30, ["s1"])]
    text = "\n".join(bd.markdown(records, tg.Goal(40, 0.8, ("fig08", "fig10")), 42, 48, 60.0, 2, None, "b.csv",
                                 {"fig03.boxes": "a limit"}, margin=0))
    assert "Not counting **s1** (it lowered the most bounds), 1 candidate models" in text
    assert "not counting any one statement, at most 1 (s1)." in text
    assert "| s1 | 3 | 2 | U_c 2, supercritical 1 |" in text and "| s2 | 2 | 1 | U_c 1, supercritical 1 |" in text
    assert "4 bounded in this stage with 4 scenes decided (1.00 per model; 0.0 h" in text
    assert "4 of the scenes were computed by the calls that wrote the records" in text


def test_prior_bound_records_round_trip_and_merge(tmp_path):
    """An earlier call's bound.csv read back equals what was written (every column; a file of the
    version before the ``rule`` column reads with the rule empty), joins a new call's records only
    for the screen points (reading and yaw) that call did not decide, and the markdown says how many
    records came from it. A file that is not a bound.csv is one line naming the file."""
    import csv

    from autocable.spec import SpecError
    published = Path(__file__).resolve().parents[1] / "docs" / "calibration" / "bound.csv"
    prior = bd.read_csv(published)
    assert len(prior) == len(published.read_text().splitlines()) - 1 > 0
    again = tmp_path / "again.csv"
    bd.write_csv(prior, again)
    old_rows, new_rows = (list(csv.DictReader(open(f, newline=""))) for f in (published, again))
    assert [{k: v for k, v in r.items() if k in old_rows[0]} for r in new_rows] == old_rows
    assert all(r["rule"] == (o.get("rule") or "") for r, o in zip(new_rows, old_rows))
    assert bd.read_csv(again) == prior
    # a new call deciding one screen point the prior file also has: that point's records are not
    # taken from it, the other yaws of the same reading are
    taken = dict(prior[0]["readings"])
    mine = [dict(prior[0], name="new", prior=False, bound=20)]
    merged = bd.merge_prior(mine, prior)
    point = [r for r in prior if r["readings"] == taken and r["yaw_deg"] == prior[0]["yaw_deg"]]
    assert 0 < len(point) < sum(r["readings"] == taken for r in prior)
    assert len(merged) == 1 + len(prior) - len(point)
    assert not any(r["readings"] == taken and r["yaw_deg"] == prior[0]["yaw_deg"] for r in merged if r.get("prior"))
    assert any(r["readings"] == taken for r in merged if r.get("prior"))
    goal = tg.Goal(statements_yes=40, boxes_share=0.8, boxes_scenes=("fig08", "fig10"))
    lines = bd.markdown(merged, goal, 42, 48, 1.0, 2, None, "bound.csv", {})
    assert any(f"{len(merged) - 1} of the {len(merged)} records" in x for x in lines)
    bad = tmp_path / "bad.csv"
    bad.write_text("name,bound\nx,3\n")
    with pytest.raises(SpecError) as err:
        bd.read_csv(bad)
    assert "bad.csv" in str(err.value) and "\n" not in str(err.value)


def test_study_bound_is_part_of_the_rule_and_prior_records_of_another_rule_are_checked():
    """The AME-vs-(21) study's bounds decide the boxes: a change of them is a new rule (a stored
    record is decided again). Records read from an earlier file under another rule are checked for
    what a looser study bound could change: a bound that every boxes statement turned yes would lift
    to the goal, or a stop by the boxes, must be decided again; the markdown names them."""
    from autocable.studies.ame_bounds import STUDY_MAX_ERROR
    goal = tg.Goal(statements_yes=40, boxes_share=0.8, boxes_scenes=("fig08", "fig10"))
    base = bd.rule_of(["a.x"], set(), {}, goal)
    assert base == bd.rule_of(["a.x"], set(), {}, goal, study=dict(STUDY_MAX_ERROR))
    assert base != bd.rule_of(["a.x"], set(), {}, goal, study={**STUDY_MAX_ERROR, 1.4e-3: 0.265})

    def rec(name, b, lowered, status="stopped: statements", rule=""):
        return {"name": name, "readings": {"twist_ends": "natural", "load_axes": "reference",
                                           "angle_convention": "reversed", "load_length": "diameter"},
                "yaw_deg": 0.0, "bound": b, "status": status, "lowered_by": list(lowered), "scenes_run": ["fig03"],
                "boxes_good": 0, "boxes_points": 0, "boxes_short": status == "stopped: boxes",
                "reaches_goal": False, "wall_s": 1.0, "scene_s": 2.0, "computed_scenes": 0,
                "screen_not_met": [], "prior": True, "rule": rule}
    lifts = rec("lifts", 38, ["fig08.boxes", "fig10.boxes", "fig03.trivial"])    # 38 + 2 = 40
    short = rec("short", 37, ["fig08.boxes", "fig03.trivial", "fig11.x"])         # 37 + 1 = 38 < 40
    boxes = rec("boxes", 36, ["fig03.trivial"], "stopped: boxes")
    same = rec("same-rule", 39, ["fig08.boxes"], rule="R")                          # this call's rule: not read again
    assert [bd.boxes_could_lift(r, goal) for r in (lifts, short, boxes)] == [True, False, True]
    text = "\n".join(bd.markdown([lifts, short, boxes, same], goal, 42, 48, 1.0, 2, None, "b.csv", {}, rule="R"))
    assert "3 of the read records were decided under another rule" in text
    assert "2 of them could then reach the goal (lifts, boxes) and must be decided again." in text
    text = "\n".join(bd.markdown([short, same], goal, 42, 48, 1.0, 2, None, "b.csv", {}, rule="R"))
    assert "1 of the read records were decided under another rule" in text and "none of them could then" in text


@pytest.mark.slow
def test_fig03_statements_other_than_boxes_are_decided_without_the_overlay(tmp_path):
    """The bound drops Fig. 3's eq. (21) overlay (`run_bound`, ``skip_overlay``): fig03's statements
    other than fig03.boxes must be decided the same from the scene without its overlay as with it
    (the sample's Fig. 3, run both ways)."""
    from autocable.paper.candidates import _drop_table
    from autocable.paper.figures import run_figures
    from autocable.paper.report import load_scene_data
    runs = Path.cwd() / "runs"
    targets = [t for t in tg.load_targets(TARGETS) if t.kind == "statement" and t.scene == "fig03"]
    (tmp_path / "runs").mkdir()
    bare = tmp_path / "runs" / "fig03.toml"
    bare.write_text((runs / "fig03.toml").read_text().replace('model = "../models/', f'model = "{runs.parent}/models/'))
    assert _drop_table(bare, "overlay") and "[overlay]" not in bare.read_text()
    assert not _drop_table(bare, "overlay")                     # nothing left to drop
    full = run_figures([runs / "fig03.toml"], tmp_path / "full", workers=0)
    without = run_figures([bare], tmp_path / "bare", workers=0)
    assert full[0].status == without[0].status == "ok"
    a = {v.id: v.shown for v in tg.decide_statements(targets, {"fig03": load_scene_data(tmp_path / "full" / "fig03")})}
    b = {v.id: v.shown for v in tg.decide_statements(targets, {"fig03": load_scene_data(tmp_path / "bare" / "fig03")})}
    assert set(a) == set(b) == {"fig03.galloping", "fig03.trivial", "fig03.boxes"}
    assert {k: v for k, v in a.items() if k != "fig03.boxes"} == {k: v for k, v in b.items() if k != "fig03.boxes"}
    assert a["fig03.galloping"] == "yes"                        # the sample's Fig. 3 (a real decision)


def test_switch_off_sets_a_key_of_one_table_only(tmp_path):
    """`candidates._switch_off`: ``key = false`` in the named table (replacing a true value with its
    comment, or added where absent and true by default), nothing elsewhere; False when already off."""
    from autocable.paper.candidates import _switch_off
    from autocable.spec import read_toml
    path = tmp_path / "s.toml"
    path.write_text('title = "x"\n\n[time]\nU = 1.3\node21 = true    # a comment\n\n[plot]\node21 = true\n')
    assert _switch_off(path, "time", "ode21")
    data, _ = read_toml(path)
    assert data["time"] == {"U": 1.3, "ode21": False} and data["plot"] == {"ode21": True}
    assert not _switch_off(path, "time", "ode21") and not _switch_off(path, "overlay", "ode21")
    path.write_text("[time]\nU = 1.3\n")
    assert _switch_off(path, "time", "ode21") and read_toml(path)[0]["time"] == {"ode21": False, "U": 1.3}


@pytest.mark.slow
def test_fig11_ame_statement_is_decided_without_the_ode21_series(tmp_path):
    """The bound drops Fig. 11's eq. (21) series (`run_bound`, ``skip_ode21``): it decides only
    fig11.envelope21 and fig11.same_motion, autocable's own checks that never lower a bound; the
    statement of the paper's Fig. 11, fig11.ame_periodic, must be decided the same without it (the
    sample's Fig. 11, run both ways)."""
    from autocable.paper.figures import run_figures
    from autocable.paper.report import load_scene_data
    runs = Path.cwd() / "runs"
    targets = tg.load_targets(TARGETS)
    unused = bd.not_used_to_prune(targets)
    assert all(f"fig11.{x}" in unused for x in bd.IF_NO_ODE21)
    fig11 = [t for t in targets if t.kind == "statement" and t.scene == "fig11"]
    (tmp_path / "runs").mkdir()
    bare = tmp_path / "runs" / "fig11.toml"
    notes = bd.scene_copy(runs / "fig11.toml", bare, (runs.parent / SAMPLE).resolve(), drop_orbits=True,
                          drop_overlay=True, drop_ode21=True)
    assert notes == ["fig11: ode21"]
    full = run_figures([runs / "fig11.toml"], tmp_path / "full", workers=0)
    without = run_figures([bare], tmp_path / "bare", workers=0)
    assert full[0].status == without[0].status == "ok"
    a = {v.id: v for v in tg.decide_statements(fig11, {"fig11": load_scene_data(tmp_path / "full" / "fig11")})}
    b = {v.id: v for v in tg.decide_statements(fig11, {"fig11": load_scene_data(tmp_path / "bare" / "fig11")})}
    assert a["fig11.ame_periodic"].shown == b["fig11.ame_periodic"].shown == "yes"   # the sample's Fig. 11
    assert a["fig11.ame_periodic"].evidence == b["fig11.ame_periodic"].evidence
    assert "ode21" not in {r.get("source") for r in load_scene_data(tmp_path / "bare" / "fig11").series}


@pytest.mark.slow
def test_a_deferred_overlay_runs_only_when_its_boxes_can_change_the_outcome(tmp_path):
    """Fig. 8 on the sample's candidate, goal boxes of fig08 alone. A goal the branches' statements
    cannot settle: the scene runs without its overlay, then again with it (two runs), and the boxes
    are decided. A goal one above the bound the branches leave: one run, no overlay, the boxes
    counted yes (the bound one higher than with them if they lowered it). The same folder under the
    lower goal again: the overlay-less run is reused and only the run with the overlay computed,
    giving the first call's bound and boxes."""
    from autocable.paper import calibration as cal
    from autocable.paper.figures import run_figures
    runs = Path.cwd() / "runs"
    targets = tg.load_targets(TARGETS)
    ref = tmp_path / "ref"
    assert all(o.status == "ok" for o in run_figures([runs / f"{n}.toml" for n in bd.NO_WIND], ref, workers=2))
    spec = load_model(SAMPLE)
    a = spec.aero
    r = cal.Readings(spec.cable.twist_ends, a.load_axes, a.angle_convention, a.load_length, a.air_density_kg_m3)
    roots, _ = cal.theta0_roots(cal.candidate_spec(spec, r, a.yaw_deg, None))
    cands = [{"readings": cal.asdict(r), "yaw_deg": a.yaw_deg, "rivulet_angle_deg": min(roots, key=abs),
              "ordering": "paper", "verdicts": {}}]
    capped = {"fig06.island_ii", "fig06.boxes"}
    model = Path(SAMPLE).resolve()

    def bound(goal_yes, folder):
        recs = bd.run_bound(model, targets, tg.Goal(goal_yes, 0.8, ("fig08",)), cands, [], folder, runs, ref,
                            capped, 2, lambda m: None, order=("fig08",))
        (rec,) = recs
        return rec, tmp_path / folder / "bound" / rec["name"]

    first, fa = bound(1, tmp_path / "a")
    assert first["computed_scenes"] == 2 and first["scenes_run"] == ["fig08"]
    assert (fa / "out" / "fig08" / "overlay.csv").is_file() and "[overlay]" in (fa / "runs" / "fig08.toml").read_text()
    assert first["boxes"]["fig08"]["points"] == 22 and not any("deferred" in d for d in first["dropped_runs"])
    boxes_lowered = "fig08.boxes" in first["lowered_by"]
    branches_bound = first["bound"] + boxes_lowered
    # the scene time counts both runs: the one without the overlay (kept before the rerun) and the rerun
    assert first["scene_s"] > bd.scene_seconds(fa / "out", ["fig08"]) > 0

    second, fb = bound(branches_bound + 1, tmp_path / "b")
    assert second["computed_scenes"] == 1 and second["status"] == "stopped: statements"
    assert second["bound"] == branches_bound and "fig08.boxes" not in second["lowered_by"]
    assert not (fb / "out" / "fig08" / "overlay.csv").exists() and "fig08" not in second["boxes"]
    assert any(d.startswith("fig08: overlay (deferred") for d in second["dropped_runs"])
    assert sorted(second["lowered_by"]) == sorted(x for x in first["lowered_by"] if x != "fig08.boxes")

    third, _ = bound(1, tmp_path / "b")
    assert third["computed_scenes"] == 1 and (fb / "out" / "fig08" / "overlay.csv").is_file()
    assert (third["bound"], third["boxes"], sorted(third["lowered_by"])) == (
        first["bound"], first["boxes"], sorted(first["lowered_by"]))
    assert not any("deferred" in d for d in third["dropped_runs"])


def test_candidate_scene_copies_find_their_model_from_a_relative_folder(tmp_path, monkeypatch):
    """A calibration run with a relative --out (``--out cal``) wrote the cwd-relative model path into
    its candidates' scene files, which resolve the model from their own folder: every full
    evaluation failed with "model: no such file". The copies now name the model relative to
    themselves (`candidates.scene_on_model`), for the bound stage's copies and the full
    evaluations' alike, and still find it after the folder is moved."""
    from autocable.paper import candidates as cm
    from autocable.scene.schema import load_scene
    repo = Path.cwd()
    monkeypatch.chdir(tmp_path)
    model = Path("cal/cand/model.toml")
    model.parent.mkdir(parents=True)
    model.write_text((repo / SAMPLE).read_text())
    copy = Path("cal/cand/runs/fig03.toml")
    copy.parent.mkdir()
    bd.scene_copy(repo / "runs" / "fig03.toml", copy, model, False, False)
    assert Path(load_scene(copy).model).resolve() == model.resolve()
    full = Path("cal/cand/runs/fig05a.toml")
    full.write_text(cm.scene_on_model((repo / "runs" / "fig05a.toml").read_text(), model, full.parent))
    assert Path(load_scene(full).model).resolve() == model.resolve()
    Path("cal").rename("moved")
    for name in ("fig03", "fig05a"):
        scene = load_scene(Path("moved/cand/runs") / f"{name}.toml")
        assert Path(scene.model).resolve() == (tmp_path / "moved/cand/model.toml").resolve()
        load_model(scene.model)
