"""autocable.codegen.compat: PyDSTool imports on Python 3.11, chatter is silenced, builds stay in
their folder, failures are one-line PyDSToolErrors."""
from __future__ import annotations

import ctypes
import os
import subprocess
import sys
from pathlib import Path

import pytest
import sympy

from autocable.codegen import compat, pydstool
from autocable.codegen.compat import PyDSToolError


def test_import_pydstool_registers_stand_ins_and_is_idempotent():
    dst = compat.import_pydstool()
    assert dst.__name__ == "PyDSTool"
    assert "PyDSTool.PyCont" in sys.modules
    assert hasattr(dst, "ContClass") and hasattr(dst.Generator, "Dopri_ODEsystem")
    assert "parser" in sys.modules and "symbol" in sys.modules
    assert compat.import_pydstool() is dst


def test_stand_in_parser_fails_clearly():
    compat.import_pydstool()
    parser = sys.modules["parser"]
    if not hasattr(parser, "STType") or parser.__doc__ is None or "autocable" not in parser.__doc__:
        pytest.skip("a real 'parser' module is present (Python < 3.10)")
    with pytest.raises(PyDSToolError, match="powers"):
        parser.expr("x**2")


def test_failing_pydstool_call_is_a_one_line_pydstool_error():
    dst = compat.import_pydstool()
    bad = dst.args(name="bad_spec", varspecs={"x": "-x*undefined_name"}, tdata=[0, 1], ics={"x": 1.0})
    with pytest.raises(PyDSToolError) as info:
        with compat.quiet() as chatter, compat.pydstool_errors("making a test generator", chatter):
            dst.Generator.Vode_ODEsystem(bad)
    err = info.value
    assert str(err).startswith("making a test generator failed: ")
    assert "\n" not in str(err)
    assert isinstance(err, RuntimeError)
    assert err.__cause__ is not None  # the original stays available for developers
    assert isinstance(err.chatter, str)


def test_bad_algparam_through_make_ode_generator_is_a_pydstool_error():
    x = sympy.Symbol("x")
    vf = pydstool.VectorField("compat_probe", ("x",), [-x], {})
    with pytest.raises(PyDSToolError, match=r"^building the Dopri integrator .* failed: .*Invalid keys"):
        pydstool.make_ode_generator(vf, "Dopri", algparams={"no_such_option": 1})


def test_quiet_silences_fd_level_writes_and_restores(capfd):
    libc = ctypes.CDLL(None)
    print("before", flush=True)
    with compat.quiet() as chatter:
        os.write(1, b"raw fd1\n")
        os.write(2, b"raw fd2\n")
        libc.printf(b"C printf\n")  # buffered in C stdio: quiet must flush it before restoring
        print("python print")
        sys.stderr.write("python stderr\n")
        subprocess.run(["sh", "-c", "echo child process; echo child err >&2"], check=True)
    os.write(1, b"after\n")
    out, err = capfd.readouterr()
    assert out == "before\nafter\n"
    assert err == ""
    for piece in ("raw fd1", "raw fd2", "C printf", "python print", "python stderr",
                  "child process", "child err"):
        assert piece in chatter.text


def test_quiet_restores_fds_after_an_exception(capfd):
    with pytest.raises(ZeroDivisionError):
        with compat.quiet():
            os.write(1, b"hidden\n")
            1 / 0
    os.write(1, b"visible\n")
    print("visible too")
    out, _ = capfd.readouterr()
    assert out == "visible\nvisible too\n"


def test_error_raised_inside_quiet_carries_the_chatter_tail():
    with pytest.raises(PyDSToolError) as info:
        with compat.quiet() as chatter, compat.pydstool_errors("compiling", chatter):
            os.write(2, b"gcc: error: something specific broke\n")
            raise SystemExit("error: command 'gcc' failed with exit status 1")
    assert "something specific broke" in info.value.chatter
    assert "\n" not in str(info.value)
    assert "gcc" in str(info.value)


def test_debug_env_lets_chatter_through(capfd, monkeypatch):
    monkeypatch.setenv("AUTOCABLE_DEBUG", "1")
    with compat.quiet() as chatter:
        os.write(1, b"for developers\n")
    assert capfd.readouterr().out == "for developers\n"
    assert chatter.text == ""


def test_build_dir_restores_cwd_sys_path_and_path_after_exception(tmp_path):
    cwd, sys_path, path = os.getcwd(), list(sys.path), os.environ.get("PATH")
    target = tmp_path / "a" / "b"
    venv_bin = os.path.dirname(sys.executable)
    with pytest.raises(KeyError):
        with compat.build_dir(target) as folder:
            assert folder == target.resolve()
            assert Path(os.getcwd()) == target.resolve()
            assert sys.path[0] == str(target.resolve())
            assert os.environ["PATH"].split(os.pathsep)[0] == venv_bin
            raise KeyError("boom")
    assert os.getcwd() == cwd
    assert sys.path == sys_path
    assert os.environ.get("PATH") == path


