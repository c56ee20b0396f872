"""Generated cases of the kind ``scheduler_failures``: `autocable figures`, `sweep` and `calibrate`
on a real `dask scheduler` with real `dask worker` processes on this machine, each case with one
failure drawn (docs/cluster.md; autocable/executor.py):

* ``no_worker``: the scheduler never had a worker;
* ``kill_only_worker``: the only worker killed (SIGKILL or SIGTERM) at a moment drawn in the run;
* ``no_autocable``: the only worker cannot import autocable (the import blocked, or a copy of the
  package with a syntax error first on its path);
* ``foreign``: the only worker runs another copy of autocable (one comment more: another
  fingerprint);
* ``kill_scheduler``: the scheduler killed at a moment drawn in the run;
* ``bad_address``: a ``--scheduler`` that is malformed, refused, unreachable, a missing or broken
  scheduler file, or a port that accepts and never answers;
* ``two_workers_one_killed``: two workers, one killed at a moment drawn in the run;
* ``healthy``: one worker, nothing done to it (the control).

``AUTOCABLE_NO_WORKER_TIMEOUT`` is `NO_WORKER_S`. The oracle of each case: the command ends within
`HARD_LIMIT_S` (else ``hang``: it is killed); no traceback; with no live worker, exit 3 and one line
naming ``--scheduler``; a refused worker or address, exit 2 and one line naming ``--scheduler``;
a run whose worker survived (or that ended before the failure) exits 0 and its results equal a
reference computed without Dask (a figure scene's data files to 1e-9 relative, a sweep's a1 and a2);
a run that did not exit 0 leaves no folder reading as complete with other results than the
reference, and no scene folder saying "running"; ``calibrate``'s start line counts the live workers (none is not "1 workers"); 10 s after
the case, no process of the command, of its workers or of its scheduler is alive (``orphaned``; the
workers are stopped by SIGTERM at the end of a case, and killed if still running 3 s later: a worker
whose scheduler is gone finishes its running scene before it exits).

A scheduler is shared by the cases that do not kill it; before each case it is checked to have no
worker left (else it is replaced). Each case starts its own workers and stops them.
"""
from __future__ import annotations

import json
import os
import random
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass
from pathlib import Path

from tools.hardening.fuzz_cache import CLASSES, _scene_tables, budgeted_cases, difference

__all__ = ["FAILURES", "scheduler_case", "run_scheduler_failures"]

_REPO = Path(__file__).resolve().parents[2]
NO_WORKER_S = 2.5
#: A command still running after this is a hang (the no-worker limit plus start-up plus a scene).
HARD_LIMIT_S = 150.0
#: How long the processes of a case may take to end once it is over.
ORPHAN_WAIT_S = 10.0

FAILURES = ("no_worker", "kill_only_worker", "no_autocable", "foreign", "kill_scheduler", "bad_address",
            "two_workers_one_killed", "healthy")
#: The commands each failure is tried on: calibrate only where it ends before its screen computes
#: (a calibration's screen takes minutes).
COMMANDS = {f: ("figures", "sweep", "calibrate") if f in ("no_worker", "no_autocable", "foreign", "bad_address")
            else ("figures", "sweep") for f in FAILURES}
#: Seconds after the command's start in which a kill lands (its start-up and its tasks here).
WINDOW = {"figures": 3.5, "sweep": 2.5, "calibrate": 5.0}

_SWEEP = """title = "hardening: a small sweep on a cluster"
model = "{model}"
method = "shooting"

[grid]
U = 0.0
eta = 8.2e-5
sigma = {{ from = -0.03, to = 0.03, num = 8 }}
"""


def _dask() -> str:
    exe = Path(sys.executable).with_name("dask")
    return str(exe) if exe.is_file() else (shutil.which("dask") or "")


def _session(sid: int) -> list[int]:
    """The living processes of session ``sid`` (zombies left out)."""
    found = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
            rest = stat.rsplit(") ", 1)[1].split()
            if int(rest[3]) == sid and rest[0] != "Z":
                found.append(int(entry.name))
        except (OSError, ValueError, IndexError):
            continue
    return found


def _gone(sids: list[int], seconds: float) -> list[int]:
    """The processes of ``sids`` still alive after ``seconds`` (waited for)."""
    deadline = time.monotonic() + seconds
    while True:
        alive = [p for s in sids for p in _session(s)]
        if not alive or time.monotonic() >= deadline:
            return alive
        time.sleep(0.2)


