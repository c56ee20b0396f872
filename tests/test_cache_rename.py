"""Cache libraries are replaced by rename only, and a running process survives a library
rewritten in place under it (it loaded a private copy): no SIGBUS."""
from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]

_SCRIPT = textwrap.dedent('''
    import sys
    from pathlib import Path
    import numpy as np
    import sympy as sp
    from autocable.codegen.cintegrate import compiled_integrator, sample_grid
    y, k = sp.symbols("y k")
    ci = compiled_integrator("decay", ["y"], ["k"], [-k * y], None)
    grid = sample_grid(0.0, 1.0, 0.5)
    before = ci.run(np.array([1.0]), grid, [2.0], rtol=1e-10, atol=1e-12).y[-1, 0]
    lib = Path(ci.path)
    inode = lib.stat().st_ino
    if sys.argv[1] == "overwrite":
        # rewrite the cache file in place (same inode), as `cp other.so kernel.so` does
        with open(lib, "r+b") as fh:
            fh.write(b"\\0" * lib.stat().st_size)
    after = ci.run(np.array([1.0]), grid, [2.0], rtol=1e-10, atol=1e-12).y[-1, 0]
    print(repr(before), repr(after), inode == lib.stat().st_ino,
          sorted(p.name for p in lib.parent.iterdir() if p.name.startswith(".load.")))
''')


def _run(tmp_path, mode):
    env = dict(os.environ, PYTHONPATH=str(REPO), AUTOCABLE_CACHE=str(tmp_path / "cache"))
    return subprocess.run([sys.executable, "-c", _SCRIPT, mode], capture_output=True, text=True, env=env,
                          timeout=300)


def test_a_library_rewritten_in_place_does_not_crash_the_process_that_loaded_it(tmp_path):
    """exp(-2) from y' = -2 y over [0, 1] before and after the cache's library is overwritten
    with zeros in place: the same number, exit 0 (a mapping of the cache file itself would die
    with SIGBUS, -7), and no private copy left behind."""
    import math
    done = _run(tmp_path, "overwrite")
    assert done.returncode == 0, (done.returncode, done.stderr[-500:])
    before, after, same_inode, leftovers = done.stdout.split(" ", 3)
    assert float(before) == float(after) and abs(float(before) - math.exp(-2.0)) < 1e-9
    assert same_inode == "True" and leftovers.strip() == "[]"
