"""One executor for every parallel job of autocable: the figure scenes (`autocable figures`), the
calibration's screen points, its full evaluations and its bound scenes (`autocable calibrate`), and
the sweeps (`autocable sweep`) are all tasks on Dask.

Where the tasks run (`Executor`):

* by default a ``LocalCluster`` of one single-threaded worker process per core (``workers=N``:
  N of them);
* ``scheduler="tcp://host:8786"`` (or the path of a scheduler file written by
  ``dask scheduler --scheduler-file``): the workers of an existing Dask cluster, on this machine or
  on many (docs/cluster.md: what each worker needs);
* ``workers=0``: in this process, one task after the other in the order submitted (the serial
  path, which the tests compare with the others, and a debugger can step through).

What a lost worker costs. A worker process that dies (killed, out of memory, its machine gone)
loses only the task it was running: the scheduler gives that task to another worker (Dask retries a
task whose worker died, up to ``distributed.scheduler.allowed-failures`` times). Results are
written by the tasks into the output folder as they finish, so a rerun of an interrupted command
resumes as before. With ``journal`` each task start is appended to that file (``label`` and the
worker's pid), so that a command can count the tasks computed more than once (`attempts`).

Isolation of a scene. A figure scene runs in a child forked by its worker (`run_forked`): PyDSTool's
build changes the process's working folder, a crash in generated C code must fail its scene rather
than kill the worker, and a scene over its time limit must be stoppable. The child dies with its
worker (`autocable._children.die_with_parent`).
"""
from __future__ import annotations

import heapq
import itertools
import json
import logging
import math
import os
import pickle
import select
import signal
import time
import traceback
import uuid
import warnings
from collections import Counter
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Iterator

from autocable.errors import ComputationError

__all__ = ["Executor", "Done", "run_forked", "attempts", "check_scheduler", "check_workers", "scheduler_address",
           "SCHEDULER_TIMEOUT", "NO_WORKER_TIMEOUT", "NO_WORKER_ENV", "NoLiveWorker", "SchedulerLost",
           "no_worker_seconds", "time_left"]

#: Seconds to reach a Dask scheduler and hear it answer (`check_scheduler`): a refused port, a
#: service that is not Dask or a peer that never answers is named at once, not after minutes.
SCHEDULER_TIMEOUT = 10.0


#: Seconds a run on Dask waits with tasks to do and no live worker before it stops
#: (`NoLiveWorker`): every worker died, the scheduler never had one, or the only one cannot import
#: autocable. Overridden by ``$AUTOCABLE_NO_WORKER_TIMEOUT`` or `Executor` ``no_worker_timeout``.
NO_WORKER_TIMEOUT = 60.0
NO_WORKER_ENV = "AUTOCABLE_NO_WORKER_TIMEOUT"


class NoLiveWorker(ComputationError):
    """A run on Dask had tasks to do and no live worker for `no_worker_seconds` seconds
    (exit status 3); ``str(err)`` is one line naming ``--scheduler`` (or ``--workers``)."""


class SchedulerLost(NoLiveWorker):
    """The connection to a ``--scheduler`` was lost with tasks unfinished (the scheduler stopped,
    or the network between them failed): Dask cancels every task of the client at once, so the
    run stops then, as with no live worker (exit status 3, one line naming ``--scheduler``)."""

#: Dask's own loggers, which print tracebacks on stderr when a scheduler goes away (the client's
#: reconnection attempts): quiet while a command is connected to a ``--scheduler``; what happened
#: is said by `SchedulerLost` in one line.
_DASK_LOGGERS = ("distributed", "distributed.client", "distributed.comm", "distributed.core",
                 "distributed.utils", "distributed.batched")


