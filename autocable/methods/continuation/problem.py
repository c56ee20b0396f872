"""What to continue: `EquilibriumProblem`, the `ContinuationResult` it produces with its
`ContinuationSettings` (how, in `settings`), and `StartError` (a start point that is not an equilibrium).

Immutable values only (see `autocable.methods.continuation` for the design)."""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field, replace
from types import MappingProxyType
from typing import Callable, Mapping

from autocable.methods.continuation.settings import ContinuationSettings
from autocable.model.premises import ArgumentError, check_interval, check_number, check_type
from autocable.methods.continuation.system import System, auto_state_scale
from autocable.results import Branch, SpecialPoint, TruncatedBranchWarning, truncation_notes
from autocable.spec import show


Progress = Callable[[str], None]


class StartError(ValueError):
    """The start point of a continuation is not an equilibrium (Newton or integration failed)."""


@dataclass(frozen=True)
class EquilibriumProblem:
    """What to continue: ``system`` with ``values`` (every parameter; the continued one at its start
    value), ``parameter`` over ``bounds``, states measured on ``state_scale``.

    ``state_scale`` left out (None): for the AME of `ame_system` the size of its linear forced
    response at ``values`` (`auto_state_scale`, what a scene's ``state_scale = "auto"`` uses; 1e-2
    without forcing, eta = 0); 1 for any other system (states of order one)."""

    system: System
    parameter: str
    values: Mapping[str, float]
    bounds: tuple[float, float]
    state_scale: float | None = None

    def __post_init__(self):
        # the API's checker (autocable.model.premises): a wrong argument named, not an AttributeError
        f = "EquilibriumProblem"
        check_type(f, "system", self.system, System, "a System (ac.ame_system(...))")
        if not isinstance(self.parameter, str) or self.parameter not in self.system.parameter_names:
            raise ArgumentError(f, "parameter", f"expected a parameter of {self.system.name!r}, one of "
                                                f"{', '.join(self.system.parameter_names)}, got {show(self.parameter)}")
        check_type(f, "values", self.values, Mapping, "a mapping of parameter values, e.g. {\"sigma\": -0.05}")
        for k, v in self.values.items():
            if k not in self.system.parameter_names:
                raise ArgumentError(f, f"values[{k!r}]", f"not a parameter of {self.system.name!r} (it has "
                                                         f"{', '.join(self.system.parameter_names)})")
            check_number(f, f"values[{k!r}]", v)
        lo, hi = check_interval(f, "bounds", self.bounds, what=f"the range of {self.parameter}")
        values = dict(zip(self.system.parameter_names, self.system.parameter_vector(self.values)))
        if not lo <= values[self.parameter] <= hi:
            raise ValueError(f"start value {self.parameter} = {values[self.parameter]:g} is outside "
                             f"the range [{lo:g}, {hi:g}]")
        if self.state_scale is None:
            scale = auto_state_scale(self.system, values) if self.system.amplitude_equations else 1.0
            object.__setattr__(self, "state_scale", float(scale))
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

    def __post_init__(self):
        # Where every continuation hands its branch back: the branch learns the range it was asked
        # for, and an end at the point budget is said at once (a truncated branch drawn or tabled
        # as if whole would be read as the whole solution family).
        b = self.branch
        if b.parameter == self.problem.parameter and "range" not in b.info:
            b = b.replace(info={**b.info, "range": [float(v) for v in self.problem.bounds]})
            object.__setattr__(self, "branch", b)
        for note in truncation_notes([b]):
            warnings.warn(note, TruncatedBranchWarning, stacklevel=3)

    def __repr__(self) -> str:
        return f"ContinuationResult({self.branch!r})"

    def special(self, label: str) -> SpecialPoint:
        return self.branch.special(label)


def _resolve(source, label: str | SpecialPoint) -> tuple[SpecialPoint, EquilibriumProblem, ContinuationSettings]:
    if isinstance(label, SpecialPoint):
        sp_ = label
    else:
        sp_ = source.special(label)
    return sp_, source.problem, source.settings
