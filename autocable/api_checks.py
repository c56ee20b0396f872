"""The public API's argument table: what each function of `autocable` (``import autocable as ac``)
accepts, checked before the call by the one checker the command line uses
(`autocable.model.premises`: `check_type`, `check_choice`, `check_number`, `check_interval`).

A wrong argument is an `autocable.model.premises.ArgumentError` (a `SpecError`, so a `ValueError`)
of one line, ``function: argument: what is accepted, got <the value as given>``, instead of an
AttributeError or TypeError from deep inside. The checks are the types and choices a caller can
get wrong; the values (U*, eta*, sigma within the premises, time budgets) are checked by the
functions themselves with the same checker. `autocable.__getattr__` hands out `guarded` functions;
the package's own modules call the plain ones.

The table names types as "module:Name" strings, imported when a guarded function is first called
(``import autocable`` stays free).
"""
from __future__ import annotations

import functools
import importlib
import inspect
import re

from autocable.model.premises import ArgumentError, check_choice, check_interval, check_number
from autocable.spec import show

__all__ = ["RULES", "guarded", "check_arguments"]

_PATH = ("builtins:str", "os:PathLike")
_RESULT = ("autocable.methods.continuation:ContinuationResult",)
_LABEL = ("builtins:str", "autocable.results:SpecialPoint")
_SETTINGS = ("autocable.methods.continuation:ContinuationSettings", "builtins:NoneType")
_SYSTEM = ("autocable.methods.continuation:System",)
_MAPPING = ("collections.abc:Mapping",)
_DIRECTIONS = ("both", "forward", "backward")
_ENGINES = ("pycont", "compiled")
_ORDERINGS = ("paper", "natural")


def _types(*names):
    return ("types", names)


def _choice(*values):
    return ("choice", values)


_POSITIVE = ("positive", None)
_INTERVAL = ("interval", None)

#: function -> argument -> rule: ("types", "module:Name", ...) an instance of one of them;
#: ("choice", values) one of the values; positive: a number > 0; interval: (lo, hi), lo < hi.
RULES: dict[str, dict[str, tuple]] = {
    "derive_ame": {"ordering": _choice(*_ORDERINGS),
                   "source": _types("autocable.model.derive:Derivation", "autocable.model.equations:TwoModeODE")},
    "ame_system": {"ame": _types("autocable.model.ame:AmplitudeEquations"), "dof": _choice("2dof", "1dof"),
                   "wind": _types("builtins:bool")},
    "auto_state_scale": {"system": _types(*_SYSTEM), "values": _types(*_MAPPING)},
    "continue_equilibria": {"problem": _types("autocable.methods.continuation:EquilibriumProblem"),
                            "settings": _types(*_SETTINGS), "engine": _choice(*_ENGINES)},
    "switch_branch": {"source": _types(*_RESULT), "bp": _types(*_LABEL), "settings": _types(*_SETTINGS),
                      "engine": _choice(*_ENGINES)},
    "continue_cycles": {"source": _types(*_RESULT), "hopf": _types(*_LABEL), "settings": _types(*_SETTINGS),
                        "engine": _choice(*_ENGINES)},
    "continue_cycles_from_orbit": {"problem": _types("autocable.methods.continuation:EquilibriumProblem"),
                                   "settings": _types("autocable.methods.continuation:ContinuationSettings"),
                                   "period": _POSITIVE, "directions": _choice(*_DIRECTIONS)},
    "continue_folds": {"source": _types(*_RESULT), "fold": _types(*_LABEL), "second_parameter": _types("builtins:str"),
                       "bounds": _INTERVAL, "settings": _types(*_SETTINGS), "directions": _choice(*_DIRECTIONS)},
    "continue_hopf": {"source": _types(*_RESULT), "hopf": _types(*_LABEL), "second_parameter": _types("builtins:str"),
                      "bounds": _INTERVAL, "settings": _types(*_SETTINGS), "directions": _choice(*_DIRECTIONS)},
    "continue_branch_points": {"source": _types(*_RESULT), "label": _types(*_LABEL),
                               "second_parameter": _types("builtins:str"), "bounds": _INTERVAL,
                               "settings": _types(*_SETTINGS), "directions": _choice(*_DIRECTIONS)},
    "equilibrium_near": {"system": _types(*_SYSTEM), "p": _types(*_MAPPING, "numpy:ndarray")},
    "settle": {"system": _types(*_SYSTEM), "values": _types(*_MAPPING), "engine": _choice(*_ENGINES)},
    "periodic_orbit": {"system": _types(*_SYSTEM), "values": _types(*_MAPPING)},
    "read_results": {"out_dir": _types(*_PATH)},
    "load_scene": {"path": _types(*_PATH)},
    "load_sweep": {"path": _types(*_PATH)},
    "write_results": {"results": _types("autocable.results:RunResults"), "out_dir": _types(*_PATH)},
    "branches_dataframe": {"branches": ("branches", None)},
    "plot_plane": {"results": ("has", "branches")},
    "plot_chart": {"results": ("has", "branches")},
    "plot_time_series": {"series": _types(*_MAPPING)},
    "plot_simulation": {"history": _types("builtins:tuple", "builtins:list"), "Omega": _POSITIVE},
    "save_figure": {"fig": ("has", "savefig"), "stem": _types(*_PATH)},
    "si_scales": {"length_m": _POSITIVE, "omega_rad_s": _POSITIVE, "critical_wind_speed_m_s": _POSITIVE},
    "sweep": {"integrator": ("has", "simulate"), "parameter": _choice("sigma", "U", "eta"),
              "fixed": _types(*_MAPPING)},
}

