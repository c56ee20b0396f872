"""The hardening harness outside the package (tools/hardening): its command runs from the
repository's top folder, and the `autocable bench` subcommands it replaced say where it went."""
import json
import subprocess
import sys

import pytest

from conftest import REPO


def _run(*argv, cwd=REPO):
    return subprocess.run([sys.executable, *argv], cwd=cwd, capture_output=True, text=True, timeout=300)


@pytest.mark.slow
def test_the_harness_runs_from_the_top_folder():
    """A tiny fuzz run: the counts asked for are the counts run, no problem, exit 0."""
    res = _run("-m", "tools.hardening", "fuzz", "--specs", "3", "--scenes", "2", "--args", "2",
               "--runs", "0", "--quiet")
    assert res.returncode == 0, res.stderr
    out = json.loads(res.stdout)
    assert (out["specs"], out["scenes"], out["args"], out["problem_count"]) == (3, 2, 2, 0)


def test_a_bad_harness_option_is_one_named_line():
    res = _run("-m", "tools.hardening", "kill", "--repeats", "1000")
    assert res.returncode == 2
    assert res.stderr.count("\n") == 1 and "--repeats" in res.stderr and "Traceback" not in res.stderr


def test_the_old_bench_subcommands_say_where_the_harness_went():
    for what in ("fuzz", "kill", "kill-surfaces"):
        res = _run("-m", "autocable.cli", "bench", what)
        assert res.returncode == 2, what
        line = res.stderr.strip()
        assert "\n" not in line and f"python -m tools.hardening {what}" in line, line


def test_the_package_holds_no_harness():
    assert not list((REPO / "autocable").rglob("fuzz*.py")) and not list((REPO / "autocable").rglob("kill*.py"))
