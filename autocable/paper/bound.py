"""`autocable calibrate --bound`: can any candidate of the space reach the goal? (branch and bound)

The full evaluation (`calibration.full_evaluation`) runs every figure scene on a few candidates. To
say of the whole declared space that no candidate reaches the targets file's ``[goal]`` (at least
N statements of Sect. 5 "yes", and eq. (21)'s boxes of Figs. 8 and 10 within the AME-vs-(21) study's
bound at a share of their points), every candidate must be looked at, which the full evaluation
cannot afford. This stage does it by branch and bound:

* Each candidate model starts from the no-wind ceiling's upper bound (`calibration.no_wind_ceiling`:
  the statements every candidate shows at best "partly"). The no-wind scenes (Figs. 5a, 5b, 6) are
  the same for every candidate (the ceiling's premises, measured), so they are run once and their
  statements decided once, for all.
* Its wind scenes then run one at a time, cheapest and most decisive first (`ORDER`). After each,
  that scene's statements are decided by the report's code (`targets.decide_statements`, the same
  as report.md and the full evaluation); every one decided other than "yes" lowers the bound by one.
* The candidate stops as soon as its bound is below the goal, or as soon as the boxes of the goal's
  scenes are known to fall short of the goal's share. A candidate that is never stopped has run every
  scene: its bound is then its count of statements shown.

The bound is an upper bound, never an estimate: a statement not decided yet counts as "yes", and so
does every statement the paper does not print (a ``source`` other than "paper" in the targets file:
autocable's own checks, such as eq. (21) beside Fig. 11, which shows the amplitude equations alone, and
results beyond Sect. 5), so that a model is ruled out by what Sect. 5 states and nothing else. So do
the statements whose "no" would say more about the tool than about the model: a statement of a scene
that failed, the cycle statements of a scene whose orbit-started run had to be dropped (its start was
chosen on the sample model, `IF_DROPPED`), and Fig. 3's boxes (`NOT_USED_TO_PRUNE`), which cannot be
"yes" for any model today because the autonomous galloping cycles at eta* = 0 never pass the
overlay's steady test and the study has no bound at eta* = 0.

A run whose statements can never lower a bound is not run: the orbit-started runs (the AME's cycle
branch P of Figs. 8 and 10, beyond Sect. 5) are dropped from a candidate's scene copies before the
scene runs (`NOT_RUN`, recorded in ``dropped.json``), about half of those scenes' time. So is the
eq. (21) overlay of a scene whose only statement that reads it (``<scene>.boxes``) never lowers a
bound and whose boxes the goal does not count: Fig. 3's (its ``boxes`` cannot be shown by any model
today, `NOT_USED_TO_PRUNE`), the first scene every candidate runs; the scene's other statements are
decided from its branches alone (tests/test_bound.py checks they are decided the same without it).
So is Fig. 11's eq. (21) series (``[time] ode21``, `IF_NO_ODE21`): it decides only autocable's own
checks beside the paper's Fig. 11, and fig11.ame_periodic is decided the same without it (tested).

The other overlays (Figs. 4a-10: eq. (21) at 22 points each, the costliest part of a scene when the
response is not steady and each point is integrated to the overlay's end) decide one statement, the
scene's ``boxes``, and the goal's boxes. They are deferred (`DEFERRED`): a scene runs first without
its overlay, its boxes counted yes as undecided; the candidate stops there if its branches'
statements already put it below the goal, and otherwise the scene runs again with its overlay before
anything else, so a candidate that needs its boxes gets them as before. A candidate stopped without
an overlay may record a bound one higher (the boxes counted yes): still an upper bound, and the
conclusion over the space is drawn from the same rule (tested on the sample's Fig. 8: the same
bound and boxes as the scene with its overlay once the overlay is needed).

Resumable: one ``bound.json`` per candidate model under ``DIR/bound/``, stamped with the rule that
decided it (`rule_of`: a record of another rule, e.g. after the targets file changed, is decided
again); the scene folders of a candidate are reused (`candidates.scene_complete`). Parallel: each scene is a
task of the calibration's executor (`autocable.executor`: a LocalCluster, or the workers of a
``--scheduler``), as many in flight as there are workers, over candidates; a lost worker costs its
scene only.
"""
from __future__ import annotations

import json
import math
import time
from dataclasses import dataclass, field
from pathlib import Path

from autocable.paper import targets as tg
from autocable.plotting.style import styled

#: The wind scenes in the order they are run: the cheapest and the most often decisive first
#: (measured on the fully evaluated candidates: Fig. 3 about 3 s and Fig. 11 about 2 s stop most
#: candidates; Figs. 4b and 4c, about 25 s each, run last).
ORDER = ("fig03", "fig11", "fig08", "fig10", "fig09", "fig07", "fig04a", "fig04b", "fig04c")
#: The scenes the no-wind reference provides (the same for every candidate).
NO_WIND = ("fig05a", "fig05b", "fig06")
#: The scenes whose output a scene's statements read besides its own (report._features).
NEEDS = {"fig04c": ("fig04a", "fig04b"), "fig07": ("fig05b",), "fig08": ("fig05b",),
         "fig09": ("fig06",), "fig10": ("fig06",)}
#: Statements never used to lower a bound because of a measurement limit, and why (besides these,
#: every statement whose ``source`` is not "paper": `not_used_to_prune`).
NOT_USED_TO_PRUNE = {
    "fig03.boxes": "no model can show it today: eq. (21)'s galloping cycles at eta* = 0 are classed "
                   "periodic on their own period with a stated error, but the AME-vs-(21) study has no "
                   "bound at eta* = 0 to judge them by",
}
#: A scene still running after this is stopped and counted failed (its statements stay undecided):
#: the longest scene of the fully evaluated candidates took about 35 s.
SCENE_TIMEOUT_S = 600.0
#: The status of a candidate the time budget left unbounded.
NOT_BOUNDED = "not bounded (time budget)"
#: Statement ids (after the scene name) that a dropped orbit-started run would decide.
IF_DROPPED = ("periodic_p",)
#: The note of a run the stage does not run because no statement it decides may lower a bound.
NOT_RUN = "not run: no statement it decides lowers a bound"
#: The note of an eq. (21) overlay the stage runs only when its boxes can change the outcome.
DEFERRED = "deferred: run only if its boxes can change the outcome"
#: Statement ids (after the scene name) that a time scene's eq. (21) series (``[time] ode21``) decides.
IF_NO_ODE21 = ("envelope21", "same_motion")