def no_worker_seconds(value: float | None = None) -> float:
    """``value``, else ``$AUTOCABLE_NO_WORKER_TIMEOUT``, else `NO_WORKER_TIMEOUT`; a value that is
    not a positive number of seconds is refused (`SpecError` naming the variable)."""
    from autocable.spec import SpecError
    if value is None:
        text = os.environ.get(NO_WORKER_ENV, "").strip()
        if not text:
            return NO_WORKER_TIMEOUT
        try:
            value = float(text)
        except ValueError:
            value = math.nan
        if not (math.isfinite(value) and value > 0):
            raise SpecError("environment", NO_WORKER_ENV, f"expected a positive number of seconds, got {text!r}; "
                                                          f"unset it for the default of {NO_WORKER_TIMEOUT:g} s")
        return value
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not (math.isfinite(value) and value > 0):
        raise SpecError("arguments", "no_worker_timeout", f"expected a positive number of seconds, got {value!r}")
    return float(value)


@dataclass
class Done:
    """A finished task: its ``label``, the function's return ``value``, or ``error`` (one line) when
    the task raised or its workers kept dying (Dask's ``KilledWorker``). ``code``: the autocable the
    task ran on (`autocable._store.running_code` of its worker, taken when it ended; None for a
    failed task), which decides whether its result may be stored under a key naming the code."""

    label: str
    value: Any = None
    error: str = ""
    code: dict | None = None

    @property
    def ok(self) -> bool:
        return not self.error


#: Worker processes: more than this is a typing error on any machine autocable targets.
WORKERS_LIMIT = 1024


def check_workers(option: str, value) -> None:
    """Refuse (`SpecError` naming ``option``) a worker count that is not a whole number in [0,
    twice the cores]: each worker is a process of its own; more than the cores only share them,
    and a thousand start for minutes before the first task."""
    from autocable.spec import SpecError
    if value is None:
        return
    cores = os.cpu_count() or 1
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= WORKERS_LIMIT:
        raise SpecError("arguments", option, f"expected an integer in [0, {WORKERS_LIMIT}], got {value!r}")
    if value > 2 * cores:
        raise SpecError("arguments", option, f"{value} worker processes on {cores} cores; give at most "
                                             f"{2 * cores} (twice the cores)")


# ------------------------------------------------------------------------------------------------
# the scheduler's address
# ------------------------------------------------------------------------------------------------
def scheduler_address(where: str) -> str:
    """The address of a scheduler given as an address (``tcp://host:8786``, ``host:8786``) or as
    the path of a scheduler file (``dask scheduler --scheduler-file F``: JSON with ``address``)."""
    from autocable.spec import SpecError
    if isinstance(where, str) and "://" not in where and (where.endswith(".json") or os.path.isfile(where)):
        try:
            data = json.loads(Path(where).read_text())
        except (OSError, ValueError) as exc:
            raise SpecError("arguments", "--scheduler", f"cannot read the scheduler file {where}: "
                                                        f"{getattr(exc, 'strerror', None) or exc}; give the file "
                                                        "`dask scheduler --scheduler-file` wrote, or an address "
                                                        "like tcp://host:8786") from None
        address = data.get("address") if isinstance(data, dict) else None
        if not isinstance(address, str) or not address:
            raise SpecError("arguments", "--scheduler", f"the scheduler file {where} names no address; give the "
                                                        "file `dask scheduler --scheduler-file` wrote")
        return address
    return where


