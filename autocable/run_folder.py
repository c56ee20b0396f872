"""A run's output folder: staged while the run computes, published when it ends, run.json last.

`output_folder` is what `autocable.scene.runner.run_scene` writes through: a reader of the folder
(`autocable.results.is_complete`, `read_results`) sees either the earlier state or a run.json whose
``status`` says the folder is not a result ("running", "failed", "interrupted"), never a mix of two
runs that reads as complete. A rerun replaces only the files an earlier run listed, and removes
what killed runs left (their staging folders, half-written temporary files). docs/robustness.md
says what a reader can rely on.
"""
from __future__ import annotations

import json
import os
import re
import shutil
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator, Sequence

from autocable._store import atomic_write_json, read_json
from autocable.results import BRANCHES_CSV, RUN_JSON, SPECIAL_CSV, STATUS_COMPLETE, status_of
from autocable.spec import SpecError

__all__ = ["STAGING_PREFIX", "is_leftover", "output_folder", "pid_alive", "reclaim"]

#: The staging folder of the process ``<pid>`` inside an output folder.
STAGING_PREFIX = ".autocable-staging-"
#: Fixed names of the files a run writes (an earlier run's run.json without a manifest, or none).
_RUN_FILES = (BRANCHES_CSV, SPECIAL_CSV, "overlay.csv", "overlay_ame.csv", "compare.json", "time_series.csv",
              "regions.csv", "regions.json")
#: Temporary files of an atomic write killed half-way: ``.<name>.<mkstemp's 8 characters>.<suffix>``
#: (``.tmp``; earlier versions drew figures into ``.<scene>.png.<8>.png``).
_TEMP = re.compile(r"^\.(?P<name>.+)\.[a-z0-9_]{8}\.(tmp|png|pdf)$")


@contextmanager
def folder_lock(out: Path, lock_name: str, command: str) -> Iterator[None]:
    """Hold the lock ``lock_name`` of the output folder ``out`` (made if needed) for one run of
    ``autocable command``: an advisory ``flock`` the kernel releases however the process ends, the
    file holding the holder's pid to name it. A folder another live run holds is refused (one line
    naming ``--out`` and that process): two writers would mix their files and remove each other's
    temporaries. While it is held, a temporary in ``out`` is a dead writer's."""
    import fcntl
    try:
        out.mkdir(parents=True, exist_ok=True)
        fd = os.open(out / lock_name, os.O_RDWR | os.O_CREAT, 0o644)
    except OSError as exc:
        raise SpecError("arguments", "--out", f"cannot use {out}: {exc.strerror or exc}; give a folder that "
                                              "can be written") from None
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.pread(fd, 32, 0).decode("ascii", "replace").strip() or "?"
            raise SpecError("arguments", "--out", f"another autocable {command} (process {holder}) is writing into "
                                                  f"{out}; wait for it or give another folder") from None
        os.ftruncate(fd, 0)
        os.pwrite(fd, str(os.getpid()).encode(), 0)
        yield
    finally:
        os.close(fd)


def temporary_of(name: str) -> str | None:
    """The name of the file whose atomic write left the temporary ``name`` (``.<name>.<8>.tmp``),
    or None when ``name`` is no such temporary."""
    m = _TEMP.match(name)
    return m["name"] if m else None


def is_leftover(name: str) -> bool:
    """Whether a name in an output folder is what a killed run leaves: its staging folder or the
    temporary file of an atomic write (the next run into the folder removes both)."""
    return name.startswith(STAGING_PREFIX) or bool(_TEMP.match(name))


