"""Scene results reused across runs of `autocable figures`, keyed by everything that makes them.

A figure scene (Figs. 3-11) is a deterministic function of its inputs: the scene file, the model
spec and every other file the scene reads (digitised points, a response map), the overrides of the
command (``--model``, ``--engine``), whether figures are drawn, autocable's own source code and the
versions of the libraries and compiler that compute it. `scene_inputs` gathers all of these as
plain data; `scene_key` is the sha256 of that. A scene that completed is stored under its key in
the cache folder (`store`: its files, each with its sha256, and when and in how long it was
computed); a later run whose scene has the same key publishes those files into its own output
folder (`restore`) instead of computing them again. Any change to any input, including one byte
of autocable's code, gives another key: the scene is computed.

Why it is safe: the scenes are deterministic (a scene computed twice on one machine gives the same
numbers: tests/test_reuse.py), so the stored files are what a new computation would write. Why it is
there: a warm `autocable figures` on the sample otherwise spends about 20 s recomputing the same
twelve scenes (docs/benchmarks.md). ``autocable figures --recompute`` computes every scene anyway
(and stores the result again).

A stored entry is checked before it is used (every file's sha256); one that fails is removed,
reported on stderr, and the scene computed. A read-only cache is only read. A scene is stored only
when the process that computed it ran the code its key names (`code_mismatch`: the worker's
`autocable._store.running_code`, returned with the result by `autocable.executor`), so code edited
while a run goes on can never leave its results under the old code's key.
"""
from __future__ import annotations

import dataclasses
import functools
import hashlib
import importlib.metadata
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

__all__ = ["FORMAT", "code_fingerprint", "code_mismatch", "tree_sha256", "scene_inputs", "scene_key", "lookup",
           "restore", "store", "entry_folder"]

#: Format of a stored entry (`store`); another format is never read.
FORMAT = "autocable.reuse/1"
_ENTRY_JSON = "entry.json"
#: The libraries whose numbers or drawings a scene's files depend on.
_LIBRARIES = ("numpy", "scipy", "sympy", "matplotlib", "PyDSTool")


def code_fingerprint() -> str:
    """The sha256 of every file of the autocable package (`tree_sha256` of it), computed from the
    files on every call (`autocable._store.code_fingerprint`: stat, and the bytes of a file whose
    stat changed): any change to the code that computes a scene makes another key, also one made
    while this process runs."""
    from autocable._store import code_fingerprint as fingerprint
    return fingerprint("package")


def tree_sha256(root: Path) -> str:
    """The sha256 of every file under ``root`` by relative path and the sha256 of its bytes,
    compiled caches (``__pycache__``, .pyc) left out: what `code_fingerprint` computes for the
    package, from scratch."""
    from autocable._store import file_sha256
    digest = hashlib.sha256()
    for path in sorted(p for p in root.rglob("*") if p.is_file() and "__pycache__" not in p.parts
                       and p.suffix not in (".pyc", ".pyo")):
        rel = path.relative_to(root).as_posix()
        digest.update(rel.encode() + b"\0" + (file_sha256(path) or "unreadable").encode() + b"\0")
    return digest.hexdigest()


@functools.lru_cache(maxsize=1)
def _toolchain() -> dict:
    """Python, the libraries, the machine and the C compiler (the compiled engine's kernels)."""
    versions = {}
    for name in _LIBRARIES:
        try:
            versions[name] = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            versions[name] = None
    cc = os.environ.get("CC", "").strip() or "gcc"
    try:
        banner = subprocess.run([cc, "--version"], capture_output=True, text=True, timeout=10).stdout
        cc_version = banner.splitlines()[0] if banner else ""
    except (OSError, subprocess.SubprocessError):
        cc_version = ""
    return {"python": sys.version, "machine": platform.machine(), "system": platform.system(),
            "libraries": versions, "cc": cc, "cc_version": cc_version}


def _file_sha(path: Path) -> str | None:
    from autocable._store import file_sha256
    return file_sha256(path)


def _paths_in(obj: Any, found: set[Path]) -> None:
    """Every `Path` held anywhere in a scene's dataclasses: the files the scene reads."""
    if isinstance(obj, Path):
        found.add(obj)
    elif dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        for f in dataclasses.fields(obj):
            _paths_in(getattr(obj, f.name), found)
    elif isinstance(obj, dict):
        for v in obj.values():
            _paths_in(v, found)
    elif isinstance(obj, (list, tuple, set, frozenset)):
        for v in obj:
            _paths_in(v, found)


