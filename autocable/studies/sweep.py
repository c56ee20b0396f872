"""Brute-force maps of eq. (21) over (U*, eta*, sigma) as one dataset, on Dask.

What it computes. At every point of a sweep file's grid (`autocable.scene.sweep_schema`) the steady
response reached from the start q0 by one method: ``shooting`` (`methods.integration.shooting`:
Newton on the period map after a short transient, Floquet multipliers, the response class),
``ode21`` (transient integration of eq. (21) with the compiled DOP853, classified afterwards, the
multipliers of the period map at the state it ends in when that is periodic) or ``ame`` (the
Cartesian AME (24) integrated to its steady state; no Floquet multipliers).

With ``follow = AXIS`` (and ``direction``) each line of the grid along that axis is swept in
order, every point starting from its neighbour's response (shooting: Newton from the neighbour's
orbit, judged by integration from it; ode21: integration from its end state plus q0, exactly as
`methods.integration.sweeps`): the two sides of a hysteresis loop, and fewer transients. A line
is a chain of one-point tasks (``chunk`` points each), each depending on the one before, so every
point reaches its file as it finishes: an interrupted line keeps its finished points.

Where. Points are grouped into small tasks and run on a ``dask.distributed`` cluster: a
`LocalCluster` of one single-threaded worker process per core by default (``workers``), or an
existing scheduler (``scheduler`` address); ``workers=0`` runs them in this process, in order (the
serial reference). A worker derives eq. (21) and loads the compiled integrators once per model
(`model_context`); the integrators come from the content-hashed cache, whose builds are serialised by a
file lock (`codegen.cintegrate`, `codegen.ckernel._lock`): two workers of one machine never build
the same library into the same place at once, the second loads what the first built, and a worker
on another machine with its own cache builds its own.

Streaming and resuming. The client writes each finished point to ``DIR/points/<key>.json`` as its
task returns (the key hashes the model, method, settings and the point), so an interrupted sweep
loses at most the points in flight: a rerun finds the files, counts them as resumed and computes
only the rest. ``DIR/sweep.nc`` (xarray, NetCDF 3 through scipy) is assembled from the point files
at the end: dims U, eta, sigma (and start), data variables a1, a2, their envelopes, the response
class (int8 with CF flag_values/flag_meanings), ``bimodal`` (a period-1 response whose a2 is not
slaved to a1, by structure: `bimodal_flag`), the Floquet multipliers (real and imaginary parts,
dim ``multiplier``), provenance in the attributes. ``DIR/sweep.json`` holds the run's summary.
"""
from __future__ import annotations

import functools
import json
import math
import os
import time
from pathlib import Path

import numpy as np

from autocable._store import atomic_write_json, atomic_write_text, content_hash
# the scheduler check lives with the executor every command shares (re-exported for older imports)
from autocable.executor import SCHEDULER_TIMEOUT, check_scheduler  # noqa: F401
from autocable.scene.sweep_schema import AXES, SweepSpec

#: Bump when a point record changes meaning (part of every point key). 2: eta* = 0 cycles are
#: autonomous-periodic (were quasi-periodic).
POINT_FORMAT = "2"
#: Codes of the `response` variable: `shooting.RESPONSE_CLASSES` in order; -1 marks a point not
#: computed (an interrupted sweep assembled anyway).
RESPONSE_CLASSES = ("rest", "period-1", "period-2", "quasi-periodic", "diverged", "autonomous-periodic")
NOT_COMPUTED = -1
#: Below this amplitude a steady response is the rest state (`ode21`'s rest floor, 1e3 x atol).
REST_FLOOR = 1e-10
#: Above this many points a sweep states what it will cost before it starts (`estimate`).
ESTIMATE_ABOVE = 100_000
#: Points per second and worker of the easiest sweeps: shooting over runs/sweep_U_eta.toml
#: measured 165-185 points/s on 2 workers (docs/benchmarks.md); harder points cost seconds.
FASTEST_RATE = 90.0
#: A point file's bytes (about 700) rounded up to what a filesystem gives the smallest file.
POINT_FILE_BYTES = 1024


# -- one point ----------------------------------------------------------------------------------

@functools.lru_cache(maxsize=4)
def model_context(model, method: str):
    """(derivation, solver) of one model on this worker, built once per process. ``model`` is the
    `ModelSpec` (frozen, hashable): it travels to the workers by value, so a worker on another
    machine needs no copy of the model file."""
    from autocable.model.derive import derive
    d = derive(model)
    if method == "ame":
        from autocable.methods.integration.ame import AmeIntegrator
        from autocable.model.ame_cache import derive_ame
        return d, AmeIntegrator(derive_ame(d).ame)
    from autocable.methods.integration.shooting import ShootingSolver
    solver = ShootingSolver(d.ode)
    # Load (or build, under the cache's file lock) both compiled integrators now, not in a point.
    solver._variational()
    solver.integrator._c_integrator()
    return d, solver