def _has_table(text: str, name: str) -> bool:
    from autocable.paper.candidates import table_span
    return table_span(text.splitlines(), name) is not None


def _table_text(text: str, name: str) -> str:
    """The ``[name]`` table of a scene file's text, with its ``[name.*]`` subtables."""
    from autocable.paper.candidates import table_span
    lines = text.splitlines()
    i0, _, end = table_span(lines, name)
    return "\n".join(lines[i0:end]).rstrip("\n") + "\n"


def orbit_runs(path: Path) -> list[int]:
    """The indices of a scene file's runs started from an integrated orbit (``start = { orbit = ... }``)."""
    from autocable.spec import read_toml
    data, _ = read_toml(path)
    return [k for k, r in enumerate(data.get("run") or []) if isinstance(r, dict)
            and isinstance(r.get("start"), dict) and "orbit" in r["start"]]


def scene_copy(src: Path, dst: Path, model: Path, drop_orbits: bool, drop_overlay: bool,
               drop_ode21: bool = False) -> list[str]:
    """A copy of the scene file ``src`` at ``dst`` on ``model``, without its orbit-started runs
    (``drop_orbits``), its eq. (21) overlay (``drop_overlay``) and its eq. (21) time series
    (``drop_ode21``), as `run_bound` prepares a candidate's scenes (an overlay it defers included);
    returns the notes of what was dropped (for `autocable bench bound-scenes`)."""
    from autocable.paper import candidates as cm
    dst.write_text(cm.scene_on_model(src.read_text(), model, dst.parent))
    notes = []
    if drop_orbits:
        notes += [f"{src.stem}: run[{k}]" for k in reversed(orbit_runs(dst)) if cm._drop_run(dst, k)]
    if drop_overlay and cm._drop_table(dst, "overlay"):
        notes.append(f"{src.stem}: overlay")
    if drop_ode21 and cm._switch_off(dst, "time", "ode21"):
        notes.append(f"{src.stem}: ode21")
    return notes


@dataclass
class Candidate:
    """One candidate model in the bound stage."""

    key: str
    c: dict
    folder: Path
    todo: list = field(default_factory=list)
    verdicts: dict = field(default_factory=dict)     # statement id -> {"shown", "evidence"}
    failed: list = field(default_factory=list)       # scenes that failed (their statements undecided)
    dropped: list = field(default_factory=list)
    boxes: dict = field(default_factory=dict)
    scenes_run: list = field(default_factory=list)
    prepared: bool = False
    computed: int = 0                                # scene runs started by this call (not reused)
    wall_s: float = 0.0
    deferred_s: float = 0.0                          # recorded time of runs before a deferred overlay


def unknown_scenes(targets) -> list[str]:
    """The scenes of the targets' statements that the bound stage neither runs nor takes from the
    no-wind reference (a targets file for other scenes: refused before any work)."""
    return sorted({t.scene for t in targets if t.kind == "statement"} - set(ORDER) - set(NO_WIND))


def not_used_to_prune(targets) -> dict[str, str]:
    """The statements that never lower a bound, with why: the measurement limits (`NOT_USED_TO_PRUNE`)
    and every statement the paper does not print (a ``source`` other than "paper" in the targets
    file: autocable's own checks, results beyond Sect. 5), so that the bound rests on Sect. 5 alone."""
    out = {sid: why for sid, why in NOT_USED_TO_PRUNE.items()}
    for t in targets:
        if t.kind == "statement" and t.source != "paper":
            out[t.id] = tg.SOURCES[t.source]
    return out


#: The layout of a bound.json record; part of `rule_of`, so a record of an older layout is decided
#: again (from its scenes) rather than read with fields missing.
RECORD_FORMAT = "autocable.bound/2"


def rule_of(statement_ids, capped, unused, goal: tg.Goal, margin: int = 0, study: dict | None = None) -> str:
    """A fingerprint of what decides a bound (the statements, the ceiling's caps, the statements not
    used, the goal, the stopping margin, the record's layout, and the AME-vs-(21) study's bounds
    ``study`` that decide every ``<scene>.boxes`` statement and the goal's boxes; default
    `STUDY_MAX_ERROR`): a stored record made under another rule is decided again (its scenes reused)."""
    import hashlib

    from autocable.studies.ame_bounds import study_stamp
    doc = json.dumps([RECORD_FORMAT, list(statement_ids), sorted(capped), sorted(unused), goal.statements_yes,
                      goal.boxes_share, list(goal.boxes_scenes), int(margin), study_stamp(study)])
    return hashlib.sha256(doc.encode()).hexdigest()[:16]


def bound_of(verdicts: dict, statement_ids: list, capped: set, unused, failed=(),
             dropped=()) -> tuple[int, list]:
    """(upper bound on the statements "yes", the ids that lowered it): every statement counts as
    "yes" unless it is capped by the ceiling or decided other than "yes" and usable to prune
    (``unused``: the ids never used, `not_used_to_prune`; ``failed``: scenes that failed;
    ``dropped``: the drop notes "scene: run[k] (why)" of the scenes' orbit-started runs)."""
    dropped_scenes = {d.split(":")[0] for d in dropped}
    lowered = []
    for sid in statement_ids:
        if sid in capped:
            continue
        v = verdicts.get(sid)
        if v is None or v.get("shown") == "yes" or sid in unused:
            continue
        scene, _, rest = sid.partition(".")
        if scene in failed or (scene in dropped_scenes and rest in IF_DROPPED):
            continue
        lowered.append(sid)
    return len(statement_ids) - len(capped) - len(lowered), lowered


