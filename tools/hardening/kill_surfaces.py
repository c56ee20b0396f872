"""`python -m tools.hardening kill-surfaces`: the kill trials on sweeps (grid and follow), charts and
calibrations.

As `tools.hardening.kill` does for a scene run: one uninterrupted run measures the wall time T, then
``trials`` runs into the same folder, each killed (SIGKILL and SIGINT alternating) at a moment drawn
in its own slice of [0, T]. After each kill:

* a sweep folder reads as complete (sweep.json ``"status": "complete"``) only if sweep.nc opens and
  holds the summary's points with as many not computed as the summary says missing; a chart folder
  is checked by `tools.hardening.kill.folder_state`; a calibration reads as complete
  (calibration.json) only if it counts every point of the space;
* no process the killed run started (the Dask workers, the calibration's pool) is alive 10 s later
  (``orphans``).

A last uninterrupted run must complete, and a sweep's dataset must equal the first run's (the
resumed points are the same numbers).
"""
from __future__ import annotations

import json
import os
import random
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Callable

from autocable._paths import RUNS_DIR, SAMPLE_MODEL
from tools.hardening.kill import sigint_default

__all__ = ["kill_sweep", "kill_calibrate", "descendants"]

_SIGNALS = (signal.SIGKILL, signal.SIGINT)
#: How long the processes a killed run started may take to end.
_ORPHAN_WAIT_S = 10.0

_SWEEPS = {
    "grid": 'method = "shooting"\n[grid]\nU = [0.0, 0.5]\neta = [8.2e-5, 4e-4]\nsigma = { from = -0.03, to = 0.03, '
            'num = 7 }\n',
    "follow": 'method = "ode21"\nfollow = "sigma"\nmax_time = 6000.0\n[grid]\neta = 1.4e-3\n'
              'sigma = { from = -0.05, to = 0.05, num = 21 }\n',
}


def descendants(pid: int) -> set[int]:
    """The living processes below ``pid`` (children, their children, ...), from /proc."""
    parent = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                stat = (entry / "stat").read_text()
                parent[int(entry.name)] = int(stat.rsplit(") ", 1)[1].split()[1])
            except (OSError, ValueError, IndexError):
                continue
    found, frontier = set(), {pid}
    while frontier:
        frontier = {p for p, pp in parent.items() if pp in frontier} - found
        found |= frontier
    return found


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as fh:
            return fh.read().rsplit(") ", 1)[1][0] != "Z"
    except (OSError, IndexError):
        return False


def _run(cmd, env, at: float | None, sig) -> dict:
    """Start ``cmd``; at ``at`` s send ``sig`` (unless it ended); its end; the processes it had
    started still alive `_ORPHAN_WAIT_S` after it ended (then killed, to leave the machine clean)."""
    t0 = time.time()
    # stderr into a file, not a pipe: an orphan holding the pipe would keep the bench waiting
    errfile = tempfile.TemporaryFile()
    proc = subprocess.Popen(cmd, env=env, stdout=subprocess.DEVNULL, stderr=errfile, preexec_fn=sigint_default)
    ended_first, below = False, set()
    if at is None:
        proc.wait()
    else:
        deadline = t0 + at
        while time.time() < deadline and proc.poll() is None:
            below |= descendants(proc.pid)
            time.sleep(min(0.2, max(0.0, deadline - time.time())))
        if proc.poll() is None:
            below |= descendants(proc.pid)
            proc.send_signal(sig)
        else:
            ended_first = True
        try:
            proc.wait(timeout=120)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
    errfile.seek(0)
    err = errfile.read()
    errfile.close()
    end = time.time() + _ORPHAN_WAIT_S
    while time.time() < end and any(_alive(p) for p in below):
        time.sleep(0.1)
    orphans = sorted(p for p in below if _alive(p))
    for p in orphans:
        try:
            os.kill(p, signal.SIGKILL)
        except OSError:
            pass
    return {"pid": proc.pid, "t0": t0, "wall": time.time() - t0, "code": proc.returncode,
            "ended_first": ended_first, "orphans": orphans,
            "stderr": err.decode("utf-8", "replace").strip().splitlines()[-1:]}