def _finite(x):
    x = float(x)
    return x if math.isfinite(x) else None


def _record(kind, a, env, mu, periods, steady, t_end, wall, message, fallback=False, state=()) -> dict:
    state = [_finite(v) for v in state]
    return {"response": kind, "a1": _finite(a[0]), "a2": _finite(a[1]), "state0": state,
            "a1_min": _finite(env[0]), "a1_max": _finite(env[1]),
            "a2_min": _finite(env[2]), "a2_max": _finite(env[3]),
            "multipliers": [[float(m.real), float(m.imag)] for m in mu], "periods": int(periods),
            "steady": bool(steady), "t_end": _finite(t_end), "wall_seconds": float(wall),
            "message": message, "fallback": bool(fallback)}


def _carried_start(carried, q0) -> tuple:
    """The start (q1, q1', q2, q2') from a neighbour's state (q1, q2, q1', q2') plus the offset q0
    (as `methods.integration.sweeps` carries states: the q2 seed is kept, so a planar response
    cannot hide an out-of-plane instability)."""
    c = carried
    return (c[0] + q0[0], c[2] + q0[1], c[1] + q0[2], c[3] + q0[3])


def compute_point(model, method: str, U: float, eta: float, sigma: float, q0, max_time: float,
                  carried=None) -> dict:
    """The record of one grid point (plain JSON values; non-finite numbers are None). ``carried``:
    a neighbour's state (q1, q2, q1', q2') at forcing phase 0 (a sweep with ``follow``): shooting
    tries Newton from it first, and both methods integrate from it (plus q0) otherwise."""
    d, solver = model_context(model, method)
    start = time.perf_counter()
    if carried is not None:
        q0 = _carried_start(carried, q0)
    if method == "shooting":
        r = solver.steady(U, eta, sigma, q0, max_time=max_time, guess=carried)
        rec = _record(r.response, (r.a1, r.a2), (r.a1_min, r.a1_max, r.a2_min, r.a2_max), r.multipliers,
                      r.periods, r.steady, r.t_end, r.wall_seconds, r.message, r.fallback, r.state0)
        if r.response == "period-1":
            rec["bimodal"] = bimodal_flag(model, U, eta, sigma, r.state0, r.Omega)
        return rec
    if method == "ode21":
        r = solver.integrator.simulate(U, eta, sigma, q0, max_time=max_time)
        a, env = (r.a1, r.a2), (r.a1_min, r.a1_max, r.a2_min, r.a2_max)
        if not math.isfinite(r.a1):
            return _record("diverged", a, env, [], 0, False, r.t_end, time.perf_counter() - start, r.message,
                           state=r.final_state)
        mu, kind, periods = [], "quasi-periodic", 0
        if r.steady and max(a) < REST_FLOOR:
            kind, periods = "rest", 1
        elif r.steady and r.periodic and r.autonomous:
            # eta* = 0: a cycle of its own period (ode21, "Autonomous responses"); its multipliers
            # by autonomous shooting from the end state, the trivial 1 left out
            kind, periods = "autonomous-periodic", 1
            got = solver.cycle(U, eta, r.Omega, np.asarray(r.final_state), judge=False)
            if got is not None and "multipliers" in got:
                mu = got["multipliers"]
            return _record(kind, a, env, mu, periods, r.steady, r.t_end, time.perf_counter() - start,
                           r.message, state=r.final_state)
        elif r.steady and r.periodic:
            kind, periods = "period-1", 1
        elif r.steady:
            # the transient ends on a whole forcing period: is its end state on a period-2 orbit?
            got = solver.flow(U, eta, r.Omega, r.final_state, 2)
            y = np.asarray(r.final_state)
            if got is not None and np.linalg.norm(got[0] - y) <= 1e-6 * np.linalg.norm(y):
                kind, periods = "period-2", 2
        if periods:
            from autocable.methods.integration.floquet21 import multipliers_of
            got = solver.flow(U, eta, r.Omega, r.final_state, periods)
            mu = multipliers_of(got[1]) if got is not None else []
        rec = _record(kind, a, env, mu, periods, r.steady, r.t_end, time.perf_counter() - start, r.message,
                      state=r.final_state)
        if kind == "period-1":
            rec["bimodal"] = bimodal_flag(model, U, eta, sigma, r.final_state, r.Omega)
        return rec
    r = solver.simulate(U, eta, sigma, q0, max_time=max_time)
    a, env = (r.a1, r.a2), (r.a1_min, r.a1_max, r.a2_min, r.a2_max)
    if not math.isfinite(r.a1) or not math.isfinite(r.a2):
        kind = "diverged"
    elif r.steady and r.periodic:
        kind = "rest" if max(a) < REST_FLOOR else "period-1"
    else:
        kind = "quasi-periodic"     # a limit cycle of the AME: amplitude-modulated q
    rec = _record(kind, a, env, [], 1 if kind in ("rest", "period-1") else 0, r.steady, r.t_end,
                  time.perf_counter() - start, r.message)
    if kind == "period-1":
        rec["bimodal"] = bimodal_flag(model, U, eta, sigma, r.final_state)
    return rec