def scene_inputs(scene_path: str | Path, model: str | Path | None = None, engine: str | None = None,
                 plot: bool = True) -> dict | None:
    """Everything a scene's results depend on, as plain data (`scene_key` hashes it): each file the
    scene reads (the scene file, its model or ``model``, digitised points, a map) by resolved path
    and sha256, the overrides, ``plot`` (and with it the matplotlibrc in effect), `code_fingerprint`
    and the toolchain. None when the scene cannot be read or a file it names is missing (the scene
    is then computed, and fails with its own message)."""
    from dataclasses import replace

    from autocable.scene.runner import load_scene
    try:
        scene = load_scene(scene_path)
    except Exception:   # noqa: BLE001 - reported by the scene's own run
        return None
    if model is not None:
        scene = replace(scene, model=Path(model))
    found: set[Path] = set()
    _paths_in(scene, found)
    files = {}
    for path in sorted(found):
        full = Path(path).resolve()
        sha = _file_sha(full)
        if sha is None:
            return None
        files[str(full)] = sha
    return {"format": FORMAT, "scene": str(Path(scene_path).resolve()), "files": files, "engine": engine,
            "model_override": None if model is None else str(Path(model).resolve()), "plot": bool(plot),
            "matplotlibrc": _matplotlibrc() if plot else None,
            "code": code_fingerprint(), "toolchain": _toolchain()}


def _matplotlibrc() -> str | None:
    """The sha256 of the matplotlibrc in effect: autocable sets its own style, but a setting it
    leaves alone (a font, say) would change the drawn figures."""
    import matplotlib
    return _file_sha(Path(matplotlib.matplotlib_fname()))


def scene_key(inputs: dict) -> str:
    """The sha256 of `scene_inputs` (hex, 64 characters)."""
    from autocable._store import canonical_json
    return hashlib.sha256(canonical_json(inputs).encode("utf-8")).hexdigest()


def _slot(inputs: dict) -> str:
    """The scene, model override and options of ``inputs`` without the file contents, code and
    toolchain: one slot holds the latest entry of a scene run one way (older ones are removed when
    a newer one is stored, so the store does not grow with every edit of a model or of the code)."""
    from autocable._store import canonical_json
    slot = {k: inputs.get(k) for k in ("scene", "model_override", "engine", "plot")}
    return hashlib.sha256(canonical_json(slot).encode("utf-8")).hexdigest()[:24]


def entry_folder(inputs: dict) -> Path:
    """Where the entry of ``inputs`` lives: ``<cache>/scenes/<slot>/<key>`` (not created)."""
    from autocable._store import cache_root
    return cache_root() / "scenes" / _slot(inputs) / scene_key(inputs)


def lookup(inputs: dict) -> dict | None:
    """The checked entry of ``inputs`` (its entry.json payload plus ``folder``), or None when there
    is none. An entry whose entry.json or any file fails its sha256 is removed and reported: the
    scene is then computed again."""
    from autocable._store import load_checked_json, report_rebuilt
    from autocable.results import RUN_JSON
    key = scene_key(inputs)
    folder = entry_folder(inputs)
    if not folder.is_dir():
        return None
    meta = load_checked_json(folder / _ENTRY_JSON, None)
    ok = (isinstance(meta, dict) and meta.get("format") == FORMAT and meta.get("key") == key
          and isinstance(meta.get("files"), dict) and RUN_JSON in meta["files"])
    if ok:
        for name, sha in meta["files"].items():
            if "/" in name or name in ("", ".", "..") or _file_sha(folder / name) != sha:
                ok = False
                break
    if not ok:
        report_rebuilt(f"the stored results of a scene ({folder.name[:12]})")
        shutil.rmtree(folder, ignore_errors=True)
        return None
    return {**meta, "folder": str(folder)}