def check_scheduler(address: str, timeout: float | None = None) -> None:
    """Refuse (`SpecError` naming ``--scheduler``) an address where no Dask scheduler answers
    within ``timeout`` seconds (default `SCHEDULER_TIMEOUT`): an empty or malformed address, a
    refused port (found at once), a service that never answers, or one that answers with other
    bytes (Dask would read its first bytes as a frame length and try to allocate exabytes). A
    scheduler file is read for its address first (`scheduler_address`)."""
    import asyncio
    import socket

    from autocable.spec import SpecError
    timeout = SCHEDULER_TIMEOUT if timeout is None else timeout

    def refuse(why: str):
        return SpecError("arguments", "--scheduler", f"{why}; give the address of a running Dask scheduler, "
                                                     "e.g. tcp://host:8786, or its scheduler file "
                                                     "(or leave --scheduler out)")

    if not isinstance(address, str) or not address.strip() or any(c.isspace() for c in address):
        raise refuse(f"expected an address like tcp://host:8786, got {address!r}")
    address = scheduler_address(address)
    if "://" not in address or address.startswith("tcp://"):
        hostport = address.split("://", 1)[-1]
        host, _, port = hostport.rpartition(":")
        if not host or not port.isdigit() or not 0 < int(port) < 65536:
            raise refuse(f"expected host:port, got {address!r}")
        try:
            socket.create_connection((host.strip("[]"), int(port)), timeout=timeout).close()
        except OSError as exc:
            raise refuse(f"cannot connect to {address}: {exc.strerror or exc}") from None

    async def identity():
        from distributed.comm import connect
        comm = await connect(address, timeout=timeout)
        try:
            await comm.write({"op": "identity", "reply": True})
            return await comm.read()
        finally:
            comm.abort()

    try:
        reply = asyncio.run(asyncio.wait_for(identity(), timeout))
    except (asyncio.TimeoutError, TimeoutError):
        raise refuse(f"{address} did not answer as a Dask scheduler within {timeout:g} s") from None
    except Exception as exc:  # noqa: BLE001 - whatever the peer sent, it is not a Dask scheduler
        first = (str(exc).strip().splitlines() or [""])[0][:100]
        raise refuse(f"{address} is not a Dask scheduler ({type(exc).__name__}: {first})") from None
    if not isinstance(reply, dict) or reply.get("type") != "Scheduler":
        raise refuse(f"{address} answered, but not as a Dask scheduler")


# ------------------------------------------------------------------------------------------------
# the journal of task starts
# ------------------------------------------------------------------------------------------------
@dataclass
class _Ran:
    """What a task on Dask returns: the function's ``value`` and the ``code`` its worker ran
    (`autocable._store.running_code`). A task given another task's future as an argument (a
    followed sweep's segments) gets the ``value`` (`_journaled` unwraps it)."""

    value: Any
    code: dict


def _foreign(ran: dict, expected: dict) -> str:
    """Why a worker running ``ran`` (`autocable._store.running_code`) may not run the tasks of a
    command running ``expected`` ("" when it may), with the fix; short, the worker's path last
    (a `SpecError` is cut at 240 characters)."""
    where = f"(its autocable: {ran.get('path')})"
    if ran.get("version") != expected.get("version"):
        return (f"runs autocable {ran.get('version')}, this command {expected.get('version')}; install this "
                f"command's autocable on the workers {where}")
    if not ran.get("code"):
        return (f"runs autocable whose {ran.get('changed')} changed after the worker started; restart the "
                f"workers {where}")
    if ran.get("code") != expected.get("code"):
        return (f"runs other autocable files (sha256 {str(ran.get('code'))[:12]}, this command's "
                f"{str(expected.get('code'))[:12]}); install this command's autocable on the workers {where}")
    return ""


def _worker_name() -> str:
    try:
        from distributed import get_worker
        return get_worker().address
    except Exception:   # noqa: BLE001 - not on a Dask worker (the serial path)
        return f"process {os.getpid()}"