@functools.lru_cache(maxsize=4)
def _ame_systems(model):
    """The Cartesian AME (24) of a model with and without its wind rows (the wind rows carry 1/U:
    at U* = 0 the system without them), built once per worker."""
    from autocable.methods.continuation.system import ame_system
    from autocable.model.ame_cache import derive_ame
    from autocable.model.derive import derive
    ame = derive_ame(derive(model)).ame
    return ame_system(ame, "2dof", wind=True), ame_system(ame, "2dof", wind=False)


def bimodal_flag(model, U: float, eta: float, sigma: float, x0, Omega: float | None = None) -> int:
    """Whether a period-1 response is bi-modal by structure (`regions.a2_slaved`): 1 when the AME
    equilibrium it lies on has an a2 not slaved to a1, 0 when slaved, -1 undecided (no AME
    equilibrium within the AME-vs-(21) study's NEAR of it: the AME cannot say). ``x0``: the AME
    state (r1, s1, r2, s2), or with ``Omega`` an eq. (21) state (q1, q2, q1', q2') at forcing phase
    0, read to first order as q_k = r_k cos(Omega t) - s_k sin(Omega t)."""
    from autocable.methods.regions import a2_slaved, refine_equilibrium
    from autocable.studies.ame_bounds import NEAR
    system = _ame_systems(model)[0 if U != 0 else 1]
    x0 = np.asarray(x0, float)
    if Omega is not None:
        x0 = np.array([x0[0], -x0[2] / Omega, x0[1], -x0[3] / Omega])
    p = system.parameter_vector({"U": U, "eta": eta, "sigma": sigma})
    y, ok = refine_equilibrium(system, x0, p)
    a0 = np.array([math.hypot(x0[0], x0[1]), math.hypot(x0[2], x0[3])])
    a = np.array([math.hypot(y[0], y[1]), math.hypot(y[2], y[3])])
    if not ok or np.linalg.norm(a - a0) > NEAR * np.linalg.norm(a0):
        return -1
    return int(a2_slaved(system, y, p) is False)


def _warm(model, method: str) -> int:
    model_context(model, method)
    return os.getpid()


def carry_from(rec: dict):
    """The state a neighbour starts from: a bounded response's, else None (start from q0)."""
    st = rec.get("state0") or []
    # as `methods.integration.sweeps`: only a steady, bounded response is carried
    if ("error" in rec or rec.get("response") == "diverged" or not rec.get("steady")
            or len(st) != 4 or any(v is None for v in st)):
        return None
    return tuple(st)


def compute_chunk(model, method: str, max_time: float, units, follow: bool = False, emit=None) -> list:
    """[(key, record)] of a list of units, one Dask task. A unit is (carried, points): points
    (key, U, eta, sigma, q0) computed in order; with ``follow`` each starts from the previous one's
    response (the first from ``carried``, a finished neighbour's state, or from q0 when None).
    ``emit(key, record)``: called as each point finishes (the serial sweep's sink, so that an
    interrupted line keeps its finished points)."""
    out = []
    for carried, points in units:
        for key, U, eta, sigma, q0 in points:
            try:
                rec = compute_point(model, method, U, eta, sigma, q0, max_time, carried if follow else None)
            except Exception as exc:  # noqa: BLE001 - one failed point must not stop the sweep
                text = str(exc).strip().splitlines()
                rec = {"error": f"{type(exc).__name__}: {text[0] if text else ''}"[:300]}
            rec.update({"U": U, "eta": eta, "sigma": sigma, "q0": list(q0), "pid": os.getpid()})
            out.append((key, rec))
            if emit is not None:
                emit(key, rec)
            if follow:
                carried = carry_from(rec)
    return out


def compute_segment(model, method: str, max_time: float, points, previous=None, carried=None) -> list:
    """[(key, record)] of consecutive points of a followed line, one Dask task: started from
    ``previous`` (the result of the segment before it, a Dask dependency resolved on the workers)
    or, for a line's first segment, from ``carried``. A line is a chain of such tasks, so each
    segment reaches the client (and its point files) as soon as it finishes, not with the line."""
    if previous:
        carried = carry_from(previous[-1][1])
    return compute_chunk(model, method, max_time, [(carried, points)], True)


