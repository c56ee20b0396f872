"""Every cached artefact is keyed by the code that computes it (the sha256 of its source files,
`autocable._store.code_fingerprint`), not by a version label someone must remember to bump, and
is stored only when that code did not change while it was computed.

The package is never edited in place: each test copies it into a temporary folder, points the
fingerprint at the copy (`_store._code_root`) and edits the copy. A fresh ``_LOADED`` stands for a
new process that loaded the edited code. Run time: about 35-45 s on two shared cores (one
multiscale derivation, two small C builds, one PyDSTool build, one LocalCluster worker)."""
from __future__ import annotations

import shutil
import time
from pathlib import Path

import pytest
import sympy as sp

from autocable import _store

ROOT = Path(__file__).resolve().parents[1]
MODEL = ROOT / "models" / "luongo_zulli_2012.toml"


@pytest.fixture()
def code_copy(tmp_path, monkeypatch):
    """A copy of the package that the fingerprints read, and an empty cache."""
    copy = tmp_path / "pkg"
    shutil.copytree(ROOT / "autocable", copy, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    monkeypatch.setattr(_store, "_code_root", lambda: copy)
    monkeypatch.setattr(_store, "_LOADED", {})
    monkeypatch.setenv("AUTOCABLE_CACHE", str(tmp_path / "cache"))
    return copy


def _edit(path: Path) -> None:
    """A change that alters no number and bumps no version: one comment line."""
    path.write_text(path.read_text() + "\n# edited by a test\n")


def _new_process(monkeypatch) -> None:
    """The state of a process started after the edit: it loaded the edited files."""
    monkeypatch.setattr(_store, "_LOADED", {})


# ------------------------------------------------------------------------------------------------
# the fingerprint itself
# ------------------------------------------------------------------------------------------------
def test_the_fingerprint_follows_the_bytes_on_every_call_and_its_fast_path_is_cheap(code_copy):
    before = _store.code_fingerprint("derivation")
    assert before == _store.code_fingerprint("derivation")
    lam = _store.code_fingerprint("lambda")
    _edit(code_copy / "model" / "galerkin.py")
    after = _store.code_fingerprint("derivation")        # no per-process memo of the answer
    assert after != before
    assert _store.code_fingerprint("lambda") == lam      # not one of its files
    (code_copy / "model" / "__pycache__").mkdir(exist_ok=True)
    (code_copy / "model" / "__pycache__" / "x.pyc").write_bytes(b"\0")
    assert _store.code_fingerprint("derivation") == after   # compiled caches are not code
    # the same bytes again (a checkout back) give the same fingerprint
    text = (code_copy / "model" / "galerkin.py").read_text().replace("\n# edited by a test\n", "")
    (code_copy / "model" / "galerkin.py").write_text(text)
    assert _store.code_fingerprint("derivation") == before
    # fast path: a whole-package fingerprint with no file changed only stats (measured, bounded
    # loosely for a loaded machine: about 2 ms here against about 12 ms hashing every file)
    _store.code_fingerprint("package")
    t0 = time.perf_counter()
    for _ in range(20):
        _store.code_fingerprint("package")
    assert (time.perf_counter() - t0) / 20 < 0.05


def test_the_scene_fingerprint_is_the_tree_hash_of_the_package():
    from autocable.paper import reuse
    assert reuse.code_fingerprint() == reuse.tree_sha256(ROOT / "autocable")


# ------------------------------------------------------------------------------------------------
# edited between key and store: nothing stored, one line says why
# ------------------------------------------------------------------------------------------------
def test_a_module_edited_while_a_derivation_runs_stores_nothing_and_says_why(code_copy, monkeypatch, capsys):
    from autocable.model import derive as D
    real = D._compute

    def compute_while_someone_edits(spec, integrator):
        data = real(spec, integrator)
        _edit(code_copy / "model" / "statics.py")
        return data

    monkeypatch.setattr(D, "_compute", compute_while_someone_edits)
    first = D.derive(MODEL)
    assert not first.from_cache
    assert list((Path(_store.cache_root()) / "derivations").glob("eq21-*.json")) == []
    err = capsys.readouterr().err
    assert "not stored: autocable/model/statics.py changed while it was computed" in err
    # the next process (the edited code loaded) stores under the new code's key
    monkeypatch.setattr(D, "_compute", real)
    _new_process(monkeypatch)
    assert not D.derive(MODEL).from_cache
    assert len(list((Path(_store.cache_root()) / "derivations").glob("eq21-*.json"))) == 1
    assert D.derive(MODEL).from_cache


def test_a_file_changed_after_the_process_loaded_it_stores_nothing(code_copy, capsys):
    from autocable.model.derive import derive
    _store.code_fingerprint("derivation")        # the process has seen (loaded) the files
    _edit(code_copy / "spec.py")                 # edited before the key is made: the key names
    derive(MODEL)                                # the new bytes, the process runs the old ones
    assert "not stored: autocable/spec.py changed after this process loaded it" in capsys.readouterr().err
    assert list((Path(_store.cache_root()) / "derivations").glob("eq21-*.json")) == []


# ------------------------------------------------------------------------------------------------
# one per artefact kind: a code change without a version bump never serves the old artefact
# ------------------------------------------------------------------------------------------------
def test_derivation_and_nmode(code_copy, monkeypatch):
    from autocable.model.derive import DERIVATION_VERSION, derive
    from autocable.model.derive_n import NMODE_VERSION, derive_nmode
    d = derive(MODEL)
    derive_nmode(d, 1, 1)
    assert derive(MODEL).from_cache
    folder = Path(_store.cache_root()) / "derivations"
    assert len(list(folder.glob("nmode1x1-*.json"))) == 1
    _edit(code_copy / "model" / "derive.py")       # no DERIVATION_VERSION / NMODE_VERSION bump
    _new_process(monkeypatch)
    again = derive(MODEL)
    assert not again.from_cache
    derive_nmode(again, 1, 1)
    assert len(list(folder.glob("eq21-*.json"))) == 2 and len(list(folder.glob("nmode1x1-*.json"))) == 2
    assert (DERIVATION_VERSION, NMODE_VERSION) == ("eq21-v3", "nmode-v2")   # the labels did not move
    # the numbers are the same code's: equal equations (the edit was a comment)
    assert again.ode.content_hash() == d.ode.content_hash()


def test_amplitude_equations(code_copy, monkeypatch):
    from autocable.model import multiscale
    from autocable.model.ame_cache import AME_VERSION, derive_ame
    from autocable.model.derive import derive
    d = derive(MODEL)
    first = derive_ame(d)
    assert not first.from_cache and derive_ame(d).from_cache
    _edit(code_copy / "model" / "multiscale.py")
    _new_process(monkeypatch)
    calls = []
    real = multiscale.derive
    monkeypatch.setattr(multiscale, "derive", lambda *a, **k: calls.append(1) or real(*a, **k))
    second = derive_ame(d)
    assert not second.from_cache and calls == [1] and second.key != first.key
    assert AME_VERSION == "ame-v1"
    def without_provenance(ame):      # (it records timings)
        return {k: v for k, v in ame.to_dict().items() if k != "provenance"}
    assert without_provenance(second.ame) == without_provenance(first.ame)


def test_continuation_system_and_lambda_texts(code_copy, monkeypatch):
    from autocable.methods import lambda_cache as L
    from autocable.methods.continuation.system import ame_system
    from autocable.model.ame_cache import derive_ame
    from autocable.model.derive import derive
    ame = derive_ame(derive(MODEL)).ame
    systems = Path(_store.cache_root()) / "systems"
    ame_system(ame, "2dof", wind=False)
    assert len(list(systems.glob("*.json"))) == 1
    _edit(code_copy / "methods" / "continuation" / "system.py")
    _new_process(monkeypatch)
    ame_system(ame, "2dof", wind=False)
    assert len(list(systems.glob("*.json"))) == 2          # built again, under the new code's key

    x, y, s = sp.symbols("x y sigma")
    rhs = [s * x - y * (x**2 + y**2), x + s * y]
    lambdas = Path(_store.cache_root()) / "lambdas"
    L.numeric_function("f", ["x", "y"], ["sigma"], rhs)
    assert len(list(lambdas.glob("f-*.py"))) == 1
    _edit(code_copy / "methods" / "lambda_cache.py")
    _new_process(monkeypatch)
    L.numeric_function("f", ["x", "y"], ["sigma"], rhs)
    assert len(list(lambdas.glob("f-*.py"))) == 2


def test_compiled_kernels_integrators_and_pydstool_names(code_copy, monkeypatch):
    from autocable.codegen import ckernel, cintegrate, pydstool
    from autocable.methods.continuation.system import System
    u, v, k = sp.symbols("u v k")
    system = System("keyed_by_code", ("u", "v"), (-0.1 * u - k * v, -0.1 * v + k * u - 1), (("k", 1.0),), ())
    template = system.template
    key0 = ckernel._key(system.variables, system.parameter_names, template, "gcc")
    ikey0 = cintegrate._key(system.variables, system.parameter_names, "t", template, "gcc")
    vf = pydstool.VectorField("keyed_by_code", ("u", "v"), (-0.1 * u - k * v, -0.1 * v + k * u - 1), (("k", 1.0),))
    name0 = pydstool.model_name(vf)
    ckernel._kernel_for.cache_clear()
    ckernel.compiled_kernel(system)
    assert len(list((Path(_store.cache_root()) / "ckernel").iterdir())) == 1
    _edit(code_copy / "codegen" / "ckernel.py")           # no KERNEL_VERSION / INTEGRATOR_VERSION bump
    _new_process(monkeypatch)
    assert ckernel._key(system.variables, system.parameter_names, template, "gcc") != key0
    assert cintegrate._key(system.variables, system.parameter_names, "t", template, "gcc") != ikey0
    assert pydstool.model_name(vf) != name0
    ckernel._kernel_for.cache_clear()
    ckernel.compiled_kernel(system)
    built = sorted((Path(_store.cache_root()) / "ckernel").iterdir())
    assert len(built) == 2 and all((f / "kernel.json").is_file() for f in built)
    ckernel._kernel_for.cache_clear()


def test_a_kernel_built_while_its_generator_changed_gets_no_manifest(code_copy, capsys):
    from autocable.codegen import ckernel
    from autocable.methods.continuation.system import System
    u, v, k = sp.symbols("u v k")
    system = System("edited_meanwhile", ("u", "v"), (-0.2 * u - k * v, -0.2 * v + k * u), (("k", 1.0),), ())
    real = ckernel._compile

    def compile_while_someone_edits(*args, **kwargs):
        out = real(*args, **kwargs)
        _edit(code_copy / "codegen" / "coefficients.py")
        return out

    ckernel._kernel_for.cache_clear()
    try:
        ckernel._compile = compile_while_someone_edits
        kernel = ckernel.compiled_kernel(system)
    finally:
        ckernel._compile = real
        ckernel._kernel_for.cache_clear()
    assert kernel.n == 2                                    # used by this process
    (folder,) = (Path(_store.cache_root()) / "ckernel").iterdir()
    assert not (folder / "kernel.json").exists()            # not trusted by the next one
    assert "not stored: autocable/codegen/coefficients.py changed while it was computed" in capsys.readouterr().err


def test_a_stored_scene_needs_the_code_its_worker_ran(code_copy, tmp_path, monkeypatch, capsys):
    """`reuse.store` keeps a scene only when the worker's code (returned with the result) is the
    code the key names and this process's files did not change since."""
    from autocable.paper import reuse
    keyed = {"code": _store.code_fingerprint("package")}
    assert reuse.code_mismatch(keyed, None) == "the code that computed it is not known"
    assert "changed while it was computed" in reuse.code_mismatch(keyed, {"code": None, "changed": "results.py"})
    other = {"code": "0" * 64, "version": "0.1.0", "path": "/elsewhere/autocable"}
    assert "other code than the key names" in reuse.code_mismatch(keyed, other)
    assert reuse.code_mismatch(keyed, _store.running_code()) == ""
    # and the store itself refuses, with its line
    monkeypatch.setattr("autocable.results.is_complete", lambda folder: True)
    assert reuse.store(keyed, tmp_path, 1.0, ran=other) is False
    assert "not stored: it was computed by other code" in capsys.readouterr().err
    assert not (tmp_path / "cache" / "scenes").exists()


def test_the_serial_executor_returns_the_code_each_task_ran(code_copy):
    from autocable.executor import Executor
    with Executor(workers=0) as ex:
        ex.submit("a", abs, -2)
        (done,) = list(ex.completed())
    assert done.value == 2 and done.code == _store.running_code()
    assert done.code["code"] == _store.code_fingerprint("package") and done.code["version"]


@pytest.mark.slow
def test_a_pydstool_library_built_after_its_generator_changed_gets_no_manifest(code_copy, capsys):
    """PyDSTool's build (a C library, its wrapper and pickled generator) is recorded in its manifest
    only when autocable/codegen did not change since the process loaded it."""
    from autocable.codegen import pydstool
    x = sp.Symbol("x")
    vf = pydstool.VectorField("keyed_pyds", ("x",), [-x**3 - x], {})
    pydstool.model_name(vf)                            # named (keyed) with the loaded code
    _edit(code_copy / "codegen" / "compat.py")
    gen = pydstool.make_ode_generator(vf, "Dopri").pydstool
    assert list(gen.funcspec.vars) == ["x"]            # built and used by this process
    manifests = list((Path(_store.cache_root()) / "pydstool").rglob("*.json"))
    assert not [m for m in manifests if "specs" not in m.parts]      # no build manifest
    assert "not stored: autocable/codegen/compat.py changed after this process loaded it" in capsys.readouterr().err


def test_dask_tasks_return_their_workers_code_and_a_chained_task_gets_the_value(code_copy):
    """A task's result carries the code its worker ran; a task that takes another's future (a
    followed sweep's segments) still receives the plain value. One LocalCluster worker: ~5 s."""
    import operator

    from autocable.executor import Executor
    with Executor(workers=1) as ex:
        first = ex.submit("a", operator.add, 1, 2)
        ex.submit("b", operator.mul, first, 10)
        done = {d.label: d for d in ex.completed()}
    assert done["a"].value == 3 and done["b"].value == 30, done
    for d in done.values():
        # (None with the file named when someone edits the package while the worker runs)
        assert d.ok and d.code["version"] and (len(d.code["code"]) == 64 if d.code["code"] else d.code["changed"])