def boxes_short(boxes: dict, goal: tg.Goal) -> bool | None:
    """True when the goal's boxes are known to fall short of its share, None while a scene is missing.
    A box counts when eq. (21) is within the bound there, or both are at rest (report.overlay_summary)."""
    if not goal.boxes_scenes or any(s not in boxes for s in goal.boxes_scenes):
        return None
    good = sum(boxes[s]["within"] + boxes[s]["at_rest"] for s in goal.boxes_scenes)
    points = sum(boxes[s]["points"] for s in goal.boxes_scenes)
    return points == 0 or good < goal.boxes_share * points


def scene_seconds(out: Path, scenes) -> float:
    """The wall time of a candidate's scenes as each scene's run.json records it (``stages.total_s``),
    whether this call computed the scene or reused it; a failed scene records none."""
    total = 0.0
    for n in scenes:
        try:
            rj = json.loads((out / n / "run.json").read_text())
            total += float(rj.get("provenance", {}).get("stages", {}).get("total_s", 0.0))
        except (OSError, ValueError, TypeError, AttributeError):
            pass
    return total


def screen_not_met(c: dict) -> list[str]:
    """The screen's and the printed numbers' targets the candidate does not meet (calibration.csv):
    computed from eq. (21) and the AME directly, independently of the scenes' decisions."""
    return sorted(k for k, v in (c.get("verdicts") or {}).items() if isinstance(v, dict) and v.get("shown") != "yes")


def model_key(c: dict) -> str:
    """One key per candidate model: the orderings share it (the scenes keep their own)."""
    return json.dumps([c["readings"], c["yaw_deg"], round(c["rivulet_angle_deg"], 9)], sort_keys=True)