class _Sink:
    """Where finished points go: a point file each; a failed point is counted and reported, not
    written (it stays not computed in the dataset, and a rerun tries it again)."""

    def __init__(self, folder: Path, progress: "_Progress", log):
        self.folder, self.progress, self.log = folder, progress, log
        self.computed = 0
        self.failed = []

    def take(self, key: str, rec: dict) -> None:
        if "error" in rec:
            self.failed.append({k: rec[k] for k in ("U", "eta", "sigma", "q0", "error")})
            if self.log:
                self.log(f"sweep: point U={rec['U']:g} eta={rec['eta']:g} sigma={rec['sigma']:g} failed: "
                         f"{rec['error']}")
        else:
            _write_point(self.folder, key, rec)
            self.computed += 1
        self.progress.step()


# -- the sweep ----------------------------------------------------------------------------------

def sweep_hash(spec: SweepSpec, model) -> str:
    """What makes a point's result: the model, method and settings (not the grid)."""
    from autocable.methods.integration.shooting import SHOOTING_VERSION
    what = {"model": model.content_hash(), "method": spec.method, "max_time": spec.max_time,
            "format": POINT_FORMAT, "shooting": SHOOTING_VERSION}
    if spec.follow:
        what.update(follow=spec.follow, direction=spec.direction)
    return content_hash(what)


def point_key(shash: str, U, eta, sigma, q0, after: str | None = None) -> str:
    """A point's file name: its settings and parameters, and with ``follow`` the key of the point
    it starts from (``after``), so that a changed line never reuses a stale neighbour's result."""
    what = {"sweep": shash, "U": float(U), "eta": float(eta), "sigma": float(sigma),
            "q0": [float(v) for v in q0]}
    if after is not None:
        what["after"] = after
    return content_hash(what)


def _plan(spec: SweepSpec, shash: str, folder: Path):
    """(grid, units, resumed, damaged): grid rows (idx, key, U, eta, sigma, q0) for the dataset;
    the units still to compute (see `compute_chunk`): single points, or with ``follow`` the runs
    of unfinished consecutive points of each line, started from the finished point before the run.
    A point file that is not a valid record of its own point (emptied, truncated, edited, copied
    from another point) is removed and its point computed again (``damaged`` counts them)."""
    have = {p.stem for p in folder.glob("*.json")}
    grid, units, resumed, damaged = [], [], 0, 0
    for line in spec.lines():
        prev_key, run, carried = None, [], None
        for idx in line:
            U, eta, sigma, q0 = spec.point(idx)
            key = point_key(shash, U, eta, sigma, q0, prev_key if spec.follow else None)
            grid.append((idx, key, U, eta, sigma, q0))
            rec = read_valid_point(folder / f"{key}.json", U, eta, sigma, q0) if key in have else None
            if key in have and rec is None:
                damaged += 1
                (folder / f"{key}.json").unlink(missing_ok=True)
            if rec is not None:
                resumed += 1
                if run:
                    units.append((carried, run))
                    run = []
                carried = carry_from(rec) if spec.follow else None
            else:
                run.append((key, U, eta, sigma, q0))
            prev_key = key
        if run:
            units.append((carried, run))
    order = {idx: k for k, idx in enumerate(spec.points_order())}
    grid.sort(key=lambda row: order[row[0]])
    return grid, units, resumed, damaged


def _write_point(folder: Path, key: str, rec: dict) -> None:
    """One point file, atomically (no fsync: a crash loses at most the point being written, which a
    rerun computes again)."""
    atomic_write_text(folder / f"{key}.json", json.dumps(rec, allow_nan=False), fsync=False)


def _read_point(path: Path):
    try:
        with open(path, encoding="utf-8") as fh:
            return json.load(fh)
    except (OSError, ValueError):
        return None


def _is_number(v, *, optional: bool = True) -> bool:
    if v is None:
        return optional
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def valid_point(rec, U, eta, sigma, q0) -> bool:
    """Whether ``rec`` is a complete record (as `_record` writes it) of the point (U, eta, sigma,
    q0): every field present with its type, finite numbers or None where a value may be missing,
    and the point's own parameters (a file copied under another point's name is not its record)."""
    if not isinstance(rec, dict) or rec.get("response") not in RESPONSE_CLASSES:
        return False
    if not all(_is_number(rec.get(k, 0.0)) and k in rec
               for k in ("a1", "a2", "a1_min", "a1_max", "a2_min", "a2_max", "t_end")):
        return False
    if not _is_number(rec.get("wall_seconds"), optional=False):
        return False
    periods = rec.get("periods")
    if isinstance(periods, bool) or not isinstance(periods, int) or not 0 <= periods <= 127:
        return False
    if not all(isinstance(rec.get(k), bool) for k in ("steady", "fallback")):
        return False
    mu = rec.get("multipliers")
    if not isinstance(mu, list) or not all(isinstance(m, list) and len(m) == 2
                                           and all(_is_number(v, optional=False) for v in m) for m in mu):
        return False
    state = rec.get("state0")
    if not isinstance(state, list) or len(state) not in (0, 4) or not all(_is_number(v) for v in state):
        return False
    if not isinstance(rec.get("message", ""), str):
        return False
    given = [rec.get("U"), rec.get("eta"), rec.get("sigma")] + list(rec.get("q0") or [])
    wanted = [U, eta, sigma] + list(q0)
    return (len(given) == len(wanted) and all(_is_number(v, optional=False) for v in given)
            and all(float(a) == float(b) for a, b in zip(given, wanted)))


