"""What every command checks where an option enters, and the strict JSON they all print.

An option outside its accepted range is a `autocable.spec.SpecError` naming the option (exit 2,
`autocable.errors`); JSON output is strict: a non-finite number is null, with a status beside it.
"""
from __future__ import annotations

import errno
import json
import math
import os
import re

from autocable.errors import EXIT_FAILED, EXIT_INPUT
# one rule for the worker count of every command (re-exported)
from autocable.executor import WORKERS_LIMIT, check_workers  # noqa: F401
from autocable.model.premises import MAX_INTEGRATION_TIME
from autocable.model.premises import check_number as check_api_number
from autocable.spec import SpecError

#: Accepted ranges of the numeric options that premises.check_parameters does not cover.
#: Time limit of `simulate` (t* units): `autocable.model.premises.MAX_INTEGRATION_TIME`.
MAX_TIME_LIMIT = MAX_INTEGRATION_TIME
#: Modes per plane of `simulate --modes`: the symbolic N-mode derivation grows as N^4.
MODES_LIMIT = 6

#: Repeats of a benchmark: each costs up to minutes.
REPEATS_LIMIT = 100

def refuse(option: str, message: str):
    """The one-line input error for a command-line option (exit 2)."""
    return SpecError("arguments", option, message)


def check_number(option: str, value, lo: float, hi: float, *, integer: bool = False,
                  lo_open: bool = False) -> None:
    """Refuse a non-finite ``value`` or one outside [lo, hi] ((lo, hi] with ``lo_open``): the
    API's checker (`autocable.model.premises.check_number`) with the option's name; None (an
    option not given) passes."""
    if value is None:
        return
    check_api_number("arguments", option, value, lo, hi, integer=integer, lo_open=lo_open)


class Typed(float):
    """A number as typed on the command line: a float whose ``repr`` is the text the user typed,
    so that a refusal quotes ``1e9``, not ``1000000000.0`` (arithmetic gives plain floats)."""

    def __new__(cls, text: str):
        value = super().__new__(cls, text)
        value.text = text.strip()
        return value

    def __repr__(self) -> str:
        return self.text


def typed_number(text: str) -> float:
    """The argparse ``type`` of a numeric option: a `Typed` float (argparse names the option when
    the text is not a number)."""
    return Typed(text)


def check_out(option: str, value) -> None:
    """An output path given as "" would fall back to the default folder: refuse it."""
    if value is not None and not str(value).strip():
        raise refuse(option, "an empty path; give a file or folder name (or leave the option out)")


def check_folder(option: str, value) -> None:
    """Make the output folder ``value`` of ``option`` now (before any work) and refuse one that
    cannot be made or written: a path under a file, a file, a read-only place."""
    import os
    from pathlib import Path
    if value is None:
        return
    path = Path(value)
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise refuse(option, f"cannot make the folder {path}: {exc.strerror or exc}; give a folder that can "
                             "be created") from None
    if not os.access(path, os.W_OK | os.X_OK):
        raise refuse(option, f"cannot write into {path} (read-only or not permitted); give a writable folder")


def check_file_target(option: str, value) -> None:
    """Refuse an output file ``value`` of ``option`` that cannot be written: a folder, a path under
    a file or in a folder that does not exist, a read-only folder (found before the computation)."""
    import os
    from pathlib import Path
    if value is None:
        return
    path = Path(value)
    if path.is_dir():
        raise refuse(option, f"{path} is a folder; give a file name")
    parent = path.parent
    if not parent.is_dir():
        why = "is not a folder" if parent.exists() else "does not exist"
        raise refuse(option, f"cannot write {path}: {parent} {why}; give a file in an existing folder")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise refuse(option, f"cannot write into {parent} (read-only or not permitted); give a writable folder")