def code_mismatch(inputs: dict, ran: dict | None) -> str:
    """Why a scene computed by the code ``ran`` (`autocable._store.running_code` of the process
    that computed it, returned with its result by `autocable.executor`) must not be stored under
    the key of ``inputs`` ("" when it may): that process's code is unknown, changed while it ran,
    or is not the code the key names; or this process's files changed since the key was made."""
    from autocable._store import code_refusal
    keyed = inputs.get("code")
    if not isinstance(ran, dict):
        return "the code that computed it is not known"
    if not ran.get("code"):
        return f"autocable/{ran.get('changed') or '?'} changed while it was computed"
    if ran["code"] != keyed:
        return (f"it was computed by other code than the key names (autocable {ran.get('version')} at "
                f"{ran.get('path')}): autocable's files changed after the run started")
    return code_refusal("package", keyed)


def store(inputs: dict, scene_folder: str | Path, wall_s: float, ran: dict | None = None) -> bool:
    """Keep the complete scene in ``scene_folder`` under the key of ``inputs`` (its files as listed
    by its run.json, each with its sha256; the computation's wall time and date), and remove the
    older entries of its slot (`_slot`). Written beside the entry and renamed into place, so a
    reader sees a whole entry or none; an entry already there is left. False (and nothing stored)
    when the folder is not a complete run, the cache cannot be written (a shared read-only
    cache), or the code that computed it, ``ran`` (`autocable._store.running_code` returned by the
    worker), is not the code the key names (`code_mismatch`; one line on stderr says why)."""
    from autocable._store import read_json, report_not_stored, store_checked_json
    from autocable.results import RUN_JSON, is_complete
    src = Path(scene_folder)
    if not is_complete(src):
        return False
    why = code_mismatch(inputs, ran)
    if why:
        report_not_stored(f"the results of scene {src.name}", why)
        return False
    meta = read_json(src / RUN_JSON)
    names = [n for n in meta.get("files", []) if isinstance(n, str) and "/" not in n] + [RUN_JSON]
    key = scene_key(inputs)
    final = entry_folder(inputs)
    if final.is_dir():
        return True
    try:
        final.parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=".entry-", dir=final.parent))
    except OSError:
        return False
    try:
        files = {}
        for name in names:
            shutil.copyfile(src / name, tmp / name)
            files[name] = _file_sha(tmp / name)
        store_checked_json(tmp / _ENTRY_JSON, {
            "format": FORMAT, "key": key, "inputs": inputs, "files": files,
            "computed": time.strftime("%Y-%m-%dT%H:%M:%S%z"), "wall_s": round(float(wall_s), 3)})
        os.rename(tmp, final)
        for older in final.parent.iterdir():
            # a dot: an entry being written by another run, or left by a killed one (after an hour)
            if older.name != key and (not older.name.startswith(".") or _age_s(older) > 3600.0):
                shutil.rmtree(older, ignore_errors=True)
        return True
    except Exception:   # noqa: BLE001 - a full disk, a CacheError, a race: not storing never fails the run
        return False
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def _age_s(path: Path) -> float:
    try:
        return time.time() - path.stat().st_mtime
    except OSError:
        return 0.0


def restore(entry: dict, scene_folder: str | Path, name: str, inputs: dict) -> None:
    """Publish the stored files of ``entry`` (`lookup`) into ``scene_folder`` as a complete run
    (`autocable.run_folder.output_folder`: an earlier run's files there are replaced, files no run
    listed refuse the folder), run.json saying where they came from under ``reused``: the key, when
    and in how many seconds they were computed."""
    from autocable._store import atomic_write_json, read_json
    from autocable.results import RUN_JSON
    from autocable.run_folder import output_folder
    folder = Path(entry["folder"])
    scene_inputs_files = tuple(Path(p) for p in inputs.get("files", {}))
    with output_folder(scene_folder, name, scene_inputs_files) as stage:
        for fname in entry["files"]:
            if fname != RUN_JSON:
                shutil.copyfile(folder / fname, stage / fname)
        meta = read_json(folder / RUN_JSON)
        meta = dict(meta) if isinstance(meta, dict) else {"format": "autocable.run/1", "name": name}
        meta["reused"] = {"key": entry["key"], "computed": entry.get("computed"), "wall_s": entry.get("wall_s"),
                          "what": "these files were computed by an earlier run with the same inputs "
                                  "(scene, model, overrides, autocable's code, libraries) and copied"}
        atomic_write_json(stage / RUN_JSON, meta)