def read_valid_point(path: Path, U, eta, sigma, q0):
    """The record in ``path`` when it is a valid record of this point (`valid_point`), else None."""
    rec = _read_point(path)
    return rec if valid_point(rec, U, eta, sigma, q0) else None


class _Progress:
    """Points done, rate and time left, at most once a second (and at the end)."""

    def __init__(self, total: int, resumed: int, log):
        self.total, self.resumed, self.log = total, resumed, log
        self.done = 0
        self.t0 = time.perf_counter()
        self.last = -math.inf

    def start(self) -> None:
        """The task phase begins (after the cluster's start-up): the rate counts from here."""
        self.t0 = time.perf_counter()

    def step(self, n: int = 1) -> None:
        self.done += n
        now = time.perf_counter()
        if self.log is None or (now - self.last < 1.0 and self.resumed + self.done < self.total):
            return
        self.last = now
        rate = self.done / max(now - self.t0, 1e-9)
        left = self.total - self.resumed - self.done
        self.log(f"sweep: {self.resumed + self.done}/{self.total} points ({self.resumed} resumed), "
                 f"{rate:.1f} points/s, ~{left / rate if rate > 0 else math.inf:.0f} s left")


def _chunks(items: list, size: int) -> list:
    """Tasks of about ``size`` points, strided through the grid: neighbouring points cost alike
    (a slow corner of the grid, e.g. the bi-modal region of Fig. 6, is spread over all tasks)."""
    n = max(1, math.ceil(len(items) / size))
    return [items[k::n] for k in range(n)]


def estimate(points: int, workers: int, folder: Path) -> dict:
    """What ``points`` still to compute will cost at least: CPU hours at `FASTEST_RATE` per worker,
    and the disk of their point files (one filesystem block each, at least `POINT_FILE_BYTES`)
    against the space free under ``folder``."""
    import shutil
    try:
        block = max(POINT_FILE_BYTES, os.statvfs(folder).f_bsize)
    except (OSError, AttributeError):
        block = 4096
    return {"points": points, "hours_at_least": points / (FASTEST_RATE * max(workers, 1)) / 3600,
            "disk_bytes": points * block, "free_bytes": shutil.disk_usage(folder).free}


#: The lock a running sweep holds on its output folder (an advisory ``flock``: released by the
#: kernel when the process ends, however it ends).
LOCK_NAME = ".autocable-sweep.lock"


def folder_lock(out: Path):
    """Hold the sweep lock of ``out`` (`autocable.run_folder.folder_lock`): two sweeps into one
    folder would each remove the other's sweep.nc and mix their summaries."""
    from autocable.run_folder import folder_lock as lock
    return lock(out, LOCK_NAME, "sweep")


def run_sweep(spec: SweepSpec, out_dir, **kwargs) -> dict:
    """Run a sweep into ``out_dir`` (points/, sweep.nc, sweep.json) under the folder's lock
    (`folder_lock`); returns the summary. Keywords: `run_sweep_unlocked`'s."""
    from autocable.model.premises import ArgumentError
    if not isinstance(spec, SweepSpec):
        raise ArgumentError("run_sweep", "spec", f"expected a SweepSpec (load_sweep(path)), got {type(spec).__name__}")
    for name, lo in (("workers", 0), ("chunk", 1)):
        value = kwargs.get(name)
        if value is not None and (isinstance(value, bool) or not isinstance(value, int) or value < lo):
            raise ArgumentError("run_sweep", name, f"expected a whole number >= {lo} or None, got {value!r}")
    if kwargs.get("scheduler") is not None:
        check_scheduler(kwargs["scheduler"])   # before any work: a dead or foreign address is named at once
    with folder_lock(Path(out_dir)):
        return run_sweep_unlocked(spec, out_dir, **kwargs)