def test_build_leaves_nothing_in_the_working_directory(tmp_path, monkeypatch):
    """A compiled build plus an integration, run from an empty directory, leave it empty."""
    monkeypatch.chdir(tmp_path)
    x, t = sympy.Symbol("x"), pydstool.TIME
    k = sympy.Symbol("k")
    vf = pydstool.VectorField("compat_probe", ("x",), [-k * x + sympy.sin(t)], {"k": 2.0})
    gen = pydstool.make_ode_generator(vf, "Dopri")
    times, states = pydstool.integrate(gen, [1.0], None, 0.0, 1.0, 0.5)
    assert times.tolist() == [0.0, 0.5, 1.0]
    assert states.shape == (3, 1)
    assert list(tmp_path.iterdir()) == []
    assert os.getcwd() == str(tmp_path)


def test_bad_algparam_is_caught_also_when_the_library_is_already_loaded():
    x = sympy.Symbol("x")
    vf = pydstool.VectorField("compat_probe_loaded", ("x",), [-x], {})
    pydstool.make_ode_generator(vf, "Dopri")
    with pytest.raises(PyDSToolError, match=r"failed: .*Invalid keys"):
        pydstool.make_ode_generator(vf, "Dopri", algparams={"no_such_option": 1})


def test_memoized_name_map_maps_like_pydstools_own():
    """`memoize_name_map`: the generator's map returns what PyDSTool's symbolMapClass returns for
    names, dotted names, expressions, dicts (numbers, strings, a renamed key), lists and tuples,
    before and after the table changes; it is applied once; pickling gives PyDSTool's class back;
    and the Rhs of the generator is unchanged."""
    import pickle

    import numpy as np
    compat.import_pydstool()
    from PyDSTool.parseUtils import symbolMapClass
    x, y = sympy.Symbol("x"), sympy.Symbol("y")
    vf = pydstool.VectorField("compat_memo", ("x", "y"), [-x + y, -y], {"k": 2.0})
    gen = pydstool.make_ode_generator(vf, "Vode").pydstool
    memo = gen._FScompatibleNames
    assert type(memo) is not symbolMapClass and isinstance(memo, symbolMapClass)
    table = dict(memo.lookupDict, **{"a.b": "a_b", "c.d": "c_d"})
    memo.update({"a.b": "a_b", "c.d": "c_d"})
    plain = symbolMapClass(table)
    probes = ["x", "k", "a.b", "a.b+c.d*2", "sin(a.b)", "unknown",
              {"x": 1.5, "a.b": np.float64(2.0), "c.d": "a.b", "y": 3}, ["a.b", "x", "c.d"], ("c.d", "y")]
    for _ in range(2):                       # the second pass answers from the memo
        for arg in probes:
            got, want = memo(arg), plain(arg)
            assert got == want and type(got) is type(want), (arg, got, want)
    assert list(memo({"a.b": 1.0, "x": 2.0})) == list(plain({"a.b": 1.0, "x": 2.0}))   # key order too
    memo["x"] = "x_renamed"                  # a changed table is not answered from the memo
    plain["x"] = "x_renamed"
    assert memo("x") == plain("x") == "x_renamed" and memo({"x": 1.0}) == {"x_renamed": 1.0}
    del memo["x"]
    assert memo("x") == "x"
    compat.memoize_name_map(gen)
    assert gen._FScompatibleNames is memo    # not wrapped twice
    back = pickle.loads(pickle.dumps(memo))
    assert type(back) is symbolMapClass and back.lookupDict == memo.lookupDict
    assert np.allclose(gen.Rhs(0.0, {"x": 1.0, "y": 2.0}), [1.0, -2.0])


_FULL_DISK_AT_EXIT = """
import atexit, errno, sys
from numpy.distutils import ccompiler_opt
from autocable.codegen import compat

class FullDisk:
    def cache_flush(self):
        print("flush", flush=True)
        raise OSError(errno.ENOSPC, "No space left on device")

opt = FullDisk()
ccompiler_opt._share_cache["full-disk"] = opt
atexit.register(opt.cache_flush)            # what CCompilerOpt.__init__ does
if sys.argv[1] == "session":
    with compat._compiler_opt_caches_written():
        pass
print("end", flush=True)
"""


