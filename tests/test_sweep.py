"""Sweeps as data on Dask: the sweep file, the dataset, Dask against serial,
resuming after a kill, and the build lock that lets workers share the compiled-model cache."""
import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

from autocable.cli import main
from autocable.scene.sweep_schema import DEFAULT_Q0, load_sweep
from autocable.spec import SpecError
from autocable.studies.sweep import RESPONSE_CLASSES, run_sweep
from conftest import legacy_path

REPO = Path(__file__).resolve().parents[1]
#: The legacy-sense sample (conftest.legacy_path): the known classes below (diverged at U* = 1.3)
#: are that reading's; the sample ("mirrored") stays bounded there.
MODEL = legacy_path()

xr = pytest.importorskip("xarray")
pytest.importorskip("dask.distributed")


def write_sweep(folder: Path, body: str, name="s.toml") -> Path:
    path = folder / name
    path.write_text(f'model = "{MODEL}"\n' + textwrap.dedent(body))
    return path


# A small mixed grid: rest (eta = 0), period-1 (Fig. 5a) and a diverged point (U = 1.3 > U_c).
SMALL = """
method = "shooting"
[grid]
U = [0.0, 1.3]
eta = [0.0, 8.2e-5]
sigma = { from = -0.02, to = 0.02, num = 3 }
"""


def load(out: Path):
    return xr.open_dataset(out / "sweep.nc", engine="scipy")


def same_numbers(a, b) -> None:
    for name in a.data_vars:
        if name == "wall_seconds":
            continue
        x, y = np.asarray(a[name].values), np.asarray(b[name].values)
        assert x.shape == y.shape, name
        assert np.array_equal(x, y, equal_nan=x.dtype.kind == "f"), name


@pytest.fixture(scope="module")
def serial(tmp_path_factory):
    folder = tmp_path_factory.mktemp("serial")
    spec = load_sweep(write_sweep(folder, SMALL))
    summary = run_sweep(spec, folder / "out", workers=0)
    return spec, folder / "out", summary


def test_serial_sweep_dataset(serial):
    """sweep.nc is self-describing: dims U, eta, sigma with their values, the response classes with
    a legend, amplitudes, envelopes and multipliers; provenance in the attributes. The classes are
    the known ones: rest at eta = 0 and U = 0, period-1 at Fig. 5a's eta, diverged at U = 1.3."""
    spec, out, summary = serial
    assert summary["computed"] == 12 and summary["resumed"] == 0 and summary["missing"] == 0
    ds = load(out)
    assert ds["a1"].dims == ("U", "eta", "sigma")
    assert list(ds["U"].values) == [0.0, 1.3] and list(ds["eta"].values) == [0.0, 8.2e-5]
    assert np.allclose(ds["sigma"].values, [-0.02, 0.0, 0.02], rtol=0, atol=1e-15)
    assert json.loads(ds["response"].attrs["legend"])["1"] == "period-1"
    resp = ds["response"].values
    assert (resp[0, 0] == RESPONSE_CLASSES.index("rest")).all()
    assert (resp[0, 1] == RESPONSE_CLASSES.index("period-1")).all()
    assert (resp[1] == RESPONSE_CLASSES.index("diverged")).all()
    assert np.isnan(ds["a1"].values[1]).all()
    assert ds["floquet_re"].shape == (2, 2, 3, 4)
    assert (ds["max_multiplier_modulus"].values[0] < 1).all()
    for key in ("model_hash", "sweep_hash", "versions", "settings", "sweep_text", "method"):
        assert key in ds.attrs
    assert json.loads(ds.attrs["versions"])["xarray"] == xr.__version__
    # the point at Fig. 5a, sigma = 0 equals a direct shooting call (the sweep adds nothing)
    from autocable.methods.integration.shooting import ShootingSolver
    from autocable.model.derive import derive
    from autocable.spec import load_model
    r = ShootingSolver(derive(load_model(MODEL)).ode).steady(0.0, 8.2e-5, 0.0)
    assert ds["a1"].values[0, 1, 1] == r.a1