def run_bound(model_path: Path, targets, goal: tg.Goal, cands: list, full: list, out: Path, runs: Path,
              reference_out: Path, capped: set, executor, say, order: tuple = ORDER,
              minutes: float | None = None, margin: int = 0) -> list[dict]:
    """The bound stage over ``cands`` (the screen's candidates); ``full`` are the fully evaluated
    ones (their verdicts give their bound directly), ``reference_out`` an output folder holding the
    no-wind scenes, ``capped`` the ceiling's statement ids, ``order`` the wind scenes to run, in order.
    ``minutes``: no scene is started after this wall time; the candidates not bounded by then get a
    record "not bounded (time budget)" with the bound so far (not stored: a rerun goes on with them).
    ``margin``: a candidate stops on statements only when its bound is below the goal by more than
    this (0: as soon as it is below), so that the conclusion survives any ``margin`` of the decisions
    that lowered it being wrong. ``executor``: the `autocable.executor.Executor` the scenes run on,
    or a worker count (an executor of that many workers is made for this call; 0: this process).
    Returns one record per candidate model."""
    if not hasattr(executor, "submit"):
        from autocable.executor import Executor
        from autocable.paper.figures import _preload
        with Executor(int(executor), warm=_preload, strict_priority=True) as own:
            return run_bound(model_path, targets, goal, cands, full, out, runs, reference_out, capped, own, say,
                             order, minutes, margin)
    from autocable._store import atomic_write_json
    from autocable.paper import candidates as cm
    from autocable.executor import time_left
    from autocable.paper.figures import scene_task
    from autocable.paper.report import load_scene_data, overlay_summary

    stmt_ids = [t.id for t in targets if t.kind == "statement"]
    unused = not_used_to_prune(targets)
    rule = rule_of(stmt_ids, capped, unused, goal, margin)
    # the scenes whose orbit-started runs decide only statements that never lower a bound
    skip_orbits = {}
    for n in order:
        ids = [f"{n}.{x}" for x in IF_DROPPED if f"{n}.{x}" in stmt_ids]
        if ids and all(i in unused for i in ids):
            skip_orbits[n] = ids
    # the scenes whose eq. (21) overlay decides only statements that never lower a bound
    skip_overlay = {n: f"{n}.boxes" for n in order
                    if n not in goal.boxes_scenes and (f"{n}.boxes" not in stmt_ids or f"{n}.boxes" in unused)}
    # the scenes whose eq. (21) time series decides only statements that never lower a bound
    skip_ode21 = {}
    for n in order:
        ids = [f"{n}.{x}" for x in IF_NO_ODE21 if f"{n}.{x}" in stmt_ids]
        if ids and all(i in unused for i in ids):
            skip_ode21[n] = ids
    # the other overlays: a scene runs without its overlay first, and again with it only if the
    # candidate is not stopped by then (its boxes, the one statement the overlay decides, counted
    # yes until known): most candidates stop on their branches' statements alone
    original = {n: (runs / f"{n}.toml").read_text() for n in order}
    defer_overlay = {n for n in order if n not in skip_overlay and _has_table(original[n], "overlay")}
    stop_below = goal.statements_yes - int(margin)
    by_scene: dict[str, list] = {}
    for t in targets:
        if t.kind == "statement":
            by_scene.setdefault(t.scene, []).append(t)
    unknown = unknown_scenes(targets)
    by_scene = {n: ts for n, ts in by_scene.items() if n in order or n in NO_WIND}
    if unknown:
        raise ValueError(f"the bound stage does not know the scenes {unknown} of the targets file")
    reference = {n: load_scene_data(reference_out / n) for n in NO_WIND}
    base = {}
    for v in tg.decide_statements([t for n in NO_WIND for t in by_scene.get(n, [])], reference):
        base[v.id] = {"shown": v.shown, "evidence": v.evidence}
    records, seen, todo, n_redecide = [], set(), [], 0
    full_keys = {model_key(c): c for c in full}
    for key, c in full_keys.items():
        fv = c["full"]["verdicts"]
        failed = {sid.split(".")[0] for sid, v in fv.items() if str(v.get("evidence", "")).startswith("scene failed")}
        b, lowered = bound_of(fv, stmt_ids, capped, unused, failed, c["full"].get("dropped_runs") or [])
        short = boxes_short(c["full"].get("boxes") or {}, goal)
        records.append(_record(c, b, lowered, "fully evaluated", sorted(ORDER), c["full"].get("boxes") or {},
                               sorted(failed), c["full"].get("dropped_runs") or [], c["full"].get("wall_s", 0.0),
                               goal, short, scene_s=c["full"].get("wall_s", 0.0)))
        records[-1]["rule"] = rule
        seen.add(key)
    for c in sorted(cands, key=cm.screen_score, reverse=True):
        key = model_key(c)
        if key in seen:
            continue
        seen.add(key)
        folder = out / "bound" / cm.candidate_name(c)
        done = folder / "bound.json"
        if done.is_file():
            try:
                rec = json.loads(done.read_text())
            except ValueError:
                rec = None
            if isinstance(rec, dict) and rec.get("rule") == rule:
                records.append(rec)
                continue
            if rec is not None:
                n_redecide += 1
        todo.append(Candidate(key, c, folder, list(order), dict(base)))
    n_reused = len(records) - len(full_keys)
    say(f"bound: {len(todo) + len(records)} candidate models, {len(full_keys)} fully evaluated, "
        f"{n_reused} already on disk, {len(todo)} to bound ({n_redecide} of them stored under another rule: "
        f"decided again, their finished scenes reused); goal {goal.statements_yes} statements, boxes "
        f">= {goal.boxes_share:.0%} of {', '.join(goal.boxes_scenes)}"
        + (f"; a candidate stops at a bound of {stop_below - 1} or less (margin {margin})" if margin else ""))
    if not todo:
        return records

    def prepare(cand: Candidate) -> None:
        """The candidate's model file and scene copies (kept: a rerun reuses them with their drops)."""
        model = cm.write_candidate_model(model_path, cand.c, cand.folder / "model.toml")
        (cand.folder / "runs").mkdir(parents=True, exist_ok=True)
        (cand.folder / "out").mkdir(parents=True, exist_ok=True)
        cand.dropped = cm._recorded_drops(cand.folder)
        for n in order:
            dst = cand.folder / "runs" / f"{n}.toml"
            if not dst.is_file():
                text = (runs / f"{n}.toml").read_text()
                dst.write_text(cm.scene_on_model(text, model, dst.parent))
            if skip_orbits.get(n) and not cm.scene_complete(cand.folder / "out" / n, dst):
                # an orbit run decides only statements that never lower a bound: a bound need not
                # pay for it (a finished scene keeps it: its text is what made its results)
                for k in reversed(orbit_runs(dst)):
                    if cm._drop_run(dst, k):
                        cand.dropped.append(f"{n}: run[{k}] ({NOT_RUN}: {', '.join(skip_orbits[n])})")
                atomic_write_json(cand.folder / "dropped.json", cand.dropped)
            if skip_overlay.get(n) and not cm.scene_complete(cand.folder / "out" / n, dst) \
                    and cm._drop_table(dst, "overlay"):
                cand.dropped.append(f"{n}: overlay ({NOT_RUN}: {skip_overlay[n]})")
                atomic_write_json(cand.folder / "dropped.json", cand.dropped)
            if skip_ode21.get(n) and not cm.scene_complete(cand.folder / "out" / n, dst) \
                    and cm._switch_off(dst, "time", "ode21"):
                cand.dropped.append(f"{n}: ode21 ({NOT_RUN}: {', '.join(skip_ode21[n])})")
                atomic_write_json(cand.folder / "dropped.json", cand.dropped)
            if n in defer_overlay and not cm.scene_complete(cand.folder / "out" / n, dst) \
                    and cm._drop_table(dst, "overlay"):
                cand.dropped.append(f"{n}: overlay ({DEFERRED}: {n}.boxes)")
                atomic_write_json(cand.folder / "dropped.json", cand.dropped)
        cand.prepared = True

    def deferred(cand: Candidate, scene: str) -> bool:
        """Whether the scene's copy still lacks the overlay the stage deferred."""
        return scene in defer_overlay and not _has_table((cand.folder / "runs" / f"{scene}.toml").read_text(),
                                                         "overlay")

    def restore_overlay(cand: Candidate, scene: str) -> None:
        """Put the deferred overlay back into the scene's copy (the scene then runs again, with it);
        the time of the run without it is kept for the record."""
        path = cand.folder / "runs" / f"{scene}.toml"
        block = _table_text(original[scene], "overlay")
        path.write_text(path.read_text().rstrip("\n") + "\n\n" + block)
        cand.deferred_s += scene_seconds(cand.folder / "out", [scene])
        cand.dropped = [d for d in cand.dropped if not (d.startswith(f"{scene}: overlay") and DEFERRED in d)]
        atomic_write_json(cand.folder / "dropped.json", cand.dropped)
    queue = list(todo)          # candidates waiting for their next scene
    running: dict = {}          # task label -> (candidate, scene)
    n_done, t_start, n_started = 0, time.perf_counter(), 0
    capacity = max(1, executor.n_workers)

    def over_budget() -> bool:
        return minutes is not None and time.perf_counter() - t_start >= 60.0 * minutes

    def decide(cand: Candidate, scene: str, ok: bool, error: str) -> None:
        if not ok:
            cand.failed.append(scene)
            for t in by_scene.get(scene, []):
                cand.verdicts[t.id] = {"shown": "no", "evidence": f"scene failed: {error}"}
            return
        have = {n: load_scene_data(cand.folder / "out" / n) for n in cand.scenes_run if n not in cand.failed}
        have.update(reference)
        for v in tg.decide_statements(by_scene.get(scene, []), have):
            cand.verdicts[v.id] = {"shown": v.shown, "evidence": v.evidence}
        if deferred(cand, scene):
            # the overlay has not run: its boxes are not known (counted yes, as undecided)
            cand.verdicts.pop(f"{scene}.boxes", None)
            cand.boxes.pop(scene, None)
            return
        if scene in goal.boxes_scenes:
            s = overlay_summary(have[scene])
            cand.boxes[scene] = {"points": s["points"], "within": s["within"], "at_rest": s["at_rest"],
                                 "not_steady": s["not_steady"]}

    def settle(cand: Candidate) -> bool:
        """Write the candidate's record when it is stopped or has run everything; True if so."""
        nonlocal n_done
        b, lowered = bound_of(cand.verdicts, stmt_ids, capped, unused, cand.failed, cand.dropped)
        short = boxes_short(cand.boxes, goal)
        if b >= stop_below and not short:
            pending = [n for n in cand.scenes_run if n not in cand.failed and deferred(cand, n)]
            if pending:
                # not stopped by the branches: the deferred overlay runs next (as it would have
                # run with its scene), the scene with it
                restore_overlay(cand, pending[0])
                cand.todo.insert(0, pending[0])
                return False
        if b >= stop_below and not short and cand.todo:
            return False
        status = ("stopped: statements" if b < stop_below else "stopped: boxes" if short
                  else "every scene run")
        rec = _record(cand.c, b, lowered, status, cand.scenes_run, cand.boxes, cand.failed, cand.dropped,
                      cand.wall_s, goal, short,
                      scene_s=scene_seconds(cand.folder / "out", cand.scenes_run) + cand.deferred_s)
        rec["computed_scenes"] = cand.computed
        rec["rule"] = rule
        atomic_write_json(cand.folder / "bound.json", cm._finite(rec))
        records.append(rec)
        n_done += 1
        elapsed = time.perf_counter() - t_start
        rate = n_done / max(elapsed, 1e-9) * 60
        left = time_left(n_done, len(todo), elapsed)
        say(f"[{n_done}/{len(todo)}] {cm.candidate_name(cand.c)}: at most {b} yes ({status}; "
            f"{len(cand.scenes_run)} scenes; {rate:.1f} candidates/min" + (f"; {left}" if left else "") + ")")
        return True

    def start_next() -> bool:
        """Submit the next scene of the first waiting candidate (or settle it); False if none waits."""
        nonlocal n_started
        while queue and not over_budget():
            cand = queue.pop(0)
            if not cand.prepared:
                prepare(cand)
            if settle(cand):
                continue
            scene = cand.todo.pop(0)
            path, dst = cand.folder / "runs" / f"{scene}.toml", cand.folder / "out" / scene
            if cm.scene_complete(dst, path):
                if scene not in cand.scenes_run:
                    cand.scenes_run.append(scene)
                decide(cand, scene, True, "")
                queue.insert(0, cand)
                continue
            # no figure: a bound needs the scene's results only (a reader runs the scene to see it)
            n_started += 1
            label = f"bound:{n_started}:{scene}"
            executor.submit(label, scene_task, str(path.resolve()), str(dst.resolve()), None, None, False,
                            SCENE_TIMEOUT_S)
            cand.computed += 1
            running[label] = (cand, scene)
            return True
        return False

    while len(running) < capacity and start_next():
        pass
    for done in executor.completed():
        if done.label not in running:
            continue
        cand, scene = running.pop(done.label)
        status, error, _detail, wall = done.value if done.ok else ("failed", done.error, "", 0.0)
        cand.wall_s += wall
        k = cm._failed_start(error) if status != "ok" else None
        path = cand.folder / "runs" / f"{scene}.toml"
        if k is not None and sum(d.startswith(scene + ":") and NOT_RUN not in d and DEFERRED not in d
                                 for d in cand.dropped) < 2 \
                and cm._drop_run(path, k):
            # as the full evaluation: the run whose sample-tuned start failed goes, the scene reruns
            cand.dropped.append(f"{scene}: run[{k}] ({error.split(': ', 2)[-1][:160]})")
            atomic_write_json(cand.folder / "dropped.json", cand.dropped)
            cand.todo.insert(0, scene)
        else:
            if scene not in cand.scenes_run:
                cand.scenes_run.append(scene)
            decide(cand, scene, status == "ok", error)
        queue.insert(0, cand)
        while len(running) < capacity and start_next():
            pass
    left = list(queue)
    for cand in left:
        b, lowered = bound_of(cand.verdicts, stmt_ids, capped, unused, cand.failed, cand.dropped)
        if (b < stop_below or boxes_short(cand.boxes, goal) or (cand.prepared and not cand.todo)) \
                and settle(cand):   # settled by what was decided before the budget ran out
            continue
        records.append(_record(cand.c, b, lowered, NOT_BOUNDED, cand.scenes_run, cand.boxes, cand.failed,
                               cand.dropped, cand.wall_s, goal, boxes_short(cand.boxes, goal)))
    if left:
        say(f"bound: the time budget of {minutes:g} min is spent; {sum(r['status'] == NOT_BOUNDED for r in records)} "
            "candidate models not bounded (a rerun goes on with them)")
    return records


