"""The one cache folder of autocable, content hashes that name what goes in it, and atomic writes.

Built artefacts are named by a hash of their content, never by user text (a model's name may hold
``/`` or ``..``), so a changed model can never pick up a stale build and no name can lead outside the
folder. The folder is ``$AUTOCABLE_CACHE`` or ``~/.cache/autocable``; autocable never writes caches
into the working directory.

Every artefact is checked when loaded: JSON files carry the sha256 of their payload
(`store_checked_json` / `load_checked_json`), binary builds have their sha256 recorded in a
manifest (`file_sha256`). One that fails its check is rebuilt, with one line on stderr
(`report_rebuilt`). A warm cache is only read (no folder, lock or file is created), so a shared
read-only cache works; a write it cannot make raises `autocable.errors.CacheError`.
"""
from __future__ import annotations

import contextlib
import hashlib
import json
import os
import stat
import sys
import tempfile
import time
from pathlib import Path
from typing import Any, Iterator

from autocable.errors import CacheError

__all__ = [
    "CACHE_ENV",
    "HASH_CHARS",
    "cache_root",
    "cache_dir",
    "canonical_json",
    "content_hash",
    "atomic_write_bytes",
    "atomic_write_text",
    "atomic_write_json",
    "read_json",
    "cache_error",
    "cache_write_bytes",
    "file_mode",
    "require_writable",
    "store_checked_json",
    "load_checked_json",
    "file_sha256",
    "report_rebuilt",
    "cache_lock",
    "CODE_DEPS",
    "code_fingerprint",
    "code_refusal",
    "running_code",
    "report_not_stored",
    "store_checked_json_for_code",
    "loaded_code_changed",
]

#: Environment variable that overrides the cache folder.
CACHE_ENV = "AUTOCABLE_CACHE"
#: Length of `content_hash` (hex characters): 48 bits, ample for the number of models one user has.
HASH_CHARS = 12


def cache_root() -> Path:
    """The cache folder: ``$AUTOCABLE_CACHE`` if set (and not empty), else ``~/.cache/autocable``.

    Absolute, not created (see `cache_dir`).
    """
    override = os.environ.get(CACHE_ENV, "").strip()
    root = Path(override).expanduser() if override else Path.home() / ".cache" / "autocable"
    return root.resolve()


def _check_part(part: str) -> None:
    """Refuse a path component that could leave its parent folder or is not one plain name."""
    if (not isinstance(part, str) or part in ("", ".", "..") or os.sep in part or "/" in part
            or (os.altsep and os.altsep in part) or any(ord(ch) < 32 or ord(ch) == 127 for ch in part)):
        raise ValueError(f"cache folder names must be plain names, got {part!r}")


def cache_error(path: str | os.PathLike, exc: BaseException) -> CacheError:
    """The `CacheError` for a failed write at ``path`` (one line naming the variable and folder)."""
    reason = getattr(exc, "strerror", None) or type(exc).__name__
    err = CacheError(f"the autocable cache {cache_root()} cannot be written ({reason}: {path}); "
                     f"make it writable or set {CACHE_ENV} to a writable folder")
    err.errno = getattr(exc, "errno", None)       # a full disk is a failed run, not a path to change
    return err


def _move_aside(path: Path) -> None:
    """Rename a foreign object (a folder or pipe where a file belongs, or the reverse) out of the way."""
    os.rename(path, path.with_name(f".{path.name}.broken-{os.getpid()}-{time.time_ns()}"))


def cache_dir(*parts: str) -> Path:
    """A sub-folder of `cache_root`, e.g. ``cache_dir("pydstool")``; each part a plain name.

    Created if missing (nothing is written when it exists, so a read-only warm cache works); a
    non-folder in its place is moved aside. Raises `CacheError` if it cannot be created."""
    for part in parts:
        _check_part(part)
    folder = cache_root().joinpath(*parts)
    if folder.is_dir():
        return folder
    try:
        for level in [cache_root().joinpath(*parts[:k]) for k in range(1, len(parts) + 1)]:
            if (level.exists() or level.is_symlink()) and not level.is_dir():
                _move_aside(level)
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise cache_error(folder, exc) from None
    return folder