def run_sweep_unlocked(spec: SweepSpec, out_dir, *, workers: int | None = None, scheduler: str | None = None,
                       chunk: int | None = None, log=None, cluster_kwargs: dict | None = None,
                       on_client=None) -> dict:
    """Run a sweep into ``out_dir`` (points/, sweep.nc, sweep.json); returns the summary.

    ``workers``: LocalCluster worker processes (default: one per core; 0: serial in this process);
    ``scheduler``: the address of an existing Dask scheduler (then ``workers`` is ignored);
    ``chunk``: units per task, a unit being a point, or with ``follow`` a line (default: about eight
    tasks per worker, at most 16 points each; with ``follow`` one line per task);
    ``on_client``: called with the Dask client once the tasks are submitted (tests)."""
    from autocable.spec import load_model
    model = load_model(spec.model)
    out = Path(out_dir)
    folder = out / "points"
    folder.mkdir(parents=True, exist_ok=True)
    # The dataset and summary describe a finished sweep: an earlier one's must not pass for this
    # one's if this one is stopped (the points stay: a rerun resumes from them).
    for done in ("sweep.json", "sweep.nc"):
        (out / done).unlink(missing_ok=True)
    shash = sweep_hash(spec, model)
    if spec.size > ESTIMATE_ABOVE:
        n_workers = 1 if workers == 0 and scheduler is None else workers or (os.cpu_count() or 1)
        cost = estimate(spec.size, n_workers, folder)
        if cost["disk_bytes"] > cost["free_bytes"]:
            from autocable.spec import SpecError
            raise SpecError("arguments", "--out", f"{spec.size:,} points need up to {cost['disk_bytes'] / 1e9:.3g} GB "
                            f"of point files and {out} has {cost['free_bytes'] / 1e9:.3g} GB free; give a folder "
                            "with more space or a smaller grid")
        if log:
            log(f"sweep: {spec.size:,} points: at least {cost['hours_at_least']:.3g} hours on "
                f"{n_workers} workers (at the fastest rate measured, {FASTEST_RATE:g} "
                f"points/s a worker), up to {cost['disk_bytes'] / 1e9:.3g} GB of point files; planning the "
                f"grid first (about 15 s a million points)")
    grid, todo, resumed, damaged = _plan(spec, shash, folder)
    progress = _Progress(len(grid), resumed, log)
    if log:
        log(f"sweep {spec.path.name}: {len(grid)} points, method {spec.method}"
            + (f", following {spec.follow} {spec.direction}" if spec.follow else "")
            + f"; {resumed} already computed (resumed), {len(grid) - resumed} to compute"
            + (f" ({damaged} damaged point files removed and computed again)" if damaged else ""))
    t0 = time.perf_counter()
    where = {"mode": "serial"}
    sink = _Sink(folder, progress, log)
    if todo and (workers == 0 and scheduler is None):
        _warm(model, spec.method)
        where["startup_seconds"] = time.perf_counter() - t0
        t_tasks, cpu0 = time.perf_counter(), time.process_time()
        progress.start()
        for unit in todo:
            compute_chunk(model, spec.method, spec.max_time, [unit], bool(spec.follow), emit=sink.take)
        where["compute_seconds"] = time.perf_counter() - t_tasks
        where["cpu_seconds"] = time.process_time() - cpu0
        where["compute_points_per_second"] = (sink.computed + len(sink.failed)) / where["compute_seconds"]
    elif todo:
        where = _run_dask(spec, model, todo, sink, workers, scheduler, chunk, cluster_kwargs or {}, on_client)
    computed = sink.computed
    wall = time.perf_counter() - t0
    ds = assemble(spec, model, grid, folder, shash)
    tmp = out / ".sweep.nc.tmp"
    ds.to_netcdf(tmp, engine="scipy")
    os.replace(tmp, out / "sweep.nc")
    counts = {name: int(np.sum(ds["response"].values == k)) for k, name in enumerate(RESPONSE_CLASSES)}
    summary = {"sweep": str(spec.path), "method": spec.method, "points": len(grid), "resumed": resumed,
               "computed": computed, "damaged": damaged, "missing": int(np.sum(ds["response"].values == NOT_COMPUTED)),
               "failed": sink.failed,
               "wall_seconds": wall, "points_per_second": computed / wall if wall > 0 and computed else None,
               "responses": counts, "where": where, "sweep_hash": shash,
               "dataset": str(out / "sweep.nc"), "status": "complete"}
    atomic_write_json(out / "sweep.json", summary)
    return summary


def _cpu_times(ex) -> dict:
    """Each reachable worker's CPU seconds (a worker that died meanwhile is left out, not an error)."""
    return {w: v for w, v in ex.run_on_workers(time.process_time).items() if isinstance(v, float)}