def _record(c: dict, bound: int, lowered: list, status: str, scenes: list, boxes: dict, failed, dropped,
            wall: float, goal: tg.Goal, short, scene_s: float = 0.0) -> dict:
    from autocable.paper.candidates import candidate_name
    good = sum(boxes[s]["within"] + boxes[s]["at_rest"] for s in goal.boxes_scenes if s in boxes)
    points = sum(boxes[s]["points"] for s in goal.boxes_scenes if s in boxes)
    return {"name": candidate_name(c), "readings": c["readings"], "yaw_deg": c["yaw_deg"],
            "rivulet_angle_deg": c["rivulet_angle_deg"], "bound": bound, "status": status,
            "lowered_by": lowered, "scenes_run": list(scenes), "failed_scenes": list(failed),
            "dropped_runs": list(dropped), "boxes": boxes, "boxes_good": good, "boxes_points": points,
            "boxes_short": short, "reaches_goal": bound >= goal.statements_yes and short is False,
            "wall_s": wall, "scene_s": scene_s, "screen_not_met": screen_not_met(c)}


def summary(records: list[dict], goal: tg.Goal) -> dict:
    """Counts over the records: how many were stopped by what, the highest bound among the settled
    ones, who reaches the goal, who is not settled (not bounded within the time budget, or bound not
    below the goal with the boxes unknown)."""
    by = {}
    for r in records:
        by[r["status"]] = by.get(r["status"], 0) + 1
    settled = [r for r in records if r["status"] != NOT_BOUNDED]
    best = max(settled, key=lambda r: r["bound"], default=None)
    lowered = {}
    for r in records:
        for sid in r["lowered_by"]:
            lowered[sid] = lowered.get(sid, 0) + 1
    return {"models": len(records), "by_status": by, "highest_bound": best["bound"] if best else math.nan,
            "highest": best["name"] if best else "", "reach_goal": [r["name"] for r in records if r["reaches_goal"]],
            "not_bounded": [r["name"] for r in records if r["status"] == NOT_BOUNDED],
            "could_still_reach": [r["name"] for r in settled if r["bound"] >= goal.statements_yes
                                  and r["boxes_short"] is not True and not r["reaches_goal"]],
            "lowered_by": dict(sorted(lowered.items(), key=lambda kv: -kv[1]))}