def sweep_state(out: Path) -> dict:
    """Whether the sweep folder reads as complete, and if so whether it is."""
    try:
        summary = json.loads((out / "sweep.json").read_text())
    except (OSError, ValueError):
        return {"status": "incomplete", "consistent": None, "why": ""}
    if summary.get("status") != "complete":
        return {"status": str(summary.get("status")), "consistent": None, "why": ""}
    why = []
    try:
        import numpy as np
        import xarray as xr
        with xr.open_dataset(out / "sweep.nc", engine="scipy") as ds:
            resp = ds["response"].values
        if resp.size != summary["points"]:
            why.append(f"sweep.nc holds {resp.size} points, the summary {summary['points']}")
        if int(np.sum(resp == -1)) != summary["missing"]:
            why.append("the points not computed differ from the summary's missing")
    except Exception as exc:  # noqa: BLE001 - a dataset that does not read is inconsistent
        why.append(f"sweep.nc: {type(exc).__name__}: {exc}")
    return {"status": "complete", "consistent": not why, "why": "; ".join(why)}


def _numbers(out: Path):
    import xarray as xr
    with xr.open_dataset(out / "sweep.nc", engine="scipy") as ds:
        return {k: ds[k].values.copy() for k in ("a1", "a2", "response")}


def _trials(cmd, env, trials, seed, state, say, what, reset=None) -> tuple[dict, list, float]:
    """The kill trials; ``reset(i)`` before trial i (a sweep or calibration resumes from its finished
    points: every other trial starts from an empty folder, so that each is killed mid-way)."""
    first = _run(cmd, env, None, None)
    if first["code"] != 0:
        raise RuntimeError(f"the uninterrupted {what} failed (exit {first['code']}): {first['stderr']}")
    T = first["wall"]
    say(f"{what}: uninterrupted run {T:.2f} s; {trials} trials")
    rng = random.Random(seed)
    moments = [T * (i + rng.random()) / trials for i in range(trials)]
    rng.shuffle(moments)
    counts = {"trials": trials, "killed": 0, "read_as_complete_while_incomplete": 0, "orphaned_processes": 0,
              "interrupt_ignored": 0}
    records = []
    for i, at in enumerate(moments):
        sig = _SIGNALS[i % len(_SIGNALS)]
        if reset is not None:
            reset(i)
        r = _run(cmd, env, at, sig)
        st = state()
        counts["killed"] += not r["ended_first"]
        bad = st["status"] == "complete" and st["consistent"] is False
        counts["read_as_complete_while_incomplete"] += bad
        counts["orphaned_processes"] += len(r["orphans"])
        # a run interrupted (SIGINT) that exits 0 without a complete result ignored the interrupt; one
        # that exits 0 complete had finished its work (the interrupt came as it shut down)
        counts["interrupt_ignored"] += (sig == signal.SIGINT and not r["ended_first"] and r["code"] == 0
                                        and st["status"] != "complete")
        records.append({"trial": i, "signal": signal.Signals(sig).name, "at_s": round(at, 3), "exit": r["code"],
                        "status": st["status"], "why": st["why"], "orphans": r["orphans"]})
        say(f"{what} trial {i + 1}/{trials}: {signal.Signals(sig).name} at {at:.2f} s, exit {r['code']}, "
            f"status {st['status']}" + (f", orphans {r['orphans']}" if r["orphans"] else "") + (f": {st['why']}" if bad else ""))
    return counts, records, T


def kill_sweep(kind: str = "grid", trials: int = 8, *, workers: int = 2, seed: int = 0,
               log: Callable[[str], None] | None = None) -> dict:
    """Kill trials of ``autocable sweep`` (a ``kind`` of `_SWEEPS`: "grid" or "follow") on ``workers``
    Dask workers (0: serial)."""
    say = log or (lambda m: None)
    with tempfile.TemporaryDirectory(prefix="autocable-killsweep-") as tmp:
        path = Path(tmp) / f"{kind}.toml"
        path.write_text(f'model = "{SAMPLE_MODEL.as_posix()}"\n' + _SWEEPS[kind])
        ref, out = Path(tmp) / "ref", Path(tmp) / "out"
        base = [sys.executable, "-m", "autocable.cli", "sweep", str(path), "--quiet", "--workers", str(workers)]
        env = dict(os.environ)
        done = _run(base + ["--out", str(ref)], env, None, None)
        if done["code"] != 0:
            raise RuntimeError(f"the reference sweep failed: {done['stderr']}")
        counts, records, T = _trials(base + ["--out", str(out)], env, trials, seed, lambda: sweep_state(out),
                                     say, f"sweep {kind}", lambda i: i % 2 or shutil.rmtree(out, ignore_errors=True))
        last = _run(base + ["--out", str(out)], env, None, None)
        st = sweep_state(out)
        same = False
        if last["code"] == 0 and st["status"] == "complete":
            import numpy as np
            a, b = _numbers(ref), _numbers(out)
            same = all(np.array_equal(a[k], b[k], equal_nan=True) for k in a)
        return {**counts, "final_run_complete": last["code"] == 0 and bool(st["consistent"]),
                "final_equals_uninterrupted": same, "run_seconds": round(T, 3), "kind": kind,
                "workers": workers, "records": records}


