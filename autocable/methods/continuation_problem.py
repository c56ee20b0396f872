"""What and how to continue: `EquilibriumProblem`, `ContinuationSettings`, the `ContinuationResult`
they produce, and `StartError` (a start point that is not an equilibrium).

Immutable values only (see `autocable.methods.continuation` for the design)."""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from types import MappingProxyType
from typing import Callable, Mapping

from autocable.methods.system import System
from autocable.results import Branch, SpecialPoint


Progress = Callable[[str], None]


class StartError(ValueError):
    """The start point of a continuation is not an equilibrium (Newton or integration failed)."""


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

    def __post_init__(self):
        for name in ("step", "min_step", "max_step", "tol", "test_tol", "newton_tol", "cycle_step",
                     "cycle_max_step", "switch_step", "curve_step", "curve_max_step", "curve_check_tol"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and v > 0 and math.isfinite(v)):
                raise ValueError(f"{name} must be a positive number, got {v!r}")
        if not self.min_step <= self.step <= self.max_step:
            raise ValueError(f"need min_step <= step <= max_step, got {self.min_step}, {self.step}, {self.max_step}")
        if not self.min_step <= self.curve_step <= self.curve_max_step:
            raise ValueError(f"need min_step <= curve_step <= curve_max_step, got {self.min_step}, "
                             f"{self.curve_step}, {self.curve_max_step}")
        for name in ("max_points", "chunk", "cycle_max_points", "ntst", "ncol", "max_corrector_iters",
                     "curve_max_points"):
            if int(getattr(self, name)) < 1:
                raise ValueError(f"{name} must be a positive integer")
        bad = set(self.locate) - {"LP", "H", "BP"}
        if bad:
            raise ValueError(f"locate: unknown special points {sorted(bad)}; use LP, H, BP")


@dataclass(frozen=True)
class EquilibriumProblem:
    """What to continue: ``system`` with ``values`` (every parameter; the continued one at its start
    value), ``parameter`` over ``bounds``, states measured on ``state_scale``."""

    system: System
    parameter: str
    values: Mapping[str, float]
    bounds: tuple[float, float]
    state_scale: float = 1.0

    def __post_init__(self):
        if self.parameter not in self.system.parameter_names:
            raise ValueError(f"{self.parameter!r} is not a parameter of {self.system.name!r} "
                             f"(it has {list(self.system.parameter_names)})")
        values = dict(zip(self.system.parameter_names, self.system.parameter_vector(self.values)))
        lo, hi = (float(b) for b in self.bounds)
        if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
            raise ValueError(f"range of {self.parameter} must be two finite numbers lo < hi, got {self.bounds}")
        if not lo <= values[self.parameter] <= hi:
            raise ValueError(f"start value {self.parameter} = {values[self.parameter]:g} is outside "
                             f"the range [{lo:g}, {hi:g}]")
        if not (self.state_scale > 0 and math.isfinite(self.state_scale)):
            raise ValueError(f"state_scale must be positive, got {self.state_scale}")
        object.__setattr__(self, "values", MappingProxyType(values))
        object.__setattr__(self, "bounds", (lo, hi))

    @property
    def span(self) -> float:
        return self.bounds[1] - self.bounds[0]

    def at(self, **values) -> "EquilibriumProblem":
        """The same problem with some parameter values changed."""
        return replace(self, values={**self.values, **values})


@dataclass(frozen=True, eq=False)
class ContinuationResult:
    """A branch together with the problem and settings that produced it (so branch switching and
    cycle continuation start from its labelled points, not from PyCont strings)."""

    branch: Branch
    problem: EquilibriumProblem
    settings: ContinuationSettings
    timings: Mapping[str, float] = field(default_factory=dict)

    def special(self, label: str) -> SpecialPoint:
        return self.branch.special(label)


def _resolve(source, label: str | SpecialPoint) -> tuple[SpecialPoint, EquilibriumProblem, ContinuationSettings]:
    if isinstance(label, SpecialPoint):
        sp_ = label
    else:
        sp_ = source.special(label)
    return sp_, source.problem, source.settings
