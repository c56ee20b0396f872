"""Hostile conditions around `autocable sweep` (issue: damaged point files, interrupted follow
lines, concurrent sweeps, the grid's size before any axis is built, option checks)."""
import json
import textwrap
from pathlib import Path

import numpy as np
import pytest

from autocable.scene.sweep_schema import load_sweep
from autocable.studies.sweep import RESPONSE_CLASSES, run_sweep

REPO = Path(__file__).resolve().parents[1]
MODEL = REPO / "models" / "luongo_zulli_2012.toml"

xr = pytest.importorskip("xarray")

# Three cheap points of Fig. 5a's setting (period-1 responses by shooting).
SMALL = 'method = "shooting"\n[grid]\neta = 8.2e-5\nsigma = [-0.01, 0.0, 0.01]\n'


def write_sweep(folder: Path, body: str, name="s.toml") -> Path:
    path = folder / name
    path.write_text(f'model = "{MODEL}"\n' + textwrap.dedent(body))
    return path


def numbers(out: Path) -> dict:
    with xr.open_dataset(out / "sweep.nc", engine="scipy") as ds:
        return {k: ds[k].values.copy() for k in ("a1", "a2", "response")}


def test_damaged_point_files_are_computed_again(tmp_path):
    """A finished sweep whose point files were emptied, replaced by ``{}`` or by another point's
    record: the rerun removes them, computes those points again (damaged 3, computed 3, missing 0)
    and the dataset equals the first run's; a third run resumes everything."""
    spec = load_sweep(write_sweep(tmp_path, SMALL))
    out = tmp_path / "o"
    first = run_sweep(spec, out, workers=0)
    assert first["computed"] == 3 and first["missing"] == 0
    ref = numbers(out)
    files = sorted((out / "points").glob("*.json"), key=lambda p: json.loads(p.read_text())["sigma"])
    other = files[2].read_text()
    files[0].write_text("")
    files[1].write_text("{}")
    files[2].write_text(other.replace('"sigma": 0.01', '"sigma": 0.02'))   # a record of another point
    again = run_sweep(spec, out, workers=0)
    assert (again["damaged"], again["resumed"], again["computed"], again["missing"]) == (3, 0, 3, 0)
    got = numbers(out)
    for k in ref:
        assert np.array_equal(ref[k], got[k]), k
    assert (got["response"] == RESPONSE_CLASSES.index("period-1")).all()
    third = run_sweep(spec, out, workers=0)
    assert (third["damaged"], third["resumed"], third["computed"]) == (0, 3, 0)


def test_interrupted_follow_line_keeps_its_finished_points(tmp_path, monkeypatch):
    """A followed line interrupted (Ctrl-C) at its fourth point keeps the three finished points as
    files (each handed to the sink as it finishes, not with the line); the rerun resumes them and
    computes the rest from the third point's state, as the uninterrupted line would."""
    from autocable.studies import sweep as sw
    body = 'method = "shooting"\nfollow = "sigma"\n[grid]\neta = 8.2e-5\nsigma = [-0.02, -0.01, 0.0, 0.01, 0.02]\n'
    spec = load_sweep(write_sweep(tmp_path, body))
    ref = run_sweep(spec, tmp_path / "ref", workers=0)
    assert ref["computed"] == 5
    real, calls = sw.compute_point, []

    def interrupted(*args, **kwargs):
        calls.append(args[4])
        if len(calls) == 4:
            raise KeyboardInterrupt
        return real(*args, **kwargs)

    monkeypatch.setattr(sw, "compute_point", interrupted)
    with pytest.raises(KeyboardInterrupt):
        run_sweep(spec, tmp_path / "o", workers=0)
    assert len(list((tmp_path / "o" / "points").glob("*.json"))) == 3
    monkeypatch.setattr(sw, "compute_point", real)
    again = run_sweep(spec, tmp_path / "o", workers=0)
    assert (again["resumed"], again["computed"]) == (3, 2)
    a, b = numbers(tmp_path / "ref"), numbers(tmp_path / "o")
    for k in a:
        assert np.array_equal(a[k], b[k]), k


@pytest.mark.slow
def test_follow_line_on_dask_is_one_task_per_point(tmp_path):
    """On Dask a followed line is a chain of one-point tasks (each point's file is written as its
    task returns), and the chain gives the serial line's numbers bit for bit."""
    pytest.importorskip("dask.distributed")
    body = 'method = "ode21"\nfollow = "sigma"\nmax_time = 3000.0\n[grid]\neta = 8.2e-5\nsigma = [-0.02, 0.0, 0.02]\n'
    spec = load_sweep(write_sweep(tmp_path, body))
    serial = run_sweep(spec, tmp_path / "serial", workers=0)
    dask = run_sweep(spec, tmp_path / "dask", workers=1)
    assert dask["where"]["tasks"] == 3 and dask["computed"] == serial["computed"] == 3
    a, b = numbers(tmp_path / "serial"), numbers(tmp_path / "dask")
    for k in a:
        assert np.array_equal(a[k], b[k], equal_nan=True), k


@pytest.mark.parametrize("grid,field", [
    ("U = { from = 0.0, to = 1.0, num = 10000000 }", "grid.U.num"),
    ("U = { from = 0.0, to = 1.0, num = 1000 }\neta = { from = 0.0, to = 1e-3, num = 1000 }\n"
     "sigma = { from = -0.1, to = 0.1, num = 1000 }", "grid"),
])
def test_grid_size_is_checked_from_the_nums_before_any_axis_is_built(tmp_path, grid, field):
    """10^9 points (three axes of 1000) are refused from the nums in milliseconds and without
    building an axis (tracemalloc: under 1 MB allocated)."""
    import time
    import tracemalloc

    from autocable.scene.sweep_schema import MAX_POINTS
    from autocable.spec import SpecError
    path = write_sweep(tmp_path, f"[grid]\n{grid}\n")
    tracemalloc.start()
    t0 = time.perf_counter()
    with pytest.raises(SpecError, match=f": {field}: .*{MAX_POINTS:,}"):
        load_sweep(path)
    elapsed = time.perf_counter() - t0
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert elapsed < 0.5 and peak < 1e6


