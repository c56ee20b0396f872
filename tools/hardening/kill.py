"""`python -m tools.hardening kill`: a scene run killed at random moments never leaves a folder that reads as complete.

One uninterrupted run first measures the run's wall time T (and warms the cache); then ``trials`` runs
of the same scene into the same folder, each killed (SIGKILL and SIGINT alternating) at a moment
drawn in its own slice of [0, T] (stratified: the moments cover the whole run). After each kill:

* the folder reads as complete (`autocable.results.is_complete`) only if its files are complete and
  consistent: the manifest of run.json is exactly the files there, `read_results` reads them, the
  figures are whole; a complete folder written by this run means it finished before the kill, one
  written before it started means the kill came before the run touched the folder;
* a run that got past its start (run.json names its process, or it finished) has removed what the
  earlier killed runs left: their staging folders and temporary files.

A last uninterrupted run must end complete, consistent and with no leftovers. Prints the counts.
"""
from __future__ import annotations

import os
import random
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Callable

from autocable._paths import RUNS_DIR
from autocable._store import read_json
from autocable.results import RUN_JSON, is_complete, read_results, run_status
from autocable.run_folder import is_leftover

__all__ = ["MIN_TRIALS", "kill_bench", "run_kill_bench", "folder_state"]

#: The fewest trials the command runs (the acceptance of the output folders' robustness).
MIN_TRIALS = 20
_SIGNALS = (signal.SIGKILL, signal.SIGINT)
#: How long a SIGINT'd run may take to publish its "interrupted" folder before it is SIGKILLed.
_GRACE_S = 60.0


def folder_state(folder: Path) -> dict:
    """What a reader finds in ``folder``: run.json's status, pid and mtime, the leftovers of killed
    runs, and, for a complete folder, whether its files are complete and consistent."""
    meta = read_json(folder / RUN_JSON)
    names = sorted(p.name for p in folder.iterdir()) if folder.is_dir() else []
    state = {"status": run_status(folder), "pid": meta.get("pid") if isinstance(meta, dict) else None,
             "mtime": (folder / RUN_JSON).stat().st_mtime if (folder / RUN_JSON).is_file() else None,
             "leftovers": [n for n in names if is_leftover(n)], "consistent": None, "why": ""}
    if is_complete(folder):
        files = set(meta.get("files") or [])
        here = {n for n in names if n != RUN_JSON and not is_leftover(n)}
        why = []
        if files != here:
            why.append(f"manifest {sorted(files ^ here)} differs from the folder")
        try:
            read_results(folder)
        except Exception as exc:   # noqa: BLE001 - any failure to read is an inconsistency
            why.append(f"read_results: {exc}")
        for n in here:
            data = (folder / n).read_bytes()
            if n.endswith(".png") and not (data.startswith(b"\x89PNG") and data.endswith(b"IEND\xaeB`\x82")):
                why.append(f"{n} is not a whole PNG")
            if n.endswith(".pdf") and b"%%EOF" not in data[-64:]:
                why.append(f"{n} is not a whole PDF")
        state["consistent"] = not why
        state["why"] = "; ".join(why)
    return state


