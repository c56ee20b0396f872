"""The one executor of every parallel job (`autocable.executor`): the serial path and the Dask path
give the same results; a task in a forked child reports its value, its error, its crash and its time
limit; a killed worker during `autocable figures` and during a calibration screen loses nothing and
only its own task is computed again (counted from the journal of task starts)."""
from __future__ import annotations

import json
import math
import os
import signal
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from conftest import REPO, SAMPLE

from autocable.bench.calibration import space_text

from autocable.executor import Done, Executor, attempts, run_forked, time_left

RUNS = REPO / "runs"
TARGETS = REPO / "models" / "luongo_zulli_2012.targets.toml"


def _work(k: int) -> float:
    """A small numeric task: the same bits wherever it runs."""
    x = np.linspace(0.0, 1.0, 257) * (k + 1)
    return float(np.sum(np.sin(x) ** 2))


def _boom(k: int) -> float:
    raise ValueError(f"bad task {k}")


def _run_all(ex: Executor, n: int) -> dict:
    for k in range(n):
        ex.submit(f"w:{k}", _work, k)
    got = {}
    for done in ex.completed():
        assert done.ok, done.error
        k = int(done.label.split(":")[1])
        got[k] = done.value
        if k < 3:                           # tasks submitted while iterating join the same loop
            ex.submit(f"w:{k + 100}", _work, k + 100)
    return got


def test_serial_and_local_cluster_give_the_same_values(tmp_path):
    with Executor(0, journal=tmp_path / "serial.jsonl") as ex:
        serial = _run_all(ex, 8)
    with Executor(2, journal=tmp_path / "dask.jsonl") as ex:
        assert ex.where["mode"] == "LocalCluster" and ex.n_workers == 2
        dask = _run_all(ex, 8)
    assert serial == dask                   # bitwise: the same function on the same inputs
    assert sorted(serial) == [0, 1, 2, 3, 4, 5, 6, 7, 100, 101, 102]
    assert serial[5] == _work(5)
    # every task started exactly once on both paths
    for name in ("serial.jsonl", "dask.jsonl"):
        counts = attempts(tmp_path / name)
        assert len(counts) == 11 and set(counts.values()) == {1}


def test_a_task_that_raises_comes_back_with_its_error_and_the_others_go_on():
    for workers in (0, 1):
        with Executor(workers) as ex:
            ex.submit("ok", _work, 1)
            ex.submit("bad", _boom, 7)
            got = {d.label: d for d in ex.completed()}
        assert got["ok"].ok and got["ok"].value == _work(1)
        assert not got["bad"].ok and got["bad"].error == "ValueError: bad task 7"


def _segfault():
    import faulthandler
    faulthandler.disable()          # pytest's handler would print the child's stack into the log
    os.kill(os.getpid(), signal.SIGSEGV)


def _sleep(s):
    time.sleep(s)
    return s


def test_run_forked_reports_value_error_crash_and_time_limit():
    assert run_forked(_work, (3,)) == ("ok", _work(3), "")
    status, error, tb = run_forked(_boom, (2,))
    assert (status, error) == ("failed", "ValueError: bad task 2") and "Traceback" in tb
    assert run_forked(_segfault) == ("failed", f"the task's process died (killed by signal {int(signal.SIGSEGV)}) "
                                               "without a result", "")
    t0 = time.perf_counter()
    assert run_forked(_sleep, (30,), timeout=0.5) == ("failed", "stopped after the time limit of 0.5 s", "")
    assert time.perf_counter() - t0 < 5.0
    # a large value crosses the pipe whole
    big = list(range(200_000))
    assert run_forked(list, (big,))[1] == big


def test_time_left_is_the_mean_rate_so_far():
    assert time_left(0, 10, 5.0) == ""
    assert time_left(2, 10, 20.0) == "about 80 s left"           # 10 s per task, 8 to go
    assert time_left(1, 31, 60.0) == "about 30 min left"
    assert time_left(10, 10, 5.0) == ""


def test_journal_lines_cut_by_a_kill_are_skipped(tmp_path):
    j = tmp_path / "j.jsonl"
    j.write_text('{"label": "a", "pid": 1}\n{"label": "a", "pid": 2}\n{"label": "b", "pi')
    assert attempts(j) == {"a": 2}
    assert attempts(tmp_path / "missing") == {}