# ------------------------------------------------------------------------------------------------
# what the stage writes
# ------------------------------------------------------------------------------------------------
CSV_FIELDS = ("name", "twist_ends", "load_axes", "angle_convention", "load_length", "yaw_deg",
              "rivulet_angle_deg", "bound", "status", "boxes_good", "boxes_points", "reaches_goal",
              "scenes_run", "lowered_by", "failed_scenes", "screen_not_met", "scene_s", "rule")
#: Columns a bound.csv of an earlier version may lack (read as empty: the rule then is not known).
CSV_OPTIONAL = ("rule",)


def write_csv(records: list[dict], path: Path) -> None:
    import csv
    with open(path, "w", newline="", encoding="utf-8") as fh:
        w = csv.DictWriter(fh, fieldnames=list(CSV_FIELDS))
        w.writeheader()
        for r in sorted(records, key=lambda r: (-r["bound"], r["name"])):
            row = {k: r.get(k, "") for k in CSV_FIELDS}
            row.update({k: r["readings"][k] for k in ("twist_ends", "load_axes", "angle_convention", "load_length")})
            row.update({k: " ".join(r.get(k, [])) for k in ("scenes_run", "lowered_by", "failed_scenes", "screen_not_met")})
            w.writerow(row)


READING_KEYS = ("twist_ends", "load_axes", "angle_convention", "load_length")


def read_csv(path: Path) -> list[dict]:
    """The records of an earlier call's bound.csv (`write_csv`), as the stage's records: the bound
    outputs of a new call can then cover readings that call did not run (``calibrate --prior-bound``).
    A bad file is one line naming it and the column. Each record is marked ``prior``."""
    import csv

    from autocable.spec import SpecError
    path = Path(path)
    try:
        with open(path, newline="", encoding="utf-8") as fh:
            rows = list(csv.DictReader(fh))
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise SpecError(path, "--prior-bound", f"cannot read it as bound.csv: {exc}") from None
    out = []
    for i, row in enumerate(rows):
        missing = [k for k in CSV_FIELDS if k not in row and k not in CSV_OPTIONAL]
        if missing:
            raise SpecError(path, f"row {i + 1}", f"is not a bound.csv row (missing columns {missing})")
        try:
            rec = {"name": row["name"], "readings": {k: row[k] for k in READING_KEYS},
                   "yaw_deg": float(row["yaw_deg"]), "rivulet_angle_deg": float(row["rivulet_angle_deg"]),
                   "bound": int(row["bound"]), "status": row["status"],
                   "boxes_good": int(row["boxes_good"] or 0), "boxes_points": int(row["boxes_points"] or 0),
                   "reaches_goal": row["reaches_goal"] == "True", "scene_s": float(row["scene_s"] or 0.0),
                   "boxes_short": row["status"] == "stopped: boxes", "prior": True, "computed_scenes": 0,
                   "rule": row.get("rule") or ""}
        except ValueError as exc:
            raise SpecError(path, f"row {i + 1}", f"has a value that is not a number: {exc}") from None
        rec.update({k: row[k].split() for k in ("scenes_run", "lowered_by", "failed_scenes", "screen_not_met")})
        out.append(rec)
    return out


def _screen_point(r: dict) -> tuple:
    return tuple(r["readings"][k] for k in READING_KEYS) + (round(float(r["yaw_deg"]), 9),)


def merge_prior(records: list[dict], prior: list[dict]) -> list[dict]:
    """``records`` and the ``prior`` records of screen points (reading and yaw) none of ``records``
    has: every candidate of a screen point decided by this call comes from this call, never from an
    earlier one (a call over a few yaws of a reading replaces those yaws' records and keeps the rest)."""
    mine = {_screen_point(r) for r in records}
    return list(records) + [r for r in prior if _screen_point(r) not in mine]


def boxes_could_lift(r: dict, goal: tg.Goal) -> bool:
    """Whether the record's bound could reach the goal if every ``<scene>.boxes`` statement that
    lowered it turned yes, or its boxes stopped it: what a looser AME-vs-(21) study bound can change
    (the boxes are the only decisions that read it, and a looser bound only turns boxes yes)."""
    lifted = r["bound"] + sum(1 for sid in r["lowered_by"] if sid.endswith(".boxes"))
    return lifted >= goal.statements_yes or r["status"] == "stopped: boxes"