def _journaled(journal: str | None, label: str, expected: dict | None, fn: Callable, *args):
    """Run ``fn(*args)`` on a worker after appending ``label`` to the journal (one short line, one
    ``write`` on a file opened for appending: lines of concurrent workers do not interleave), and
    return `_Ran` (its value and the autocable the worker runs: `autocable._store.running_code`);
    an argument that is another task's `_Ran` is given to ``fn`` as its value. With
    ``expected`` (the command's), a worker running another autocable refuses the task, by name,
    before it writes anything."""
    from autocable._store import running_code
    args = tuple(a.value if isinstance(a, _Ran) else a for a in args)    # a dependency's result
    if expected is not None:
        why = _foreign(running_code(), expected)
        if why:
            raise RuntimeError(f"the worker {_worker_name()} {why}")
    if journal:
        try:
            fd = os.open(journal, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
            try:
                os.write(fd, (json.dumps({"label": label, "pid": os.getpid()}) + "\n").encode())
            finally:
                os.close(fd)
        except OSError:
            pass    # a worker without the shared folder: the journal only counts, the task still runs
    return _Ran(fn(*args), running_code())    # the code taken after the task: an edit meanwhile is seen


def attempts(journal: str | Path) -> Counter:
    """How many times each task label was started, from a journal (`Executor` ``journal``)."""
    counts: Counter = Counter()
    try:
        text = Path(journal).read_text()
    except OSError:
        return counts
    for line in text.splitlines():
        try:
            counts[json.loads(line)["label"]] += 1
        except (ValueError, KeyError, TypeError):
            continue    # a line cut by a kill
    return counts


# ------------------------------------------------------------------------------------------------
# the executor
# ------------------------------------------------------------------------------------------------
class Executor:
    """Tasks on Dask (module docstring). Use as a context manager::

        with Executor(workers=2) as ex:
            for item in items:
                ex.submit(label, fn, item)
            for done in ex.completed():        # as they finish; tasks submitted meanwhile join
                ...

    ``workers``: LocalCluster worker processes (None: one per core; 0: serial, in this process);
    ``scheduler``: an existing scheduler's address or scheduler file (``workers`` is then
    ignored); ``warm``: a function every worker runs once before the first task (imports,
    compiled integrators), none of whose result is kept; ``journal``: a file the task starts are
    appended to (`attempts`), emptied at the start; ``cluster_kwargs``: more LocalCluster
    arguments; ``strict_priority``: tasks are handed to the cluster one per free worker, the one of
    highest priority at that moment (tasks of seconds, whose order matters: figure scenes and
    calibration points; on the serial path too). ``no_worker_timeout``: seconds with tasks to do
    and no live worker before `completed` raises `NoLiveWorker` (default `no_worker_seconds`). On
    a ``scheduler``'s cluster every worker must run the command's autocable (same version and
    package sha256): the workers there at the start are checked at once (a `SpecError` naming
    ``--scheduler`` and the worker), one that joins later refuses its tasks by name."""

    def __init__(self, workers: int | None = None, scheduler: str | None = None, *,
                 warm: Callable[[], Any] | None = None, journal: str | Path | None = None,
                 cluster_kwargs: dict | None = None, strict_priority: bool = False,
                 no_worker_timeout: float | None = None):
        self.workers, self.scheduler, self.warm = workers, scheduler, warm
        self.no_worker_timeout = no_worker_seconds(no_worker_timeout)
        self._expected: dict | None = None     # the command's autocable, checked on a scheduler's workers
        self.strict_priority = strict_priority
        self.journal = str(Path(journal).resolve()) if journal else None
        self.cluster_kwargs = dict(cluster_kwargs or {})
        self.client = self._cluster = self._ac = None
        self._log_levels: dict = {}
        self._queue: list = []          # the serial path's tasks, in order
        self._held: list = []           # strict priority: a heap of the tasks not yet handed out
        self._seq = itertools.count()
        self._in_flight = 0
        self._pending = 0
        self.where: dict = {}

    @property
    def serial(self) -> bool:
        return self.workers == 0 and not self.scheduler

    @property
    def n_workers(self) -> int:
        """Workers at hand now, at least 1 (1 on the serial path): what sizes the tasks. A count to
        tell a user is `live_workers`, which can be 0."""
        if self.client is None:
            return 1
        return max(len(self.client.scheduler_info().get("workers", {})), 1)

    @property
    def live_workers(self) -> int:
        """Workers the cluster has now: 0 on a scheduler no worker has joined or whose workers all
        died (the tasks then wait `no_worker_timeout` seconds for one, then `NoLiveWorker`); 1 on
        the serial path."""
        if self.client is None:
            return 1
        return self._live_workers()

    def __enter__(self) -> "Executor":
        t0 = time.perf_counter()
        if self.journal:
            try:
                Path(self.journal).parent.mkdir(parents=True, exist_ok=True)
                Path(self.journal).write_text("")
            except OSError:
                self.journal = None
        if self.serial:
            self.where = {"mode": "serial"}
            if self.warm is not None:
                self.warm()
        else:
            import dask
            from dask.distributed import Client, LocalCluster

            from autocable._store import cache_dir
            # Dask's scratch space (spilled data, worker folders) inside autocable's cache, not the
            # system temporary folder: a command writes nowhere but its --out and the cache.
            scratch = str(cache_dir("dask-scratch"))
            with dask.config.set({"temporary-directory": scratch}):
                if self.scheduler:
                    from autocable.spec import SpecError
                    address = scheduler_address(self.scheduler)
                    self._quiet_dask()
                    try:
                        self.client = Client(address, timeout=SCHEDULER_TIMEOUT)
                    except Exception as exc:  # noqa: BLE001 - it answered check_scheduler, then went away
                        self.close()
                        raise SpecError("arguments", "--scheduler", f"{address} stopped answering while this "
                                                                    f"command connected ({_one_line(exc)[:100]}); "
                                                                    "check that the scheduler runs") from None
                    self.where = {"mode": "scheduler", "address": address}
                    self._check_workers_code(address)
                else:
                    n = self.workers if self.workers else (os.cpu_count() or 1)
                    with warnings.catch_warnings():
                        # the scheduler's HTTP port taken by another cluster on this machine: Dask
                        # moves to a free one and says so on stderr; nothing for a user to do
                        warnings.filterwarnings("ignore", message=r"Port \d+ is already in use")
                        self._cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                                                     dashboard_address=None, silence_logs=logging.ERROR,
                                                     local_directory=scratch, **self.cluster_kwargs)
                    self.client = Client(self._cluster)
                    self.where = {"mode": "LocalCluster", "workers": n}
            if self.warm is not None:
                # every worker at hand now; one that joins later does it in its first task
                try:
                    warmed = self.run_on_workers(self.warm)
                except Exception as exc:  # noqa: BLE001 - on a scheduler: it went away meanwhile
                    if not self.scheduler or self._connected():
                        raise
                    self.close()
                    raise self._lost(self._pending) from None
                for value in warmed.values():
                    if isinstance(value, BaseException):
                        raise value
            self.where["workers_seen"] = self.live_workers
        self.where["startup_seconds"] = time.perf_counter() - t0
        return self

    def _check_workers_code(self, address: str) -> None:
        """Refuse (`SpecError` naming ``--scheduler`` and the worker) a cluster whose workers at
        hand run another autocable than this command (version or package sha256), or cannot
        import it; workers that join later are checked by each task (`_journaled`)."""
        from autocable._store import code_fingerprint
        from autocable._version import __version__
        from autocable.spec import SpecError
        self._expected = {"version": __version__, "code": code_fingerprint("package")}
        from autocable._store import running_code
        try:
            seen = self.run_on_workers(running_code)
        except Exception as exc:   # noqa: BLE001 - the scheduler went away meanwhile
            self.close()
            raise SpecError("arguments", "--scheduler", f"cannot ask the workers of {address} which autocable they "
                                                        f"run ({_one_line(exc)}); check the scheduler") from None
        for worker, ran in sorted(seen.items()):
            if isinstance(ran, BaseException):
                why = (f"cannot run autocable's code ({_one_line(ran)[:80]}); install autocable in the workers' "
                       "environment")
            elif not isinstance(ran, dict):
                why = "answered with something else than its autocable; install autocable on the workers"
            else:
                why = _foreign(ran, self._expected)
            if why:
                self.close()
                raise SpecError("arguments", "--scheduler", f"the worker {worker} {why}")

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        if self.client is not None:
            self.client.close()
            self.client = None
        if self._cluster is not None:
            self._cluster.close()
            self._cluster = None
        for name, level in self._log_levels.items():
            logging.getLogger(name).setLevel(level)
        self._log_levels = {}

    def _quiet_dask(self) -> None:
        """Dask's loggers quiet until `close` (`_DASK_LOGGERS`)."""
        for name in _DASK_LOGGERS:
            log = logging.getLogger(name)
            self._log_levels.setdefault(name, log.level)
            log.setLevel(logging.CRITICAL + 1)

    def run_on_workers(self, fn: Callable) -> dict:
        """``fn()`` on every worker at hand: {worker address: its value, or the exception it raised}.
        A worker that cannot be reached (it died meanwhile: a connection error) is left out, as
        if it had not been there: its tasks go to the others (two workers, one killed while the
        command starts, must not stop a run the other can finish). A ``--scheduler`` that cannot
        be reached raises `SchedulerLost`."""
        try:
            seen = self.client.run(fn, on_error="return")
        except OSError:         # the scheduler itself cannot be reached (workers' errors are returned)
            if self.scheduler:
                raise self._lost(self._pending) from None
            raise
        return {w: v for w, v in seen.items() if not isinstance(v, OSError)}

    def _connected(self) -> bool:
        return self.client is not None and getattr(self.client, "status", "running") == "running"

    def _lost(self, waiting: int) -> "SchedulerLost":
        address = self.where.get("address", self.scheduler)
        return SchedulerLost(f"--scheduler {address}: the connection to the scheduler was lost with {waiting} "
                             f"task(s) unfinished (it stopped, or the network failed); start it and its workers "
                             f"again and rerun (finished results are kept)")

    def submit(self, label: str, fn: Callable, *args, priority: int = 0):
        """Queue ``fn(*args)`` (a module-level function: it travels to the workers by reference,
        its arguments by value; paths must be absolute). ``priority``: higher starts first.
        Returns the Dask future (None on the serial path, and with ``strict_priority``, where the
        task may not have been handed to Dask yet)."""
        self._pending += 1
        if self.client is None and not self.strict_priority:
            self._queue.append((label, fn, args))
            return None
        if self.strict_priority:
            # Dask assigns a task without dependencies to a worker when it is submitted (and may
            # steal it later); its priority orders only that worker's queue. Held here and handed
            # over one per free worker, the task of highest priority at that moment runs next.
            # On the serial path the heap is the queue: the highest first, the earliest of equals.
            heapq.heappush(self._held, (-priority, next(self._seq), label, fn, args))
            if self.client is not None:
                self._feed()
            return None
        return self._send(label, fn, args, priority)

    def _send(self, label: str, fn: Callable, args: tuple, priority: int):
        fut = self.client.submit(_journaled, self.journal, label, self._expected, fn, *args, pure=False,
                                 priority=priority,
                                 key=f"{label}-{uuid.uuid4().hex[:12]}")
        fut._autocable_label = label
        self._in_flight += 1
        if self._ac is not None:
            self._ac.add(fut)
        else:
            self._queue.append(fut)
        return fut

    def _slots(self) -> int:
        """Tasks the cluster can run at once now: its workers' threads (at least 1)."""
        workers = self.client.scheduler_info().get("workers", {})
        return max(sum(int(w.get("nthreads", 1)) for w in workers.values()), 1)

    def _feed(self) -> None:
        room = self._slots() - self._in_flight if self._held else 0
        while self._held and room > 0:
            neg, _, label, fn, args = heapq.heappop(self._held)
            self._send(label, fn, args, -neg)
            room -= 1

    @property
    def pending(self) -> int:
        """Tasks submitted and not yet handed back by `completed`."""
        return self._pending

    def completed(self) -> Iterator[Done]:
        """The tasks as they finish (on the serial path: run now, in order), including the tasks
        submitted while iterating; a task that raised, or whose workers kept dying, comes back with
        its ``error``."""
        if self.client is None:
            while self._queue or self._held:
                if self._held:
                    _, _, label, fn, args = heapq.heappop(self._held)
                else:
                    label, fn, args = self._queue.pop(0)
                try:
                    ran = _journaled(self.journal, label, None, fn, *args)
                    done = Done(label, ran.value, code=ran.code)
                except Exception as exc:  # noqa: BLE001 - the caller decides what a failed task means
                    done = Done(label, None, _one_line(exc))
                self._pending -= 1
                yield done
            return
        from dask.distributed import as_completed
        self._feed()        # workers that joined since the tasks were queued
        self._ac = as_completed(self._queue)
        self._queue = []
        try:
            while True:
                fut = self._next_finished()
                if fut is None:
                    break
                label = getattr(fut, "_autocable_label", str(fut.key))
                try:
                    ran = self._result(fut)
                    done = Done(label, ran.value, code=ran.code)
                except NoLiveWorker:
                    raise
                except Exception as exc:  # noqa: BLE001 - KilledWorker, or the task's own error
                    if self.scheduler and (not self._connected() or "scheduler-connection-lost" in str(exc)):
                        raise self._lost(self._pending) from None      # every task was cancelled with it
                    done = Done(label, None, _one_line(exc))
                fut.release()
                self._pending -= 1
                self._in_flight -= 1
                self._feed()        # the next task starts before the caller handles this one
                yield done
        finally:
            self._ac = None

    def _result(self, fut):
        """The result of a finished task, bounded as `_next_finished` is: a result held by a worker
        that died as the task ended is recomputed by Dask, which then waits, silently and forever,
        for a worker (found by the hardening runs: a sweep whose only worker was killed 1.5 s after
        the command started). `NoLiveWorker` (or `SchedulerLost`) after ``no_worker_timeout``
        seconds without a live worker.

        One fetch is started on the client's event loop and waited on in slices that do not cancel
        it: ``fut.result(timeout=...)`` cancels its gather at each timeout, which orphans Dask's
        inner waits; their ``AllExit`` then printed as a traceback when the client closed (1 of 46
        kills in the hardening runs)."""
        import asyncio
        fetch = asyncio.run_coroutine_threadsafe(self.client.gather([fut], asynchronous=True),
                                                 self.client.loop.asyncio_loop)
        alone_since = None
        while True:
            try:
                return fetch.result(timeout=0.5)[0]
            except TimeoutError:
                if fetch.done():
                    raise           # the task's own TimeoutError: its error, not a wait
            now = time.monotonic()
            if self.scheduler and not self._connected():
                raise self._lost(self._pending)
            if self._live_workers() > 0:
                alone_since = None
            elif alone_since is None:
                alone_since = now
            elif now - alone_since >= self.no_worker_timeout:
                raise NoLiveWorker(self._no_worker_message(self._pending - 1))

    def _live_workers(self) -> int:
        """Workers the scheduler knows now (0 when the client lost its scheduler)."""
        try:
            if getattr(self.client, "status", "running") != "running":
                return 0
            return len(self.client.scheduler_info().get("workers", {}))
        except Exception:   # noqa: BLE001 - a scheduler gone: no worker either
            return 0

    def _next_finished(self):
        """The next finished future (None when none is left), waiting as Dask's own iterator does,
        but raising `NoLiveWorker` once tasks have waited `no_worker_timeout` seconds with no live
        worker: Dask keeps such tasks queued forever."""
        ac = self._ac
        alone_since = None
        next_look = 0.0
        while not ac.has_ready():
            if ac.is_empty():
                return None
            now = time.monotonic()
            if now >= next_look:
                next_look = now + 0.5
                if self.scheduler and not self._connected():
                    raise self._lost(ac.count() + len(self._held))
                if self._live_workers() > 0:
                    alone_since = None
                elif alone_since is None:
                    alone_since = now
                elif now - alone_since >= self.no_worker_timeout:
                    raise NoLiveWorker(self._no_worker_message(ac.count()))
            cond = getattr(ac, "thread_condition", None)
            if cond is not None:
                with cond:
                    cond.wait(timeout=0.1)
            else:   # pragma: no cover - an older Dask
                time.sleep(0.1)
        return next(ac)

    def _no_worker_message(self, waiting: int) -> str:
        tasks = f"{waiting + len(self._held)} task(s) waiting"
        if self.scheduler:
            return (f"--scheduler {self.where.get('address', self.scheduler)}: no live worker for "
                    f"{self.no_worker_timeout:g} s with {tasks} (every worker died, none ever joined, or "
                    f"none can import autocable); start workers (dask worker ADDRESS --nthreads 1) with "
                    f"autocable installed, or raise {NO_WORKER_ENV}")
        return (f"--workers: no live worker process for {self.no_worker_timeout:g} s with {tasks} "
                f"(every worker died and none restarted); run again, or with --workers 0, or raise {NO_WORKER_ENV}")

    def worker_pids(self) -> list[int]:
        """The pids of the worker processes (this process on the serial path)."""
        if self.client is None:
            return [os.getpid()]
        # a worker that died since its last task (its run may well be complete) is left out
        return sorted({v for v in self.run_on_workers(os.getpid).values() if isinstance(v, int)})