def test_default_start_matches_ode21():
    from autocable.methods.integration.ode21 import DEFAULT_Q0 as ODE21_Q0
    assert DEFAULT_Q0 == ODE21_Q0


@pytest.mark.slow
def test_dask_sweep_with_two_workers_equals_serial(serial, tmp_path):
    """The same sweep on a LocalCluster of 2 worker processes: the same numbers, bit for bit (each
    point is computed independently from the same start by the same compiled code)."""
    spec, out, _ = serial
    summary = run_sweep(spec, tmp_path / "dask", workers=2, chunk=2)
    assert summary["where"]["mode"] == "LocalCluster" and len(summary["where"]["worker_pids"]) == 2
    assert summary["computed"] == 12
    same_numbers(load(out), load(tmp_path / "dask"))


@pytest.mark.slow
def test_killed_worker_sweep_completes_and_rerun_computes_nothing(serial, tmp_path):
    """A worker process killed (SIGKILL) while the sweep runs: Dask's nanny restarts it and the
    lost tasks run again, the sweep completes with the serial numbers; a rerun resumes every point
    (0 computed)."""
    spec, out, _ = serial
    killed = []

    def kill_one(client):
        pid = next(iter(client.run(os.getpid).values()))
        os.kill(pid, signal.SIGKILL)
        killed.append(pid)

    summary = run_sweep(spec, tmp_path / "k", workers=2, chunk=1, on_client=kill_one)
    assert killed and summary["computed"] == 12 and summary["missing"] == 0
    same_numbers(load(out), load(tmp_path / "k"))
    again = run_sweep(spec, tmp_path / "k", workers=2)
    assert again["resumed"] == 12 and again["computed"] == 0


