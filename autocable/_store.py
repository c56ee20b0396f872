"""The one cache folder of autocable, content hashes that name what goes in it, and atomic writes.

Built artefacts are keyed by a hash of their content, never by a user-chosen name alone, so a
changed model can never pick up a stale build. The folder is ``$AUTOCABLE_CACHE`` or
``~/.cache/autocable``; autocable never writes caches into the working directory.
"""
from __future__ import annotations

import hashlib
import json
import os
import tempfile
from pathlib import Path
from typing import Any

__all__ = [
    "CACHE_ENV",
    "HASH_CHARS",
    "cache_root",
    "cache_dir",
    "canonical_json",
    "content_hash",
    "atomic_write_text",
    "atomic_write_json",
    "read_json",
    "file_mode",
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


def cache_dir(*parts: str) -> Path:
    """A sub-folder of `cache_root` (created if missing), e.g. ``cache_dir("pydstool")``."""
    folder = cache_root().joinpath(*parts)
    folder.mkdir(parents=True, exist_ok=True)
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


def atomic_write_text(path: str | os.PathLike, text: str) -> Path:
    """Write ``text`` to ``path`` so readers see either the old file or the complete new one.

    Writes a temporary file in the same folder (same filesystem), fsyncs it, then ``os.replace``s
    it onto ``path``. Creates the parent folder. The file's mode follows the umask (`file_mode`).
    Returns the path.
    """
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    mode = file_mode()
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
    try:
        with os.fdopen(fd, "w", encoding="utf-8", newline="") as fh:
            os.fchmod(fh.fileno(), mode)
            fh.write(text)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, target)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise
    return target


def atomic_write_json(path: str | os.PathLike, obj: Any) -> Path:
    """`atomic_write_text` of ``obj`` as indented JSON with sorted keys (diff-friendly)."""
    text = json.dumps(obj, sort_keys=True, indent=2, ensure_ascii=False, allow_nan=False,
                      default=_plain)
    return atomic_write_text(path, text + "\n")


def read_json(path: str | os.PathLike) -> Any | None:
    """The JSON value stored at ``path``, or None if the file is missing, unreadable or corrupt."""
    try:
        with open(path, "r", encoding="utf-8") as fh:
            return json.load(fh)
    except (OSError, ValueError):
        return None