def _run_dask(spec, model, todo, sink, workers, scheduler, chunk, cluster_kwargs, on_client):
    import functools

    from autocable.executor import Executor
    t_start = time.perf_counter()
    # Every worker derives the model and loads the compiled integrators before the clock of the
    # tasks starts (a worker that joins later does it in its first task).
    with Executor(workers, scheduler, warm=functools.partial(_warm, model, spec.method),
                  cluster_kwargs=cluster_kwargs) as ex:
        client = ex.client
        where = {k: v for k, v in ex.where.items() if k not in ("startup_seconds", "workers_seen")}
        nw = ex.n_workers
        # units per task: single points (about 8 tasks per worker, at most 16 points each), or
        # with follow ``chunk`` consecutive points of a line (default 1), chained line by line
        size = chunk or (1 if spec.follow else max(1, min(16, math.ceil(len(todo) / (8 * nw)))))
        where["chunk"] = size
        where["startup_seconds"] = time.perf_counter() - t_start
        cpu0 = _cpu_times(ex)
        t_tasks, own0 = time.perf_counter(), time.process_time()
        sink.progress.start()
        n = 0
        if spec.follow:
            for carried, points in todo:
                previous = None
                for k in range(0, len(points), size):
                    n += 1
                    previous = ex.submit(f"sweep:{n}", compute_segment, model, spec.method, spec.max_time,
                                         points[k:k + size], previous, carried)
        else:
            for part in _chunks(todo, size):
                n += 1
                ex.submit(f"sweep:{n}", compute_chunk, model, spec.method, spec.max_time, part, False)
        where["tasks"] = n
        if on_client is not None:
            on_client(client)
        for done in ex.completed():
            if not done.ok:
                # compute_chunk keeps each point's own failure, so a whole task fails only for the
                # infrastructure (Dask's KilledWorker after repeated worker deaths) or a bug: the
                # points already written stay, and a rerun resumes from them
                from autocable.errors import ComputationError
                where_ = (f"--scheduler {scheduler}" if scheduler else
                          f"--workers {workers if workers is not None else ex.n_workers}")
                raise ComputationError(
                    f"sweep: task {done.label} failed on the workers of {where_} ({done.error}); the "
                    f"{sink.computed} point(s) computed are kept in {sink.folder}: run the same command "
                    "again to resume, or with --workers 0 to compute in this process")
            for key, rec in done.value:
                sink.take(key, rec)
        where["compute_seconds"] = time.perf_counter() - t_tasks
        where["compute_points_per_second"] = (sink.computed + len(sink.failed)) / where["compute_seconds"]
        # CPU time the workers got during the task phase (a restarted worker's is partial): on a
        # machine shared with other jobs this, not the worker count, bounds the throughput
        cpu1 = _cpu_times(ex)
        where["cpu_seconds"] = sum(v - cpu0.get(k, 0.0) for k, v in cpu1.items())
        # this process: the client, and the scheduler of a LocalCluster (Dask's overhead)
        where["client_cpu_seconds"] = time.process_time() - own0
        where["worker_pids"] = ex.worker_pids()
    return where


def _si_coordinates(spec: SweepSpec, model) -> dict:
    """The grid's axes in SI as auxiliary CF coordinates (`autocable.model.units`): U_m_s on U, eta_m on
    eta, Omega_Hz on sigma."""
    from autocable.model.derive import derive
    from autocable.model.units import units_of
    d = derive(model)
    u = units_of(d.spec, d.statics)
    return {"U_m_s": ("U", u.wind_m_s(np.array(spec.U)), {"long_name": "wind speed U", "units": "m s-1"}),
            "eta_m": ("eta", u.support_m(np.array(spec.eta)), {"long_name": "support amplitude eta",
                                                                "units": "m"}),
            "Omega_Hz": ("sigma", u.frequency_hz(d.ode.omega1 + np.array(spec.sigma)),
                         {"long_name": "forcing frequency Omega = omega1 + sigma", "units": "Hz"})}