@styled()      # the package's one look (autocable.plotting.style)
def draw_map(records: list[dict], goal: tg.Goal, ceiling_yes: int, path: Path) -> Path:
    """The bound over the space: one panel per (twist ends, angle sense), bound against yaw, one
    colour per (load axes, load length), the marker saying what stopped the candidate; the goal and
    the ceiling drawn across."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    panels = sorted({(r["readings"]["twist_ends"], r["readings"]["angle_convention"]) for r in records})
    series = sorted({(r["readings"]["load_axes"], r["readings"]["load_length"]) for r in records})
    colours = dict(zip(series, ("#1b9e77", "#d95f02", "#7570b3", "#e7298a", "#66a61e", "#e6ab02")))
    marks = {"stopped: statements": "o", "stopped: boxes": "s", "every scene run": "D", "fully evaluated": "*",
             NOT_BOUNDED: "x"}
    ncol = 2
    nrow = max(1, math.ceil(len(panels) / ncol))
    fig, axes = plt.subplots(nrow, ncol, figsize=(12, 3.4 * nrow), squeeze=False, sharey=True)
    lo = min((r["bound"] for r in records), default=0)
    for ax, (te, ac) in zip(axes.flat, panels):
        mine = [r for r in records if (r["readings"]["twist_ends"], r["readings"]["angle_convention"]) == (te, ac)]
        for k, (la, ll) in enumerate(series):
            # the series side by side (at most +-1 deg): at one yaw they would hide each other
            dx = (k - (len(series) - 1) / 2) * (2.0 / max(len(series), 1))
            for st, m in marks.items():
                pts = [r for r in mine if (r["readings"]["load_axes"], r["readings"]["load_length"]) == (la, ll)
                       and r["status"] == st]
                if pts:
                    ax.scatter([r["yaw_deg"] + dx for r in pts], [r["bound"] for r in pts], marker=m, s=22 if m != "*" else 60,
                               facecolors="none" if m in "os" else colours[(la, ll)],
                               edgecolors=None if m == "x" else colours[(la, ll)],
                               linewidths=0.8, alpha=0.8)
        ax.axhline(goal.statements_yes, color="k", ls="--", lw=1)
        ax.axhline(ceiling_yes, color="#d7301f", ls=":", lw=1.2)
        ax.set_title(f"twist ends {te}, angle sense {ac}: {len(mine)} models", fontsize=9)
        ax.set_xlabel("yaw beta [deg] (series side by side, +-1 deg)")
        ax.set_ylabel("at most this many statements yes")
        ax.set_ylim(lo - 1, ceiling_yes + 1.5)
    for ax in list(axes.flat)[len(panels):]:
        ax.axis("off")
    handles = [plt.Line2D([], [], color=colours[s], marker="o", ls="", label=f"load axes {s[0]}, length {s[1]}")
               for s in series]
    handles += [plt.Line2D([], [], color="0.3", marker=m, ls="", mfc="none" if m in "os" else "0.3", label=st)
                for st, m in marks.items()]
    handles += [plt.Line2D([], [], color="k", ls="--", label=f"goal: {goal.statements_yes}"),
                plt.Line2D([], [], color="#d7301f", ls=":", label=f"no-wind ceiling: {ceiling_yes}")]
    fig.legend(handles=handles, loc="lower center", ncol=4, fontsize=7, frameon=False)
    fig.suptitle("Upper bound on the Sect. 5 statements each candidate model can show (branch and bound)",
                 fontsize=10)
    fig.tight_layout(rect=(0, 0.07, 1, 0.97))
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def markdown(records: list[dict], goal: tg.Goal, ceiling_yes: int, n_statements: int, wall_s: float,
             jobs: int, picture: Path | None, csv_name: str, unused: dict, margin: int = 0,
             rule: str = "") -> list[str]:
    s = summary(records, goal)
    stopped = {k: v for k, v in s["by_status"].items()}
    run = [r for r in records if r["status"] not in ("fully evaluated",)]
    scenes = sum(len(r["scenes_run"]) for r in run)
    prior = [r for r in records if r.get("prior")]
    lines = ["", "## Can any candidate reach the goal? (branch and bound over the whole space)", "",
             f"Goal (the targets file's `[goal]`): at least **{goal.statements_yes} of {n_statements}** statements "
             f"yes, and eq. (21)'s boxes within the study's bound at {goal.boxes_share:.0%} or more of the overlay "
             f"points of {' and '.join(goal.boxes_scenes)} taken together.", "",
             "Every candidate model of the screen (the orderings share one: the scenes keep theirs) starts "
             f"from the no-wind ceiling, {ceiling_yes}; its wind scenes run one at a time ({', '.join(ORDER)}), "
             "each decided by the report's code, and every statement decided other than yes lowers the bound. "
             + ("The candidate stops when the bound is below the goal or its boxes cannot reach the goal's share. "
                if not margin else
                f"The candidate stops when the bound is below the goal by more than {margin} (margin {margin}: "
                f"the conclusion holds even if any {margin} of the decisions that lowered a bound were wrong) or "
                "its boxes cannot reach the goal's share. ")
             + 
             "The bound is an upper bound: undecided statements count as yes, and so do "
             + "; ".join(f"{k} ({v})" for k, v in unused.items())
             + f"; the statements of a failed scene; the {', '.join(IF_DROPPED)} statements of a scene whose "
               "orbit-started run (its start chosen on the sample) had to be dropped.", "",
             f"**{s['models']} candidate models**: "
             + ", ".join(f"{v} {k}" for k, v in sorted(stopped.items(), key=lambda kv: -kv[1]))
             + f". {len(run)} bounded in this stage with {scenes} scenes decided "
               f"({scenes / max(len(run), 1):.2f} per model; {sum(r.get('scene_s', 0.0) for r in run) / 3600:.1f} h of "
               "scene time as the scenes' run.json record it, summed; "
               f"{sum(r.get('computed_scenes', 0) for r in run)} of the scenes were computed by the calls that "
               "wrote the records, the others reused from earlier calls' folders; this call took "
               f"{wall_s / 60:.1f} min with {jobs} processes)."]
    if prior:
        got = sorted({r["readings"]["angle_convention"] for r in prior})
        lines += ["", f"{len(prior)} of the {s['models']} records (angle senses {', '.join(got)}) were read from an "
                      "earlier call's bound.csv (`--prior-bound`) for the screen points (reading and yaw) this "
                      "call's space does not hold; the others were decided by this call."]
        if rule:
            other = [r for r in prior if r.get("rule") != rule]
            lift = [r for r in other if boxes_could_lift(r, goal)]
            if other:
                lines += ["", f"{len(other)} of the read records were decided under another rule than this call's "
                              "(or one their file does not record). Where the rules differ only in the "
                              "AME-vs-(21) study's bounds and the new ones are looser, only the boxes can change, "
                              "and only towards yes: "
                          + (f"{len(lift)} of them could then reach the goal ({', '.join(r['name'] for r in lift)}) "
                             "and must be decided again." if lift else
                             "none of them could then reach the goal (each bound stays below it with every "
                             "boxes statement that lowered it counted yes, and none was stopped by its boxes).")]
    if s["reach_goal"]:
        verdict = "**Candidate models that reach the goal: " + ", ".join(s["reach_goal"]) + ".**"
    elif not s["not_bounded"] and not s["could_still_reach"]:
        verdict = (f"**No candidate model of the space reaches the goal.** The highest upper bound is "
                   f"{s['highest_bound']} ({s['highest']}).")
    else:
        verdict = (f"**No candidate model bounded so far reaches the goal** (highest upper bound "
                   f"{s['highest_bound']}, {s['highest']}); **not settled: {len(s['not_bounded'])} candidate "
                   "models not bounded within the time budget** (candidates are bounded in the screen's rank "
                   "order: these come last; `autocable calibrate ... --bound` again goes on with them)")
        if s["could_still_reach"]:
            verdict += (f", and {len(s['could_still_reach'])} whose bound is not below the goal but whose boxes "
                        "are unknown (a scene of the goal's boxes failed)")
        verdict += "."
    lines += ["", verdict]
    if picture is not None:
        lines += ["", f"![upper bound per candidate model]({picture.name})"]
    hist = {}
    for r in records:
        hist[r["bound"]] = hist.get(r["bound"], 0) + 1
    readings = sorted({tuple(r["readings"][k] for k in ("twist_ends", "load_axes", "angle_convention", "load_length"))
                       for r in records})
    lines += ["", "Per reading (twist ends, load axes, angle sense, load length):", "",
              "| reading | models | highest bound | stopped by statements | by boxes | fully evaluated | not bounded |",
              "|---|---|---|---|---|---|---|"]
    for rd in readings:
        mine = [r for r in records
                if tuple(r["readings"][k] for k in ("twist_ends", "load_axes", "angle_convention", "load_length")) == rd]
        done = [r for r in mine if r["status"] != NOT_BOUNDED]
        count = (lambda st: sum(r["status"] == st for r in mine))
        lines.append(f"| {'-'.join(rd)} | {len(mine)} | {max((r['bound'] for r in done), default='—')} | "
                     f"{count('stopped: statements')} | {count('stopped: boxes')} | {count('fully evaluated')} | "
                     f"{count(NOT_BOUNDED)} |")
    lines += ["", "Upper bound (statements yes at most): candidate models", "",
              "| bound | " + " | ".join(str(k) for k in sorted(hist, reverse=True)) + " |",
              "|---|" + "---|" * len(hist),
              "| models | " + " | ".join(str(hist[k]) for k in sorted(hist, reverse=True)) + " |", "",
              "The statements that lowered the bounds (how many candidate models each stopped or lowered):", "",
              "| statement | models |", "|---|---|"]
    lines += [f"| {k} | {v} |" for k, v in list(s["lowered_by"].items())[:20]]
    if s["lowered_by"]:
        # The bound is only as strong as the decisions that lowered it: how much rests on each one,
        # were it not counted (the one that lowered most, and the worst of all). A model whose boxes
        # fall short is out whatever its statements.
        def unsettled_without(sid):
            return sum(1 for r in records if r["status"] != NOT_BOUNDED and r.get("boxes_short") is not True
                       and r["bound"] + (sid in r["lowered_by"]) >= goal.statements_yes)
        top = next(iter(s["lowered_by"]))
        worst = max(s["lowered_by"], key=unsettled_without)
        lines += ["", f"The conclusion rests on the report's decision of each statement above. Not counting "
                      f"**{top}** (it lowered the most bounds), {unsettled_without(top)} candidate models would "
                      f"have a bound not below the goal and would have to run further scenes before the question "
                      "is settled for them; "
                  + (f"not counting any one statement, at most {unsettled_without(worst)} ({worst})."
                     if unsettled_without(worst) else
                     "the same holds for every statement: with any one decision not counted, every model is still "
                     "below the goal or short of its boxes.")]
        # The same models seen by other code: the screen's targets, computed from eq. (21) and the
        # AME directly (closed forms and integrations), for the statements that lowered the most.
        rows = []
        for sid in list(s["lowered_by"])[:5]:
            mine = [r for r in records if sid in r["lowered_by"] and "screen_not_met" in r]
            miss = {}
            for r in mine:
                for k in r["screen_not_met"]:
                    miss[k] = miss.get(k, 0) + 1
            if mine:
                rows.append(f"| {sid} | {len(mine)} | {sum(1 for r in mine if r['screen_not_met'])} | "
                            + ", ".join(f"{k} {v}" for k, v in sorted(miss.items(), key=lambda kv: -kv[1])[:4]) + " |")
        if rows:
            lines += ["", f"The same models by the screen (other code: eq. (21) and the AME computed directly; its "
                          f"targets are not among the {n_statements} and lower no bound): how many miss at least one "
                          "screen target, and the targets missed most.", "",
                      "| statement | models it lowered | miss a screen target | most missed (models) |",
                      "|---|---|---|---|"] + rows
    top = sorted(records, key=lambda r: (-r["bound"], r["name"]))[:10]
    lines += ["", "The ten highest bounds:", "", "| candidate model | at most yes | status | scenes run | "
              "boxes within (Figs. 8 + 10) | lowered by |", "|---|---|---|---|---|---|"]
    for r in top:
        box = f"{r['boxes_good']} of {r['boxes_points']}" if r["boxes_points"] else "—"
        lines.append(f"| {r['name']} | {r['bound']} | {r['status']} | {len(r['scenes_run'])} | {box} | "
                     f"{', '.join(r['lowered_by'])} |")
    lines += ["", f"One row per candidate model: [{csv_name}]({csv_name})."]
    return lines
