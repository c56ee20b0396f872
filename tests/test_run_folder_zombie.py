"""A run folder marked "running" by a process that has ended but was never reaped (a zombie: a scene
process killed with its executor worker, in a container whose PID 1 reaps nothing) is free: the
scene's rerun takes it (`autocable.run_folder.pid_alive`)."""
from __future__ import annotations

import os
import signal
import sys
import time

import pytest

from autocable.run_folder import pid_alive

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="/proc is Linux's")


def test_a_zombie_is_not_alive_and_a_live_process_is():
    pid = os.fork()
    if pid == 0:
        os._exit(0)
    deadline = time.time() + 10
    while time.time() < deadline:          # ended but not reaped: a zombie until waitpid
        with open(f"/proc/{pid}/stat") as fh:
            if fh.read().rsplit(") ", 1)[1][0] == "Z":
                break
        time.sleep(0.01)
    try:
        os.kill(pid, 0)                     # the kernel still finds it ...
        assert not pid_alive(pid)          # ... but it runs no more
    finally:
        os.waitpid(pid, 0)
    assert not pid_alive(pid)              # reaped: gone
    assert pid_alive(os.getpid())
    child = os.fork()
    if child == 0:
        time.sleep(30)
        os._exit(0)
    try:
        assert pid_alive(child)
    finally:
        os.kill(child, signal.SIGKILL)
        os.waitpid(child, 0)
