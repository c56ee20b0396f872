"""How to continue: `ContinuationSettings` (immutable) and the names of the engines.

Light on purpose (no numpy, sympy or PyDSTool): the scene schema reads its step keys and engine
names from here, so that parsing a scene file loads nothing heavy and cannot disagree with the
engines (see `autocable.methods.continuation` for the design).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, fields

__all__ = ["ContinuationSettings", "ENGINES", "CYCLE_ENGINES", "STEP_KEYS", "INTEGER_STEP_KEYS", "Budget"]

#: Engines of equilibrium continuation and branch switching: PyCont's EP-C (the AUTO-style workflow)
#: or autocable's compiled C kernel (`compiled_equilibria`).
ENGINES = ("pycont", "compiled")
#: Engines of cycle continuation: PyCont's LC-C or autocable's collocation (`compiled_cycles`).
CYCLE_ENGINES = ("pycont", "compiled")


@dataclass(frozen=True)
class ContinuationSettings:
    """How to continue (steps in the scaled coordinates of the module docstring: lam spans 1 over
    the range, x~ is the state over ``state_scale``)."""

    step: float = 5e-3               # initial pseudo-arclength step
    min_step: float = 1e-7
    max_step: float = 2e-2
    max_points: int = 2000           # per direction (equilibria) or per cycle branch
    chunk: int = 25                  # PyCont points per call (range/closure checks in between; a
                                     # call overshoots the range by up to a chunk, so keep it small)
    max_corrector_iters: int = 6
    tol: float = 1e-10               # PyCont's FuncTol and VarTol (scaled units)
    test_tol: float = 1e-8           # PyCont's TestTol
    newton_tol: float = 1e-12        # autocable's polish/refinement: relative Newton step
    locate: tuple[str, ...] = ("LP", "H", "BP")
    # cycles (LC-C)
    ntst: int = 40
    ncol: int = 4
    cycle_step: float = 1e-3
    cycle_max_step: float = 2e-2
    cycle_max_points: int = 150
    max_period_ratio: float = 20.0   # period blow-up: T > ratio * T_Hopf ends the branch
    floquet_rtol: float = 1e-10
    # branch switching
    switch_step: float = 1e-2
    # two-parameter curves (LP-C, H-C2): steps in the scaled coordinates (both ranges span 1)
    curve_step: float = 5e-3
    curve_max_step: float = 2e-2
    curve_max_points: int = 400      # per direction
    curve_check_tol: float = 1e-8    # independent check at every point: sigma_min(J)/sigma_max(J)
                                     # (folds), |Re lambda|/||J||_F of the critical pair (Hopf)
    # budgets of the integrations that find a start (`settle`, `periodic_orbit`): a start far from
    # any attractor, or a stiff one, would otherwise integrate without end
    settle_seconds: float = 60.0
    settle_evaluations: int = 2_000_000   # right-hand side evaluations
    orbit_seconds: float = 120.0

    def __post_init__(self):
        # the API's checker (autocable.model.premises): an ArgumentError naming the setting
        from autocable.model.premises import ArgumentError, check_number
        f = "ContinuationSettings"
        for name in ("step", "min_step", "max_step", "tol", "test_tol", "newton_tol", "cycle_step",
                     "cycle_max_step", "switch_step", "curve_step", "curve_max_step", "curve_check_tol",
                     "settle_seconds", "orbit_seconds"):
            check_number(f, name, getattr(self, name), 0.0, lo_open=True)
        if not self.min_step <= self.step <= self.max_step:
            raise ArgumentError(f, "step", f"need min_step <= step <= max_step, got {self.min_step}, {self.step}, "
                                           f"{self.max_step}")
        if not self.min_step <= self.curve_step <= self.curve_max_step:
            raise ArgumentError(f, "curve_step", f"need min_step <= curve_step <= curve_max_step, got {self.min_step}, "
                                                 f"{self.curve_step}, {self.curve_max_step}")
        for name in ("max_points", "chunk", "cycle_max_points", "ntst", "ncol", "max_corrector_iters",
                     "curve_max_points", "settle_evaluations"):
            check_number(f, name, getattr(self, name), 1, integer=True)
        if isinstance(self.locate, str) or not hasattr(self.locate, "__iter__"):
            raise ArgumentError(f, "locate", f"expected a sequence of \"LP\", \"H\", \"BP\", got {self.locate!r}")
        bad = set(self.locate) - {"LP", "H", "BP"}
        if bad:
            raise ArgumentError(f, "locate", f"unknown special points {sorted(bad)}; use LP, H, BP")



#: The settings a scene may set in ``steps`` (all but the internal ``locate`` and ``floquet_rtol``).
STEP_KEYS = tuple(f.name for f in fields(ContinuationSettings) if f.name not in ("locate", "floquet_rtol"))
#: Those of `STEP_KEYS` that are counts.
INTEGER_STEP_KEYS = tuple(f.name for f in fields(ContinuationSettings) if f.type == "int")


class Budget:
    """A budget of wall time and right-hand side evaluations for one integration: `spend` raises
    `BudgetExceeded` naming ``what``, the budget and the ``hint`` (how to raise it) once either is
    spent. One per integration (it holds the clock), never shared."""

    def __init__(self, what: str, seconds: float, evaluations: float = math.inf, hint: str = ""):
        import time
        self.what, self.seconds, self.evaluations, self.hint = what, float(seconds), evaluations, hint
        self._clock = time.monotonic
        self._deadline = self._clock() + self.seconds
        self.spent = 0

    def spend(self, n: int = 1, at: str = "") -> None:
        """Count ``n`` evaluations and `check`."""
        self.spent += n
        self.check(at)

    def check(self, at: str = "") -> None:
        """Raise `BudgetExceeded` if the time or the evaluations counted so far are spent."""
        from autocable.errors import BudgetExceeded
        over_time = self._clock() > self._deadline
        if over_time or self.spent > self.evaluations:
            budget = f"{self.seconds:g} s" if over_time else f"{self.evaluations:,} right-hand side evaluations"
            raise BudgetExceeded(f"{self.what} spent its budget of {budget}{' ' + at if at else ''}"
                                 f"{'; ' + self.hint if self.hint else ''}")