# ------------------------------------------------------------------------------------------------
# figures and the calibration screen on the executor
# ------------------------------------------------------------------------------------------------
def _numbers(path: Path) -> list[list[float]]:
    """The table's cells as numbers where they are, without its timing columns (wall clock)."""
    import csv
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
    keep = [i for i, name in enumerate(rows[0]) if "wall" not in name and "seconds" not in name]
    out = []
    for cells in rows[1:]:
        vals = []
        for x in (cells[i] for i in keep if i < len(cells)):
            try:
                vals.append(float(x))
            except ValueError:
                vals.append(x)
        out.append(vals)
    return out


def _same_table(a: Path, b: Path, rtol: float = 1e-10) -> None:
    ta, tb = _numbers(a), _numbers(b)
    assert len(ta) == len(tb), (a, len(ta), len(tb))
    for ra, rb in zip(ta, tb):
        assert len(ra) == len(rb)
        for x, y in zip(ra, rb):
            if isinstance(x, float) and isinstance(y, float):
                assert (math.isnan(x) and math.isnan(y)) or x == pytest.approx(y, rel=rtol, abs=1e-14), (a, x, y)
            else:
                assert x == y, (a, x, y)


QUICK_SCENES = ("fig03", "fig05a", "fig05b", "fig11")


@pytest.mark.slow
def test_figures_on_the_executor_equal_the_serial_path(tmp_path):
    """The same scenes on 2 LocalCluster workers and serially in this process: the same branches,
    special points and overlays (to 1e-10 relative: the same code on the same inputs; BLAS threads
    may differ between the paths)."""
    from autocable.paper.figures import run_figures
    scenes = [RUNS / f"{n}.toml" for n in QUICK_SCENES[:2]]
    serial = run_figures(scenes, tmp_path / "serial", workers=0)
    dask = run_figures(scenes, tmp_path / "dask", workers=2)
    assert [o.status for o in serial] == [o.status for o in dask] == ["ok", "ok"]
    assert json.loads((tmp_path / "dask" / "figures.json").read_text())["where"]["mode"] == "LocalCluster"
    for n in QUICK_SCENES[:2]:
        for f in ("branches.csv", "special_points.csv", "overlay.csv"):
            if (tmp_path / "serial" / n / f).is_file():
                _same_table(tmp_path / "serial" / n / f, tmp_path / "dask" / n / f)


def _children(pid: int) -> list[int]:
    import psutil
    try:
        return [c.pid for c in psutil.Process(pid).children()]
    except psutil.Error:
        return []


@pytest.mark.slow
def test_a_killed_worker_during_figures_loses_only_its_scene(tmp_path):
    """SIGKILL of the worker whose scene child has run for 0.5 s: every scene still ends "ok", the
    journal counts exactly one scene started twice, and figures.json names it."""
    from autocable.paper.figures import TASKS_JOURNAL, run_figures
    scenes = [RUNS / f"{n}.toml" for n in QUICK_SCENES]
    killed = {}

    def killer(pids):
        deadline = time.time() + 120
        while time.time() < deadline:
            for pid in pids:
                if _children(pid):
                    time.sleep(0.5)
                    if _children(pid):
                        os.kill(pid, signal.SIGKILL)
                        killed["pid"] = pid
                        return
            time.sleep(0.02)

    with Executor(2, journal=tmp_path / "out" / TASKS_JOURNAL) as ex:
        t = threading.Thread(target=killer, args=(ex.worker_pids(),), daemon=True)
        t.start()
        outcomes = run_figures(scenes, tmp_path / "out", executor=ex)
        t.join(5)
    assert "pid" in killed, "no worker was killed"
    assert [o.status for o in outcomes] == ["ok"] * len(scenes), [o.error for o in outcomes]
    counts = attempts(tmp_path / "out" / TASKS_JOURNAL)
    assert sorted(counts) == sorted(f"scene:{n}" for n in QUICK_SCENES)
    assert sorted(counts.values()) == [1] * (len(scenes) - 1) + [2]       # one scene computed again
    # the recomputed scene's results are whole: its folder reads as complete
    from autocable.paper.report import load_scene_data
    for n in QUICK_SCENES:
        assert load_scene_data(tmp_path / "out" / n).ok


