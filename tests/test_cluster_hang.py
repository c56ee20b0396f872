"""A run on a Dask cluster never hangs and never uses another autocable: a real
`dask scheduler` process with no worker, then with a worker that cannot import autocable, then one
that runs another copy of it, and one killed while it runs a task. The no-worker time limit is set
to 2-3 s here (``AUTOCABLE_NO_WORKER_TIMEOUT``; default 60 s). Run time: about 50 s on two shared
cores (process start-ups), most of it the `autocable` commands' imports."""
from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

from autocable.spec import MAX_MESSAGE

from conftest import REPO

LIMIT_S = 3.0


def _dask() -> str:
    exe = Path(sys.executable).with_name("dask")
    return str(exe) if exe.is_file() else (shutil.which("dask") or "")


def _wait_for(path: Path, proc, log: Path, seconds: float = 60.0) -> None:
    deadline = time.time() + seconds
    while not path.is_file() and time.time() < deadline and proc.poll() is None:
        time.sleep(0.1)
    assert path.is_file(), log.read_text()


@pytest.fixture()
def scheduler(tmp_path):
    """A `dask scheduler` process without any worker; yields its scheduler file."""
    if not _dask():
        pytest.skip("the dask command is not installed")
    sfile = tmp_path / "scheduler.json"
    log = tmp_path / "scheduler.log"
    with open(log, "w") as fh:
        proc = subprocess.Popen([_dask(), "scheduler", "--scheduler-file", str(sfile), "--port", "0",
                                 "--no-dashboard", "--host", "127.0.0.1"], stdout=fh, stderr=subprocess.STDOUT,
                                cwd=tmp_path)
    try:
        _wait_for(sfile, proc, log)
        yield sfile
    finally:
        proc.terminate()
        try:
            proc.wait(20)
        except subprocess.TimeoutExpired:
            proc.kill()


def _worker(sfile: Path, tmp_path: Path, env: dict, code: str | None = None):
    """One single-threaded worker without a nanny (its own process runs the tasks), started by
    ``python -c code`` (a prologue, then Dask's worker command) or the `dask worker` command."""
    args = ["--scheduler-file", str(sfile), "--nthreads", "1", "--no-nanny", "--no-dashboard",
            "--local-directory", str(tmp_path / "w")]
    cmd = ([sys.executable, "-c", code + "\nfrom distributed.cli.dask_worker import main\nmain()", *args] if code
           else [_dask(), "worker", *args])
    log = open(tmp_path / "worker.log", "w")
    proc = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT, env=env, cwd=tmp_path)
    from dask.distributed import Client
    with Client(scheduler_file=str(sfile), timeout=30) as c:
        c.wait_for_workers(1, timeout=60)
    return proc, log


def _stop(proc, log) -> None:
    proc.terminate()
    try:
        proc.wait(20)
    except subprocess.TimeoutExpired:
        proc.kill()
    log.close()


def _figures(sfile: Path, out: Path, tmp_path: Path) -> tuple[subprocess.CompletedProcess, float]:
    env = dict(os.environ, PYTHONPATH=str(REPO), AUTOCABLE_NO_WORKER_TIMEOUT=str(LIMIT_S),
               AUTOCABLE_CACHE=str(tmp_path / "cache"))
    t0 = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "autocable.cli", "figures", "--only", "fig03", "--scheduler",
                           str(sfile), "--out", str(out), "--quiet"], capture_output=True, text=True, env=env,
                          timeout=300)
    return done, time.perf_counter() - t0