def kill_calibrate(trials: int = 6, *, jobs: int = 2, seed: int = 0, log: Callable[[str], None] | None = None) -> dict:
    """Kill trials of ``autocable calibrate`` on a small space (one reading, four yaw angles): no
    pool worker outlives its parent; the last run completes with every point counted."""
    say = log or (lambda m: None)
    with tempfile.TemporaryDirectory(prefix="autocable-killcal-") as tmp:
        space = Path(tmp) / "s.search.toml"
        space.write_text('twist_ends = ["natural"]\nload_axes = ["reference"]\nangle_convention = ["eq12"]\n'
                         'yaw_deg = [-5.0, 0.0, 5.0, 10.0]\nrivulet_angle_deg = "calibrate"\nfull = 0\n')
        out = Path(tmp) / "out"
        targets = SAMPLE_MODEL.with_suffix("").with_suffix(".targets.toml")
        cmd = [sys.executable, "-m", "autocable.cli", "calibrate", str(SAMPLE_MODEL), str(targets), "--out", str(out),
               "--space", str(space), "--workers", str(jobs), "--quiet"]

        def state():
            try:
                stats = json.loads((out / "calibration.json").read_text())
            except (OSError, ValueError):
                return {"status": "incomplete", "consistent": None, "why": ""}
            points = stats.get("points") if isinstance(stats, dict) else None
            ok = points is None or points == 4
            return {"status": "complete", "consistent": ok, "why": "" if ok else f"{points} points, 4 in the space"}

        counts, records, T = _trials(cmd, dict(os.environ), trials, seed, state, say, "calibrate",
                                     lambda i: i % 2 or shutil.rmtree(out, ignore_errors=True))
        last = _run(cmd, dict(os.environ), None, None)
        return {**counts, "final_run_complete": last["code"] == 0 and state()["status"] == "complete",
                "run_seconds": round(T, 3), "records": records}


def kill_chart(trials: int = 4, *, seed: int = 0, log: Callable[[str], None] | None = None) -> dict:
    """Kill trials of ``autocable chart`` (runs/chart_sigma_eta_U0.toml, coarse), checked as a scene
    folder (`tools.hardening.kill.folder_state`), with the orphan count."""
    from tools.hardening.kill import folder_state
    say = log or (lambda m: None)
    with tempfile.TemporaryDirectory(prefix="autocable-killchart-") as tmp:
        out = Path(tmp) / "out"
        cmd = [sys.executable, "-m", "autocable.cli", "chart", str(RUNS_DIR / "chart_sigma_eta_U0.toml"), "--out",
               str(out), "--quiet", "--resolution", "coarse"]

        def state():
            st = folder_state(out) if out.is_dir() else {"status": "missing", "consistent": None, "why": ""}
            return {"status": st["status"], "consistent": st["consistent"], "why": st["why"]}

        counts, records, T = _trials(cmd, dict(os.environ), trials, seed, state, say, "chart")
        last = _run(cmd, dict(os.environ), None, None)
        st = state()
        return {**counts, "final_run_complete": last["code"] == 0 and st["status"] == "complete"
                and bool(st["consistent"]), "run_seconds": round(T, 3), "records": records}


def run_kill_surfaces(trials: int = 4, log: Callable[[str], None] | None = None) -> dict:
    """`python -m tools.hardening kill-surfaces`: ``trials`` kills each of a grid sweep and a followed sweep
    (2 Dask workers), a chart and a calibration; the totals and each bench's result."""
    parts = {"sweep_grid": kill_sweep("grid", trials, log=log), "sweep_follow": kill_sweep("follow", trials, log=log),
             "chart": kill_chart(trials, log=log), "calibrate": kill_calibrate(trials, log=log)}
    totals = {k: sum(p[k] for p in parts.values())
              for k in ("trials", "killed", "read_as_complete_while_incomplete", "orphaned_processes",
                        "interrupt_ignored")}
    return {**totals, "final_runs_complete": all(p["final_run_complete"] for p in parts.values()), **parts}