def _one_line(exc: BaseException) -> str:
    text = " ".join(str(exc).split())
    return f"{type(exc).__name__}: {text[:300]}" if text else type(exc).__name__


# ------------------------------------------------------------------------------------------------
# a task in a forked child
# ------------------------------------------------------------------------------------------------
def run_forked(fn: Callable, args: tuple = (), timeout: float | None = None,
               what: str = "task") -> tuple[str, Any, str]:
    """Run ``fn(*args)`` in a child forked from this process and return ``("ok", value, "")``, or
    ``("failed", one-line error, traceback)`` when it raised, died (a signal, e.g. a segfault in
    compiled code) or ran past ``timeout`` seconds (then it is killed); ``what`` names the work in
    those messages. The value must pickle.

    ``os.fork`` rather than `multiprocessing`: a Dask worker is a daemonic process, and
    multiprocessing refuses children to those. The child ends with ``os._exit`` (no exit handlers of
    the worker run in it) and dies with its parent."""
    r, w = os.pipe()
    pid = os.fork()
    if pid == 0:                                     # the child
        code = 0
        try:
            os.close(r)
            from autocable._children import die_with_parent
            die_with_parent()
            try:
                msg = ("ok", fn(*args), "")
            except BaseException as exc:  # noqa: BLE001 - everything goes back to the parent
                msg = ("failed", _one_line(exc), traceback.format_exc())
            try:
                data = pickle.dumps(msg)
            except Exception as exc:  # noqa: BLE001
                data = pickle.dumps(("failed", f"the result does not pickle: {_one_line(exc)}", ""))
            view = memoryview(data)
            while view:
                view = view[os.write(w, view):]
        except BaseException:  # noqa: BLE001
            code = 1
        finally:
            os._exit(code)
    os.close(w)
    chunks, deadline = [], (time.monotonic() + timeout) if timeout else math.inf
    timed_out = False
    try:
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                timed_out = True
                break
            ready, _, _ = select.select([r], [], [], min(left, 3600.0))
            if not ready:
                continue
            chunk = os.read(r, 1 << 16)
            if not chunk:
                break
            chunks.append(chunk)
    finally:
        os.close(r)
        if timed_out:
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
        _, status = os.waitpid(pid, 0)
    if timed_out:
        return ("failed", f"stopped after the time limit of {timeout:g} s", "")
    try:
        return pickle.loads(b"".join(chunks))
    except Exception:  # noqa: BLE001 - nothing (or half a message) came back: the child died
        if os.WIFSIGNALED(status):
            why = f"killed by signal {os.WTERMSIG(status)}"
        else:
            why = f"exit status {os.WEXITSTATUS(status)}"
        return ("failed", f"the {what}'s process died ({why}) without a result", "")


# ------------------------------------------------------------------------------------------------
# progress
# ------------------------------------------------------------------------------------------------
def time_left(done: int, total: int, elapsed: float) -> str:
    """``"about 3 min left"`` at the mean rate so far ("" before the first task is done)."""
    if done <= 0 or total <= done or elapsed <= 0:
        return ""
    s = elapsed / done * (total - done)
    if s < 90:
        return f"about {s:.0f} s left"
    if s < 5400:
        return f"about {s / 60:.0f} min left"
    return f"about {s / 3600:.1f} h left"