@pytest.mark.slow
def test_a_scheduler_without_workers_ends_in_a_bounded_time_naming_scheduler(scheduler, tmp_path):
    out = tmp_path / "out"
    done, wall = _figures(scheduler, out, tmp_path)
    assert done.returncode == 3, done.stderr
    lines = [ln for ln in done.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and "--scheduler" in lines[0] and "no live worker for 3 s" in lines[0], done.stderr
    # bounded: the limit plus the command's start-up (imports, the scene's key); measured 9-12 s here
    assert LIMIT_S <= wall < LIMIT_S + 45, wall
    print(f"scheduler without workers: exit 3 after {wall:.1f} s (limit {LIMIT_S:g} s)")
    summary = json.loads((out / "figures.json").read_text())
    assert [s["status"] for s in summary["scenes"]] == ["failed"]
    assert "no live worker" in (out / "fig03" / "error.txt").read_text()
    run = out / "fig03" / "run.json"
    assert not run.exists() or json.loads(run.read_text()).get("status") != "running"
    assert not (out / "fig03").is_dir() or not any(p.name.startswith(".autocable-staging") for p in
                                                   (out / "fig03").iterdir())


@pytest.mark.slow
def test_a_sweep_on_a_scheduler_without_workers_ends_too(scheduler, tmp_path):
    env = dict(os.environ, PYTHONPATH=str(REPO), AUTOCABLE_NO_WORKER_TIMEOUT=str(LIMIT_S),
               AUTOCABLE_CACHE=str(tmp_path / "cache"))
    out = tmp_path / "sweep"
    t0 = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "autocable.cli", "sweep", str(REPO / "runs" / "sweep_fig05a.toml"),
                           "--scheduler", str(scheduler), "--out", str(out), "--quiet"], capture_output=True,
                          text=True, env=env, timeout=300)
    wall = time.perf_counter() - t0
    assert done.returncode == 3, done.stderr
    lines = [ln for ln in done.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and "--scheduler" in lines[0] and "no live worker" in lines[0], done.stderr
    assert LIMIT_S <= wall < LIMIT_S + 45, wall
    assert not (out / "sweep.json").exists()          # not a finished sweep; a rerun resumes
    print(f"sweep on a scheduler without workers: exit 3 after {wall:.1f} s")


def test_the_executor_itself_raises_no_live_worker(scheduler):
    from autocable.executor import Executor, NoLiveWorker
    t0 = time.perf_counter()
    with Executor(scheduler=str(scheduler), no_worker_timeout=2.0) as ex:
        ex.submit("t", abs, -1)
        raised = _drain_bounded(ex)
    assert isinstance(raised, NoLiveWorker), raised
    assert re.match(r"^--scheduler .*no live worker for 2 s with 1 task\(s\) waiting", str(raised))
    assert 2.0 <= time.perf_counter() - t0 < 20


def _drain_bounded(ex, seconds: float = 30.0):
    """``list(ex.completed())`` in a thread, so that a hang fails the test instead of blocking it;
    returns what it raised (None if nothing)."""
    import threading
    box: list = []

    def drain():
        try:
            list(ex.completed())
            box.append(None)
        except BaseException as exc:   # noqa: BLE001 - handed to the test
            box.append(exc)

    t = threading.Thread(target=drain, daemon=True)
    t.start()
    t.join(seconds)
    assert not t.is_alive(), f"completed() still waiting after {seconds:g} s: the run hangs"
    return box[0]


@pytest.mark.slow
def test_a_cluster_whose_last_worker_dies_ends_too(scheduler, tmp_path):
    """The worker passes the first-contact check, starts the task and is killed: the task waits
    for a worker that never comes, and the run ends after the limit instead."""
    from autocable.executor import Executor, NoLiveWorker
    proc, log = _worker(scheduler, tmp_path, dict(os.environ, PYTHONPATH=str(REPO)))
    try:
        with Executor(scheduler=str(scheduler), no_worker_timeout=2.0) as ex:
            assert ex.n_workers == 1
            ex.submit("long", time.sleep, 60.0)       # (a function the worker can import)
            time.sleep(1.0)                   # the task has started on the worker
            proc.kill()
            proc.wait(20)
            raised = _drain_bounded(ex)
            assert isinstance(raised, NoLiveWorker) and "no live worker for 2 s with 1 task" in str(raised)
    finally:
        if proc.poll() is None:
            proc.kill()
        log.close()


def test_unfinished_scenes_are_marked_failed_not_left_running(tmp_path):
    from autocable.paper.figures import _mark_unfinished
    out = tmp_path / "out"
    (out / "fig03").mkdir(parents=True)
    (out / "fig03" / "run.json").write_text(json.dumps({"name": "fig03", "status": "running", "pid": 2**22 + 7,
                                                        "files": ["branches.csv"]}))
    _mark_unfinished(out, ["fig03", "fig05b"], "--scheduler X: no live worker for 60 s")
    meta = json.loads((out / "fig03" / "run.json").read_text())
    assert meta["status"] == "failed" and "pid" not in meta and meta["files"] == ["branches.csv"]
    assert "no live worker" in meta["reason"]
    for name in ("fig03", "fig05b"):
        assert (out / name / "error.txt").read_text().startswith(f"{name}: --scheduler X: no live worker")
    from autocable.results import is_complete
    assert not is_complete(out / "fig03")


def test_bad_time_limits_are_refused_by_name(monkeypatch):
    from autocable.executor import no_worker_seconds
    from autocable.spec import SpecError
    for bad in ("0", "-1", "nan", "inf", "soon"):
        monkeypatch.setenv("AUTOCABLE_NO_WORKER_TIMEOUT", bad)
        with pytest.raises(SpecError, match="AUTOCABLE_NO_WORKER_TIMEOUT.*positive number of seconds"):
            no_worker_seconds()
    monkeypatch.setenv("AUTOCABLE_NO_WORKER_TIMEOUT", "7.5")
    assert no_worker_seconds() == 7.5
    monkeypatch.delenv("AUTOCABLE_NO_WORKER_TIMEOUT")
    assert no_worker_seconds() == 60.0
    with pytest.raises(SpecError, match="no_worker_timeout"):
        no_worker_seconds(float("nan"))


@pytest.mark.slow
def test_a_worker_that_cannot_import_autocable_is_refused_by_name(scheduler, tmp_path):
    env = dict(os.environ, PYTHONPATH=str(tmp_path))         # and autocable blocked in the worker
    proc, log = _worker(scheduler, tmp_path, env, code="import sys\nsys.modules['autocable'] = None")
    try:
        out = tmp_path / "out"
        done, wall = _figures(scheduler, out, tmp_path)
    finally:
        _stop(proc, log)
    assert done.returncode == 2, done.stderr
    lines = [ln for ln in done.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and "--scheduler" in lines[0] and "cannot run autocable's code" in lines[0], done.stderr
    assert lines[0].endswith("install autocable in the workers' environment")
    assert "tcp://127.0.0.1:" in lines[0]                     # the worker, by its address
    assert not (out / "fig03").exists()                       # refused before any work


@pytest.mark.slow
def test_a_worker_running_another_copy_of_autocable_is_refused_by_name(scheduler, tmp_path):
    copy = tmp_path / "elsewhere"
    shutil.copytree(REPO / "autocable", copy / "autocable", ignore=shutil.ignore_patterns("__pycache__"))
    with open(copy / "autocable" / "results.py", "a") as fh:
        fh.write("\n# another copy\n")
    env = dict(os.environ, PYTHONPATH=str(copy))
    proc, log = _worker(scheduler, tmp_path, env)
    try:
        out = tmp_path / "out"
        done, _ = _figures(scheduler, out, tmp_path)
    finally:
        _stop(proc, log)
    assert done.returncode == 2, done.stderr
    lines = [ln for ln in done.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and "--scheduler" in lines[0], done.stderr
    assert "runs other autocable files" in lines[0] and "install this command's autocable on the workers" in lines[0]
    # the worker's path comes last: a long one is cut at the message's 240 characters, the fix is not
    assert "(its autocable: " + str(copy)[:20] in lines[0]
    assert len(lines[0]) <= len("autocable: error: arguments: ") + MAX_MESSAGE


# ------------------------------------------------------------------------------------------------
# one writer per figures --out
# ------------------------------------------------------------------------------------------------
def test_a_second_figures_into_one_out_is_refused_naming_the_holder(tmp_path):
    from autocable.paper.figures import figures_folder, run_figures
    from autocable.spec import SpecError
    out = tmp_path / "out"
    with figures_folder(out):
        with pytest.raises(SpecError, match=rf"--out: another autocable figures \(process {os.getpid()}\)"):
            run_figures([], out)
        env = dict(os.environ, PYTHONPATH=str(REPO), AUTOCABLE_CACHE=str(tmp_path / "cache"))
        done = subprocess.run([sys.executable, "-m", "autocable.cli", "figures", "--only", "fig03", "--workers", "0",
                               "--out", str(out), "--quiet"], capture_output=True, text=True, env=env, timeout=300)
    assert done.returncode == 2, done.stderr
    lines = [ln for ln in done.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and "--out" in lines[0] and f"process {os.getpid()}" in lines[0], done.stderr
    assert not (out / "fig03").exists() and not (out / ".tasks.jsonl").exists()     # nothing shared
    with figures_folder(out):           # released: the next run takes it
        pass


def test_figures_refuses_foreign_files_and_clears_only_its_dead_temporaries(tmp_path):
    from autocable.paper.figures import figures_folder
    from autocable.spec import SpecError
    out = tmp_path / "out"
    (out / "fig03").mkdir(parents=True)
    (out / "fig03" / "run.json").write_text(json.dumps({"name": "fig03", "status": "complete", "files": []}))
    for name in ("fig03.png", "fig03_plane.pdf", "figures.json", "report.md", ".tasks.jsonl"):
        (out / name).write_text("x")
    temporary = out / ".figures.json.ab12cd34.tmp"        # a killed run's half-written summary
    temporary.write_text("{")
    with figures_folder(out):           # an earlier run's folder: accepted
        pass
    assert not temporary.exists()
    (out / "notes.txt").write_text("mine")
    (out / ".notes.txt.ab12cd34.tmp").write_text("mine too")
    (out / "fig99.png").write_text("a figure of no scene here")
    with pytest.raises(SpecError, match=r"--out: .*holds files autocable figures did not write "
                                        r"\(\.notes\.txt\.ab12cd34\.tmp, fig99\.png, notes\.txt\)"):
        with figures_folder(out):
            pass
    assert (out / "notes.txt").read_text() == "mine" and (out / ".notes.txt.ab12cd34.tmp").exists()


def test_a_scene_folder_that_lost_its_run_json_is_still_ours(tmp_path):
    """An interrupted run's scene folder without run.json (and its copied figures) is taken back
    by a run of that scene or after a figures.json listing it; a folder of another name is not."""
    from autocable.paper.figures import figures_folder
    from autocable.spec import SpecError
    out = tmp_path / "out"
    (out / "fig05a").mkdir(parents=True)
    (out / "fig05a" / "branches.csv").write_text("x")
    (out / "fig05a.png").write_text("x")
    with figures_folder(out, ["fig05a"]):
        pass
    with pytest.raises(SpecError, match=r"did not write \(fig05a, fig05a\.png\)"):
        with figures_folder(out, ["fig03"]):
            pass
    (out / "figures.json").write_text(json.dumps({"scenes": [{"name": "fig05a"}]}))
    with figures_folder(out, ["fig03"]):
        pass