@pytest.mark.slow
def test_interrupted_sweep_resumes_without_recomputing(serial, tmp_path):
    """`autocable sweep` killed mid-way (SIGKILL, serial mode so that the kill lands between
    points): the rerun counts the finished point files as resumed, computes only the others, and
    the dataset equals the uninterrupted sweep's."""
    spec, out, _ = serial
    dest = tmp_path / "int"
    env = dict(os.environ, PYTHONPATH=str(REPO))
    proc = subprocess.Popen([sys.executable, "-m", "autocable.cli", "sweep", str(spec.path), "--out", str(dest),
                             "--workers", "0", "--quiet"], env=env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    points = dest / "points"
    deadline = time.time() + 120
    while time.time() < deadline and proc.poll() is None:
        if points.is_dir() and len(list(points.glob("*.json"))) >= 3:
            break
        time.sleep(0.005)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    finished = len(list(points.glob("*.json")))
    assert 3 <= finished < 12          # killed mid-way, not after the end
    summary = run_sweep(spec, dest, workers=0)
    assert summary["resumed"] == finished and summary["computed"] == 12 - finished
    same_numbers(load(out), load(dest))


@pytest.mark.parametrize("body,field", [
    ('method = "shoot"\n', "method"),
    ('[grid]\nsigma = { from = -0.05, to = 0.05 }\n', "grid.sigma"),
    ('[grid]\nsigma = { from = -0.05, to = 0.05, num = 0 }\n', "grid.sigma.num"),
    ('[grid]\neta = -1e-4\n', "grid.eta"),
    ('[grid]\nomega = 1.0\n', "grid.omega"),
    ('[grid]\nU = [0.0, "fast"]\n', "grid.U[1]"),
    ('q0 = [0.0, 0.0]\n', "q0"),
    ('wind = 3\n', "wind"),
    ('follow = "omega"\n', "follow"),
    ('direction = "up"\n', "direction"),
    ('follow = "sigma"\ndirection = "left"\n', "direction"),
    ('method = "ame"\nfollow = "sigma"\n', "follow"),
])
def test_bad_sweep_file_is_one_line_naming_the_field(tmp_path, capsys, body, field):
    path = write_sweep(tmp_path, body)
    with pytest.raises(SpecError) as err:
        load_sweep(path)
    assert err.value.field == field
    assert main(["sweep", str(path), "--out", str(tmp_path / "o"), "--workers", "0"]) == 2
    msg = capsys.readouterr().err.strip()
    assert "\n" not in msg and str(path) in msg and field in msg


def test_bad_model_path_names_the_field(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text('model = "nowhere.toml"\n')
    with pytest.raises(SpecError, match=r"s\.toml: model: no such file"):
        load_sweep(path)


def test_relative_model_path_and_ranges(tmp_path):
    """The model path is relative to the sweep file; {from, to, num} is linspace (ends included)."""
    spec = load_sweep(REPO / "runs" / "sweep_fig05a.toml")
    assert spec.model == REPO / "models" / "luongo_zulli_2012.toml" and spec.method == "shooting"
    assert spec.shape == (1, 1, 21) and spec.sigma[0] == -0.05 and spec.sigma[-1] == 0.05
    assert spec.sigma[10] == pytest.approx(0.0, abs=1e-17)


def test_start_axis(tmp_path):
    """[grid] start adds a `start` dimension: from rest Fig. 5a's response; from a large start at
    Fig. 6's sigma = -0.02 the bi-modal response (a2 > 0) as from rest (the same attractor)."""
    body = """
    method = "shooting"
    [grid]
    eta = 1.4e-3
    sigma = -0.02
    start = [[0.0, 0.0, 1e-6, 0.0], [0.004, 0.0, 0.004, 0.0]]
    """
    spec = load_sweep(write_sweep(tmp_path, body))
    run_sweep(spec, tmp_path / "o", workers=0)
    ds = load(tmp_path / "o")
    assert ds["a1"].dims == ("U", "eta", "sigma", "start") and ds["start_q0"].shape == (2, 4)
    assert (ds["a2"].values > 1e-3).all()


def test_build_lock_two_processes_one_compile(tmp_path):
    """Two processes asking for the same compiled integrator in an empty cache at once: one compiles
    (the file lock of the cache), the other waits and loads the same library; both integrate."""
    code = textwrap.dedent("""
        import json, sys
        import sympy as sp
        from autocable.codegen.cintegrate import compiled_integrator
        x, k = sp.symbols("x k")
        c = compiled_integrator("locktest", ("x",), ("k",), (-k * x,), None)
        r = c.run([1.0], [0.0, 1.0], [2.0], rtol=1e-10, atol=1e-12)
        print(json.dumps({"compile_s": dict(c.timings)["compile_s"], "x1": float(r.y[-1][0])}))
    """)
    env = dict(os.environ, PYTHONPATH=str(REPO), AUTOCABLE_CACHE=str(tmp_path / "cache"))
    procs = [subprocess.Popen([sys.executable, "-c", code], env=env, stdout=subprocess.PIPE, text=True)
             for _ in range(2)]
    outs = [json.loads(p.communicate(timeout=120)[0]) for p in procs]
    assert sorted(o["compile_s"] > 0 for o in outs) == [False, True]
    for o in outs:
        assert o["x1"] == pytest.approx(np.exp(-2.0), rel=1e-9)


def test_existing_scheduler(serial, tmp_path):
    """`scheduler=ADDRESS` (`--scheduler`) submits to a running Dask scheduler instead of starting a
    LocalCluster: the same numbers as the serial sweep."""
    import logging

    from dask.distributed import LocalCluster
    spec, out, _ = serial
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False, dashboard_address=None,
                      silence_logs=logging.ERROR) as cluster:
        summary = run_sweep(spec, tmp_path / "s", scheduler=cluster.scheduler_address)
    assert summary["where"]["mode"] == "scheduler" and summary["computed"] == 12
    same_numbers(load(out), load(tmp_path / "s"))


def test_failed_point_is_reported_not_written(tmp_path, monkeypatch):
    """A point whose computation fails (here the solver raises a `ComputationError` at sigma = -0.01,
    as a Newton or integrator failure would; the sweep file itself is valid) is reported with its
    reason and left out (response -1, not computed); the other points are kept; a rerun tries only
    the failed one again."""
    from autocable.errors import ComputationError
    from autocable.methods.integration import shooting
    steady = shooting.ShootingSolver.steady

    def failing(self, U, eta, sigma, *args, **kwargs):
        if sigma < 0:
            raise ComputationError(f"the integrator stopped at a bounded state (sigma = {sigma})")
        return steady(self, U, eta, sigma, *args, **kwargs)

    monkeypatch.setattr(shooting.ShootingSolver, "steady", failing)
    spec = load_sweep(write_sweep(tmp_path, 'method = "shooting"\n[grid]\neta = 8.2e-5\nsigma = [-0.01, 0.0]\n'))
    summary = run_sweep(spec, tmp_path / "o", workers=0)
    assert summary["computed"] == 1 and summary["missing"] == 1
    assert len(summary["failed"]) == 1 and "stopped at a bounded state" in summary["failed"][0]["error"]
    assert list(load(tmp_path / "o")["response"].values.ravel()) == [-1, RESPONSE_CLASSES.index("period-1")]
    again = run_sweep(spec, tmp_path / "o", workers=0)
    assert again["resumed"] == 1 and again["computed"] == 0 and len(again["failed"]) == 1


SIGMAS_11 = [round(-0.05 + 0.01 * k, 12) for k in range(11)]


@pytest.fixture(scope="module")
def followed(tmp_path_factory):
    """Fig. 6's setting swept up and down in sigma, each point from its neighbour's response:
    by `follow` with shooting and with ode21, and by `methods.integration.sweeps` (the brute-force
    up/down sweeps of the overlays, an independent implementation)."""
    from autocable.methods.integration.ode21 import Ode21Integrator
    from autocable.methods.integration.sweeps import sweep
    from autocable.model.derive import derive
    from autocable.spec import load_model
    folder = tmp_path_factory.mktemp("follow")
    integ = Ode21Integrator(derive(load_model(MODEL)).ode, engine="compiled")
    out = {}
    for direction in ("up", "down"):
        ref = sorted(sweep(integ, "sigma", SIGMAS_11, {"U": 0.0, "eta": 1.4e-3}, directions=(direction,)),
                     key=lambda p: p.value)
        out[("ref", direction)] = (np.array([p.a1 for p in ref]), np.array([p.a2 for p in ref]))
        for method in ("ode21", "shooting"):
            body = (f'method = "{method}"\nfollow = "sigma"\ndirection = "{direction}"\n[grid]\n'
                    f'eta = 1.4e-3\nsigma = {SIGMAS_11}\n')
            spec = load_sweep(write_sweep(folder, body, f"{method}-{direction}.toml"))
            dest = folder / f"{method}-{direction}"
            run_sweep(spec, dest, workers=0)
            out[(method, direction)] = (spec, dest)
    return out


@pytest.mark.slow
def test_follow_sweeps_up_and_down_like_the_brute_force_sweeps(followed):
    """With follow, ode21 reproduces `sweeps.sweep` bit for bit (the same carried starts) and
    shooting, started by Newton from the neighbour's orbit, the same responses to 1e-6; up and
    down differ above resonance (the hysteresis of Fig. 6: the upper branch is kept going up to
    sigma = 0.05, the small response taken going down)."""
    for direction in ("up", "down"):
        r1, r2 = followed[("ref", direction)]
        size = np.maximum(r1, r2)
        for method in ("ode21", "shooting"):
            ds = load(followed[(method, direction)][1])
            a1, a2 = ds["a1"].values.ravel(), ds["a2"].values.ravel()
            tol = 0.0 if method == "ode21" else 1e-6
            assert np.all(np.abs(a1 - r1) <= tol * size) and np.all(np.abs(a2 - r2) <= tol * size), (method, direction)
            assert (ds["response"].values == RESPONSE_CLASSES.index("period-1")).all()
    up, down = followed[("ref", "up")][0], followed[("ref", "down")][0]
    assert up[-1] > 1e-2 and down[-1] < 1e-3


@pytest.mark.slow
def test_follow_resumes_from_the_finished_neighbour(followed):
    """Point files removed from the middle of a followed line (an interrupted sweep): the rerun
    computes only those, starting from the finished neighbour's stored state, on a 2-worker
    LocalCluster, and the dataset equals the uninterrupted one."""
    import shutil
    spec, dest = followed[("shooting", "up")]
    copy = dest.parent / "resume-copy"
    shutil.copytree(dest, copy)
    files = sorted((copy / "points").glob("*.json"), key=lambda p: json.loads(p.read_text())["sigma"])
    for p in files[4:7]:
        p.unlink()
    (copy / "sweep.nc").unlink()
    summary = run_sweep(spec, copy, workers=2)
    assert summary["resumed"] == 8 and summary["computed"] == 3
    same_numbers(load(dest), load(copy))


class _OneTaskKilled:
    """A stand-in `Executor` in this process: runs the tasks in order, but hands the second back
    as Dask does a task whose workers kept dying (``KilledWorker``), without running it."""

    def __init__(self, workers, scheduler, **kwargs):
        self.client, self.where, self.n_workers, self.tasks = None, {"mode": "LocalCluster"}, 1, []

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return None

    def run_on_workers(self, fn):
        return {"w": fn()}

    def submit(self, label, fn, *args, priority=0):
        self.tasks.append((label, fn, args))

    def completed(self):
        from autocable.executor import Done
        for k, (label, fn, args) in enumerate(self.tasks):
            if k == 1:
                yield Done(label, None, f"KilledWorker: attempted to run task {label} on 3 different "
                                        "workers, but all those workers died")
            else:
                yield Done(label, fn(*args))

    def worker_pids(self):
        return [os.getpid()]


def test_a_task_the_workers_cannot_finish_is_a_named_failure_and_the_points_stay(tmp_path, monkeypatch, capsys):
    """A sweep task that fails as a whole (compute_chunk keeps each point's own failure, so this is
    the infrastructure: Dask's KilledWorker after repeated worker deaths) stops the sweep with one
    line, exit 3, naming the workers, the points kept and the rerun; before, a bare RuntimeError
    reached the catch-all (exit 2, unnamed). The points of the task that finished are kept and a
    serial rerun resumes them."""
    import autocable.executor as executor
    from autocable.errors import ComputationError
    monkeypatch.setattr(executor, "Executor", _OneTaskKilled)
    path = write_sweep(tmp_path, 'method = "shooting"\n[grid]\neta = 8.2e-5\nsigma = [-0.01, 0.0, 0.01, 0.02]\n')
    spec = load_sweep(path)
    with pytest.raises(ComputationError) as err:
        run_sweep(spec, tmp_path / "o", workers=2, chunk=1)
    msg = str(err.value)
    assert "\n" not in msg and "--workers 2" in msg and "KilledWorker" in msg and "run the same command" in msg
    assert "1 point(s) computed are kept" in msg
    with pytest.raises(ComputationError, match=r"on the workers of --workers 1 "):      # the default: named
        run_sweep(spec, tmp_path / "default", workers=None, chunk=1)
    assert len(list((tmp_path / "o" / "points").glob("*.json"))) == 1
    assert main(["sweep", str(path), "--out", str(tmp_path / "cli"), "--workers", "2", "--chunk", "1"]) == 3
    line = capsys.readouterr().err.strip().splitlines()[-1]
    assert line.startswith("autocable: failed: sweep: task sweep:2 failed") and "Traceback" not in line
    monkeypatch.undo()
    again = run_sweep(spec, tmp_path / "o", workers=0)
    assert again["resumed"] == 1 and again["computed"] == 3 and again["missing"] == 0