def _plain(obj: Any) -> Any:
    """JSON ``default`` hook: numpy scalars/arrays and paths become plain values; others fail."""
    if hasattr(obj, "tolist"):  # numpy arrays and scalars, without importing numpy here
        return obj.tolist()
    if isinstance(obj, os.PathLike):
        return os.fspath(obj)
    if isinstance(obj, (set, frozenset)):
        return sorted(obj, key=repr)
    raise TypeError(
        f"content_hash cannot hash a {type(obj).__name__}: convert it to str/number/list/dict first"
    )


def canonical_json(obj: Any) -> str:
    """One JSON text per value: sorted keys, no whitespace, floats by ``repr`` (round-trip exact).

    Non-finite floats are rejected: they have no JSON spelling and never belong in a model hash.
    """
    return json.dumps(obj, sort_keys=True, separators=(",", ":"), ensure_ascii=False,
                      allow_nan=False, default=_plain)


def content_hash(obj: Any) -> str:
    """The first `HASH_CHARS` hex digits of sha256 over ``obj``.

    A ``str`` is hashed as its UTF-8 text; anything else as its `canonical_json`. Equal content
    gives the same hash in every process and on every machine (unlike ``hash()``).
    """
    text = obj if isinstance(obj, str) else canonical_json(obj)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()[:HASH_CHARS]


def _umask() -> int:
    """The process's umask, read without changing it (``os.umask`` can only be read by setting it,
    which races with other threads creating files); the set-and-restore fallback only where
    /proc does not report it."""
    try:
        with open("/proc/self/status", encoding="ascii", errors="replace") as fh:
            for line in fh:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError, IndexError):
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def file_mode() -> int:
    """The mode a plain ``open(path, "w")`` would give a new file: 0o666 less the umask.

    ``tempfile.mkstemp`` creates 0o600 and ``os.replace`` keeps it, so every atomic write chmods
    its temporary file to this before publishing it."""
    return 0o666 & ~_umask()


def atomic_write_bytes(path: str | os.PathLike, data: bytes, *, fsync: bool = True) -> Path:
    """Write ``data`` to ``path`` so readers see either the old file or the complete new one.

    Writes a temporary file in the same folder (same filesystem; named ``.<name>.<8 characters>.tmp``,
    which the next run into an output folder recognises as a leftover), fsyncs it unless ``fsync``
    is False (a file that is cheap to recompute), then ``os.replace``s it onto ``path``. Creates the
    parent folder. The file's mode follows the umask (`file_mode`). Returns the path.
    """
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    mode = file_mode()
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
    try:
        with os.fdopen(fd, "wb") as fh:
            os.fchmod(fh.fileno(), mode)    # mkstemp's 0o600 would survive the replace
            fh.write(data)
            fh.flush()
            if fsync:
                os.fsync(fh.fileno())
        os.replace(tmp, target)
    except OSError as exc:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        if exc.filename is None:
            # a write or fsync error (a full disk) names no file: name the one being written
            raise OSError(exc.errno, exc.strerror or str(exc), str(target)) from exc
        raise
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
    return target


def atomic_write_text(path: str | os.PathLike, text: str, *, fsync: bool = True) -> Path:
    """`atomic_write_bytes` of ``text`` as UTF-8."""
    return atomic_write_bytes(path, text.encode("utf-8"), fsync=fsync)


def atomic_write_json(path: str | os.PathLike, obj: Any) -> Path:
    """`atomic_write_text` of ``obj`` as indented JSON with sorted keys (diff-friendly)."""
    text = json.dumps(obj, sort_keys=True, indent=2, ensure_ascii=False, allow_nan=False,
                      default=_plain)
    return atomic_write_text(path, text + "\n")


def cache_write_bytes(path: str | os.PathLike, blob: bytes) -> Path:
    """`atomic_write_bytes` of ``blob`` into the cache; a failed write raises `CacheError`."""
    try:
        return atomic_write_bytes(path, blob)
    except OSError as exc:
        raise cache_error(path, exc) from None