def _describe(pid: int, sessions: list[int], proc_pids: dict) -> str:
    """A process left alive: its pid, its session's leader and its command line, short."""
    try:
        cmd = Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace").strip()
        sid = int(Path(f"/proc/{pid}/stat").read_text().rsplit(") ", 1)[1].split()[3])
    except (OSError, ValueError, IndexError):
        return f"{pid} (gone)"
    return f"{pid} (session of {sid}{', the command' if sid == proc_pids.get('command') else ''}): {cmd[-120:]}"


def _kill_sessions(sids: list[int]) -> None:
    for s in sids:
        for p in _session(s):
            try:
                os.kill(p, signal.SIGKILL)
            except (ProcessLookupError, PermissionError):
                pass


class Scheduler:
    """A `dask scheduler` process writing its scheduler file in ``folder``."""

    def __init__(self, folder: Path):
        folder.mkdir(parents=True, exist_ok=True)
        self.file = folder / "scheduler.json"
        self.log = open(folder / "scheduler.log", "w")
        self.proc = subprocess.Popen([_dask(), "scheduler", "--scheduler-file", str(self.file), "--port", "0",
                                      "--no-dashboard", "--host", "127.0.0.1"], stdout=self.log,
                                     stderr=subprocess.STDOUT, cwd=folder, start_new_session=True)
        deadline = time.monotonic() + 60
        self.address = None
        while self.address is None and time.monotonic() < deadline and self.proc.poll() is None:
            try:                        # the file appears before its text is written
                self.address = json.loads(self.file.read_text())["address"]
            except (OSError, ValueError, KeyError):
                time.sleep(0.05)
        if self.address is None:
            raise RuntimeError(f"dask scheduler did not start: {(folder / 'scheduler.log').read_text()[-500:]}")

    def workers(self) -> int | None:
        """Workers the scheduler has now (None: it does not answer)."""
        from distributed import Client
        try:
            with Client(self.address, timeout=10) as c:
                return len(c.scheduler_info().get("workers", {}))
        except Exception:  # noqa: BLE001 - a scheduler gone
            return None

    def wait_workers(self, n: int, seconds: float = 60.0) -> bool:
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            if self.proc.poll() is not None:
                return False
            if (self.workers() or 0) >= n:
                return True
            time.sleep(0.2)
        return False

    def stop(self) -> None:
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(20)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self.log.close()


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@dataclass
class SchedulerCase:
    failure: str
    command: str
    delay: float = 0.0          # seconds after the command's start: the kill
    sig: int = signal.SIGKILL
    variant: str = ""           # no_autocable: "blocked"/"broken"; bad_address: which address

    @property
    def label(self) -> str:
        extra = (f" {signal.Signals(self.sig).name} at {self.delay:.1f} s" if "kill" in self.failure else "")
        return f"{self.command} --scheduler: {self.failure}{extra}{' ' + self.variant if self.variant else ''}"


_BAD = ("refused", "malformed", "port_range", "empty", "spaces", "missing_file", "broken_file", "silent_port",
        "no_address_file", "http_scheme")


def scheduler_case(rng: random.Random) -> SchedulerCase:
    failure = FAILURES[rng.randrange(len(FAILURES))]
    command = COMMANDS[failure][rng.randrange(len(COMMANDS[failure]))]
    c = SchedulerCase(failure, command, rng.uniform(0.0, WINDOW[command]),
                      signal.SIGKILL if rng.random() < 0.5 else signal.SIGTERM)
    if failure == "no_autocable":
        c.variant = "blocked" if rng.random() < 0.5 else "broken"
    elif failure == "bad_address":
        c.variant = _BAD[rng.randrange(len(_BAD))]
    return c


@dataclass
class Outcome:
    cls: str
    detail: str = ""
    exit: int | None = None
    seconds: float = 0.0


_TRACEBACK = "Traceback (most recent call last)"


