"""Killing `autocable calibrate` (or `figures`) leaves no orphaned workers: the executor's worker
processes and the scene processes they fork die with their parent (`autocable._children`)."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="PR_SET_PDEATHSIG is Linux's")

_PARENT = '''
import os, sys, tempfile, time
from autocable.executor import Executor, run_forked

def nap(path):
    import os, time
    from autocable.executor import run_forked

    def child():
        with open(path, "w") as fh:
            fh.write(str(os.getpid()))
        time.sleep(120)
    return run_forked(child)

if __name__ == "__main__":
    path = os.path.join(tempfile.mkdtemp(), "child")
    with Executor(workers=2) as ex:
        pids = ex.worker_pids()
        ex.submit("nap", nap, path)
        while not (os.path.isfile(path) and open(path).read()):
            time.sleep(0.01)
        print(" ".join(str(p) for p in pids + [int(open(path).read())]), flush=True)
        time.sleep(120)
'''

_PARENT_OF_SUBPROCESS = '''
import os, subprocess, sys
from autocable._children import die_with_parent
parent = os.getpid()
proc = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(120)"],
                        preexec_fn=lambda: die_with_parent(parent))
print(proc.pid, flush=True)
proc.wait()
'''


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as fh:
            return fh.read().split(") ", 1)[1][0] != "Z"    # a zombie has ended
    except FileNotFoundError:
        return False


@pytest.mark.parametrize("script", [_PARENT, _PARENT_OF_SUBPROCESS], ids=["executor", "subprocess"])
def test_workers_die_when_their_parent_is_killed(script, tmp_path):
    """The executor's LocalCluster workers and the scene child a worker forked (`run_forked`), or
    a subprocess started with `die_with_parent`, end within 10 s of a SIGKILL of their parent."""
    env = dict(os.environ, PYTHONPATH=str(REPO))
    path = tmp_path / "parent.py"       # a file: the workers of a LocalCluster import the main module
    path.write_text(script)
    parent = subprocess.Popen([sys.executable, str(path)], stdout=subprocess.PIPE, text=True, env=env)
    try:
        children = [int(p) for p in parent.stdout.readline().split()]
        assert children and all(_alive(p) for p in children)
        parent.send_signal(signal.SIGKILL)
        parent.wait()
        deadline = time.time() + 10
        while time.time() < deadline and any(_alive(p) for p in children):
            time.sleep(0.05)
        assert not any(_alive(p) for p in children), "orphaned workers"
    finally:
        parent.kill()