#: Faults of the storage itself (a full disk, a quota, an I/O error): the run failed where it
#: stood (exit 3, what was computed is kept); any other file error is a path to change (exit 2).
_STORAGE_ERRNOS = {getattr(errno, n) for n in ("ENOSPC", "EDQUOT", "EIO", "EFBIG") if hasattr(errno, n)}
#: The options and arguments that name paths, in the order a file error is matched against them.
_PATH_OPTIONS = (("csv", "--csv"), ("map", "--map"), ("space", "--space"), ("runs", "--runs"), ("out", "--out"),
                 ("model", "MODEL"), ("scene", "SCENE"), ("targets", "TARGETS"), ("sweep", "SWEEP"))
#: The hidden temporary file of an atomic write: the user knows the file it becomes.
_TEMP_NAME = re.compile(r"^\.(?P<name>.+)\.[A-Za-z0-9_]{8}\.(tmp|png|pdf)$")


def os_error(exc: OSError, args) -> tuple[str, int]:
    """(one-line message, exit status) of a file fault met while a command ran: the option whose
    path holds the file (or AUTOCABLE_CACHE), the file (a hidden temporary name shown as the file
    it becomes), the system's reason and the fix; status 3 for a full disk or an I/O error, 2 for a
    path that cannot be written."""
    from pathlib import Path

    from autocable._store import CACHE_ENV, cache_root
    name = exc.filename or exc.filename2
    option, shown = "", str(name) if name else ""
    if name:
        path = Path(os.fsdecode(name)).absolute()
        m = _TEMP_NAME.match(path.name)
        if m:
            path = path.with_name(m["name"])
        # a file staged in a run's staging folder is the folder's file to the user
        parts = [p for p in path.parts if not p.startswith(".autocable-staging-")]
        path = Path(*parts)
        shown = str(path)
        for attr, opt in _PATH_OPTIONS:
            given = getattr(args, attr, None)
            if isinstance(given, str) and given.strip():
                root = Path(given).absolute()
                if path == root or root in path.parents:
                    option = opt
                    break
        if not option:
            try:
                if cache_root().absolute() in path.parents:
                    option = CACHE_ENV
            except Exception:  # noqa: BLE001 - naming the cache is a courtesy
                pass
    elif isinstance(getattr(args, "out", None), str) and args.out.strip():
        # a write that names no file (a figure saved by a library): the output folder it went to
        option, shown = "--out", str(Path(args.out).absolute())
    storage = exc.errno in _STORAGE_ERRNOS
    fix = ("free space there and rerun (what was computed is kept and reads as not finished)" if storage
           else "give a path that can be written")
    where = ": ".join(x for x in (option, shown) if x)
    return (f"{where + ': ' if where else ''}{exc.strerror or exc}; {fix}",
            EXIT_FAILED if storage else EXIT_INPUT)


def strict(x):
    """``x`` with every non-finite float replaced by None (strict JSON: no NaN, no Infinity)."""
    if isinstance(x, float):
        return x if math.isfinite(x) else None
    if isinstance(x, dict):
        return {k: strict(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [strict(v) for v in x]
    try:                                 # numpy scalars
        import numpy as np
        if isinstance(x, np.bool_):      # a numpy comparison's result: true/false, not an error
            return bool(x)
        if isinstance(x, np.floating):
            return strict(float(x))
        if isinstance(x, np.integer):
            return int(x)
        if isinstance(x, np.ndarray):
            return strict(x.tolist())
    except ImportError:                  # pragma: no cover
        pass
    return x


def dumps(obj, **kw) -> str:
    """The JSON the command line prints or writes: strict (a non-finite number is null; a
    ``status`` beside it says why), so any JSON parser reads it."""
    return json.dumps(strict(obj), allow_nan=False, **kw)


def response_status(a1: float, steady: bool, decay_rate: float = math.nan) -> str:
    """The ``status`` of a simulated response: "diverged" (growth past the model's range; the
    amplitudes are null), "steady", "decaying" (``--max-time`` reached while the amplitudes fell
    exponentially at ``decay_rate``: on their way to rest, `autocable.methods.integration.ode21.decay_rate`)
    or "not_steady" (``--max-time`` reached first)."""
    if not math.isfinite(a1):
        return "diverged"
    if not steady and decay_rate > 0:
        return "decaying"
    return "steady" if steady else "not_steady"
