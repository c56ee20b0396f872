"""`autocable figures` and its report (autocable/paper/figures.py, autocable/paper/report.py): two tiny scenes of
the sample model run in parallel processes next to a broken one; the report's numbers are the
output folders' numbers; the broken scene is reported and makes the exit status non-zero."""
from __future__ import annotations

import csv
import json
import math
import re
from pathlib import Path

import pytest

from autocable.cli import main
from autocable.paper.figures import discover
from autocable.paper.report import STUDY_MAX_ERROR, interpolate_stable, load_scene_data, overlay_comparison
from autocable.spec import SpecError

MODEL = (Path(__file__).resolve().parents[1] / "models" / "luongo_zulli_2012.toml").as_posix()

# The A2 = 0 branch I at U = 0, eta* = 1.4e-3 over a sigma range holding both of its folds.
FOLDS = f"""
title = "tiny: folds of branch I"
model = "{MODEL}"
ame = "1dof"
[fixed]
U = 0.0
eta = 1.4e-3
[[run]]
name = "I"
parameter = "sigma"
range = [-0.2, 0.3]
start = "trivial"
"""
# Branch I of Fig. 5a on a short range below resonance.
SMALL = f"""
title = "tiny: Fig. 5a below resonance"
model = "{MODEL}"
[fixed]
U = 0.0
eta = 8.2e-5
[[run]]
name = "I"
parameter = "sigma"
range = [-0.05, -0.03]
start = "trivial"
"""
BROKEN = f"""
model = "{MODEL}"
[[run]]
name = "I"
parameter = "sigma"
range = [-0.05, 0.05]
strat = "trivial"
"""


@pytest.fixture(scope="module")
def figures(tmp_path_factory):
    runs = tmp_path_factory.mktemp("runs")
    (runs / "figt1.toml").write_text(FOLDS)
    (runs / "figt2.toml").write_text(SMALL)
    (runs / "figt9.toml").write_text(BROKEN)
    (runs / "other.toml").write_text(BROKEN)          # not fig*.toml: not a figure scene
    out = tmp_path_factory.mktemp("figures")
    status = main(["figures", "--out", str(out), "--runs", str(runs), "--workers", "2", "--quiet"])
    return status, out, runs


def _csv(path):
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


@pytest.mark.slow
def test_runner_runs_the_good_scenes_and_reports_the_broken_one(figures):
    status, out, _ = figures
    assert status == 3                                 # one scene failed (docs/robustness.md: exit 3)
    summary = json.loads((out / "figures.json").read_text())
    by = {s["name"]: s for s in summary["scenes"]}
    assert set(by) == {"figt1", "figt2", "figt9"}      # other.toml is not a figure
    assert summary["jobs"] == 2
    assert by["figt1"]["status"] == by["figt2"]["status"] == "ok"
    assert by["figt9"]["status"] == "failed"
    assert "figt9.toml: run[0].strat: unknown key" in by["figt9"]["error"]
    for name in ("figt1", "figt2"):
        for f in ("branches.csv", "special_points.csv", "run.json", f"{name}.png", f"{name}.pdf"):
            assert (out / name / f).is_file(), f
        assert (out / f"{name}.png").read_bytes() == (out / name / f"{name}.png").read_bytes()
    assert (out / "figt9" / "error.txt").read_text().startswith(by["figt9"]["error"])
    report = (out / "report.md").read_text()
    assert "| figt9 | failed: " in report and "run[0].strat: unknown key" in report
    assert "**1 scene(s) failed**" in report


@pytest.mark.slow
def test_report_numbers_are_the_output_numbers(figures):
    _, out, _ = figures
    report = (out / "report.md").read_text()
    lps = [r for r in _csv(out / "figt1" / "special_points.csv") if r["type"] == "LP"]
    assert len(lps) == 2                               # both folds of I in the range
    for lp in lps:
        sigma = float(lp["sigma"])
        m = re.search(rf"\| {lp['label']} \| I \| sigma = ([-+0-9.e]+) \| ([-+0-9.e]+) \|", report)
        assert m, lp["label"]
        assert float(m.group(1)) == pytest.approx(sigma, rel=1e-9)   # printed to 10 digits
        assert float(m.group(2)) == pytest.approx(float(lp["a1"]), rel=1e-3)
    # the branch table's largest a1 and stable count are branches.csv's
    rows = _csv(out / "figt2" / "branches.csv")
    a1max = max(float(r["a1"]) for r in rows)
    stable = sum(r["stable"] == "1" for r in rows)
    m = re.search(r"\| I \| equilibrium \| (\d+) \| sigma \| \[[^]]+\] \| ([0-9.e+-]+) \| [0-9.e+-]+ \| (\d+)/(\d+) \|",
                  report.split("### tiny: Fig. 5a")[1])
    assert m and int(m.group(1)) == len(rows) and int(m.group(4)) == len(rows) and int(m.group(3)) == stable
    assert float(m.group(2)) == pytest.approx(a1max, rel=1e-3)