def require_writable(folder: str | os.PathLike) -> None:
    """Raise `CacheError` unless a file can be created in ``folder`` (created if missing): called
    before a build whose tools (compilers, PyDSTool) would fail with a less clear message."""
    folder = Path(folder)
    try:
        folder.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=".probe.", dir=folder)
        os.close(fd)
        os.unlink(tmp)
    except OSError as exc:
        raise cache_error(folder, exc) from None


def _payload_sha(payload: Any) -> str:
    return hashlib.sha256(canonical_json(payload).encode("utf-8")).hexdigest()


def store_checked_json(path: str | os.PathLike, payload: Any) -> Path:
    """Store ``payload`` in the cache as JSON with the sha256 of its `canonical_json` beside it
    (read back by `load_checked_json`); a failed write raises `CacheError`."""
    try:
        if os.path.isdir(path) and not os.path.islink(path):
            _move_aside(Path(path))     # a folder where the file belongs: keep it, out of the way
        return atomic_write_json(path, {"sha256": _payload_sha(payload), "payload": payload})
    except OSError as exc:
        raise cache_error(path, exc) from None


def load_checked_json(path: str | os.PathLike, what: str | None) -> Any | None:
    """The payload `store_checked_json` stored at ``path``, or None if there is none or it fails its
    check (edited, truncated, foreign). A failed check of ``what`` is reported (`report_rebuilt`),
    since the caller then rebuilds it; ``what=None`` for a caller that reports it itself."""
    if not os.path.lexists(path):
        return None
    data = read_json(path)
    try:
        ok = (isinstance(data, dict) and set(data) == {"sha256", "payload"}
              and data["sha256"] == _payload_sha(data["payload"]))
    except (TypeError, ValueError):  # e.g. a NaN edited into the file
        ok = False
    if ok:
        return data["payload"]
    if what is not None:
        report_rebuilt(what)
    return None


def file_sha256(path: str | os.PathLike) -> str | None:
    """The sha256 (hex) of the file at ``path``, or None if it is missing or unreadable."""
    digest = hashlib.sha256()
    try:
        with open(path, "rb") as fh:
            for block in iter(lambda: fh.read(1 << 20), b""):
                digest.update(block)
    except OSError:
        return None
    return digest.hexdigest()


def report_rebuilt(what: str) -> None:
    """The one stderr line saying a cached artefact failed its check and is built again."""
    print(f"autocable: cache: {what} failed its check, rebuilt", file=sys.stderr, flush=True)


def _open_lock(path: Path):
    """The lock file at ``path`` opened for `flock`, or None when it cannot be created (a read-only
    cache: a reader needs no lock, and a writer fails on its first write with `CacheError`).

    Anything but a regular file there (a folder, a pipe, a symlink) is moved aside first, so a
    damaged lock never blocks every later run."""
    for _ in range(3):
        try:
            if path.is_symlink() or (path.exists() and not path.is_file()):
                _move_aside(path)
            fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW | os.O_NONBLOCK, 0o666)
        except (IsADirectoryError, FileExistsError):
            continue  # replaced between the check and the open: check again
        except OSError:
            return None
        if not stat.S_ISREG(os.fstat(fd).st_mode):  # a pipe or device created in between
            os.close(fd)
            continue
        return os.fdopen(fd, "r+")
    return None