class SchedulerHarness:
    """The shared scheduler, the package copies, the references and the folders of a run."""

    def __init__(self, base: Path):
        self.base = Path(base)
        self.cache = self.base / "cache"
        # a snapshot of the package, its models and scenes: the checkout may be edited meanwhile,
        # and a worker started before an edit is (rightly) refused by a command started after it
        self.repo = self.base / "tree"
        for name in ("autocable", "models", "runs"):
            shutil.copytree(_REPO / name, self.repo / name, ignore=shutil.ignore_patterns("__pycache__", "_data"))
        self.sweep_file = self.base / "sweep.toml"
        self.sweep_file.write_text(_SWEEP.format(model=self.repo / "models" / "luongo_zulli_2012.toml"))
        self.foreign = self.base / "foreign"
        shutil.copytree(self.repo / "autocable", self.foreign / "autocable", ignore=shutil.ignore_patterns("__pycache__"))
        with open(self.foreign / "autocable" / "results.py", "a") as fh:
            fh.write("\n# another copy of autocable\n")
        self.broken = self.base / "broken"
        shutil.copytree(self.repo / "autocable", self.broken / "autocable", ignore=shutil.ignore_patterns("__pycache__"))
        with open(self.broken / "autocable" / "_store.py", "a") as fh:
            fh.write("\ndef broken(:\n")
        self.empty = self.base / "empty"
        self.empty.mkdir()
        self.shared: Scheduler | None = None
        self._n = 0
        self.refs: dict = {}
        self.no_worker_walls: list = []

    def _folder(self, what: str) -> Path:
        self._n += 1
        p = self.base / f"{what}-{self._n}"
        p.mkdir(parents=True)
        return p

    def env(self, pythonpath: Path | None = None) -> dict:
        env = {k: v for k, v in os.environ.items() if not k.startswith("AUTOCABLE_")}
        env.update(PYTHONPATH=str(pythonpath or self.repo), AUTOCABLE_CACHE=str(self.cache),
                   AUTOCABLE_NO_WORKER_TIMEOUT=str(NO_WORKER_S), PYTHONFAULTHANDLER="1")
        return env

    # -- the command ------------------------------------------------------------------------------
    def argv(self, command: str, where: str, out: Path) -> list[str]:
        if command == "figures":
            return ["figures", "--only", "fig03", "--scheduler", where, "--out", str(out), "--recompute", "--quiet"]
        if command == "sweep":
            return ["sweep", str(self.sweep_file), "--scheduler", where, "--out", str(out), "--chunk", "1", "--quiet"]
        return ["calibrate", str(self.repo / "models" / "luongo_zulli_2012.toml"),
                str(self.repo / "models" / "luongo_zulli_2012.targets.toml"), "--scheduler", where, "--out", str(out)]

    def result(self, command: str, out: Path):
        """What is compared with the reference: a scene's tables, a sweep's a1 and a2 (None: the
        folder does not read as complete)."""
        if command == "figures":
            from autocable.results import is_complete
            return _scene_tables(out) if is_complete(out / "fig03") else None
        if command == "sweep":
            try:
                summary = json.loads((out / "sweep.json").read_text())
            except (OSError, ValueError):
                return None
            if summary.get("status") != "complete":
                return None
            import xarray as xr
            with xr.open_dataset(out / "sweep.nc") as d:
                return {"a1,a2": [[repr(float(x)) for x in d[v].values.ravel()] for v in ("a1", "a2")]}
        return None

    def reference(self, command: str):
        """The command's result without Dask (``--workers 0``), once per run."""
        if command not in self.refs:
            out = self._folder("ref")
            argv = [a for a in self.argv(command, "X", out)]
            i = argv.index("--scheduler")
            argv[i:i + 2] = ["--workers", "0"]
            done = subprocess.run([sys.executable, "-m", "autocable.cli", *argv], env=self.env(), cwd=out,
                                  capture_output=True, text=True, timeout=600)
            r = self.result(command, out)
            if done.returncode != 0 or r is None:
                raise RuntimeError(f"the reference {command} failed (exit {done.returncode}): {done.stderr[-400:]}")
            self.refs[command] = r
        return self.refs[command]

    # -- processes --------------------------------------------------------------------------------
    def scheduler(self, fresh: bool) -> Scheduler:
        if fresh:
            return Scheduler(self._folder("scheduler"))
        if self.shared is not None and (self.shared.proc.poll() is not None or self.shared.workers() != 0):
            self.shared.stop()
            self.shared = None
        if self.shared is None:
            self.shared = Scheduler(self._folder("scheduler"))
        return self.shared

    def worker(self, s: Scheduler, kind: str, folder: Path) -> subprocess.Popen:
        """A single-threaded worker without a nanny: ``kind`` "ok", "foreign", "blocked", "broken"."""
        args = ["--scheduler-file", str(s.file), "--nthreads", "1", "--no-nanny", "--no-dashboard",
                "--local-directory", str(folder / "w")]
        path = {"ok": self.repo, "foreign": self.foreign, "blocked": self.empty, "broken": self.broken}[kind]
        if kind == "blocked":
            cmd = [sys.executable, "-c", "import sys\nsys.modules['autocable'] = None\n"
                   "from distributed.cli.dask_worker import main\nmain()", *args]
        else:
            cmd = [_dask(), "worker", *args]
        log = open(folder / f"worker-{self._n}-{time.monotonic_ns()}.log", "w")
        proc = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT, env=self.env(path), cwd=folder,
                                start_new_session=True)
        log.close()
        return proc

    def bad_address(self, variant: str, folder: Path) -> tuple[str, object]:
        """(--scheduler value, a resource to close)."""
        if variant == "refused":
            return f"tcp://127.0.0.1:{_free_port()}", None
        if variant == "malformed":
            return "tcp//127.0.0.1:8786", None
        if variant == "port_range":
            return "127.0.0.1:99999", None
        if variant == "empty":
            return "", None
        if variant == "spaces":
            return "tcp://127.0.0.1: 8786", None
        if variant == "missing_file":
            return str(folder / "no-such-scheduler.json"), None
        if variant == "broken_file":
            (folder / "broken.json").write_text('{"address": ')
            return str(folder / "broken.json"), None
        if variant == "no_address_file":
            (folder / "other.json").write_text('{"type": "Scheduler"}')
            return str(folder / "other.json"), None
        if variant == "http_scheme":
            return "http://127.0.0.1:8787", None
        srv = socket.socket()                     # silent_port: accepts, never answers
        srv.bind(("127.0.0.1", 0))
        srv.listen(8)
        return f"tcp://127.0.0.1:{srv.getsockname()[1]}", srv

    # -- a case -----------------------------------------------------------------------------------
    def run_case(self, case: SchedulerCase) -> Outcome:
        folder = self._folder("case")
        out = folder / "out"
        sessions, workers, resource = [], [], None
        fresh = case.failure == "kill_scheduler"
        sched = None
        t0 = time.perf_counter()
        try:
            if case.failure == "bad_address":
                where, resource = self.bad_address(case.variant, folder)
            else:
                sched = self.scheduler(fresh)
                if fresh:
                    sessions.append(sched.proc.pid)
                where = str(sched.file)
                kinds = {"no_worker": [], "kill_only_worker": ["ok"], "no_autocable": [case.variant],
                         "foreign": ["foreign"], "kill_scheduler": ["ok"], "two_workers_one_killed": ["ok", "ok"],
                         "healthy": ["ok"]}[case.failure]
                for k in kinds:
                    w = self.worker(sched, k, folder)
                    workers.append(w)
                    sessions.append(w.pid)
                if kinds and not sched.wait_workers(len(kinds)):
                    # a worker that cannot import autocable still joins (Dask imports it per task)
                    return Outcome("hang", f"the case's {len(kinds)} worker(s) did not join in 60 s (harness)")
            t0 = time.perf_counter()
            proc = subprocess.Popen([sys.executable, "-m", "autocable.cli", *self.argv(case.command, where, out)],
                                    env=self.env(), cwd=folder, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                    text=True, start_new_session=True)
            sessions.append(proc.pid)
            if "kill" in case.failure:
                target = sched.proc if case.failure == "kill_scheduler" else workers[0]
                threading.Timer(case.delay, lambda: target.poll() is None and target.send_signal(case.sig)).start()
            try:
                stdout, stderr = proc.communicate(timeout=HARD_LIMIT_S)
                code = proc.returncode
            except subprocess.TimeoutExpired:
                # what was left, and where the command stood: SIGABRT makes Python's faulthandler
                # (PYTHONFAULTHANDLER, set in `env`) print every thread's stack on stderr
                left = [_describe(p, sessions, {"command": proc.pid}) for p in _session(proc.pid)]
                if proc.poll() is None:
                    proc.send_signal(signal.SIGABRT)
                try:
                    _, stderr = proc.communicate(timeout=5)
                except subprocess.TimeoutExpired:
                    _kill_sessions([proc.pid])
                    _, stderr = proc.communicate()
                _kill_sessions([proc.pid])
                stack = " | ".join(ln.strip() for ln in (stderr or "").splitlines() if 'File "' in ln)[-1500:]
                return Outcome("hang", f"still running after {HARD_LIMIT_S:g} s; processes: {'; '.join(left)[:600]}; "
                                       f"stacks: {stack}", None, HARD_LIMIT_S)
            wall = time.perf_counter() - t0
            if case.failure == "no_worker":
                self.no_worker_walls.append(wall)
            return self.judge(case, code, stderr, out, wall)
        finally:
            # the case's workers stopped as a user would (SIGTERM); one still finishing its task
            # after 3 s (Dask's graceful close waits for it) is killed: what the command and the
            # workers leave must then end by itself (a scene's forked child dies with its worker)
            for w in workers:
                if w.poll() is None:
                    w.terminate()
            for w in workers:
                try:
                    w.wait(3)
                except subprocess.TimeoutExpired:
                    w.kill()
            if fresh and sched is not None:
                sched.stop()
            if resource is not None:
                resource.close()
            alive = _gone(sessions, ORPHAN_WAIT_S)
            if alive:
                self._orphans = [_describe(p, sessions, proc_pids={"command": sessions[-1] if sessions else None})
                                 for p in alive]
                _kill_sessions(sessions)
            else:
                self._orphans = []
            for w in workers:
                try:
                    w.wait(10)
                except subprocess.TimeoutExpired:
                    pass
            shutil.rmtree(folder, ignore_errors=True)

    def judge(self, case: SchedulerCase, code: int, stderr: str, out: Path, wall: float) -> Outcome:
        lines = [ln for ln in stderr.splitlines() if ln.strip()]
        last = lines[-1] if lines else ""
        if _TRACEBACK in stderr:
            return Outcome("traceback", stderr.strip()[-300:], code, wall)
        try:
            r = self.result(case.command, out)
        except Exception as exc:  # noqa: BLE001 - a folder saying complete that does not read
            return Outcome("wrong_exit0" if code == 0 else "wrong_exit_nonzero",
                           f"the folder reads as complete but does not read: {exc}", code, wall)
        ref = self.reference(case.command) if case.command != "calibrate" else None
        if r is not None and ref is not None:
            why = difference(r, ref)
            if why:
                return Outcome("wrong_exit0" if code == 0 else "wrong_exit_nonzero",
                               f"exit {code}, a complete folder unlike the reference: {why}", code, wall)
        if code != 0 and case.command == "figures":
            run = out / "fig03" / "run.json"
            try:
                status = json.loads(run.read_text()).get("status") if run.is_file() else None
            except ValueError:
                status = "unreadable"
            if status == "running":             # the hang left it so: nobody is running it now
                return Outcome("wrong_exit_nonzero", f"exit {code}, fig03/run.json still says running", code, wall)
        survived = case.failure in ("two_workers_one_killed", "healthy")
        may_finish = case.failure in ("kill_only_worker", "kill_scheduler")
        if case.command == "calibrate":
            said = [ln for ln in lines if " on the scheduler " in ln]
            if said and case.failure == "no_worker" and "no worker yet" not in said[0]:
                return Outcome("wrong_exit_nonzero", f"the start line says {said[0][:160]!r} with no worker",
                               code, wall)
        if code == 0:
            if case.failure in ("no_worker", "no_autocable", "foreign", "bad_address"):
                return Outcome("wrong_exit0", f"exit 0 with {case.failure}: {last[:200]}", code, wall)
            if r is None and case.command != "calibrate":
                return Outcome("wrong_exit0", "exit 0, the folder does not read as complete", code, wall)
            return Outcome("ok", "", code, wall)
        if survived:
            return Outcome("wrong_exit_nonzero", f"exit {code} with a live worker: {last[:240]}", code, wall)
        one_line = len(lines) == 1 or case.command == "calibrate"     # calibrate prints its progress
        named = "--scheduler" in last
        if code == 3 and case.failure in ("no_worker",) + (("kill_only_worker", "kill_scheduler") if may_finish else ()):
            if not (one_line and named):
                return Outcome("unnamed_refusal", f"exit 3 in {len(lines)} line(s), last: {last[:240]}", code, wall)
            return Outcome("failed", "", code, wall)
        if code == 3 and may_finish:
            return Outcome("failed", "", code, wall)
        if code == 2 and case.failure in ("bad_address", "no_autocable", "foreign", "kill_scheduler"):
            if not (one_line and named):
                return Outcome("unnamed_refusal", f"exit 2 in {len(lines)} line(s), last: {last[:240]}", code, wall)
            return Outcome("refused_named", "", code, wall)
        return Outcome("wrong_exit_nonzero", f"exit {code} with {case.failure}: {last[:240]}", code, wall)

    def close(self) -> None:
        if self.shared is not None:
            self.shared.stop()
            sid = self.shared.proc.pid
            self.shared = None
            _kill_sessions([sid])


