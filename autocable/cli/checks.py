"""What every command checks where an option enters, and the strict JSON they all print.

An option outside its accepted range is a `autocable.spec.SpecError` naming the option (exit 2,
`autocable.errors`); JSON output is strict: a non-finite number is null, with a status beside it.
"""
from __future__ import annotations

import json
import math

from autocable.model.premises import MAX_INTEGRATION_TIME
from autocable.spec import SpecError

#: Accepted ranges of the numeric options that premises.check_parameters does not cover.
#: Time limit of `simulate` (t* units): `autocable.model.premises.MAX_INTEGRATION_TIME`.
MAX_TIME_LIMIT = MAX_INTEGRATION_TIME
#: Modes per plane of `simulate --modes`: the symbolic N-mode derivation grows as N^4.
MODES_LIMIT = 6

#: Repeats of a benchmark: each costs up to minutes.
REPEATS_LIMIT = 100
#: Processes or Dask workers: more than this is a typing error on any machine autocable targets.
WORKERS_LIMIT = 1024


def refuse(option: str, message: str):
    """The one-line input error for a command-line option (exit 2)."""
    return SpecError("arguments", option, message)


def check_number(option: str, value, lo: float, hi: float, *, integer: bool = False,
                  lo_open: bool = False) -> None:
    """Refuse a non-finite ``value`` or one outside [lo, hi] ((lo, hi] with ``lo_open``)."""
    kind = "an integer" if integer else "a number"
    span = f"{'(' if lo_open else '['}{lo:g}, {hi:g}]"
    if value is None:
        return
    if not math.isfinite(value) or not (lo < value if lo_open else lo <= value) or not value <= hi:
        raise refuse(option, f"expected {kind} in {span}, got {value!r}")


def check_out(option: str, value) -> None:
    """An output path given as "" would fall back to the default folder: refuse it."""
    if value is not None and not str(value).strip():
        raise refuse(option, "an empty path; give a file or folder name (or leave the option out)")


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


def response_status(a1: float, steady: bool) -> str:
    """The ``status`` of a simulated response: "diverged" (growth past the model's range; the
    amplitudes are null), "steady", or "not_steady" (``--max-time`` reached first)."""
    if not math.isfinite(a1):
        return "diverged"
    return "steady" if steady else "not_steady"
