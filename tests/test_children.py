"""Killing `autocable calibrate` (or `figures`) leaves no orphaned workers: the screen pool's
processes and the scene processes die with their parent (`autocable._children`)."""
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
import os, sys, time
from autocable.paper.calibration import screen_pool
pool = screen_pool(2)
futures = [pool.submit(time.sleep, 120) for _ in range(2)]
while len(pool._processes) < 2:
    time.sleep(0.01)
time.sleep(0.3)
print(" ".join(str(p) for p in pool._processes), flush=True)
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


@pytest.mark.parametrize("script", [_PARENT, _PARENT_OF_SUBPROCESS], ids=["screen pool", "subprocess"])
def test_workers_die_when_their_parent_is_killed(script):
    env = dict(os.environ, PYTHONPATH=str(REPO))
    parent = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True, env=env)
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