#: How a type is named in a message.
_SHOWN = {"builtins:str": "a string", "os:PathLike": "a path", "builtins:NoneType": "None",
          "builtins:bool": "True or False", "collections.abc:Mapping": "a mapping (dict)",
          "numpy:ndarray": "an array", "builtins:tuple": "a tuple", "builtins:list": "a list"}


def _resolve(name: str):
    module, _, attr = name.partition(":")
    if module == "builtins" and attr == "NoneType":
        return type(None)
    return getattr(importlib.import_module(module), attr)


def _check(function: str, name: str, value, rule) -> None:
    kind, spec = rule
    if kind == "types":
        if not isinstance(value, tuple(_resolve(t) for t in spec)):
            shown = " or ".join(_SHOWN.get(t, t.partition(":")[2]) for t in spec)
            raise ArgumentError(function, name, f"expected {shown}, got {_what(value)}")
    elif kind == "choice":
        check_choice(function, name, value, spec)
    elif kind == "positive":
        check_number(function, name, value, 0.0, lo_open=True)
    elif kind == "interval":
        check_interval(function, name, value)
    elif kind == "has":
        if not hasattr(value, spec):
            raise ArgumentError(function, name, f"expected an object with .{spec} (see help(ac.{function})), "
                                                f"got {_what(value)}")
    elif kind == "branches":
        from autocable.results import Branch
        items = getattr(value, "branches", value)
        if isinstance(items, (str, bytes)) or not hasattr(items, "__iter__"):
            raise ArgumentError(function, name, f"expected a sequence of Branch, got {_what(value)}")
        for k, b in enumerate(items):
            if not isinstance(getattr(b, "branch", b), Branch):
                raise ArgumentError(function, f"{name}[{k}]", f"expected a Branch, got {_what(b)}")


def _what(value) -> str:
    """A rejected value: its repr when short, else its type."""
    text = show(value)
    return text if len(text) < 50 and not text.startswith("<") else type(value).__name__


def check_arguments(function: str, fn, args, kwargs) -> None:
    """Check a call ``fn(*args, **kwargs)`` of the public ``function`` against `RULES`: a missing
    or unknown argument, or one the table refuses, is an `ArgumentError` naming it."""
    rules = RULES.get(function)
    if not rules:
        return
    try:
        bound = inspect.signature(fn).bind(*args, **kwargs)
    except TypeError as exc:            # a missing or unexpected argument: named by the message
        named = re.search(r"'(\w+)'", str(exc))
        raise ArgumentError(function, named[1] if named else "arguments",
                            f"{exc}; see help(ac.{function})") from None
    for name, value in bound.arguments.items():
        if name in rules:
            _check(function, name, value, rules[name])


def guarded(name: str, value):
    """The public ``value`` as handed out by ``ac.<name>``: a function with `RULES` checked before
    each call (the same function, same docstring and signature); anything else unchanged."""
    if name not in RULES or not inspect.isfunction(value):
        return value

    @functools.wraps(value)
    def call(*args, **kwargs):
        check_arguments(name, value, args, kwargs)
        return value(*args, **kwargs)
    return call

