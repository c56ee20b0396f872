"""The failures autocable reports, and the exit status each one means.

Exit status is part of the interface (a user scripting hundreds of runs reads it):

* 0: a computed result. A response that grows without bound is physics, not a failure: it is a
  result, reported with status ``"diverged"`` and amplitudes ``null`` (never ``Infinity``).
* 2: bad input (`autocable.spec.SpecError`: a file, field or argument outside its accepted range)
  or an environment autocable cannot use (`CacheError`: the cache folder cannot be written).
* 3: the computation failed (`ComputationError`): an integrator or Newton that does not converge,
  or a budget of steps or time spent (`BudgetExceeded`); also a sweep with failed points, figures
  with failed scenes, a full disk or I/O error mid-run. What was computed before is kept.
* 130: interrupted.
"""
from __future__ import annotations

__all__ = ["EXIT_OK", "EXIT_INPUT", "EXIT_FAILED", "EXIT_INTERRUPTED",
           "ComputationError", "BudgetExceeded", "CacheError"]

EXIT_OK = 0
EXIT_INPUT = 2
EXIT_FAILED = 3
EXIT_INTERRUPTED = 130


class ComputationError(RuntimeError):
    """A numerical failure (not bad input, not physics): ``str(err)`` is one line with the reason."""


class BudgetExceeded(ComputationError):
    """A long computation stopped at its budget of steps or wall time; ``str(err)`` names the budget
    and how to raise it."""


class CacheError(OSError):
    """The cache folder cannot be used (e.g. it must be written and is read-only); the message names
    ``AUTOCABLE_CACHE``."""
