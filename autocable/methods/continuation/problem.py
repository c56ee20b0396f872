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
from autocable.model.premises import (NOT_GIVEN, SI_PARAMETERS, ArgumentError, check_call, check_interval,
                                      check_number, check_type, choose_parameter, parameter_from_si)
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

    @classmethod
    def from_si(cls, system: System, cable, *, wind_m_s=NOT_GIVEN, deck_amplitude_m=NOT_GIVEN,
                deck_frequency_Hz=NOT_GIVEN, U=NOT_GIVEN, eta=NOT_GIVEN, sigma=NOT_GIVEN,
                state_scale: float | None = None) -> "EquilibriumProblem":
        """The problem of the AME ``system`` (`ame_system`) with its values in SI, converted on the
        cable of ``cable`` (eqs. 17-18, `autocable.model.units`, as `frequency_response` converts):
        ``wind_m_s`` for U (U* = U/U_c), ``deck_amplitude_m`` for eta (eta* = eta/l) and
        ``deck_frequency_Hz`` for sigma (sigma = 2 pi f/omega - omega1, the support motion's
        detuning from the first in-plane frequency); the nondimensional ``U``, ``eta``, ``sigma``
        are taken too, one kind per quantity. Exactly one quantity is a range (lo, hi): the
        continued parameter, started at its lower end; the others are numbers (U defaults to 0,
        eta must be given).

        ``cable``: a `Derivation` (``ac.derive(...)``), a `ModelSpec` or the path of a model file,
        the same cable the system's AME was derived from (eq. 21's ``ode`` alone carries no length,
        U_c or omega: refused by name). Every argument is checked before the conversion
        (`ArgumentError` naming it, with the value as given; the converted values within
        `autocable.model.premises.PARAMETER_RANGES`, refused by their SI keyword)::

            eq21 = ac.derive("models/luongo_zulli_2012.toml")
            system = ac.ame_system(ac.derive_ame(eq21).ame, "2dof", wind=True)
            problem = ac.EquilibriumProblem.from_si(system, eq21, wind_m_s=8.0, deck_amplitude_m=0.02,
                                                    deck_frequency_Hz=(1.10, 1.14))
        """
        f = "EquilibriumProblem.from_si"
        check_type(f, "system", system, System, "a System (ac.ame_system(...))")
        eq21 = _cable(f, cable)
        kinds = {name: choose_parameter(f, name, star, si) for name, star, si in
                 (("U", U, wind_m_s), ("eta", eta, deck_amplitude_m), ("sigma", sigma, deck_frequency_Hz))}
        if kinds["eta"] is None:
            raise ArgumentError(f, "eta", "missing: give eta (eta* = eta/l) or deck_amplitude_m (in m)")
        ranges = [n for n, k in kinds.items() if k is not None and _is_range(k[1])]
        if len(ranges) != 1:
            given = [(SI_PARAMETERS[n][0] if k[0] == "si" else n) for n, k in kinds.items() if k is not None]
            raise ArgumentError(f, ", ".join(given), f"expected exactly one of them as a range (lo, hi), the "
                                                     f"continued parameter; got {len(ranges)} ranges")
        for name in system.parameter_names:
            if name not in kinds:
                raise ArgumentError(f, "system", f"expected the AME of eq. (21) (parameters U, eta, sigma), got "
                                                 f"{system.name!r} with {', '.join(system.parameter_names)}")
        parameter = ranges[0]
        values, bounds = _si_values(f, kinds, eq21, parameter)
        values[parameter] = bounds[0]
        return cls(system, parameter, values, bounds, state_scale)

    @property
    def span(self) -> float:
        return self.bounds[1] - self.bounds[0]

    def at(self, **values) -> "EquilibriumProblem":
        """The same problem with some parameter values changed."""
        return replace(self, values={**self.values, **values})


def _is_range(value) -> bool:
    return not isinstance(value, (str, bytes)) and hasattr(value, "__len__")


def _cable(function: str, cable):
    """The `Derivation` of ``cable`` (a Derivation, a ModelSpec or a model file's path), which carries
    the scales of eqs. (17)-(18); eq. (21)'s ``ode`` alone is refused naming the argument."""
    import os

    from autocable.model.derive import Derivation, derive
    from autocable.model.equations import TwoModeODE
    from autocable.spec import ModelSpec
    if isinstance(cable, TwoModeODE):
        raise ArgumentError(function, "cable", "SI values need the cable (its length, U_c and omega): pass the "
                                               "Derivation (ac.derive(...)) rather than its .ode")
    check_type(function, "cable", cable, (Derivation, ModelSpec, str, os.PathLike),
               "a Derivation (ac.derive(...)), a ModelSpec or the path of a model file")
    return cable if isinstance(cable, Derivation) else derive(os.fspath(cable) if isinstance(
        cable, (str, os.PathLike)) else cable)


def _si_values(function: str, kinds: dict, eq21, parameter: str) -> tuple[dict, tuple[float, float]]:
    """({U, eta, sigma} nondimensional, the continued parameter's (lo, hi)) of `choose_parameter`'s
    ``kinds`` (None: not given, U = 0), the SI ones converted on the cable of the `Derivation`
    ``eq21`` by `parameter_from_si` (refused by their keyword outside the premises), the
    nondimensional ones checked by `check_call`."""
    from autocable.model.units import units_of
    units = units_of(eq21.spec, eq21.statics)
    omega1 = eq21.ode.omega1
    values, bounds = {"U": 0.0}, None
    for name, kind in kinds.items():
        if kind is None:
            continue
        label = SI_PARAMETERS[name][0] if kind[0] == "si" else name
        what = SI_PARAMETERS[name][2] if kind[0] == "si" else f"the range of {name}"
        if name == parameter:
            check_interval(function, label, kind[1], 0.0 if kind[0] == "si" else -math.inf, what=what)
            ends = []
            for k, v in enumerate(kind[1]):
                if kind[0] == "si":
                    ends.append(parameter_from_si(function, name, v, units, omega1, f"{label}[{k}]"))
                    continue
                try:
                    check_call(function, **{name: v})
                except ArgumentError as exc:
                    raise ArgumentError(function, f"{name}[{k}]", str(exc).split(f": {name}: ", 1)[-1]) from None
                ends.append(float(v))
            bounds = (ends[0], ends[1])
        elif kind[0] == "si":
            values[name] = parameter_from_si(function, name, kind[1], units, omega1)
        else:
            check_call(function, **{name: kind[1]})
            values[name] = float(kind[1])
    return values, bounds


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
