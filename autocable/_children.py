"""Child processes that die with their parent.

A calibration's screen pool, the ``autocable figures`` processes of its full evaluation and the
scene processes of ``figures`` and of the bound stage compute for minutes per task: when their
parent is killed (SIGKILL, an out-of-memory kill, a closed terminal) nothing would stop them.
`die_with_parent`, called first in each child, asks the Linux kernel to kill the child when the
parent ends (``prctl(PR_SET_PDEATHSIG, SIGKILL)``); elsewhere it does nothing.
"""
from __future__ import annotations

import ctypes
import os
import signal
import sys

__all__ = ["die_with_parent"]

#: prctl option: the signal a process gets when its parent ends (linux/prctl.h).
_PR_SET_PDEATHSIG = 1


def die_with_parent(parent: int | None = None) -> None:
    """Have this process killed (SIGKILL) when its parent process ends; ``parent``: the pid the
    caller expects as parent (a child whose parent is already gone exits at once: the request
    only covers deaths after it)."""
    if not sys.platform.startswith("linux"):
        return
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(_PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0)
    except (OSError, AttributeError):   # no prctl: the child lives on as before
        return
    if parent is not None and os.getppid() != parent:
        os._exit(1)
