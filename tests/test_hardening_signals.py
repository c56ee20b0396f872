"""The kill harness interrupts for real: a harness started in the background by a non-interactive
shell has SIGINT ignored, its children inherit that, and Python then installs no
KeyboardInterrupt handler. The SIGINT trials of `tools.hardening kill-surfaces` all exited 0,
status complete, so none of them interrupted anything. `kill.sigint_default` gives the
child its default back."""
from __future__ import annotations

import signal
import subprocess
import sys

from tools.hardening.kill import sigint_default

_ASK = ("import signal; h = signal.getsignal(signal.SIGINT); "
        "print('ignored' if h == signal.SIG_IGN else 'python' if h is signal.default_int_handler else repr(h))")


def test_a_child_gets_its_sigint_back_when_the_harness_ignores_it():
    before = signal.signal(signal.SIGINT, signal.SIG_IGN)      # as a background job of `sh -c '... &'`
    try:
        plain = subprocess.run([sys.executable, "-c", _ASK], capture_output=True, text=True, timeout=60)
        fixed = subprocess.run([sys.executable, "-c", _ASK], capture_output=True, text=True, timeout=60,
                               preexec_fn=sigint_default)
    finally:
        signal.signal(signal.SIGINT, before)
    assert plain.stdout.strip() == "ignored"                  # the inherited disposition: no interrupt
    assert fixed.stdout.strip() == "python"                   # Python's KeyboardInterrupt handler
