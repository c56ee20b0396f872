"""`autocable figures` and `autocable calibrate` on a real Dask cluster of processes: a `dask
scheduler` and a `dask worker` (2 worker processes) started on localhost from the command line, as a
user would on a cluster (docs/cluster.md). The scenes' special points and the calibration's
decisions equal those of a local run in one process."""
from __future__ import annotations

import csv
import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

from conftest import REPO, SAMPLE

from autocable.bench.calibration import space_text

# Each test starts a Dask scheduler and workers and runs figures or a calibration on them (a minute
# or more): the whole file is in the slow tier.
pytestmark = pytest.mark.slow

TARGETS = REPO / "models" / "luongo_zulli_2012.targets.toml"
SCENES = "fig03,fig06"
SPACE = space_text([-6.569711, 0.0])     # the sample's mirrored reading at these yaws, screen only


def _dask() -> str:
    exe = Path(sys.executable).with_name("dask")
    return str(exe) if exe.is_file() else (shutil.which("dask") or "")


@pytest.fixture(scope="module")
def cluster(tmp_path_factory):
    """A scheduler and two single-threaded worker processes, each a process of its own; yields the
    scheduler file."""
    if not _dask():
        pytest.skip("the dask command is not installed")
    d = tmp_path_factory.mktemp("cluster")
    sfile = d / "scheduler.json"
    env = dict(os.environ, PYTHONPATH=str(REPO))
    logs = [open(d / name, "w") for name in ("scheduler.log", "worker.log")]
    procs = [subprocess.Popen([_dask(), "scheduler", "--scheduler-file", str(sfile), "--port", "0",
                               "--no-dashboard", "--host", "127.0.0.1"], stdout=logs[0], stderr=subprocess.STDOUT,
                              env=env, cwd=d)]
    try:
        deadline = time.time() + 60
        while not sfile.is_file() and time.time() < deadline:
            time.sleep(0.1)
        assert sfile.is_file(), (d / "scheduler.log").read_text()
        procs.append(subprocess.Popen([_dask(), "worker", "--scheduler-file", str(sfile), "--nworkers", "2",
                                       "--nthreads", "1", "--no-dashboard", "--local-directory", str(d / "w")],
                                      stdout=logs[1], stderr=subprocess.STDOUT, env=env, cwd=d))
        from dask.distributed import Client
        with Client(scheduler_file=str(sfile), timeout=30) as c:
            c.wait_for_workers(2, timeout=90)
            pids = set(c.run(os.getpid).values())
        assert len(pids) == 2 and os.getpid() not in pids          # two processes, not this one
        yield sfile
    finally:
        for p in reversed(procs):
            p.terminate()
        for p in procs:
            try:
                p.wait(20)
            except subprocess.TimeoutExpired:
                p.kill()
        for f in logs:
            f.close()


def _cli(*args) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(REPO))
    return subprocess.run([sys.executable, "-m", "autocable.cli", *map(str, args)], capture_output=True, text=True,
                          env=env, timeout=900)


def _special_points(folder: Path) -> list[tuple]:
    """(branch, type, parameter value, a1, a2) of every special point, rounded to 10 digits."""
    with open(folder / "special_points.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    return sorted((r["branch"], r["type"], round(float(r[r["parameter"]]), 10), round(float(r["a1"]), 10),
                   round(float(r["a2"]), 10)) for r in rows)


def test_figures_on_a_scheduler_find_the_special_points_of_a_local_run(cluster, tmp_path):
    remote = _cli("figures", "--only", SCENES, "--out", tmp_path / "remote", "--scheduler", cluster, "--recompute")
    assert remote.returncode == 0, remote.stderr[-2000:]
    assert "on the scheduler tcp://127.0.0.1:" in remote.stdout
    summary = json.loads((tmp_path / "remote" / "figures.json").read_text())
    assert summary["where"]["mode"] == "scheduler" and summary["where"]["workers_seen"] == 2
    local = _cli("figures", "--only", SCENES, "--out", tmp_path / "local", "--workers", "0", "--recompute")
    assert local.returncode == 0, local.stderr[-2000:]
    for n in SCENES.split(","):
        sp = _special_points(tmp_path / "remote" / n)
        assert sp, n                                    # each scene has special points to compare
        assert sp == _special_points(tmp_path / "local" / n)


def test_a_calibration_on_a_scheduler_decides_as_a_local_run(cluster, tmp_path):
    space = tmp_path / "space.toml"
    space.write_text(SPACE)
    remote = _cli("calibrate", SAMPLE, TARGETS, "--space", space, "--out", tmp_path / "remote", "--scheduler",
                  cluster)
    assert remote.returncode == 0, remote.stderr[-2000:]
    assert "on the scheduler tcp://127.0.0.1:" in remote.stderr
    local = _cli("calibrate", SAMPLE, TARGETS, "--space", space, "--out", tmp_path / "local", "--workers", "0")
    assert local.returncode == 0, local.stderr[-2000:]
    stats = json.loads((tmp_path / "remote" / "calibration.json").read_text())
    assert stats["where"]["mode"] == "scheduler" and stats["computed"] == 2 and stats["candidates"] >= 2

    def rows(folder):
        with open(folder / "calibration.csv", newline="") as fh:
            return sorted(json.dumps(r, sort_keys=True) for r in csv.DictReader(fh))

    assert rows(tmp_path / "remote") == rows(tmp_path / "local")