@pytest.mark.slow
def test_interpolation_and_overlay_comparison_on_a_written_overlay(figures):
    """A hand-made overlay at a branch point's own sigma: the AME value must be the branch's
    (interpolation exact at a node), the error formula |a1_AME - a1_21| / a1_21, the bound the study's."""
    _, out, _ = figures
    d = load_scene_data(out / "figt2")
    rows = d.branch_rows("I")
    node = rows[len(rows) // 2]
    s, a1 = float(node["sigma"]), float(node["a1"])
    (out / "figt2" / "overlay.csv").write_text(
        "parameter,value,direction,method,a1,a2,a1_min,a1_max,a2_min,a2_max,steady,periodic,message,wall_seconds\n"
        f"sigma,{s!r},up,ode21,{a1 * 1.01!r},0.0,{a1!r},{a1!r},0,0,True,True,steady,0.1\n"
        f"sigma,{s!r},down,ode21,{a1 * 0.9!r},0.0,{a1!r},{a1!r},0,0,True,False,modulated,0.1\n"
        f"sigma,0.2,up,ode21,{a1!r},0.0,{a1!r},{a1!r},0,0,True,True,steady,0.1\n")
    try:
        d = load_scene_data(out / "figt2")
        (c,) = interpolate_stable(d, "sigma", s)
        assert c["a1"] == pytest.approx(a1, rel=1e-12)
        up, down, outside = overlay_comparison(d)
        assert up["rel_error"] == pytest.approx(abs(a1 - 1.01 * a1) / (1.01 * a1), rel=1e-9)
        assert up["bound"] == STUDY_MAX_ERROR[8.2e-5] and up["within"] is False   # 0.99 % > 0.108 %
        assert math.isnan(down["rel_error"]) and down["within"] is None and "not period-1" in down["note"]
        assert outside["within"] is None and outside["note"] == "no stable AME equilibrium at this value"
    finally:
        (out / "figt2" / "overlay.csv").unlink()


def test_discover_globs_figure_scenes_and_rejects_unknown_names(figures):
    _, _, runs = figures
    assert [p.stem for p in discover(runs)] == ["figt1", "figt2", "figt9"]
    assert [p.stem for p in discover(runs, ["figt2"])] == ["figt2"]
    with pytest.raises(SpecError, match="no scene figt5 .* there are figt1, figt2, figt9"):
        discover(runs, ["figt5"])
    assert main(["figures", "--out", str(runs / "x"), "--runs", str(runs), "--only", "nope"]) == 2


def test_periodicity_of_a_sampled_amplitude_history():
    """Fig. 11's test of a periodic AME solution on coarse samples (3.27 per the forcing period, as
    the scene writes them): the period of a1 = 1 + 0.5 sin(2 pi t / T) + 0.2 sin(4 pi t / T) comes
    back to 1e-4; a constant a1 is not periodic; two incommensurate tones are not periodic either."""
    from autocable.paper.report import _periodicity
    T, dt = 35.968, 3.2657
    ts = [k * dt for k in range(6000)]
    periodic = [(t, 1 + 0.5 * math.sin(2 * math.pi * t / T) + 0.2 * math.sin(4 * math.pi * t / T), 0.1) for t in ts]
    p = _periodicity(periodic)
    assert p["periodic"] and p["period"] == pytest.approx(T, rel=1e-4)
    assert p["a1_max"] == pytest.approx(max(a for _, a, _ in periodic[3000:]))
    c = _periodicity([(t, 2.0, 0.1) for t in ts])
    assert c["constant"] and not c["periodic"]
    quasi = [(t, 1 + 0.5 * math.sin(2 * math.pi * t / T) + 0.5 * math.sin(2 * math.pi * t / (T * math.sqrt(2))), 0.1)
             for t in ts]
    assert not _periodicity(quasi)["periodic"]


def test_stage_groups_add_up_to_the_scene_total(figures):
    """The benchmark's stage shares: derive + build + continue + integrate + plot + write + other is
    the scene's total, build is the runs' setup time, and a time scene's integration is 'integrate'."""
    from autocable.paper.report import FIGURE_STAGES, stage_seconds
    _, out, _ = figures
    stages = json.loads((out / "figt1" / "run.json").read_text())["provenance"]["stages"]
    st = stage_seconds(stages)
    assert sum(st[k] for k in FIGURE_STAGES) == pytest.approx(stages["total_s"], rel=1e-12)
    assert st["build"] == pytest.approx(sum(r["setup_s"] for r in stages["runs"].values()), rel=1e-12)
    timed = stage_seconds({"derive_s": 1.0, "ame_s": 0.5, "ame_integration_s": 4.0, "ode21_integration_s": 3.0,
                           "plot_s": 0.25, "total_s": 9.0})
    assert (timed["derive"], timed["integrate"], timed["plot"], timed["other"]) == (1.5, 7.0, 0.25, 0.25)


def test_report_lists_the_distance_to_digitised_points(figures):
    """compare.json (autocable/scene/compare.py: per curve label, n_points and max/RMS distance) becomes a
    table in the figure's section, the numbers as written."""
    from autocable.paper.report_md import build_report
    _, out, _ = figures
    path = out / "figt2" / "compare.json"
    path.write_text(json.dumps({"panel": "a1", "x": "sigma", "curves": {
        "I": {"n_points": 7, "max_distance": 1.25e-05, "rms_distance": 6.5e-06}}}))
    try:
        text = build_report(out).split("### tiny: Fig. 5a")[1].split("###")[0]
    finally:
        path.unlink()
    assert "| curve | n_points | max_distance | rms_distance |" in text
    assert "| I | 7 | 1.25e-05 | 6.5e-06 |" in text


@pytest.mark.slow
def test_the_runner_starts_the_expensive_scenes_first(figures, tmp_path, monkeypatch):
    """Longest first keeps the set's wall time near total / cores: by the wall times recorded in
    the cache when known, else by a weight; the summary keeps name order."""
    from autocable.paper.figures import default_runs_dir, expected_cost, recorded_wall_times
    _, out, runs = figures
    summary = json.loads((out / "figures.json").read_text())
    assert [s["name"] for s in summary["scenes"]] == ["figt1", "figt2", "figt9"]
    assert expected_cost(runs / "figt9.toml") == 0.0           # unreadable: fails at once anyway
    assert expected_cost(runs / "figt1.toml") == expected_cost(runs / "figt2.toml") == 2.0
    paper = {p.stem: expected_cost(p) for p in discover(default_runs_dir())}
    # Fig. 9: four runs, periodic orbits from two of them and the eq. (21) overlay
    assert max(paper, key=paper.get) == "fig09"
    assert paper["fig11"] > paper["fig05a"]
    # the recorded wall times win over the weights; a run records its own
    monkeypatch.setenv("AUTOCABLE_CACHE", str(tmp_path / "cache"))
    assert recorded_wall_times() == {}
    (tmp_path / "cache" / "figures").mkdir(parents=True, exist_ok=True)
    (tmp_path / "cache" / "figures" / "wall_s.json").write_text('{"figt2": 9.5, "figt1": 0.5}')
    assert expected_cost(runs / "figt2.toml", recorded_wall_times()) == 9.5
    assert main(["figures", "--out", str(tmp_path / "o"), "--runs", str(runs), "--only", "figt1",
                 "--quiet"]) == 0
    times = recorded_wall_times()
    assert times["figt2"] == 9.5 and 0 < times["figt1"] != 0.5 and "figt9" not in times


def test_blas_threads_are_shared_out_among_the_scene_processes():
    """Two scene processes on two cores get one BLAS thread each; the user's own setting is kept;
    nothing is set once numpy is loaded (too late) or when one process has every core."""
    from autocable.paper.figures import BLAS_THREAD_VARS, blas_thread_env
    assert blas_thread_env(2, 2, {}, False) == {v: "1" for v in BLAS_THREAD_VARS}
    assert blas_thread_env(2, 8, {}, False) == {v: "4" for v in BLAS_THREAD_VARS}
    assert blas_thread_env(3, 2, {}, False) == {v: "1" for v in BLAS_THREAD_VARS}
    kept = blas_thread_env(2, 2, {"OMP_NUM_THREADS": "2"}, False)
    assert "OMP_NUM_THREADS" not in kept and kept["OPENBLAS_NUM_THREADS"] == "1"
    assert blas_thread_env(2, 2, {}, True) == {} and blas_thread_env(1, 2, {}, False) == {}


def test_figures_on_another_model(tmp_path):
    """``--model`` runs the scenes on another spec (e.g. a calibration candidate): run.json names it
    (here the sample cable under another name, so the branch must equal the sample's to round-off),
    and ``--targets`` names the file report.md decides; a bad --model or --targets is exit 2."""
    runs = tmp_path / "runs"
    runs.mkdir()
    (runs / "figt2.toml").write_text(SMALL)
    other = tmp_path / "other.toml"
    other.write_text(Path(MODEL).read_text().replace('name = "luongo_zulli_2012"', 'name = "other_cable"'))
    targets = Path(MODEL).with_suffix("").with_suffix(".targets.toml")
    assert main(["figures", "--out", str(tmp_path / "a"), "--runs", str(runs), "--quiet"]) == 0
    assert main(["figures", "--out", str(tmp_path / "b"), "--runs", str(runs), "--quiet", "--model", str(other),
                 "--targets", str(targets)]) == 0
    run_b = json.loads((tmp_path / "b" / "figt2" / "run.json").read_text())
    assert run_b["provenance"]["model"] == str(other.resolve()) and run_b["provenance"]["model_name"] == "other_cable"
    # the same cable under another name: the same branch to round-off
    a1 = [float(r["a1"]) for r in _csv(tmp_path / "a" / "figt2" / "branches.csv")]
    b1 = [float(r["a1"]) for r in _csv(tmp_path / "b" / "figt2" / "branches.csv")]
    assert a1 == pytest.approx(b1, rel=1e-12)
    assert f"statements of {targets.name}" in (tmp_path / "b" / "report.md").read_text()
    assert main(["figures", "--out", str(tmp_path / "c"), "--runs", str(runs), "--model", str(tmp_path / "nope.toml")]) == 2
    assert main(["figures", "--out", str(tmp_path / "c"), "--runs", str(runs), "--targets", str(tmp_path / "nope.toml")]) == 2


def test_on_a_cold_cache_one_scene_of_each_group_goes_first(tmp_path, monkeypatch):
    """Scenes of one model, ordering and AME (`cold_group`) started side by side on a cold cache
    each derive and compile the same things: the most expensive of each group goes first and the
    others are queued only when it is done; with recorded times (a warm cache) all are queued at once.
    Checked on the serial executor, whose run order is the queue order, with the paper's scene
    files and a stand-in scene task that records what ran."""
    from autocable.paper import figures as fg
    monkeypatch.setenv("AUTOCABLE_CACHE", str(tmp_path / "cache"))
    runs = fg.default_runs_dir()
    names = ["fig04a", "fig04b", "fig04c", "fig09", "fig10", "fig05a", "fig05b", "fig06"]
    scenes = [runs / f"{n}.toml" for n in names]
    groups = {n: fg.cold_group(runs / f"{n}.toml") for n in names}
    assert groups["fig04a"] == groups["fig04b"] == groups["fig04c"] != groups["fig09"] == groups["fig10"]
    assert groups["fig05b"] == groups["fig06"] != groups["fig09"]            # no wind: another AME system
    assert groups["fig04a"][1:] == ("natural", "2dof", True, "compiled")
    assert groups["fig06"][1:] == ("paper", "2dof", False, "compiled")
    assert groups["fig05a"] != groups["fig05b"]        # PyCont builds a PyDSTool library of its own
    assert fg.cold_group(runs / "fig05a.toml", engine="compiled") == groups["fig05b"]
    ran: list[str] = []

    def fake_task(scene_path, scene_out, engine=None, model=None, plot=True, timeout=None):
        ran.append(Path(scene_path).stem)
        return ("ok", "", "", 0.01)

    monkeypatch.setattr(fg, "scene_task", fake_task)
    monkeypatch.setattr(fg, "_collect", lambda name, folder, out: [])
    said: list[str] = []
    fg.run_figures(scenes, tmp_path / "cold", workers=0, say=said.append)
    by_cost = sorted(names, key=lambda n: fg.expected_cost(runs / f"{n}.toml"), reverse=True)
    leaders = [n for k, n in enumerate(by_cost) if groups[n] not in {groups[m] for m in by_cost[:k]}]
    assert ran[:len(leaders)] == leaders and sorted(ran) == sorted(names)
    for n in names:     # every other scene ran after its group's leader
        lead = next(m for m in leaders if groups[m] == groups[n])
        assert ran.index(n) >= ran.index(lead)
    assert any("after fig" in s for s in said)
    # the run recorded every scene's time: the cache is warm, all are queued at once, by cost
    ran.clear()
    fg.run_figures(scenes, tmp_path / "warm", workers=0)
    recorded = fg.recorded_wall_times()
    assert ran == sorted(names, key=lambda n: fg.expected_cost(runs / f"{n}.toml", recorded), reverse=True)