def assemble(spec: SweepSpec, model, grid, folder: Path, shash: str):
    """The xarray Dataset of a sweep from its point files (points without a file: NaN, code -1)."""
    import xarray as xr

    from autocable.scene.provenance import versions
    shape = spec.shape
    f = {k: np.full(shape, np.nan) for k in ("a1", "a2", "a1_min", "a1_max", "a2_min", "a2_max", "t_end",
                                               "wall_seconds")}
    code = np.full(shape, NOT_COMPUTED, dtype=np.int8)
    periods = np.zeros(shape, dtype=np.int8)
    steady = np.zeros(shape, dtype=np.int8)
    fallback = np.zeros(shape, dtype=np.int8)
    bimodal = np.full(shape, -1, dtype=np.int8)
    mre = np.full(shape + (4,), np.nan)
    mim = np.full(shape + (4,), np.nan)
    for idx, key, U, eta, sigma, q0 in grid:
        rec = read_valid_point(folder / f"{key}.json", U, eta, sigma, q0)
        if rec is None:
            continue
        for k in f:
            v = rec.get(k)
            f[k][idx] = np.nan if v is None else v
        code[idx] = RESPONSE_CLASSES.index(rec["response"])
        periods[idx], steady[idx], fallback[idx] = rec["periods"], rec["steady"], rec["fallback"]
        bimodal[idx] = rec.get("bimodal", -1)
        for j, (re, im) in enumerate(rec["multipliers"][:4]):
            mre[idx + (j,)], mim[idx + (j,)] = re, im
    dims = AXES + (("start",) if spec.start_axis else ())
    coords = {"U": ("U", np.array(spec.U), {"long_name": "nondimensional wind speed U* = U/U_c (eq. 18)",
                                             "units": "1"}),
              "eta": ("eta", np.array(spec.eta), {"long_name": "nondimensional support amplitude eta* = eta/l "
                                                               "(eq. 18)", "units": "1"}),
              "sigma": ("sigma", np.array(spec.sigma), {"long_name": "detuning sigma = Omega - omega1, in units "
                                                                     "of omega (eq. 17)", "units": "1"})}
    coords.update(_si_coordinates(spec, model))
    if spec.start_axis:
        coords["start"] = ("start", np.arange(len(spec.starts)))
        coords["start_q0"] = (("start", "state"), np.array(spec.starts))
    amp = "half the peak-to-peak of q_k over the steady response (peak modal amplitude = peak displacement / l)"
    data = {
        "a1": (dims, f["a1"], {"long_name": "in-plane amplitude a1", "units": "1", "description": amp}),
        "a2": (dims, f["a2"], {"long_name": "out-of-plane amplitude a2", "units": "1", "description": amp}),
        "a1_min": (dims, f["a1_min"], {"long_name": "envelope of a1 over single forcing periods: min"}),
        "a1_max": (dims, f["a1_max"], {"long_name": "envelope of a1 over single forcing periods: max"}),
        "a2_min": (dims, f["a2_min"], {"long_name": "envelope of a2 over single forcing periods: min"}),
        "a2_max": (dims, f["a2_max"], {"long_name": "envelope of a2 over single forcing periods: max"}),
        "response": (dims, code, {"long_name": "response class", "flag_values": np.arange(-1, len(RESPONSE_CLASSES), dtype=np.int8),
                                  "flag_meanings": " ".join(["not_computed"] + [c.replace("-", "_")
                                                                                for c in RESPONSE_CLASSES]),
                                  "legend": json.dumps({str(k): c for k, c in enumerate(RESPONSE_CLASSES)}
                                                       | {str(NOT_COMPUTED): "not computed"})}),
        "periods": (dims, periods, {"long_name": "period of the orbit in forcing periods (0: none; "
                                                 "autonomous-periodic: 1, one turn of its own period)"}),
        "steady": (dims, steady, {"long_name": "1 when a steady state (or its envelope) was reached"}),
        "fallback": (dims, fallback, {"long_name": "1 when transient integration decided (shooting)"}),
        "bimodal": (dims, bimodal, {"long_name": "period-1 response with a2 not slaved to a1 (bi-modal by "
                                                 "structure, regions.a2_slaved on the AME equilibrium it lies on)",
                                    "flag_values": np.array([-1, 0, 1], dtype=np.int8),
                                    "flag_meanings": "undecided slaved bi_modal"}),
        "floquet_re": (dims + ("multiplier",), mre, {"long_name": "Floquet multipliers of the period-k map, "
                                                     "real part (sorted by modulus, largest first; NaN: none)"}),
        "floquet_im": (dims + ("multiplier",), mim, {"long_name": "Floquet multipliers, imaginary part"}),
        "t_end": (dims, f["t_end"], {"long_name": "time integrated (t*)"}),
        "wall_seconds": (dims, f["wall_seconds"], {"long_name": "compute time of the point", "units": "s"}),
    }
    with np.errstate(invalid="ignore"):
        data["max_multiplier_modulus"] = (dims, np.nanmax(np.hypot(mre, mim), axis=-1, initial=-np.inf),
                                          {"long_name": "max |Floquet multiplier| (< 1: stable)"})
    data["max_multiplier_modulus"][1][~np.isfinite(data["max_multiplier_modulus"][1])] = np.nan
    vers = versions()
    for pkg in ("dask", "distributed", "xarray"):
        try:
            from importlib import metadata
            vers[pkg] = metadata.version(pkg)
        except Exception:  # noqa: BLE001 - provenance only
            vers[pkg] = "not installed"
    attrs = {"title": spec.title, "Conventions": "CF-1.8", "source": "autocable sweep (eq. (21) of Luongo & "
             "Zulli 2012, Nonlinear Dyn.)", "method": spec.method, "model_file": str(spec.model),
             "model_name": model.name, "model_hash": model.content_hash(), "sweep_hash": shash,
             "sweep_file": str(spec.path), "sweep_text": spec.text,
             "settings": json.dumps({"max_time": spec.max_time, "q0": list(spec.starts[0]) if not spec.start_axis
                                     else None, "point_format": POINT_FORMAT, "follow": spec.follow,
                                     "direction": spec.direction if spec.follow else None}),
             "versions": json.dumps(vers),
             "diverged_amplitudes": "NaN where response = diverged (the amplitudes are unbounded)"}
    return xr.Dataset(data, coords=coords, attrs=attrs)