@pytest.mark.parametrize("how", ["session", "bare"])
@pytest.mark.slow
def test_compiler_opt_caches_are_written_at_the_end_of_a_build_and_not_at_exit(how):
    """numpy.distutils' CCompilerOpt writes its cache from an atexit hook; on a full disk the hook's
    traceback came after autocable's own message. The session writes it when the build ends (an
    OSError is swallowed: the cache is optional) and takes the hook off; without it (the control)
    the traceback is printed at exit."""
    repo = Path(__file__).resolve().parents[1]
    proc = subprocess.run([sys.executable, "-c", _FULL_DISK_AT_EXIT, how], capture_output=True, text=True,
                          env=dict(os.environ, PYTHONPATH=str(repo)), timeout=120)
    assert proc.returncode == 0
    if how == "session":
        assert proc.stdout.split() == ["flush", "end"]          # written in the session, not at exit
        assert "Traceback" not in proc.stderr and "No space left" not in proc.stderr
    else:
        assert proc.stdout.split() == ["end", "flush"]
        assert "Exception ignored in atexit callback" in proc.stderr and "No space left" in proc.stderr


@pytest.mark.slow
def test_a_full_disk_with_a_cold_cache_prints_one_line_and_no_traceback(tmp_path):
    """A cold cache on a 1.2 MB file system (a tmpfs; skipped where mounting is not permitted):
    exit 3 with autocable's one line naming the place, and no traceback from numpy.distutils'
    exit hooks after it. (The disk fills while PyDSTool compiles; that used to end the branch at its
    start point, "PyCont could not be set up", with exit 0.)"""
    mnt = tmp_path / "small"
    mnt.mkdir()
    if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=1200k", "tmpfs", str(mnt)],
                      capture_output=True).returncode != 0:
        pytest.skip("mounting a small tmpfs is not permitted here")
    try:
        repo = Path(__file__).resolve().parents[1]
        env = dict(os.environ, AUTOCABLE_CACHE=str(mnt / "cache"), PYTHONPATH=str(repo))
        proc = subprocess.run([sys.executable, "-m", "autocable.cli", "run", str(repo / "runs" / "fig05a.toml"),
                               "--out", str(mnt / "out"), "--quiet"], capture_output=True, text=True, env=env,
                              timeout=600)
    finally:
        subprocess.run(["umount", str(mnt)], capture_output=True)
    assert proc.returncode == 3, proc.stderr           # a storage fault: the run failed where it stood
    assert "No space left on device" in proc.stderr
    assert "Traceback" not in proc.stderr and len(proc.stderr.strip().splitlines()) == 1, proc.stderr


_BUILD_ONE = """
import numpy as np, sympy
from autocable.codegen import pydstool
x, k = sympy.Symbol("x"), sympy.Symbol("k")
vf = pydstool.VectorField("compat_cfg_probe", ("x",), [-k * x], {"k": 2.0})
gen = pydstool.make_ode_generator(vf, "Dopri")
times, states = pydstool.integrate(gen, [1.0], None, 0.0, 1.0, 0.5)
print(repr(float(states[-1, 0])))
"""


def test_builds_skip_the_cpu_dispatch_probe_and_keep_the_baseline_flags(tmp_path):
    """numpy.distutils probed about 40 CPU features (AVX512 and the like) before each PyDSTool
    build of a cold cache (4 s of a 6 s build), for dispatch PyDSTool's sources do not use. The
    build folder's setup.cfg (`compat.BUILD_OPTIONS`) turns the dispatch off: the build log shows
    the baseline still probed and passed (-msse3 on x86-64, so the compiled code is the same) and
    no dispatch feature tested. In a fresh process: numpy.distutils keeps its answers in memory
    for the rest of a process, so a build earlier in the test session would hide the probe."""
    import platform

    import numpy as np
    repo = Path(__file__).resolve().parents[1]
    env = dict(os.environ, AUTOCABLE_CACHE=str(tmp_path / "cache"), PYTHONPATH=str(repo))
    proc = subprocess.run([sys.executable, "-c", _BUILD_ONE], capture_output=True, text=True, env=env,
                          timeout=600)
    assert proc.returncode == 0, proc.stderr
    assert abs(float(proc.stdout.strip()) - np.exp(-2.0)) < 1e-8       # the closed form x(1) = exp(-k)
    cfgs = list((tmp_path / "cache").rglob("setup.cfg"))
    assert [c.read_text() for c in cfgs] == [compat.BUILD_OPTIONS]
    log = "\n".join(p.read_text() for p in (tmp_path / "cache").rglob("build.log"))
    tested = [ln for ln in log.splitlines() if "testing feature" in ln]
    assert tested and not any(f"'{f}'" in ln for ln in tested for f in ("AVX", "AVX2", "AVX512F", "FMA3"))
    if platform.machine() == "x86_64":
        assert "-msse -msse2 -msse3" in log