@pytest.mark.slow
def test_figures_json_records_where_the_scenes_ran_and_no_recount_without_a_loss(tmp_path):
    """With its own executor, `run_figures` writes where the scenes ran and the scenes computed
    again into figures.json: none when no worker was lost (the killed-worker test above counts one)."""
    from autocable.paper.figures import run_figures
    run_figures([RUNS / "fig03.toml"], tmp_path / "o", workers=1)
    data = json.loads((tmp_path / "o" / "figures.json").read_text())
    assert data["recomputed"] == {} and data["where"]["mode"] == "LocalCluster"


TINY_SPACE = space_text([-6.569711, 0.0, 5.0])     # the sample's mirrored reading at these yaws, screen only


def _screen_rows(folder: Path) -> list[str]:
    lines = (folder / "calibration.csv").read_text().splitlines()
    return [lines[0]] + sorted(lines[1:])


@pytest.fixture(scope="module")
def serial_screen(tmp_path_factory):
    """The tiny space's screen computed serially in this process (the reference)."""
    from autocable.paper.calibration import calibrate, load_space
    d = tmp_path_factory.mktemp("screen")
    (d / "space.toml").write_text(TINY_SPACE)
    out = d / "serial"
    stats = calibrate(SAMPLE, TARGETS, out, space=load_space(d / "space.toml"), workers=0, quiet=True)
    assert stats["where"]["mode"] == "serial" and stats["computed"] == 3
    return d, out


@pytest.mark.slow
def test_a_killed_worker_during_a_calibration_screen_loses_only_its_point(serial_screen):
    """SIGKILL of the worker 1 s into its screen point: every point is computed, the journal counts
    exactly one point started twice, calibration.json says so, and the candidates and their
    decisions equal the serial path's."""
    from autocable.paper.calibration import TASKS_JOURNAL, calibrate, load_space
    d, serial = serial_screen
    out = d / "killed"
    journal = out / TASKS_JOURNAL
    killed = {}

    def killer():
        deadline = time.time() + 300
        while time.time() < deadline:
            lines = journal.read_text().splitlines() if journal.is_file() else []
            starts = [json.loads(x) for x in lines if x.startswith("{") and x.endswith("}")]
            if starts:
                time.sleep(1.0)
                os.kill(starts[0]["pid"], signal.SIGKILL)
                killed.update(starts[0])
                return
            time.sleep(0.02)

    t = threading.Thread(target=killer, daemon=True)
    t.start()
    stats = calibrate(SAMPLE, TARGETS, out, space=load_space(d / "space.toml"), workers=2, quiet=True)
    t.join(5)
    assert killed, "no worker was killed"
    assert stats["computed"] == 3 and stats["where"]["mode"] == "LocalCluster"
    assert stats["recomputed_tasks"] == {killed["label"]: 1}
    assert json.loads((out / "calibration.json").read_text())["recomputed_tasks"] == {killed["label"]: 1}
    assert sorted(attempts(journal).values()) == [1, 1, 2]
    assert _screen_rows(out) == _screen_rows(serial)


def test_done_ok_is_the_absence_of_an_error():
    assert Done("a", 1).ok and not Done("a", None, "x").ok


def _started(seconds: float) -> float:
    t = time.time()
    time.sleep(seconds)
    return t


@pytest.mark.parametrize("workers", [0, 2])
@pytest.mark.slow
def test_strict_priority_gives_the_next_free_worker_the_highest_task(workers):
    """Dask assigns a task to a worker when it is submitted, so a task queued later with a higher
    priority (a figure scene freed when its group's first scene is done) waited behind earlier,
    lower ones. With ``strict_priority`` the executor holds the tasks and hands one to each free
    worker, the highest at that moment. Two workers: a (0.8 s) and b (0.2 s) run; c (priority 1)
    and d (8) wait; e (5) is queued when b is done; then d, e, c is the order, on the serial path
    too (where e joins after a)."""
    with Executor(workers, strict_priority=True) as ex:
        for label, s, prio in (("a", 0.8, 10), ("b", 0.2, 9), ("c", 0.05, 1), ("d", 0.05, 8)):
            ex.submit(label, _started, s, priority=prio)
        starts = {}
        for done in ex.completed():
            assert done.ok, done.error
            starts[done.label] = done.value
            if done.label == "b":
                ex.submit("e", _started, 0.05, priority=5)
    order = sorted(starts, key=starts.get)
    assert order.index("d") < order.index("e") < order.index("c")
    assert order[:2] in (["a", "b"], ["b", "a"])