def sigint_default() -> None:
    """The child's SIGINT back to its default (``preexec_fn``): a harness started in the background
    by a non-interactive shell has SIGINT ignored, which its children inherit, and Python then
    installs no KeyboardInterrupt handler, so the SIGINT trials would interrupt nothing."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _run(cmd, env, folder: Path, at: float | None, sig) -> dict:
    """Start ``cmd``; at ``at`` seconds send ``sig`` (unless it has ended); wait for its end."""
    t0 = time.time()
    proc = subprocess.Popen(cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            preexec_fn=sigint_default)
    ended_first = False
    if at is None:
        _, err = proc.communicate()
    else:
        try:
            proc.wait(timeout=at)
            ended_first = True
        except subprocess.TimeoutExpired:
            proc.send_signal(sig)
        try:
            _, err = proc.communicate(timeout=_GRACE_S)
        except subprocess.TimeoutExpired:
            proc.kill()
            _, err = proc.communicate()
    return {"pid": proc.pid, "t0": t0, "wall": time.time() - t0, "code": proc.returncode,
            "ended_first": ended_first, "stderr": err.decode("utf-8", "replace").strip().splitlines()[-1:]}


def kill_bench(scene: str | Path | None = None, trials: int = MIN_TRIALS, *, engine: str | None = "compiled",
               resolution: str = "full", seed: int = 0, folder: str | Path | None = None,
               log: Callable[[str], None] | None = None) -> dict:
    """Run the kill trials (module docstring) of ``scene`` (default: runs/fig06.toml) into ``folder``
    (default: a temporary one). Returns the counts and each trial's record."""
    scene = Path(scene) if scene else RUNS_DIR / "fig06.toml"
    say = log or (lambda msg: None)
    with tempfile.TemporaryDirectory(prefix="autocable-kill-") as tmp:
        out = Path(folder) if folder else Path(tmp) / "out"
        cmd = [sys.executable, "-m", "autocable.cli", "run", str(scene), "--out", str(out), "--quiet",
               "--resolution", resolution] + (["--engine", engine] if engine else [])
        env = dict(os.environ)
        first = _run(cmd, env, out, None, None)
        if first["code"] != 0:
            raise RuntimeError(f"the uninterrupted run of {scene} failed (exit {first['code']}): {first['stderr']}")
        T = first["wall"]
        say(f"uninterrupted run: {T:.2f} s; {trials} trials")
        rng = random.Random(seed)
        moments = [T * (i + rng.random()) / trials for i in range(trials)]
        rng.shuffle(moments)
        counts = {"trials": trials, "killed": 0, "finished_before_kill": 0, "killed_before_touching_folder": 0,
                  "read_as_complete_while_incomplete": 0, "leftovers_after_rerun": 0}
        statuses: dict[str, int] = {}
        records = []
        previous: list[str] = []
        for i, at in enumerate(moments):
            sig = _SIGNALS[i % len(_SIGNALS)]
            r = _run(cmd, env, out, at, sig)
            st = folder_state(out)
            statuses[st["status"]] = statuses.get(st["status"], 0) + 1
            killed = not r["ended_first"]
            counts["killed"] += killed
            written = st["mtime"] is not None and st["mtime"] >= r["t0"]
            verdict = "incomplete"
            if st["status"] == "complete":
                if not st["consistent"]:
                    verdict = "read as complete while incomplete: " + st["why"]
                    counts["read_as_complete_while_incomplete"] += 1
                elif written:
                    verdict = "finished before the kill"
                    counts["finished_before_kill"] += 1
                else:
                    verdict = "killed before it touched the folder (the earlier complete run is intact)"
                    counts["killed_before_touching_folder"] += 1
            # a run that got past its start has removed what the earlier ones left
            started = st["pid"] == r["pid"] or (written and st["status"] != "running")
            stale = [n for n in previous if (out / n).exists()] if started else []
            counts["leftovers_after_rerun"] += bool(stale)
            records.append({"trial": i, "signal": signal.Signals(sig).name, "at_s": round(at, 3),
                            "exit": r["code"], "status": st["status"], "verdict": verdict,
                            "leftovers": st["leftovers"], "stale_after_rerun": stale})
            say(f"trial {i + 1}/{trials}: {signal.Signals(sig).name} at {at:.2f} s, exit {r['code']}, "
                f"status {st['status']}: {verdict}" + (f"; stale {stale}" if stale else ""))
            previous = st["leftovers"]
        last = _run(cmd, env, out, None, None)
        st = folder_state(out)
        final_ok = last["code"] == 0 and st["status"] == "complete" and bool(st["consistent"]) \
            and not st["leftovers"]
        counts["leftovers_after_rerun"] += bool(st["leftovers"])
        return {**counts, "final_run_complete_and_clean": final_ok, "statuses": statuses,
                "run_seconds": round(T, 3), "scene": str(scene), "engine": engine, "resolution": resolution,
                "seed": seed, "records": records}


def run_kill_bench(what: str, model_path: str, repeats: int = MIN_TRIALS, log=None, out=None) -> dict:
    """`python -m tools.hardening kill`: `kill_bench` of runs/fig06.toml (compiled engine), at least `MIN_TRIALS`
    trials (``--repeats`` more). ``what`` and ``model_path`` are the bench command's (the scene names
    its own model)."""
    return kill_bench(trials=max(MIN_TRIALS, int(repeats)), log=log)