def pid_alive(pid: int) -> bool:
    """Whether process ``pid`` still runs. A zombie does not: a scene process killed with its
    executor worker is reparented, and where nothing reaps it (PID 1 of a container is often no
    init) it stays a zombie that ``kill(pid, 0)`` still finds, while the scene's rerun on another
    worker must be allowed to take the folder."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    except (OverflowError, ValueError, OSError):
        return False
    try:
        with open(f"/proc/{pid}/stat", encoding="ascii", errors="replace") as fh:
            return fh.read().rsplit(") ", 1)[1][:1] not in ("Z", "X")
    except (OSError, IndexError):
        return True         # no /proc (not Linux): kill(pid, 0) is all there is
    return True


def _owned_files(meta, name: str) -> set[str]:
    """The files of ``folder`` a new run may replace: those the earlier run.json lists, or, from a
    run.json without a manifest, the names a run writes; none without a run.json."""
    if isinstance(meta, dict) and isinstance(meta.get("files"), list):
        return {str(f) for f in meta["files"]}
    if not isinstance(meta, dict):
        # no run.json: no earlier run wrote here, so a file named like an output (a user's own
        # damper.png or branches.csv) is the user's, refused, not replaced
        return set()
    return _run_names(meta, name)


def reclaim(out_dir: str | Path, name: str) -> bool:
    """Take back ``out_dir`` as a folder of runs of ``name`` after its run.json was lost, for a
    caller whose own record says the folder is its (`autocable.paper.figures`: a scene folder of
    this figures run or of its earlier figures.json). Without run.json nothing there is owned
    (`_owned_files`: a user's damper.png is not replaced), so the folder of a stopped figures run
    that lost one scene's run.json was refused as foreign and the scene never ran again. run.json
    is written "failed" (not a result), listing only the files there named as a run of ``name``
    writes them: those are replaced by the next run, any other file still refuses the folder.
    Returns whether run.json was written (not when it exists or ``out_dir`` is no folder)."""
    out = Path(out_dir)
    if not out.is_dir() or out.is_symlink() or os.path.lexists(out / RUN_JSON):
        return False
    files = sorted(n for n in _run_names(None, name) if (out / n).is_file() and not (out / n).is_symlink())
    atomic_write_json(out / RUN_JSON, {"format": "autocable.run/1", "name": name, "status": "failed",
                                       "reason": "run.json was lost; taken back by a run that listed this folder",
                                       "files": files})
    return True


def _run_names(meta, name: str) -> set[str]:
    """The names a run of ``name`` (or of the scene an earlier run.json names) writes."""
    names = {name} | ({str(meta["name"])} if isinstance(meta, dict) and meta.get("name") else set())
    return set(_RUN_FILES) | {f"{n}{tail}{ext}" for n in names for tail in ("", "_plane", "_chart")
                              for ext in (".png", ".pdf")}


def _marker(name: str, files) -> dict:
    return {"format": "autocable.run/1", "name": name, "status": "running", "pid": os.getpid(),
            "files": sorted(files)}


def _prepare(out: Path, name: str, inputs=()) -> Path:
    """Check ``out``, clear what killed runs left, mark it "running" and make the staging folder.
    ``inputs`` (files the run reads: scene, model, digitised points, map) may sit in ``out``."""
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise SpecError(out, "--out", f"cannot make the output folder: {exc.strerror or exc}; "
                                      "give a folder that can be created") from None
    meta = read_json(out / RUN_JSON)
    if status_of(meta) == "running":
        pid = meta.get("pid")
        if isinstance(pid, int) and pid != os.getpid() and pid_alive(pid):
            raise SpecError(out, "--out", f"another autocable run (process {pid}) is writing into this folder; "
                                          "wait for it or give another folder")
    owned = _owned_files(meta, name)
    # a temporary file is removed only when it is one of a file autocable writes here
    temp_of = owned | _run_names(meta, name) | {RUN_JSON}
    read = {Path(p).resolve() for p in inputs if p}
    unknown, leftovers = [], []
    for entry in sorted(out.iterdir()):
        n = entry.name
        if entry.resolve() in read and n not in owned and n != RUN_JSON:
            continue
        if n.startswith(STAGING_PREFIX) and entry.is_dir() and not entry.is_symlink():
            pid = n[len(STAGING_PREFIX):]
            if pid.isdigit() and int(pid) != os.getpid() and pid_alive(int(pid)):
                raise SpecError(out, "--out", f"another autocable run (process {pid}) is writing into this "
                                              "folder; wait for it or give another folder")
            leftovers.append(entry)
        elif entry.is_file() and _TEMP.match(n) and _TEMP.match(n)["name"] in temp_of:
            leftovers.append(entry)
        elif not (n == RUN_JSON or (n in owned and entry.is_file())):
            unknown.append(n)
    if unknown:
        shown = ", ".join(unknown[:5]) + (f" and {len(unknown) - 5} more" if len(unknown) > 5 else "")
        raise SpecError(out, "--out", f"holds files autocable did not write ({shown}); a run replaces only "
                                      "the files its earlier run listed in run.json: give an empty or new folder, "
                                      "or move them away")
    for entry in leftovers:       # a killed run's staging folder or half-written temporary file
        if entry.is_dir():
            shutil.rmtree(entry, ignore_errors=True)
        else:
            entry.unlink(missing_ok=True)
    # From here the earlier run's files no longer read as a result, whatever happens to this run.
    atomic_write_json(out / RUN_JSON, _marker(name, {f for f in owned if (out / f).is_file()}))
    staging = out / f"{STAGING_PREFIX}{os.getpid()}"
    shutil.rmtree(staging, ignore_errors=True)
    staging.mkdir()
    return staging


def _publish(staging: Path, out: Path, name: str, status: str, reason: str = "") -> None:
    """Move the staged files into ``out``, remove the earlier run's others, write run.json last."""
    staged = sorted(p.name for p in staging.iterdir()
                    if p.is_file() and p.name != RUN_JSON and not _TEMP.match(p.name))
    earlier = read_json(out / RUN_JSON)
    old = set(earlier.get("files", [])) if isinstance(earlier, dict) and isinstance(earlier.get("files"), list) \
        else set()
    # Before a file moves: the marker names every file a kill during the moves could leave here.
    atomic_write_json(out / RUN_JSON, _marker(name, old | set(staged)))
    for n in staged:
        os.replace(staging / n, out / n)
    for n in sorted(old - set(staged)):
        if n != RUN_JSON and "/" not in n:
            (out / n).unlink(missing_ok=True)
    meta = read_json(staging / RUN_JSON)
    meta = dict(meta) if isinstance(meta, dict) else {"format": "autocable.run/1", "name": name}
    meta.pop("pid", None)
    meta.update(status=status, files=staged)
    if reason:
        meta["reason"] = reason
    else:
        meta.pop("reason", None)
    atomic_write_json(out / RUN_JSON, meta)
    shutil.rmtree(staging, ignore_errors=True)


def _reason(exc: BaseException) -> str:
    if isinstance(exc, KeyboardInterrupt):
        return "interrupted"
    if isinstance(exc, OSError) and exc.strerror and exc.filename:
        m = _TEMP.match(Path(os.fsdecode(exc.filename)).name)
        return f"{exc.strerror}: {m['name'] if m else Path(os.fsdecode(exc.filename)).name}"
    text = str(exc).strip().splitlines()
    first = text[0] if text else ""
    return first if isinstance(exc, SpecError) else f"{type(exc).__name__}: {first}".rstrip(": ")


@contextmanager
def output_folder(out_dir: str | Path, name: str, inputs: Sequence = ()) -> Iterator[Path]:
    """Stage a run's files and publish them into ``out_dir``; yields the staging folder.

    Before: ``out_dir`` is refused (`SpecError`) if it holds files no earlier run listed (other than
    the run's ``inputs``, e.g. the scene file or a map it reads), or another live run writes into it; a killed run's staging folder and temporary files are removed; run.json
    becomes ``status = "running"`` (the earlier results stop reading as complete). After: the staged
    files replace the earlier run's (whose other files are removed) and run.json is written last,
    ``"complete"``; a run that raises publishes what it staged as ``"failed"`` (``"interrupted"``
    for Ctrl-C) with the ``reason``, and the exception goes on. A killed run leaves "running".
    """
    out = Path(out_dir)
    staging = _prepare(out, name, inputs)
    try:
        yield staging
    except BaseException as exc:
        status = "interrupted" if isinstance(exc, KeyboardInterrupt) else "failed"
        try:
            _publish(staging, out, name, status, _reason(exc))
        except Exception:   # noqa: BLE001 - the run's own error matters (e.g. a full disk)
            _mark_in_place(out, name, status, _reason(exc))
        raise
    try:
        _publish(staging, out, name, STATUS_COMPLETE)
    except BaseException as exc:   # the disk filled (or Ctrl-C) while publishing: not a result
        _mark_in_place(out, name, "interrupted" if isinstance(exc, KeyboardInterrupt) else "failed",
                       f"publishing the results: {_reason(exc)}")
        raise


def _mark_in_place(out: Path, name: str, status: str, reason: str) -> None:
    """run.json says ``status`` (never "running" with a dead pid) when the atomic write cannot:
    on a full disk its temporary file cannot be made, while the marker's own bytes can be
    rewritten in place (no new block: the text is cut to the blocks the marker holds). A reader that meets
    the file half-rewritten reads it as not complete, which it is not."""
    path = out / RUN_JSON
    meta = read_json(path)
    files = meta.get("files") if isinstance(meta, dict) and isinstance(meta.get("files"), list) else []
    try:
        st = path.stat()
    except OSError:
        return
    # the bytes up to the end of the file's last block are already the file's: no new block
    block = getattr(st, "st_blksize", 4096) or 4096
    size = max(st.st_size, -(-st.st_size // block) * block)
    doc = {"format": "autocable.run/1", "name": name, "status": status, "reason": reason, "files": files}
    text = json.dumps(doc)
    while len(text.encode()) > size and (doc["files"] or doc["reason"]):
        # keep the status: the file list (a reader then owns nothing) and the reason go first
        if doc["files"]:
            doc["files"] = []
        else:
            doc["reason"] = doc["reason"][: max(0, len(doc["reason"]) - (len(text.encode()) - size) - 3)]
        text = json.dumps(doc)
    try:
        with open(path, "r+b") as fh:
            fh.write(text.encode())
            fh.truncate()
    except OSError:
        pass