@contextlib.contextmanager
def cache_lock(path: str | os.PathLike) -> Iterator[None]:
    """Hold an exclusive advisory lock on ``path`` (POSIX ``flock``) for the block, so concurrent
    processes build an artefact once. Recovers from a damaged lock (see `_open_lock`); without a
    lock file (read-only cache, no ``fcntl``) the block runs unlocked."""
    try:
        import fcntl
    except ImportError:  # pragma: no cover - the builds are POSIX-only
        yield
        return
    fh = _open_lock(Path(path))
    if fh is None:
        yield
        return
    with fh:
        fcntl.flock(fh, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(fh, fcntl.LOCK_UN)


def read_json(path: str | os.PathLike) -> Any | None:
    """The JSON value stored at ``path``, or None if the file is missing, unreadable or corrupt."""
    try:
        with open(path, "r", encoding="utf-8") as fh:
            return json.load(fh)
    except (OSError, ValueError):
        return None



# ------------------------------------------------------------------------------------------------
# the code a cached artefact depends on
# ------------------------------------------------------------------------------------------------
#: The source files (relative to the package; a folder means every file under it) whose code
#: computes each kind of cached artefact. Its cache key holds the sha256 of their bytes
#: (`code_fingerprint`), so a change to that code never serves an artefact the old code made,
#: whether or not a version label was bumped. ``""`` is the whole package.
CODE_DEPS: dict[str, tuple[str, ...]] = {
    "derivation": ("model", "spec.py"),                          # statics, modes, aero, Galerkin: eq. (21)
    "ame": ("model",),                                           # Multiple Scales, eqs. (22)-(24)
    "system": ("model", "methods/continuation/system.py"),      # the Cartesian AME (24) as sympy
    "lambda": ("methods/lambda_cache.py",),                     # the text lambdify writes from a rhs
    "kernel": ("codegen",),                                      # C kernels, DOP853 integrators, PyDSTool
    "package": ("",),                                            # a stored figure scene: all of it
}

_PACKAGE = Path(__file__).resolve().parent


def _code_root() -> Path:
    """The package folder whose files are fingerprinted (a test points it at a copy)."""
    return _PACKAGE


def _code_files(root: Path, deps: tuple[str, ...]) -> list[tuple[str, str]]:
    """(path relative to ``root`` with "/", absolute path) of every file of ``deps`` (compiled
    caches left out), in the order of `pathlib.Path`'s sort (by path components). Plain strings:
    a fingerprint of the package is then a few hundred stats, not thousands of Path objects."""
    base = str(root)
    found: dict[str, str] = {}
    for dep in deps:
        where = os.path.join(base, dep) if dep else base
        if os.path.isfile(where):
            found[dep] = where
        elif os.path.isdir(where):
            for folder, dirs, names in os.walk(where):
                dirs[:] = [d for d in dirs if d != "__pycache__"]
                rel_folder = os.path.relpath(folder, base).replace(os.sep, "/")
                for n in names:
                    if not n.endswith((".pyc", ".pyo")):
                        found[n if rel_folder == "." else f"{rel_folder}/{n}"] = os.path.join(folder, n)
    return sorted(found.items(), key=lambda item: item[0].split("/"))


def _stat_key(path: str) -> tuple | None:
    try:
        st = os.stat(path)
    except OSError:
        return None
    return (st.st_mtime_ns, st.st_size, st.st_ino, st.st_ctime_ns)


def _snapshot(root: Path) -> dict[str, tuple | None]:
    return {full: _stat_key(full) for _, full in _code_files(root, ("",))}


#: The stat of every package file when this process first imported autocable: the code it runs
#: (modules are imported from these files). A file whose stat differs later may hold other code
#: than the process runs, so nothing computed is stored under its fingerprint (`code_refusal`).
_LOADED: dict[str, tuple | None] = _snapshot(_PACKAGE)
#: path -> (stat, sha256): the fast path. Every call stats every file; only a file whose stat
#: changed is read and hashed again (a cache of hashes, not of the answer).
_SHA_OF: dict[str, tuple] = {}
#: fingerprint -> {relative path: sha256} of the last fingerprints made, to name a changed file.
_MANIFESTS: dict[str, dict[str, str]] = {}


def _file_digest(path: str) -> str | None:
    key = _stat_key(path)
    memo = _SHA_OF.get(path)
    if key is not None and memo is not None and memo[0] == key:
        return memo[1]
    sha = file_sha256(path)
    if key is not None and sha is not None:
        _SHA_OF[path] = (key, sha)
    return sha


def code_fingerprint(kind: str) -> str:
    """The sha256 (hex) of the source files of `CODE_DEPS` ``[kind]``, by relative path and bytes,
    as they are on disk now (computed on every call: stat of each file, bytes hashed again only
    when its stat changed)."""
    root = _code_root()
    digest = hashlib.sha256()
    manifest = {}
    for rel, path in _code_files(root, CODE_DEPS[kind]):
        if root != _PACKAGE:
            _LOADED.setdefault(path, _stat_key(path))   # a copy (a test's): loaded when first seen
        sha = _file_digest(path) or "unreadable"
        manifest[rel] = sha
        digest.update(rel.encode() + b"\0" + sha.encode() + b"\0")
    value = digest.hexdigest()
    if len(_MANIFESTS) > 64:
        _MANIFESTS.clear()
    _MANIFESTS[value] = manifest
    return value


def _changed_since_loaded(kind: str) -> str:
    """The first file of ``kind``'s code whose stat differs from when this process loaded
    autocable, or that is new or gone since ("" when none): this process may run other code than
    the files now hold."""
    root = _code_root()
    current = _code_files(root, CODE_DEPS[kind])
    for rel, path in current:
        # a file the process had not seen at its start (a copy a test points at): seen now
        loaded = _LOADED.setdefault(path, _stat_key(path)) if root != _PACKAGE else _LOADED.get(path)
        if loaded is None or loaded != _stat_key(path):
            return rel
    if root == _PACKAGE:
        bases = [os.path.join(str(root), d) if d else str(root) for d in CODE_DEPS[kind]]
        seen = {path for _, path in current}
        for name in _LOADED:
            if name not in seen and any(name == b or name.startswith(b + os.sep) for b in bases):
                return Path(name).relative_to(root).as_posix() + " (removed)"
    return ""


def loaded_code_changed(kind: str) -> str:
    """The first file of ``kind``'s code (`CODE_DEPS`) changed, added or removed since this process
    loaded autocable, relative to the package ("" when none): a build keyed earlier in the
    process, then made by the code it loaded, must not be kept when this is not empty."""
    return _changed_since_loaded(kind)


def code_refusal(kind: str, keyed: str) -> str:
    """Why an artefact of ``kind`` computed now must not be stored under a key made with the code
    fingerprint ``keyed`` ("" when it may): a file of its code changed since the key was made, or
    since this process loaded autocable (the computation then ran code the key does not name)."""
    now = code_fingerprint(kind)
    if now != keyed:
        before, after = _MANIFESTS.get(keyed, {}), _MANIFESTS.get(now, {})
        diff = sorted(k for k in set(before) | set(after) if before.get(k) != after.get(k))
        name = f"autocable/{diff[0]}" if diff else "autocable's code"
        return f"{name} changed while it was computed"
    changed = _changed_since_loaded(kind)
    if changed:
        return f"autocable/{changed} changed after this process loaded it"
    return ""


def report_not_stored(what: str, why: str) -> None:
    """The one stderr line saying a computed artefact was used but not kept in the cache."""
    print(f"autocable: cache: {what} not stored: {why}", file=sys.stderr, flush=True)


def running_code() -> dict:
    """The autocable this process runs: its version, where it lives, and the fingerprint of the
    whole package (`code_fingerprint` ``"package"``), or None with ``changed`` naming a file that
    changed since the process loaded it. A worker returns this with each result
    (`autocable.executor`), so that a result is stored or trusted only for the command's code."""
    from autocable._version import __version__
    changed = _changed_since_loaded("package")
    return {"version": __version__, "path": str(_code_root()), "code": None if changed else
            code_fingerprint("package"), "changed": changed}


def store_checked_json_for_code(kind: str, keyed: str, path: str | os.PathLike, payload: Any, what: str) -> bool:
    """`store_checked_json` of ``payload`` computed under a key holding the code fingerprint
    ``keyed`` of ``kind``, unless that code changed meanwhile (`code_refusal`): then nothing is
    stored and one line says why (the result is still used by this process). Whether it was stored."""
    why = code_refusal(kind, keyed)
    if why:
        report_not_stored(what, why)
        return False
    store_checked_json(path, payload)
    return True