def test_a_large_sweep_states_its_cost_and_refuses_a_disk_too_small(tmp_path, monkeypatch):
    """Above ESTIMATE_ABOVE points the sweep logs its least CPU time and disk before planning; with
    less free space than the point files need it is refused naming --out, before any file."""
    import shutil
    from collections import namedtuple

    from autocable.spec import SpecError
    from autocable.studies import sweep as sw
    monkeypatch.setattr(sw, "ESTIMATE_ABOVE", 2)
    spec = load_sweep(write_sweep(tmp_path, SMALL))
    lines = []
    run_sweep(spec, tmp_path / "o", workers=0, log=lines.append)
    expected = 3 / sw.FASTEST_RATE / 3600
    assert any(f"3 points: at least {expected:.3g} hours" in line for line in lines), lines
    usage = namedtuple("usage", "total used free")
    monkeypatch.setattr(shutil, "disk_usage", lambda p: usage(10**9, 10**9 - 100, 100))
    with pytest.raises(SpecError, match="--out: 3 points need up to .* GB of point files"):
        run_sweep(spec, tmp_path / "p", workers=0)
    assert not (tmp_path / "p" / "sweep.json").exists()


def test_a_folder_a_live_sweep_holds_is_refused_and_freed_when_it_ends(tmp_path):
    """A second sweep into the folder of a running one is refused naming --out and the process
    (the lock is held here by this process through `folder_lock`, as a running sweep holds it);
    once the holder is gone the folder is free, with no stale lock to clean."""
    import os
    import subprocess
    import sys

    from autocable.spec import SpecError
    from autocable.studies.sweep import folder_lock
    spec = load_sweep(write_sweep(tmp_path, SMALL))
    out = tmp_path / "o"
    holder = subprocess.Popen([sys.executable, "-c", "import sys, time\nfrom pathlib import Path\n"
                               "from autocable.studies.sweep import folder_lock\n"
                               f"with folder_lock(Path({str(out)!r})):\n    print('held', flush=True)\n"
                               "    time.sleep(60)\n"],
                              stdout=subprocess.PIPE, text=True, env=dict(os.environ, PYTHONPATH=str(REPO)))
    try:
        assert holder.stdout.readline().strip() == "held"
        with pytest.raises(SpecError, match=rf"--out: another autocable sweep \(process {holder.pid}\)"):
            run_sweep(spec, out, workers=0)
        assert not (out / "points").exists()
    finally:
        holder.kill()
        holder.wait()
    with folder_lock(out):            # the killed holder's lock went with it
        pass
    assert run_sweep(spec, out, workers=0)["computed"] == 3


@pytest.mark.slow
def test_dask_scratch_space_is_inside_the_cache(tmp_path, monkeypatch):
    """A LocalCluster sweep writes its Dask scratch space under $AUTOCABLE_CACHE/dask-scratch and
    nothing into the system temporary folder (TMPDIR pointed at an empty folder here)."""
    import tempfile
    pytest.importorskip("dask.distributed")
    from autocable._store import cache_root
    tmp = tmp_path / "systmp"
    tmp.mkdir()
    monkeypatch.setenv("TMPDIR", str(tmp))
    monkeypatch.setattr(tempfile, "tempdir", None)
    spec = load_sweep(write_sweep(tmp_path, 'method = "ame"\n[grid]\neta = 8.2e-5\nsigma = [0.0, 0.01]\n'))
    summary = run_sweep(spec, tmp_path / "o", workers=1)
    assert summary["computed"] == 2
    assert (cache_root() / "dask-scratch").is_dir() and any((cache_root() / "dask-scratch").iterdir())
    assert not any(p.name.startswith("dask") for p in tmp.rglob("*")), sorted(tmp.rglob("*"))


def test_workers_beyond_twice_the_cores_are_refused(tmp_path, capsys):
    import os

    from autocable.cli import main
    n = 2 * (os.cpu_count() or 1) + 1
    code = main(["sweep", str(write_sweep(tmp_path, SMALL)), "--out", str(tmp_path / "o"), "--workers", str(n)])
    err = capsys.readouterr().err
    assert code == 2 and f"--workers: {n} worker processes on {os.cpu_count()} cores" in err
    assert not (tmp_path / "o").exists()


def test_kill_bench_reads_a_sweep_folder_as_a_reader_would(tmp_path):
    """`python -m tools.hardening kill-surfaces`' reader: a finished sweep is complete and consistent; its sweep.json
    without the dataset, or with a dataset of other points, reads complete but inconsistent (what
    the trials count as read_as_complete_while_incomplete); no sweep.json is incomplete."""
    import shutil

    from tools.hardening.kill_surfaces import sweep_state
    spec = load_sweep(write_sweep(tmp_path, SMALL))
    out = tmp_path / "o"
    run_sweep(spec, out, workers=0)
    assert sweep_state(out) == {"status": "complete", "consistent": True, "why": ""}
    summary = json.loads((out / "sweep.json").read_text())
    (out / "sweep.json").write_text(json.dumps(dict(summary, points=4)))
    assert sweep_state(out)["consistent"] is False
    (out / "sweep.json").write_text(json.dumps(summary))
    (out / "sweep.nc").unlink()
    assert sweep_state(out)["consistent"] is False
    shutil.rmtree(out)
    assert sweep_state(out)["status"] == "incomplete"