def run_scheduler_failures(n: int = 1000, seed: int = 0, base=None, log=None, budget_s: float | None = None,
                           cases: list | None = None) -> dict:
    """``n`` seeded `scheduler_case` cases, classified: {"table": {"scheduler_failures": {class:
    count}}, ...} with the seconds per case, the no-worker runs' wall times and the first problems.
    ``budget_s``: no case starts after so many seconds (``cases`` then says how many ran);
    ``cases``: these `SchedulerCase` instead of ``n`` drawn ones."""
    if not _dask():
        raise RuntimeError("the dask command is not installed (distributed)")
    say = log or (lambda s: None)
    tmp = None
    if base is None:
        tmp = base = tempfile.mkdtemp(prefix="autocable-scheduler-")
    row = dict.fromkeys(CLASSES, 0)
    examples, per_failure = [], {}
    h = SchedulerHarness(Path(base))
    t0 = time.perf_counter()
    try:
        if cases is not None:
            n = len(cases)
        for c in sorted({c.command for c in cases} - {"calibrate"}) if cases is not None else ("figures", "sweep"):
            h.reference(c)
        t_refs = time.perf_counter() - t0
        t1 = time.perf_counter()
        done = 0

        def draw(i):
            return scheduler_case(random.Random(f"{seed}:scheduler_failures:{i}"))
        for i, case in budgeted_cases(n, cases, draw, t0, budget_s):
            done += 1
            tc = time.perf_counter()
            o = h.run_case(case)
            cls = "orphaned" if h._orphans and o.cls not in ("hang", "traceback") else o.cls
            if h._orphans and cls == "orphaned":
                o.detail = (f"{len(h._orphans)} process(es) alive {ORPHAN_WAIT_S:g} s after the case: "
                            f"{'; '.join(h._orphans)}; {o.detail}")
            row[cls] += 1
            f = per_failure.setdefault(case.failure, {"cases": 0, "seconds": 0.0})
            f["cases"] += 1
            f["seconds"] += time.perf_counter() - tc
            if cls not in ("ok", "refused_named", "failed"):
                say(f"scheduler_failures case {i}: {cls}: {case.label}: exit {o.exit}: {o.detail[:2500]}")
                if len(examples) < 12:
                    examples.append({"class": cls, "case": case.label, "exit": o.exit, "problem": o.detail[:2500]})
            if (i + 1) % 20 == 0:
                say(f"scheduler_failures {i + 1}/{n} ({time.perf_counter() - t1:.0f} s) {row}")
        secs = time.perf_counter() - t1
    finally:
        h.close()
        if tmp:
            shutil.rmtree(tmp, ignore_errors=True)
    walls = sorted(h.no_worker_walls)
    return {"seed": seed, "cases": done, "cases_asked": n, "table": {"scheduler_failures": row},
            "seconds": {"scheduler_failures": round(secs, 1), "references": round(t_refs, 1)},
            "seconds_per_case": round(secs / done, 2) if done else None,
            "per_failure": {k: {"cases": v["cases"], "seconds_per_case": round(v["seconds"] / v["cases"], 1)}
                            for k, v in sorted(per_failure.items())},
            "no_worker_exit_seconds": ({"limit": NO_WORKER_S, "min": round(walls[0], 1), "median":
                                        round(walls[len(walls) // 2], 1), "max": round(walls[-1], 1)}
                                       if walls else None),
            "examples": examples}
