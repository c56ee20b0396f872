"""The two generated-input kinds of real processes (docs/robustness.md): ``cache_edits`` (autocable's
code or a run's input edited while `derive` stores into the cache, then two more runs compared with
empty-cache references) and ``scheduler_failures`` (real `dask scheduler` and `dask worker`
processes, one failure each), a handful of cases each, with zero in every bad column; and
`calibrate --scheduler` on a scheduler without workers, whose start line said "1 workers".

Slow tier: real subprocesses and Dask processes, about a minute on two shared cores."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest

from conftest import REPO

pytestmark = pytest.mark.slow

_GOOD = ("ok", "refused_named", "failed")


def _bad(row: dict) -> dict:
    return {c: n for c, n in row.items() if c not in _GOOD and n}


def test_cache_edits_cases_find_no_stale_result(tmp_path):
    from tools.hardening.fuzz_cache import CacheCase, run_cache_edits
    cases = [CacheCase("derive", "code:derive_damping", 0.3, keep=True),           # a number changes
             CacheCase("derive", "code:derive_damping_same_size", 0.6, keep=False),
             CacheCase("derive", "input:model_damping", 0.5, keep=False)]
    r = run_cache_edits(seed=39, base=tmp_path, cases=cases)
    row = r["table"]["cache_edits"]
    assert sum(row.values()) == len(cases) and not _bad(row), r["examples"]
    assert row["ok"] == len(cases)


def test_the_stale_oracle_can_fail(tmp_path):
    """A result of another tree state is not its state's reference: the comparison the stale
    column rests on tells the edited derivation from the base one."""
    from tools.hardening.fuzz_cache import CacheHarness, difference
    h = CacheHarness(tmp_path)
    base, edited = h.reference("derive", None), h.reference("derive", "code:derive_damping")
    assert '"xi_s": 0.008' in edited and '"xi_s": 0.004' in base   # eq. (21)'s xi_s doubled (0.4 % in the model)
    assert difference(edited, base) and not difference(base, base)


def test_scheduler_failures_each_failure_once(tmp_path):
    from tools.hardening.fuzz_scheduler import SchedulerCase, run_scheduler_failures
    # all on the sweep: one reference to compute (figures on a scheduler: tests/test_cluster_hang.py)
    cases = [SchedulerCase("no_worker", "sweep"),
             SchedulerCase("kill_only_worker", "sweep", 1.0, signal.SIGKILL),
             SchedulerCase("no_autocable", "sweep", variant="blocked"),
             SchedulerCase("foreign", "sweep"),
             SchedulerCase("kill_scheduler", "sweep", 1.5, signal.SIGKILL),
             SchedulerCase("bad_address", "sweep", variant="refused"),
             SchedulerCase("two_workers_one_killed", "sweep", 1.0, signal.SIGTERM),
             SchedulerCase("healthy", "sweep")]
    r = run_scheduler_failures(seed=39, base=tmp_path, cases=cases)
    row = r["table"]["scheduler_failures"]
    assert sum(row.values()) == len(cases) and not _bad(row), r["examples"]
    assert row["ok"] >= 2          # the healthy worker and the surviving one completed, correctly
    assert r["per_failure"]["healthy"]["cases"] == 1
    walls = r["no_worker_exit_seconds"]
    assert walls and walls["limit"] <= walls["max"] < walls["limit"] + 45


def test_calibrate_on_a_scheduler_without_workers_says_none_and_stops(tmp_path):
    """The start line counted max(workers, 1): "1 workers" on a scheduler none had joined."""
    from tools.hardening.fuzz_scheduler import Scheduler, _dask
    if not _dask():
        pytest.skip("the dask command is not installed")
    s = Scheduler(tmp_path / "scheduler")
    try:
        env = dict(os.environ, PYTHONPATH=str(REPO), AUTOCABLE_NO_WORKER_TIMEOUT="2",
                   AUTOCABLE_CACHE=str(tmp_path / "cache"))
        done = subprocess.run([sys.executable, "-m", "autocable.cli", "calibrate",
                               str(REPO / "models" / "luongo_zulli_2012.toml"),
                               str(REPO / "models" / "luongo_zulli_2012.targets.toml"), "--scheduler",
                               str(s.file), "--out", str(tmp_path / "out")], capture_output=True, text=True,
                              env=env, timeout=300)
    finally:
        s.stop()
    assert done.returncode == 3, done.stderr
    lines = [ln for ln in done.stderr.splitlines() if ln.strip()]
    start = [ln for ln in lines if "on the scheduler" in ln]
    assert start and "no worker yet" in start[0] and "1 workers" not in done.stderr, done.stderr
    assert "--scheduler" in lines[-1] and "no live worker for 2 s" in lines[-1], done.stderr


# ------------------------------------------------------------------------------------------------
# defects the scheduler_failures kind found (autocable/executor.py)
# ------------------------------------------------------------------------------------------------
def test_a_scheduler_lost_mid_run_stops_the_run_in_one_line(tmp_path, capfd):
    """The scheduler killed while its only worker runs a task: Dask cancels the client's tasks
    ("scheduler-connection-lost") and logs its reconnection attempts with tracebacks on stderr.
    Before: the task came back as an ordinary failed task ("fig03 failed: FutureCancelledError"),
    under those tracebacks; now `SchedulerLost` (exit 3) naming --scheduler, and Dask quiet."""
    import time

    from autocable.executor import Executor, NoLiveWorker, SchedulerLost
    from tools.hardening.fuzz_scheduler import Scheduler, SchedulerHarness, _dask
    if not _dask():
        pytest.skip("the dask command is not installed")
    h = SchedulerHarness(tmp_path / "h")
    s = Scheduler(tmp_path / "scheduler")
    w = h.worker(s, "ok", tmp_path)
    try:
        assert s.wait_workers(1)
        with Executor(scheduler=str(s.file), no_worker_timeout=30.0) as ex:
            ex.submit("long", time.sleep, 60.0)
            time.sleep(1.0)
            s.proc.kill()
            t0 = time.monotonic()
            with pytest.raises(SchedulerLost) as raised:
                list(ex.completed())
            waited = time.monotonic() - t0
        assert isinstance(raised.value, NoLiveWorker)          # figures marks its scenes failed for it
        assert str(raised.value).startswith(f"--scheduler {s.address}: the connection to the scheduler was lost")
        assert waited < 15.0, waited                            # at once, not after the 30 s no-worker limit
    finally:
        w.kill()
        w.wait(20)
        s.stop()
    err = capfd.readouterr().err
    assert "Traceback" not in err and "distributed.client - ERROR" not in err, err[-2000:]


def test_a_scheduler_gone_before_the_client_connects_is_named(monkeypatch):
    """`check_scheduler` saw it answer, then it stopped before Dask's client connected: the client's
    own error (OSError, CommClosedError) reached the catch-all, exit 2 without --scheduler."""
    import socket

    import autocable.executor as executor
    from autocable.spec import SpecError
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        port = sock.getsockname()[1]                           # closed again: nothing listens there
    monkeypatch.setattr(executor, "SCHEDULER_TIMEOUT", 1.0)
    with pytest.raises(SpecError, match=rf"--scheduler: tcp://127.0.0.1:{port} stopped answering while this "
                                        r"command connected .*check that the scheduler runs"):
        with executor.Executor(scheduler=f"tcp://127.0.0.1:{port}"):
            pass


class _Client:
    """A Dask client stand-in whose ``run`` answers for two workers, the second one dead (Dask
    returns its connection error with ``on_error="return"``, raises it with the default)."""

    status = "running"

    def __init__(self, scheduler_gone: bool = False):
        self.scheduler_gone = scheduler_gone

    def run(self, fn, on_error="raise"):
        from distributed.comm.core import CommClosedError
        if self.scheduler_gone:
            raise CommClosedError("in <TCP (closed) Client->Scheduler>: Stream is closed")
        dead = CommClosedError("in <TCP (closed) Scheduler Broadcast>: Stream is closed")
        if on_error == "raise":
            raise dead
        return {"tcp://127.0.0.1:1": fn(), "tcp://127.0.0.1:2": dead}      # (this process as worker 1)


def test_a_worker_dead_while_the_command_starts_is_left_out_not_fatal():
    """Two workers, one killed while `sweep --scheduler` starts: the CPU accounting's
    ``client.run`` raised the dead worker's CommClosedError through the catch-all (exit 2) although
    the other worker could finish the sweep."""
    import time

    from autocable.executor import Executor, SchedulerLost
    from autocable.studies.sweep import _cpu_times
    ex = Executor(scheduler="tcp://127.0.0.1:3")
    ex.client = _Client()
    cpu = _cpu_times(ex)
    assert list(cpu) == ["tcp://127.0.0.1:1"] and 0 < cpu["tcp://127.0.0.1:1"] <= time.process_time()
    # the sweep's last step, its workers' pids: a worker killed as the last task ended made a
    # complete sweep exit 2 (CommClosedError: Address removed.)
    assert ex.worker_pids() == [os.getpid()]
    ex.client = _Client(scheduler_gone=True)              # the scheduler itself: the run stops, named
    with pytest.raises(SchedulerLost, match=r"^--scheduler tcp://127.0.0.1:3: the connection to the scheduler"):
        ex.run_on_workers(time.process_time)
    ex.client = None


class _Loop:
    """The client's event loop, as Dask's ``client.loop``: an asyncio loop on its own thread."""

    def __init__(self):
        import asyncio
        import threading
        self.asyncio_loop = asyncio.new_event_loop()
        threading.Thread(target=self.asyncio_loop.run_forever, daemon=True).start()

    def stop(self):
        self.asyncio_loop.call_soon_threadsafe(self.asyncio_loop.stop)


class _FetchClient(_Client):
    """`_Client` with Dask's ``gather(..., asynchronous=True)`` (a coroutine run on ``loop``),
    counting the fetches started and cancelled."""

    def __init__(self):
        super().__init__()
        self.loop, self.fetches, self.cancelled = _Loop(), 0, 0

    def gather(self, futures, asynchronous=None):
        import asyncio
        assert asynchronous is True

        async def fetch():
            self.fetches += 1
            try:
                return [await futures[0].value()]
            except asyncio.CancelledError:
                self.cancelled += 1
                raise
        return fetch()


class _Future:
    """A Dask future stand-in: its value comes after ``after`` seconds (None: never, as a result
    lost with its worker and recomputed by Dask with no worker left), or its task raises ``error``.
    ``result(timeout=...)`` is refused: each timeout cancels Dask's gather and orphans its inner waits,
    whose ``AllExit`` printed as a traceback when the client closed."""

    def __init__(self, after=None, value=None, error=None):
        self.after, self._value, self.error = after, value, error

    async def value(self):
        import asyncio
        if self.after is None:
            await asyncio.Event().wait()
        await asyncio.sleep(self.after)
        if self.error is not None:
            raise self.error
        return self._value

    def result(self, timeout=None):
        raise AssertionError("fut.result() waits forever without a timeout, and cancels Dask's gather "
                             "at each timeout with one")


def _executor(no_worker_timeout: float, live: int):
    from autocable.executor import Executor
    ex = Executor(scheduler="tcp://127.0.0.1:3", no_worker_timeout=no_worker_timeout)
    ex.client, ex._pending = _FetchClient(), 1
    ex._live_workers = lambda: live
    return ex


def test_a_result_lost_with_the_last_worker_ends_the_run_not_hangs():
    """The hang of scheduler_failures (seed 0, case 731): `sweep --scheduler`, its only worker
    SIGKILLed 1.5 s after the start, still running at 150 s, waiting in ``fut.result()`` in
    `Executor.completed` (the thread stacks of the hung command)."""
    from autocable.executor import NoLiveWorker
    ex = _executor(0.3, live=0)
    t0 = time.monotonic()
    with pytest.raises(NoLiveWorker, match=r"^--scheduler tcp://127.0.0.1:3: no live worker for 0.3 s"):
        ex._result(_Future(after=None))
    assert time.monotonic() - t0 < 5.0
    ex.client.loop.stop()
    ex.client = None


def test_a_result_is_fetched_once_and_never_cancelled():
    """A result that takes several of `Executor._result`'s half-second slices (a worker alive all
    along) is fetched by one gather, never cancelled (the AllExit traceback of 1 in 46 kills came
    from the gathers ``fut.result(timeout=0.5)`` cancelled); a task's own TimeoutError is its error,
    raised at once, not taken for a slice that timed out."""
    ex = _executor(0.3, live=1)
    t0 = time.monotonic()
    assert ex._result(_Future(after=1.3, value=42)) == 42
    assert 1.3 <= time.monotonic() - t0 < 3.0
    assert ex.client.fetches == 1 and ex.client.cancelled == 0
    t0 = time.monotonic()
    with pytest.raises(TimeoutError, match="the task's own"):
        ex._result(_Future(after=0.1, error=TimeoutError("the task's own")))
    assert time.monotonic() - t0 < 0.45
    ex.client.loop.stop()
    ex.client = None
