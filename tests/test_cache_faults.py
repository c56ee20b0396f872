"""The cache under faults: hostile model names, damaged artefacts, broken locks, a read-only cache.

Each test is a reproduction that used to give a wrong answer with exit 0 (or fail every later run)
and now gives the clean-cache answer, with at most one stderr line saying what was rebuilt. The
reference is `autocable simulate` of the sample cable in a fresh cache; a rebuilt artefact must
reproduce it to 1e-12 relative (the same code on the same input: only rounding-free reuse differs).
"""
from __future__ import annotations

import dataclasses
import json
import os
import shutil
import stat
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from conftest import REPO, SAMPLE

SIMULATE = ("simulate", str(SAMPLE), "--U", "0.7", "--eta", "4.1e-4", "--sigma", "0.01", "--json")
AME = (*SIMULATE, "--method", "ame")
REBUILT = "autocable: cache: "


def _env(cache: Path) -> dict:
    return {**os.environ, "AUTOCABLE_CACHE": str(cache),
            "PYTHONPATH": os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")])}


def _cli(cache: Path, *args: str, cwd: Path | None = None, prefix: tuple = ()) -> subprocess.CompletedProcess:
    return subprocess.run([*prefix, sys.executable, "-m", "autocable.cli", *args], env=_env(cache),
                          cwd=cwd or REPO, capture_output=True, text=True, timeout=600)


def _a1(done: subprocess.CompletedProcess) -> float:
    assert done.returncode == 0, done.stderr[-2000:]
    return json.loads(done.stdout)["a1"]


def _rebuilt_lines(done: subprocess.CompletedProcess) -> list[str]:
    return [ln for ln in done.stderr.splitlines() if ln.startswith(REBUILT)]


@pytest.fixture(scope="module")
def warm(tmp_path_factory):
    """A cache warmed by one clean `simulate` of the sample (eq. (21), then the AME: the compiled
    PyDSTool and C integrators, the derivation and the AME), a1 of eq. (21) and a1 of the AME."""
    cache = tmp_path_factory.mktemp("warm") / "cache"
    return cache, _a1(_cli(cache, *SIMULATE)), _a1(_cli(cache, *AME))


@pytest.fixture()
def cache(warm, tmp_path):
    """A private copy of the warm cache (each test damages its own)."""
    copy = tmp_path / "cache"
    shutil.copytree(warm[0], copy, symlinks=True)
    return copy


def _files(root: Path) -> set[Path]:
    return {p for p in root.rglob("*")}


# ------------------------------------------------------------------------------------------------
# names from content hashes only

HOSTILE_NAMES = ["../../escaped", "a/b", "line\nbreak/../../x", "ABSOLUTE"]


@pytest.mark.parametrize("name", HOSTILE_NAMES)
def test_model_name_never_makes_a_path(name, tmp_path, monkeypatch, sample_spec):
    """`derive` of a spec whose name is a relative escape, holds '/' or a newline, or is an absolute
    path writes only inside the cache folder, under names that do not contain the model name."""
    from autocable.model.derive import derive
    root = tmp_path / "root"
    cache_folder = root / "c1" / "c2" / "cache"
    cache_folder.mkdir(parents=True)
    if name == "ABSOLUTE":
        name = str(root / "abs" / "escaped")
    monkeypatch.setenv("AUTOCABLE_CACHE", str(cache_folder))
    d = derive(dataclasses.replace(sample_spec, name=name))
    assert not d.from_cache
    created = _files(root)
    assert created, "derive wrote nothing"
    outside = sorted(str(p) for p in created if p != cache_folder and cache_folder not in p.parents
                     and p not in cache_folder.parents)
    assert outside == []
    assert not any("escaped" in p.name or "break" in p.name for p in created)


@pytest.mark.parametrize("name", ["../../escaped", "x/../../../y\nz"])
@pytest.mark.slow
def test_model_file_with_hostile_name_writes_only_in_the_cache(name, cache, warm, tmp_path):
    """The same through the command line and a model file: `derive` and a `simulate` either refuse
    the name (exit 2) or run, and every file created lies in the cache folder; a run gives the
    sample's a1 (the name is not physics)."""
    shutil.rmtree(cache / "derivations")          # so the derivation is written again
    work = tmp_path / "w1" / "w2"
    work.mkdir(parents=True)
    text = SAMPLE.read_text(encoding="utf-8").replace('name = "luongo_zulli_2012"',
                                                      f"name = {json.dumps(name)}", 1)
    assert json.dumps(name) in text
    model = work / "model.toml"
    model.write_text(text, encoding="utf-8")
    before = _files(tmp_path)
    for args in (("derive", str(model), "--json"), ("simulate", str(model), *SIMULATE[2:])):
        done = _cli(cache, *args, cwd=work)
        assert done.returncode in (0, 2), done.stderr[-2000:]
        if done.returncode == 0 and args[0] == "simulate":
            assert json.loads(done.stdout)["a1"] == pytest.approx(warm[1], rel=1e-12, abs=0)
    new = _files(tmp_path) - before
    assert sorted(str(p) for p in new if cache not in p.parents) == []


# ------------------------------------------------------------------------------------------------
# every artefact checked on load

def _only(folder: Path, pattern: str) -> Path:
    found = [p for p in folder.rglob(pattern) if "__pycache__" not in p.parts]
    assert len(found) == 1, found
    return found[0]


@pytest.mark.parametrize("damage", ["emptied", "garbled"])
@pytest.mark.slow
def test_damaged_pydstool_wrapper_is_rebuilt(damage, cache, warm):
    """An emptied or garbled ``*_vf.py`` wrapper of the PyDSTool build gave a1 = Infinity,
    "diverged", exit 0 in every later run: now the build fails its check and is made again."""
    wrapper = _only(cache / "pydstool", "dop853_*_vf.py")
    wrapper.write_text("" if damage == "emptied" else "import sys\nx = (\n", encoding="utf-8")
    done = _cli(cache, *SIMULATE)
    assert _a1(done) == pytest.approx(warm[1], rel=1e-12, abs=0)
    assert len(_rebuilt_lines(done)) == 1 and "PyDSTool library" in done.stderr
    again = _cli(cache, *SIMULATE)                 # repaired for good: silent and right
    assert _a1(again) == pytest.approx(warm[1], rel=1e-12, abs=0) and _rebuilt_lines(again) == []


@pytest.mark.parametrize("damage", ["library", "pickle"])
@pytest.mark.slow
def test_corrupt_library_or_truncated_pickle_is_rebuilt(damage, cache, warm):
    """Two bytes changed inside the compiled library, or the pickled generator cut short: the
    sha256 in the build manifest no longer matches, the artefact is rebuilt, a1 is the clean one."""
    if damage == "library":
        target = _only(cache / "pydstool", "_dop853_*_vf*.so")
        blob = bytearray(target.read_bytes())
        blob[len(blob) // 2: len(blob) // 2 + 2] = b"\xff\xfe"
        target.write_bytes(bytes(blob))
    else:
        target = _only(cache / "pydstool", "*.generator.pickle")
        target.write_bytes(target.read_bytes()[:100])
    done = _cli(cache, *SIMULATE)
    assert _a1(done) == pytest.approx(warm[1], rel=1e-12, abs=0)
    assert len(_rebuilt_lines(done)) == 1
    assert ("pickled generator" if damage == "pickle" else "PyDSTool library") in done.stderr


@pytest.mark.slow
def test_edited_derivation_is_derived_again(cache, warm):
    """A cached derivation edited in place (omega1 x 1.01) was used as is (a1 off by 41 %): its
    payload no longer matches its sha256, so eq. (21) is derived again and a1 is the clean one."""
    path = _only(cache / "derivations", "eq21-*.json")
    doc = json.loads(path.read_text(encoding="utf-8"))
    doc["payload"]["ode"]["omega1"] *= 1.01
    path.write_text(json.dumps(doc), encoding="utf-8")
    done = _cli(cache, *SIMULATE)
    assert _a1(done) == pytest.approx(warm[1], rel=1e-12, abs=0)
    assert _rebuilt_lines(done) == [f"{REBUILT}derivation {path.name} failed its check, rebuilt"]
    assert json.loads(path.read_text(encoding="utf-8"))["payload"]["ode"]["omega1"] == \
        pytest.approx(doc["payload"]["ode"]["omega1"] / 1.01, rel=1e-15, abs=0)


@pytest.mark.slow
def test_edited_amplitude_equations_are_derived_again(cache, warm):
    """The same for the cached AME (22)-(24): its frequencies x 1.01 are detected, the AME derived
    again, and `simulate --method ame` gives the clean a1."""
    path = _only(cache / "ame", "ame-*.json")
    doc = json.loads(path.read_text(encoding="utf-8"))
    doc["payload"]["omegas"] = [w * 1.01 for w in doc["payload"]["omegas"]]
    path.write_text(json.dumps(doc), encoding="utf-8")
    done = _cli(cache, *AME)
    assert _a1(done) == pytest.approx(warm[2], rel=1e-12, abs=0)
    assert _rebuilt_lines(done) == [f"{REBUILT}amplitude equations {path.name} failed its check, rebuilt"]


_C_SCRIPT = textwrap.dedent("""
    import json
    import sympy as sp
    from autocable.codegen.cintegrate import compiled_integrator
    from autocable.codegen.ckernel import compiled_kernel
    x, k = sp.symbols("x k")
    c = compiled_integrator("../../decay", ("x",), ("k",), (-k * x,), None)
    run = c.run([1.0], [0.0, 1.0], [2.0], rtol=1e-10, atol=1e-12)
    from autocable.methods.continuation.system import System
    kern = compiled_kernel(System("../../cubic", ("x",), (-k * x ** 3,), {"k": 3.0}, ()))
    print(json.dumps({"x1": float(run.y[-1][0]), "f": float(kern.f([2.0], [3.0])[0]),
                      "compiled": [dict(c.timings)["compile_s"] > 0, dict(kern.timings)["compile_s"] > 0]}))
""")


@pytest.mark.parametrize("damage", ["garbled", "truncated", "lock is a folder"])
@pytest.mark.slow
def test_c_kernel_and_integrator_checked_and_locks_recover(damage, tmp_path):
    """The C integrator (`cintegrate`) and kernel (`ckernel`): a garbled or truncated ``kernel.so``
    is rebuilt (one line each), a build lock replaced by a folder no longer blocks the build; the
    numbers are the closed forms (exp(-2) and -k x^3 = -24). The folders are content hashes: the
    names "../../..." never reach a path."""
    cache = tmp_path / "cache"
    first = subprocess.run([sys.executable, "-c", _C_SCRIPT], env=_env(cache), capture_output=True,
                           text=True, timeout=300)
    assert first.returncode == 0, first.stderr[-2000:]
    assert json.loads(first.stdout)["compiled"] == [True, True]
    libs = sorted(cache.glob("*/*/kernel.so"))
    assert [p.parent.parent.name for p in libs] == ["cintegrate", "ckernel"]
    assert {p.name for p in tmp_path.iterdir()} == {"cache"}
    for lib in libs:
        if damage == "garbled":
            blob = bytearray(lib.read_bytes())
            blob[len(blob) // 2: len(blob) // 2 + 4] = b"\x00\x01\x02\x03"
            lib.write_bytes(bytes(blob))
        elif damage == "truncated":
            lib.write_bytes(lib.read_bytes()[:64])
        else:
            lib.unlink()                           # a build is needed, under the broken lock
            (lib.parent / "build.lock").unlink()
            (lib.parent / "build.lock").mkdir()
    done = subprocess.run([sys.executable, "-c", _C_SCRIPT], env=_env(cache), capture_output=True,
                          text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    out = json.loads(done.stdout)
    assert out["compiled"] == [True, True]
    assert out["x1"] == pytest.approx(2.718281828459045 ** -2, rel=1e-9, abs=0)
    assert out["f"] == -24.0
    assert len(_rebuilt_lines(done)) == 2      # one line per artefact that failed its check
    for lib in libs:
        assert (lib.parent / "build.lock").is_file()


@pytest.mark.slow
def test_pydstool_lock_replaced_by_a_folder_recovers(cache, warm):
    """A PyDSTool build lock replaced by a folder failed every run; now it is moved aside (the
    wrapper is deleted too, so the run must build under that lock)."""
    locks = sorted((cache / "pydstool" / "locks").glob("*.lock"))
    assert locks
    for lock in locks:
        lock.unlink()
        lock.mkdir()
    _only(cache / "pydstool", "dop853_*_vf.py").unlink()
    done = _cli(cache, *SIMULATE)
    assert _a1(done) == pytest.approx(warm[1], rel=1e-12, abs=0)
    assert all(lock.is_file() for lock in locks)


def test_cache_lock_moves_aside_anything_but_a_file(tmp_path):
    """`cache_lock` on a folder, a named pipe (opening it would block) or a symlink to a file
    outside: each is moved aside and a plain lock file made; the symlink's target is untouched."""
    from autocable._store import cache_lock
    outside = tmp_path / "outside.txt"
    outside.write_text("keep", encoding="utf-8")
    makers = {"folder": lambda p: p.mkdir(), "fifo": os.mkfifo, "symlink": lambda p: p.symlink_to(outside)}
    for kind, make in makers.items():
        lock = tmp_path / f"{kind}.lock"
        make(lock)
        with cache_lock(lock):
            assert stat.S_ISREG(os.lstat(lock).st_mode)
    assert outside.read_text(encoding="utf-8") == "keep"
    assert len(list(tmp_path.glob(".*.lock.broken-*"))) == 3


# ------------------------------------------------------------------------------------------------
# a read-only cache

def _read_only_prefix() -> tuple:
    """How to run a child that cannot write a folder without write permission. As root, chmod does
    not stop writes (CAP_DAC_OVERRIDE), so the child keeps uid 0 but drops every capability
    (``setpriv``, util-linux): the owner bits then apply to it like to any user, and the venv and
    the repository (root's own files) stay readable."""
    if os.geteuid() != 0:
        return ()
    setpriv = shutil.which("setpriv")
    assert setpriv, "running as root, the read-only cache test needs setpriv (util-linux)"
    return (setpriv, "--bounding-set=-all", "--inh-caps=-all")


def _make_read_only(root: Path) -> None:
    for path in [root, *root.rglob("*")]:
        if not path.is_symlink():
            path.chmod(stat.S_IMODE(path.stat().st_mode) & ~0o222)


def _make_writable(root: Path) -> None:
    for path in [root, *root.rglob("*")]:
        if not path.is_symlink():
            path.chmod(stat.S_IMODE(path.stat().st_mode) | 0o200)


def _snapshot(root: Path) -> dict:
    return {str(p): (p.stat().st_mtime_ns, p.stat().st_size) for p in root.rglob("*") if not p.is_symlink()}


@pytest.mark.slow
def test_read_only_warm_cache_is_used_and_a_needed_write_is_a_cache_error(cache, warm, tmp_path):
    """A shared, pre-built cache without write permission: a warm `simulate` runs from it and
    changes nothing (no folder, lock or timing file is made); a model it does not hold must be
    written, which fails with exit 2 and one line naming AUTOCABLE_CACHE and the folder."""
    prefix = _read_only_prefix()
    _make_read_only(cache)
    try:
        probe = subprocess.run([*prefix, sys.executable, "-c",
                                f"try:\n    open({str(cache / 'probe')!r}, 'w')\n"
                                f"except PermissionError:\n    print('denied')"],
                               capture_output=True, text=True)
        assert probe.stdout == "denied\n", f"the child could write the read-only cache: {probe.stderr}"
        before = _snapshot(cache)
        for args, a1 in ((SIMULATE, warm[1]), (AME, warm[2])):
            done = _cli(cache, *args, prefix=prefix)
            assert _a1(done) == pytest.approx(a1, rel=1e-12, abs=0)
            assert "AUTOCABLE_CACHE" not in done.stderr and _rebuilt_lines(done) == []
        assert _snapshot(cache) == before

        other = tmp_path / "other.toml"
        other.write_text(SAMPLE.read_text(encoding="utf-8").replace("damping_ratio = 0.004 ",
                                                                    "damping_ratio = 0.0041 ", 1),
                         encoding="utf-8")
        assert other.read_text(encoding="utf-8") != SAMPLE.read_text(encoding="utf-8")
        failed = _cli(cache, "derive", str(other), prefix=prefix)
        assert failed.returncode == 2
        lines = failed.stderr.strip().splitlines()
        assert len(lines) == 1 and "AUTOCABLE_CACHE" in lines[0] and str(cache) in lines[0]
        assert "Traceback" not in failed.stderr
        assert _snapshot(cache) == before
    finally:
        _make_writable(cache)


def test_missing_cache_under_a_read_only_folder_is_a_cache_error(tmp_path):
    """AUTOCABLE_CACHE naming a folder that cannot be created: exit 2, one line naming it."""
    prefix = _read_only_prefix()
    parent = tmp_path / "ro"
    parent.mkdir()
    parent.chmod(0o555)
    try:
        done = _cli(parent / "cache", "derive", str(SAMPLE), prefix=prefix)
    finally:
        parent.chmod(0o755)
    assert done.returncode == 2, done.stderr[-2000:]
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "AUTOCABLE_CACHE" in lines[0] and str(parent / "cache") in lines[0]


def test_cache_dir_refuses_names_that_are_not_one_plain_component(tmp_path, monkeypatch):
    """The last guard: a cache sub-folder name with '/', '..', a newline or a NUL is refused."""
    from autocable._store import cache_dir
    monkeypatch.setenv("AUTOCABLE_CACHE", str(tmp_path / "cache"))
    for bad in ("..", "a/b", "/abs", "x\ny", "x\0y", ""):
        with pytest.raises(ValueError, match="plain names"):
            cache_dir("derivations", bad)
    assert cache_dir("derivations", "ok") == tmp_path / "cache" / "derivations" / "ok"


def test_figure_timings_are_read_without_creating_the_cache(tmp_path, monkeypatch):
    """The figure runner's wall-time hint (``figures/wall_s.json``) is read without creating any
    folder, and only finite, non-negative numbers are taken from it."""
    from autocable.paper.figures import recorded_wall_times
    monkeypatch.setenv("AUTOCABLE_CACHE", str(tmp_path / "cache"))
    assert recorded_wall_times() == {}
    assert not (tmp_path / "cache").exists()
    (tmp_path / "cache" / "figures").mkdir(parents=True)
    (tmp_path / "cache" / "figures" / "wall_s.json").write_text(
        '{"a": 1.5, "b": NaN, "c": -2, "d": "x", "e": Infinity}', encoding="utf-8")
    assert recorded_wall_times() == {"a": 1.5}
