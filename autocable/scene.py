"""Scene files (``runs/*.toml``): one paper figure each, as a chain of continuation runs.

A scene says which cable model (a path relative to the scene file), which amplitude equations
(``ame = "2dof"``, eq. 24, or ``"1dof"``, the A2 = 0 reduction of Sect. 5), which parameters are fixed,
and a list of runs, each continuing one of the paper's control parameters (``sigma``, ``U``, ``eta``)
over a range from a start point; later runs may start from labelled points of earlier ones, like
AUTO-07p's ``.auto`` scripts (``start = "I:LP1"``); ``kind = "curve"`` continues a fold (LP) or Hopf
point (H) of an earlier run in two parameters (``parameter`` over ``range`` and ``parameter2`` over
``range2``): the curve of folds or of Hopf points. Follow-ups: ``cycles = true`` continues the
periodic orbits born at every Hopf point of a run, ``switch = true`` the branches through every
branch point. The schema is closed: an unknown key, a bad value, a parameter outside its range or a
start that does not converge raise `autocable.spec.SpecError` with one line naming the file and field.

    title = "Fig. 5a: ..."            # optional text
    model = "../models/luongo_zulli_2012.toml"
    ame = "2dof"                      # "2dof" | "1dof" | "1dof-amplitude" (eta = 0, Fig. 3) | "auto":
                                      # the lightest AME within ame_tol (autocable.advise), chosen by
                                      # cheap probes before the runs and recorded in run.json
    ame_tol = 0.02                    # only with ame = "auto"
    ordering = "paper"                # Multiple Scales ordering (Sect. 4): "paper" (every aerodynamic
                                      # term at third order) or "natural" (aerodynamic terms at their
                                      # natural order, quadratic ones second; multiscale.ordering_named)
    engine = "pycont"                 # equilibria, switching and cycles: "pycont" (PyCont EP-C and
                                      # LC-C, default) or "compiled" (autocable's C kernel and its own
                                      # collocation: the same branches, tested to agree, 25-100x
                                      # faster); curves always use PyCont
    state_scale = "auto"              # amplitude scale for the continuation ("auto" or a number)
    [fixed]                           # U, eta, sigma shared by every run (default 0)
    [[run]]
    name = "I"                        # branch name; letters, digits, '_' and '-'
    kind = "equilibria"               # "equilibria" | "cycles" (from start = "RUN:Hk", or { orbit = [a1, a2] }:
                                      # the stable periodic orbit integration reaches from there; compiled
                                      # engine) | "switch" (from "RUN:BPk")
                                      # | "curve" (from "RUN:LPk" or "RUN:Hk": a two-parameter curve)
    parameter = "sigma"               # the continued parameter: "sigma" | "U" | "eta"
    range = [-0.05, 0.05]
    start = "trivial"                 # "trivial" | { integrate = [a1, a2] } | { state = [r1, s1, r2, s2] } | "RUN:LABEL"
                                      # | { orbit = [a1, a2] } (cycles runs)
    at = -0.05                        # the parameter's start value (default: range[0], or the label's)
    directions = "both"               # "both" | "forward" | "backward" (curves: forward = increasing parameter2)
    parameter2 = "eta"                # curves only: the second parameter, and its range
    range2 = [0.0, 3e-3]
    cycles = false                    # follow-up: cycles from every Hopf point
    switch = false                    # follow-up: branch switching at every branch point
    [run.fixed]                       # per-run overrides of [fixed]
    [run.steps]                       # step controls (ContinuationSettings names)
    [plot]
    x = "sigma"                       # default: the first run's parameter
    y = ["a1"]                        # one panel per amplitude: "a1", "a2"
    plane = ["sigma", "eta"]          # the (p, p2) plane of the curves, <scene>_plane.png (default:
                                      # the first curve run's parameters; only with curve runs)
    title = "..."                     # default: the scene title
    labels = true                     # write special-point labels (H1, LP1, BP1) on the plot
    [compare]                         # optional digitised points to overlay
    csv = "fig05a_digitised.csv"      # columns x, y, curve, stable (path relative to the scene)
    panel = "a1"

A ``[time]`` scene (Fig. 11) has no runs: it integrates the AME (24) at one parameter point over
[0, t_end] and the amplitude envelope of eq. (21) from the same start (runs/README.md):

    [time]
    U = 1.3                           # > 0; eta, sigma as above
    eta = 1.4e-3
    sigma = -0.042
    t_end = 60000.0
    start = "rest"                    # "rest" (q2 = 1e-6) | { amplitudes = [a1, a2] }
    ode21 = true                      # also the envelope of eq. (21): half peak-to-peak per forcing period
    summary_from = 40000.0            # the summary's window t >= summary_from (default t_end / 2)
    samples_per_period = 2            # AME output samples per forcing period

and writes ``time_series.csv`` (columns source,t,a1,a2; source "ame" or "ode21"), ``run.json`` (the
provenance and a "summary": per source a1/a2 min/max and the modulation period) and
``<scene>.png``/``.pdf``. A ``[compare]`` table also writes ``compare.json`` (`autocable.compare`:
distance of the digitised points to the computed branches). ``run_scene(..., resolution="coarse")``
runs a scene with longer steps and capped cycle runs (`coarse_settings`; the tests).

`run_scene(load_scene(path), out_dir)` runs it and writes ``branches.csv``, ``special_points.csv``,
``run.json`` (`autocable.results`) and ``<scene>.png``/``.pdf`` (`autocable.plotting.diagrams`), with
curve runs also ``<scene>_plane.png``/``.pdf``.
"""
from __future__ import annotations

import math
import platform
import re
import sys
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Callable, Mapping

from autocable.spec import SpecError, load_model, read_toml

__all__ = [
    "Scene",
    "RunSpec",
    "StartSpec",
    "PlotSpec",
    "CompareSpec",
    "load_scene",
    "parse_scene",
    "run_scene",
    "add_run_parser",
    "cmd_run",
]

PARAMETERS = ("sigma", "U", "eta")
#: The equilibrium engines of `autocable.methods.equilibria.ENGINES` (not imported here: parsing a
#: scene must not load PyDSTool).
ENGINES = ("pycont", "compiled")
_NAME = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_\-]*$")
_LABEL = re.compile(r"^([A-Za-z0-9_\-]+):([A-Z]+[0-9]+)$")
_TOP_KEYS = ("title", "description", "model", "ame", "ame_tol", "ordering", "engine", "state_scale", "fixed", "run",
             "plot", "compare", "overlay", "time")
#: The Multiple Scales orderings of `autocable.model.multiscale.ORDERINGS` (not imported here:
#: parsing a scene must not load sympy).
ORDERINGS = ("paper", "natural")
_RUN_KEYS = ("name", "kind", "parameter", "range", "start", "at", "directions", "cycles", "switch",
             "fixed", "steps", "parameter2", "range2")
_STEP_KEYS = ("step", "min_step", "max_step", "max_points", "chunk", "max_corrector_iters", "tol",
              "test_tol", "newton_tol", "ntst", "ncol", "cycle_step", "cycle_max_step", "cycle_max_points",
              "max_period_ratio", "switch_step", "curve_step", "curve_max_step", "curve_max_points",
              "curve_check_tol")
_PLOT_KEYS = ("x", "y", "title", "labels", "plane")
_COMPARE_KEYS = ("csv", "panel", "label")
_OVERLAY_KEYS = ("method", "parameter", "range", "points", "directions", "max_time")
_KINDS = ("equilibria", "cycles", "switch", "curve")
_TIME_KEYS = ("U", "eta", "sigma", "t_end", "start", "ode21", "summary_from", "samples_per_period")
#: `run_scene(..., resolution=...)`: "full" as written; "coarse" for the tests (see `coarse_settings`).
RESOLUTIONS = ("full", "coarse")

Progress = Callable[[str], None]


# ================================================================================================
# the schema as data
# ================================================================================================
#: `ame` of a scene: the Cartesian AME (24) of both modes, its A2 = 0 reduction, or the one-mode
#: polar amplitude equation (23) at eta = 0 (galloping, Fig. 3; see methods/amplitude_system.py).
AME_KINDS = ("2dof", "1dof", "1dof-amplitude")


@dataclass(frozen=True)
class StartSpec:
    """Where a run starts: ``kind`` is "trivial", "integrate" (amplitudes a_k, phases 0), "state"
    (a state vector refined by Newton), "label" (``label`` = "RUN:LABEL") or "orbit" (amplitudes
    a_k, phases 0: the periodic orbit the AME settles on from there, for a cycles run)."""

    kind: str
    values: tuple[float, ...] = ()
    label: str = ""


@dataclass(frozen=True)
class RunSpec:
    name: str
    kind: str
    parameter: str
    range: tuple[float, float]
    start: StartSpec
    at: float | None
    directions: str
    cycles: bool
    switch: bool
    fixed: Mapping[str, float]
    steps: Mapping[str, float]
    index: int
    parameter2: str = ""                        # curves: the second parameter and its range
    range2: tuple[float, float] | None = None


@dataclass(frozen=True)
class PlotSpec:
    x: str
    y: tuple[str, ...]
    title: str
    labels: bool = True
    plane: tuple[str, str] | None = None        # (x, y) of the parameter-plane figure of the curves


@dataclass(frozen=True)
class CompareSpec:
    csv: Path
    panel: str = "a1"
    label: str = "digitised"


@dataclass(frozen=True)
class OverlaySpec:
    """Direct-integration "empty boxes" (Figs. 9-10): steady responses at sampled parameter values,
    swept up and down (methods/sweeps.py)."""
    method: str                     # "ode21" (eq. 21, the paper's check) or "ame"
    parameter: str
    range: tuple[float, float]
    points: int
    directions: tuple[str, ...]
    max_time: float


@dataclass(frozen=True)
class Scene:
    path: Path
    name: str
    title: str
    description: str
    model: Path
    ame: str
    state_scale: float | None          # None: automatic
    fixed: Mapping[str, float]
    runs: tuple[RunSpec, ...]
    plot: PlotSpec
    compare: CompareSpec | None = None
    text: str = field(default="", repr=False)
    overlay: OverlaySpec | None = None
    time: "TimeSpec | None" = None
    engine: str = "pycont"             # equilibria, branch switching and cycles: "pycont" | "compiled"
    ame_tol: float = 0.02              # with ame = "auto": the tolerance the advice uses
    ordering: str = "paper"            # the Multiple Scales ordering of the AME (ORDERINGS)


@dataclass(frozen=True)
class TimeSpec:
    """A time-evolution scene (Fig. 11): the AME (24) integrated from ``start`` over [0, t_end] at
    one parameter point, and the amplitude envelope of eq. (21) integrated from the same start."""
    U: float
    eta: float
    sigma: float
    t_end: float
    start: tuple[float, float] | None       # (a1, a2) with phases 0; None: rest with q2 = 1e-6
    ode21: bool = True
    summary_from: float = 0.0               # min/max and modulation period over t >= summary_from
    samples_per_period: int = 2             # AME output samples per forcing period


# ================================================================================================
# parsing
# ================================================================================================
def _check_keys(table, allowed, path, where) -> None:
    if not isinstance(table, dict):
        raise SpecError(path, where, "expected a table")
    for key in table:
        if key not in allowed:
            raise SpecError(path, f"{where}.{key}" if where else key,
                            f"unknown key; allowed: {', '.join(allowed)}")


def _num(value, path, where, what="a number") -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(float(value)):
        raise SpecError(path, where, f"expected {what}, got {value!r}")
    return float(value)


def _bool(value, path, where) -> bool:
    if not isinstance(value, bool):
        raise SpecError(path, where, f"expected true or false, got {value!r}")
    return value


def _params(table, path, where) -> dict[str, float]:
    _check_keys(table, PARAMETERS, path, where)
    out = {k: _num(v, path, f"{where}.{k}") for k, v in table.items()}
    if out.get("eta", 0.0) < 0:
        raise SpecError(path, f"{where}.eta", f"the support amplitude eta must be >= 0, got {out['eta']}")
    if out.get("U", 0.0) < 0:
        raise SpecError(path, f"{where}.U", f"the wind speed U must be >= 0, got {out['U']}")
    return out


def _start(value, path, where) -> StartSpec:
    if value == "trivial":
        return StartSpec("trivial")
    if isinstance(value, str):
        if not _LABEL.match(value):
            raise SpecError(path, where, f'expected "trivial", "RUN:LABEL" (e.g. "I:H1"), '
                                         f'{{integrate = [a1, a2]}}, {{state = [...]}} or {{orbit = [a1, a2]}}, '
                                         f'got {value!r}')
        return StartSpec("label", label=value)
    if isinstance(value, dict):
        _check_keys(value, ("integrate", "state", "orbit"), path, where)
        if len(value) != 1:
            raise SpecError(path, where, "give exactly one of integrate = [a1, a2], state = [r1, s1, ...] "
                                         "or orbit = [a1, a2]")
        (kind, vals), = value.items()
        if not isinstance(vals, list) or not vals:
            raise SpecError(path, f"{where}.{kind}", f"expected a list of numbers, got {vals!r}")
        nums = tuple(_num(v, path, f"{where}.{kind}") for v in vals)
        if kind in ("integrate", "orbit") and any(v < 0 for v in nums):
            raise SpecError(path, f"{where}.{kind}", "amplitudes must be >= 0")
        return StartSpec(kind, nums)
    raise SpecError(path, where, f'expected "trivial", "RUN:LABEL", {{integrate = [...]}}, '
                                 f'{{state = [...]}} or {{orbit = [...]}}, got {value!r}')


def _steps(table, path, where) -> dict[str, float]:
    from autocable.methods.continuation import ContinuationSettings
    _check_keys(table, _STEP_KEYS, path, where)
    ints = {"max_points", "chunk", "max_corrector_iters", "ntst", "ncol", "cycle_max_points", "curve_max_points"}
    out: dict[str, Any] = {}
    for k, v in table.items():
        x = _num(v, path, f"{where}.{k}", "a positive number")
        if x <= 0:
            raise SpecError(path, f"{where}.{k}", f"expected a positive number, got {v!r}")
        out[k] = int(x) if k in ints else x
    try:
        ContinuationSettings(**out)
    except (TypeError, ValueError) as exc:
        raise SpecError(path, where, str(exc)) from None
    return out


def parse_scene(data: Mapping, path: str | Path = "<scene>", text: str = "") -> Scene:
    """Validate a parsed scene document (see the module docstring for the schema)."""
    path = Path(path)
    _check_keys(data, _TOP_KEYS, path, "")
    if "model" not in data:
        raise SpecError(path, "model", "missing; give the model file, e.g. \"../models/luongo_zulli_2012.toml\"")
    if not isinstance(data["model"], str):
        raise SpecError(path, "model", f"expected a path string, got {data['model']!r}")
    model = (path.parent / data["model"]).resolve()
    if not model.is_file():
        raise SpecError(path, "model", f"no such file: {model}")
    ame = data.get("ame", "2dof")
    if ame not in AME_KINDS + ("auto",):
        raise SpecError(path, "ame", f'expected "2dof", "1dof", "1dof-amplitude" or "auto", got {ame!r}')
    ame_tol = data.get("ame_tol", 0.02)
    if "ame_tol" in data and ame != "auto":
        raise SpecError(path, "ame_tol", 'only with ame = "auto" (the tolerance `autocable advise` chooses by)')
    if isinstance(ame_tol, bool) or not isinstance(ame_tol, (int, float)) or not 0 < ame_tol < 1:
        raise SpecError(path, "ame_tol", f"expected a relative tolerance in (0, 1), got {ame_tol!r}")
    ordering = data.get("ordering", "paper")
    if ordering not in ORDERINGS:
        raise SpecError(path, "ordering", f'expected "paper" (Sect. 4: every aerodynamic term at third order) or '
                                          f'"natural" (aerodynamic terms at their natural order), got {ordering!r}')
    engine = data.get("engine", "pycont")
    if engine not in ENGINES:
        raise SpecError(path, "engine", f'expected "pycont" (PyCont EP-C) or "compiled" (autocable\'s C '
                                        f'kernel, same branches), got {engine!r}')
    scale = data.get("state_scale", "auto")
    if scale == "auto":
        scale = None
    else:
        scale = _num(scale, path, "state_scale", 'a positive number or "auto"')
        if scale <= 0:
            raise SpecError(path, "state_scale", f"expected a positive number, got {scale}")
    for key in ("title", "description"):
        if key in data and not isinstance(data[key], str):
            raise SpecError(path, key, "expected a string")
    fixed = _params(data.get("fixed", {}), path, "fixed")
    if "time" in data:
        return replace(_time_scene(data, path, text, model, ame, scale), ordering=ordering)
    raw_runs = data.get("run")
    if not isinstance(raw_runs, list) or not raw_runs:
        raise SpecError(path, "run", "missing; add at least one [[run]] table")
    runs: list[RunSpec] = []
    names: set[str] = set()
    for i, r in enumerate(raw_runs):
        where = f"run[{i}]"
        _check_keys(r, _RUN_KEYS, path, where)
        name = r.get("name", f"R{i + 1}")
        if not isinstance(name, str) or not _NAME.match(name) or name in names:
            raise SpecError(path, f"{where}.name", f"expected a new name of letters, digits, '_' or '-', got {name!r}")
        names.add(name)
        kind = r.get("kind", "equilibria")
        if kind not in _KINDS:
            raise SpecError(path, f"{where}.kind", f"expected one of {', '.join(_KINDS)}, got {kind!r}")
        if "parameter" not in r:
            raise SpecError(path, f"{where}.parameter", f"missing; the continued parameter, one of {', '.join(PARAMETERS)}")
        parameter = r["parameter"]
        if parameter not in PARAMETERS:
            raise SpecError(path, f"{where}.parameter", f"expected one of {', '.join(PARAMETERS)}, got {parameter!r}")
        rng = r.get("range")
        if not (isinstance(rng, list) and len(rng) == 2):
            raise SpecError(path, f"{where}.range", f"expected [lo, hi], got {rng!r}")
        lo, hi = (_num(v, path, f"{where}.range") for v in rng)
        if not lo < hi:
            raise SpecError(path, f"{where}.range", f"expected lo < hi, got [{lo}, {hi}]")
        if parameter in ("eta", "U") and lo < 0:
            raise SpecError(path, f"{where}.range", f"{parameter} must stay >= 0, got [{lo}, {hi}]")
        start = _start(r.get("start", "trivial"), path, f"{where}.start")
        if start.kind == "label":
            src = start.label.split(":")[0]
            earlier = names - {name}
            # a follow-up branch of run R is named R-H1, R-BP2, ... (cycles, switching)
            if not any(src == n or src.startswith(n + "-") for n in earlier):
                raise SpecError(path, f"{where}.start", f"{start.label!r} refers to branch {src!r}, which is "
                                                        f"not an earlier run (or a follow-up of one) of this scene")
        if kind == "cycles" and not (start.kind == "label" and ":H" in start.label) and start.kind != "orbit":
            raise SpecError(path, f"{where}.start", 'a "cycles" run starts from a Hopf point, e.g. "I:H1", or '
                                                    'from the periodic orbit reached by integration, '
                                                    '{ orbit = [a1, a2] }')
        if start.kind == "orbit" and kind != "cycles":
            raise SpecError(path, f"{where}.start", '{ orbit = [...] } starts a "cycles" run: set kind = "cycles"')
        if start.kind == "orbit" and engine != "compiled":
            raise SpecError(path, f"{where}.start", 'a cycles run from { orbit = [...] } needs engine = '
                                                    '"compiled" (PyCont\'s LC-C starts only at Hopf points here)')
        if kind == "switch" and not (start.kind == "label" and ":BP" in start.label):
            raise SpecError(path, f"{where}.start", 'a "switch" run starts from a branch point, e.g. "I:BP1"')
        parameter2, range2 = "", None
        if kind == "curve":
            if not (start.kind == "label" and re.search(r":(LP|H)[0-9]+$", start.label)):
                raise SpecError(path, f"{where}.start", 'a "curve" run starts from a fold or a Hopf point, '
                                                        'e.g. "I:LP1" or "I:H1"')
            for key in ("at", "cycles", "switch"):
                if key in r:
                    raise SpecError(path, f"{where}.{key}", 'not allowed in a "curve" run (it starts at its '
                                                            'labelled point and has no follow-ups)')
            if "parameter2" not in r:
                raise SpecError(path, f"{where}.parameter2", f"missing; the second parameter of the curve, "
                                                             f"one of {', '.join(PARAMETERS)}")
            parameter2 = r["parameter2"]
            if parameter2 not in PARAMETERS or parameter2 == parameter:
                raise SpecError(path, f"{where}.parameter2", f"expected one of {', '.join(PARAMETERS)} other "
                                                             f"than parameter ({parameter}), got {parameter2!r}")
            rng2 = r.get("range2")
            if not (isinstance(rng2, list) and len(rng2) == 2):
                raise SpecError(path, f"{where}.range2", f"expected [lo, hi], got {rng2!r}")
            lo2, hi2 = (_num(v, path, f"{where}.range2") for v in rng2)
            if not lo2 < hi2:
                raise SpecError(path, f"{where}.range2", f"expected lo < hi, got [{lo2}, {hi2}]")
            if parameter2 in ("eta", "U") and lo2 < 0:
                raise SpecError(path, f"{where}.range2", f"{parameter2} must stay >= 0, got [{lo2}, {hi2}]")
            range2 = (lo2, hi2)
        else:
            for key in ("parameter2", "range2"):
                if key in r:
                    raise SpecError(path, f"{where}.{key}", 'only a "curve" run has a second parameter')
        at = r.get("at")
        if at is not None:
            at = _num(at, path, f"{where}.at")
            if not lo <= at <= hi:
                raise SpecError(path, f"{where}.at", f"{parameter} = {at:g} is outside the range [{lo:g}, {hi:g}]")
        directions = r.get("directions", "both")
        if directions not in ("both", "forward", "backward"):
            raise SpecError(path, f"{where}.directions", f'expected "both", "forward" or "backward", got {directions!r}')
        runs.append(RunSpec(
            name=name, kind=kind, parameter=parameter, range=(lo, hi), start=start, at=at,
            directions=directions, cycles=_bool(r.get("cycles", False), path, f"{where}.cycles"),
            switch=_bool(r.get("switch", False), path, f"{where}.switch"),
            fixed=_params(r.get("fixed", {}), path, f"{where}.fixed"),
            steps=_steps(r.get("steps", {}), path, f"{where}.steps"), index=i,
            parameter2=parameter2, range2=range2))
    plot = data.get("plot", {})
    _check_keys(plot, _PLOT_KEYS, path, "plot")
    x = plot.get("x", runs[0].parameter)
    if x not in PARAMETERS:
        raise SpecError(path, "plot.x", f"expected one of {', '.join(PARAMETERS)}, got {x!r}")
    y = plot.get("y", ["a1"])
    y = [y] if isinstance(y, str) else y
    if not isinstance(y, list) or not y or any(v not in ("a1", "a2") for v in y):
        raise SpecError(path, "plot.y", f'expected a list of "a1" and/or "a2", got {plot.get("y")!r}')
    title = data.get("title", path.stem)
    ptitle = plot.get("title", title)
    if not isinstance(ptitle, str):
        raise SpecError(path, "plot.title", "expected a string")
    labels = _bool(plot.get("labels", True), path, "plot.labels")
    curves = [r for r in runs if r.kind == "curve"]
    plane = plot.get("plane")
    if plane is not None:
        if not (isinstance(plane, list) and len(plane) == 2 and all(v in PARAMETERS for v in plane)
                and plane[0] != plane[1]):
            raise SpecError(path, "plot.plane", f"expected two different parameters of {', '.join(PARAMETERS)}, "
                                                f"got {plane!r}")
        if not curves:
            raise SpecError(path, "plot.plane", 'the parameter plane is drawn for "curve" runs; this scene has none')
        plane = tuple(plane)
    elif curves:
        plane = (curves[0].parameter, curves[0].parameter2)
    compare = None
    if "compare" in data:
        c = data["compare"]
        _check_keys(c, _COMPARE_KEYS, path, "compare")
        if not isinstance(c.get("csv"), str):
            raise SpecError(path, "compare.csv", "missing; the path of a CSV with columns x, y, curve, stable")
        csv_path = (path.parent / c["csv"]).resolve()
        if not csv_path.is_file():
            raise SpecError(path, "compare.csv", f"no such file: {csv_path}")
        panel = c.get("panel", y[0])
        if panel not in y:
            raise SpecError(path, "compare.panel", f"expected one of the plotted amplitudes {y}, got {panel!r}")
        compare = CompareSpec(csv_path, panel, str(c.get("label", "digitised")))
    overlay = _overlay(data["overlay"], path, x, runs) if "overlay" in data else None
    return Scene(path=path, name=path.stem, title=title, description=data.get("description", ""),
                 model=model, ame=ame, state_scale=scale, fixed=fixed, runs=tuple(runs),
                 plot=PlotSpec(x, tuple(y), ptitle, labels, plane), compare=compare, text=text,
                 overlay=overlay, engine=engine, ame_tol=float(ame_tol), ordering=ordering)


def _overlay(table, path, x: str, runs) -> OverlaySpec:
    """The [overlay] table: which method, which parameter and values, which sweep directions."""
    if not isinstance(table, dict):
        raise SpecError(path, "overlay", "expected a table")
    _check_keys(table, _OVERLAY_KEYS, path, "overlay")
    method = table.get("method", "ode21")
    if method not in ("ode21", "ame"):
        raise SpecError(path, "overlay.method", f'expected "ode21" or "ame", got {method!r}')
    parameter = table.get("parameter", x)
    if parameter not in PARAMETERS:
        raise SpecError(path, "overlay.parameter", f"expected one of {', '.join(PARAMETERS)}, got {parameter!r}")
    default = next((r.range for r in runs if r.parameter == parameter and r.kind != "curve"), None)
    rng = table.get("range", list(default) if default else None)
    if not (isinstance(rng, list) and len(rng) == 2):
        raise SpecError(path, "overlay.range", "expected [lo, hi]")
    lo, hi = (_num(v, path, "overlay.range") for v in rng)
    if not lo < hi:
        raise SpecError(path, "overlay.range", f"expected lo < hi, got {rng}")
    if parameter == "U" and lo <= 0:
        raise SpecError(path, "overlay.range", "sweeping U needs U > 0 (the aerodynamic terms carry 1/U)")
    points = table.get("points", 11)
    if isinstance(points, bool) or not isinstance(points, int) or not 1 <= points <= 201:
        raise SpecError(path, "overlay.points", f"expected a whole number from 1 to 201, got {points!r}")
    directions = table.get("directions", ["up", "down"])
    if not (isinstance(directions, list) and directions and set(directions) <= {"up", "down"}):
        raise SpecError(path, "overlay.directions", f'expected a list of "up" and/or "down", got {directions!r}')
    max_time = _num(table.get("max_time", 30000.0), path, "overlay.max_time")
    if max_time <= 0:
        raise SpecError(path, "overlay.max_time", "expected a positive time (t* units)")
    return OverlaySpec(method, parameter, (lo, hi), points, tuple(directions), max_time)


def _time_scene(data, path: Path, text: str, model: Path, ame: str, scale) -> Scene:
    """A scene with a ``[time]`` table: a time evolution (Fig. 11) instead of continuation runs."""
    extra = [k for k in ("run", "overlay", "compare", "fixed", "state_scale") if k in data]
    if extra:
        raise SpecError(path, extra[0], "a [time] scene has no runs, overlay, comparison, [fixed] or state_scale "
                                        "(its parameters are in [time]); remove it or the [time] table")
    if ame != "2dof":
        raise SpecError(path, "ame", 'a [time] scene integrates the 2-dof AME (24): use ame = "2dof"')
    t = data["time"]
    _check_keys(t, _TIME_KEYS, path, "time")
    for key in ("U", "eta", "sigma", "t_end"):
        if key not in t:
            raise SpecError(path, f"time.{key}", "missing; a [time] scene needs U, eta, sigma and t_end")
    vals = _params({k: t[k] for k in ("U", "eta", "sigma")}, path, "time")
    if vals["U"] == 0.0:
        # One vector field for the time scenes: the AME with its wind rows (1/U powers).
        raise SpecError(path, "time.U", "a [time] scene needs wind, U > 0 (the aerodynamic terms carry 1/U)")
    t_end = _num(t["t_end"], path, "time.t_end")
    if t_end <= 0:
        raise SpecError(path, "time.t_end", f"expected a positive time (t* units), got {t_end}")
    start = t.get("start", "rest")
    if start == "rest":
        start = None
    elif isinstance(start, dict) and set(start) == {"amplitudes"} and isinstance(start["amplitudes"], list) \
            and len(start["amplitudes"]) == 2:
        start = tuple(_num(v, path, "time.start.amplitudes") for v in start["amplitudes"])
        if min(start) < 0:
            raise SpecError(path, "time.start.amplitudes", "amplitudes must be >= 0")
    else:
        raise SpecError(path, "time.start", f'expected "rest" or {{amplitudes = [a1, a2]}}, got {start!r}')
    summary_from = _num(t.get("summary_from", t_end / 2), path, "time.summary_from")
    if not 0 <= summary_from < t_end:
        raise SpecError(path, "time.summary_from", f"expected a time in [0, t_end = {t_end:g}), got {summary_from:g}")
    spp = t.get("samples_per_period", 2)
    if isinstance(spp, bool) or not isinstance(spp, int) or not 1 <= spp <= 64:
        raise SpecError(path, "time.samples_per_period", f"expected a whole number from 1 to 64, got {spp!r}")
    plot = data.get("plot", {})
    _check_keys(plot, ("title", "y"), path, "plot")
    y = plot.get("y", ["a1", "a2"])
    y = [y] if isinstance(y, str) else y
    if not isinstance(y, list) or not y or any(v not in ("a1", "a2") for v in y):
        raise SpecError(path, "plot.y", f'expected a list of "a1" and/or "a2", got {plot.get("y")!r}')
    title = data.get("title", path.stem)
    ptitle = plot.get("title", title)
    if not isinstance(ptitle, str):
        raise SpecError(path, "plot.title", "expected a string")
    spec = TimeSpec(U=vals["U"], eta=vals["eta"], sigma=vals["sigma"], t_end=t_end, start=start,
                    ode21=_bool(t.get("ode21", True), path, "time.ode21"), summary_from=summary_from,
                    samples_per_period=spp)
    return Scene(path=path, name=path.stem, title=title, description=data.get("description", ""),
                 model=model, ame=ame, state_scale=scale, fixed=vals, runs=(),
                 plot=PlotSpec("t", tuple(y), ptitle, False), text=text, time=spec)


def load_scene(path: str | Path) -> Scene:
    """Read and validate a scene file; errors are one-line `SpecError`s."""
    path = Path(path)
    data, text = read_toml(path)
    return parse_scene(data, path, text)


def read_compare(spec: CompareSpec) -> list[dict]:
    """The digitised points of ``spec.csv``: dicts with x, y (floats), curve (str), stable (bool)."""
    import csv
    rows = []
    with open(spec.csv, newline="", encoding="utf-8") as fh:
        reader = csv.DictReader(fh)
        missing = {"x", "y"} - set(reader.fieldnames or ())
        if missing:
            raise SpecError(spec.csv, "", f"missing columns {sorted(missing)}; expected x, y, curve, stable")
        for k, r in enumerate(reader):
            try:
                rows.append({"x": float(r["x"]), "y": float(r["y"]), "curve": r.get("curve", "") or "",
                             "stable": str(r.get("stable", "1")).strip().lower() in ("1", "true", "yes", "s")})
            except ValueError:
                raise SpecError(spec.csv, f"row {k + 2}", "x and y must be numbers") from None
    return rows


# ================================================================================================
# running
# ================================================================================================
def _versions() -> dict[str, str]:
    from importlib import metadata

    from autocable import __version__
    out = {"autocable": __version__, "python": platform.python_version()}
    for pkg in ("numpy", "scipy", "sympy", "PyDSTool", "matplotlib"):
        try:
            out[pkg] = metadata.version(pkg)
        except metadata.PackageNotFoundError:
            out[pkg] = "not installed"
    return out


def _system_for(scene: Scene, ame, values: Mapping[str, float], parameter: str, rng, path, where,
                memo: dict | None = None):
    """The AME system for a run: aerodynamic rows only when the wind blows (1/U powers).

    ``memo`` (one per scene run) hands every run the same `System` object: building the wind AME
    as sympy data costs about a second, and its numeric functions and C kernel load once."""
    from autocable.methods.continuation import ame_system
    if scene.ame == "1dof-amplitude":
        from autocable.methods.amplitude_system import galloping_amplitude_system
        if parameter == "eta" or values.get("eta", 0.0) != 0.0:
            raise SpecError(path, f"{where}.fixed.eta", 'ame = "1dof-amplitude" (Fig. 3) holds at '
                                                       "eta = 0 only; fix eta = 0 and do not continue it")
        if parameter == "U" and rng[0] <= 0:
            raise SpecError(path, f"{where}.range", "continuing U needs U > 0 over the whole range "
                                                    "(the aerodynamic terms carry 1/U); start just above 0")
        return galloping_amplitude_system(ame)
    if parameter == "U":
        if rng[0] <= 0:
            raise SpecError(path, f"{where}.range", "continuing U needs U > 0 over the whole range "
                                                    "(the aerodynamic terms carry 1/U); start just above 0")
        wind = True
    else:
        wind = values.get("U", 0.0) != 0.0
    memo = {} if memo is None else memo
    if (scene.ame, wind) not in memo:
        memo[(scene.ame, wind)] = ame_system(ame, scene.ame, wind=wind)
    return memo[(scene.ame, wind)]


def coarse_settings(steps: Mapping[str, Any]) -> dict[str, Any]:
    """The ``resolution = "coarse"`` step controls for a run's ``steps`` (what the tests run):
    longer largest steps (x2, at most 0.1 of the range; x3 made Fig. 6's II step over a branch point),
    at most 20 points per cycle branch and 150 per curve direction. Special points are still
    located and refined by autocable's test functions, so their locations do not depend on the
    step; only the density of the drawn branches does."""
    from autocable.methods.continuation import ContinuationSettings
    base = ContinuationSettings(**steps)
    out = dict(steps)
    out["max_step"] = max(base.max_step, min(2 * base.max_step, 0.1))
    out["cycle_max_step"] = max(base.cycle_max_step, min(2 * base.cycle_max_step, 0.1))
    out["curve_max_step"] = max(base.curve_max_step, min(2 * base.curve_max_step, 0.1))
    out["cycle_max_points"] = min(base.cycle_max_points, 20)
    out["curve_max_points"] = min(base.curve_max_points, 150)
    return out


def _settings(run: RunSpec, resolution: str = "full"):
    from autocable.methods.continuation import ContinuationSettings
    return ContinuationSettings(**(coarse_settings(run.steps) if resolution == "coarse" else run.steps))


def run_scene(scene: Scene, out_dir: str | Path, *, progress: Progress | None = None,
              plot: bool = True, resolution: str = "full"):
    """Run every run of ``scene`` in order, write the results into ``out_dir`` and plot them.

    ``resolution = "coarse"`` (the tests) runs the same scene with longer steps and capped cycle
    and curve runs (`coarse_settings`) and every third overlay value; a ``[time]`` scene is the
    same at both resolutions.

    Returns the `RunResults`. A branch that fails part-way is kept with its points and an end
    reason; a start that does not converge, or a start value outside the range, stops the scene
    with a `SpecError` naming the run.
    """
    import numpy as np

    from autocable.methods import continuation as C
    from autocable.model.ame_cache import derive_ame
    from autocable.model.derive import derive
    from autocable.results import RunResults, write_results

    def say(msg: str) -> None:
        if progress:
            progress(f"[{scene.name}] {msg}")

    if resolution not in RESOLUTIONS:
        raise ValueError(f"resolution must be one of {RESOLUTIONS}, got {resolution!r}")
    if scene.time is not None:
        return _run_time_scene(scene, out_dir, say, plot, resolution)

    t_all = time.perf_counter()
    stages: dict[str, Any] = {}
    advice = None
    if scene.ame == "auto":
        # The lightest AME that reproduces this scene within ame_tol (issue 6, `autocable advise`):
        # cheap probes first, then the whole scene with the chosen rung.
        from autocable.advise import advice_report, choose_ame
        t0 = time.perf_counter()
        say(f'ame = "auto": probing which amplitude equations this scene needs (tol {scene.ame_tol:g})')
        advice = choose_ame(scene, tol=scene.ame_tol)
        for line in advice_report(advice).splitlines():
            say(f"  {line}")
        scene = replace(scene, ame=advice.ame)
        stages["advise_s"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    say(f"model {scene.model.name}: eq. (21)")
    spec = load_model(scene.model)
    deriv = derive(spec)
    stages["derive_s"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    say(f"amplitude equations (24), {scene.ordering} ordering")
    cached = derive_ame(deriv, ordering=scene.ordering)
    ame = cached.ame
    stages["ame_s"] = time.perf_counter() - t0
    omega1 = float(ame.omegas[0])
    results: dict[str, C.ContinuationResult] = {}
    systems: dict = {}
    branches = []
    run_times: dict[str, Any] = {}
    path = scene.path

    def check_values(values, where):
        if values["sigma"] <= -omega1:
            raise SpecError(path, where, f"sigma = {values['sigma']:g} gives a non-positive forcing "
                                         f"frequency Omega = omega1 + sigma")

    def add(result: C.ContinuationResult):
        results[result.branch.name] = result
        branches.append(result.branch)
        b = result.branch
        ends = "; ".join(f"{e.side}: {e.reason}" for e in b.ends)
        say(f"  {b.name}: {len(b)} points" + (f" ({b.kind} curve in {b.parameter}, {b.parameter2})"
                                              if b.parameter2 else "") + ", special points "
            f"{', '.join(s.label for s in b.special_points) or 'none'} ({ends})")

    for run in scene.runs:
        where = f"run[{run.index}]"
        t_run = time.perf_counter()
        lo, hi = run.range
        values = {p: 0.0 for p in PARAMETERS}
        values.update(scene.fixed)
        values.update(run.fixed)
        start_state = None
        source = None
        if run.start.kind == "label":
            src_name, label = run.start.label.split(":")
            if src_name not in results:
                raise SpecError(path, f"{where}.start", f"no branch {src_name!r} has been computed")
            try:
                sp_ = results[src_name].special(label)
            except KeyError as exc:
                raise SpecError(path, f"{where}.start", str(exc).strip("'\"")) from None
            source = results[src_name]
            values.update(sp_.parameters)
            values.update(run.fixed)
            start_state = np.array(sp_.state)
        at = run.at if run.at is not None else (values[run.parameter] if run.start.kind == "label" else lo)
        if not lo <= at <= hi:
            raise SpecError(path, f"{where}.range", f"the start value {run.parameter} = {at:g} is outside "
                                                    f"the range [{lo:g}, {hi:g}]")
        values[run.parameter] = at
        check_values(values, where)
        check_values({**values, "sigma": lo if run.parameter == "sigma" else values["sigma"]}, f"{where}.range")
        if run.kind == "curve":
            lo2, hi2 = run.range2
            v2 = values[run.parameter2]
            if not lo2 <= v2 <= hi2:
                raise SpecError(path, f"{where}.range2", f"the start point {run.start.label} has {run.parameter2} = "
                                                         f"{v2:g}, outside the range [{lo2:g}, {hi2:g}]")
            if run.parameter2 == "U" and lo2 <= 0:
                raise SpecError(path, f"{where}.range2", "continuing U needs U > 0 over the whole range "
                                                         "(the aerodynamic terms carry 1/U); start just above 0")
            if run.parameter2 == "sigma":
                check_values({**values, "sigma": lo2}, f"{where}.range2")
        if run.kind == "curve" and run.parameter2 == "U":
            system = _system_for(scene, ame, values, "U", run.range2, path, where, systems)
        else:
            system = _system_for(scene, ame, values, run.parameter, run.range, path, where, systems)
        scale = scene.state_scale or C.auto_state_scale(system, values)
        problem = C.EquilibriumProblem(system, run.parameter, values, run.range, state_scale=scale)
        settings = _settings(run, resolution)
        if run.kind == "curve":
            say(f"run {run.name}: curve of {'folds' if ':LP' in run.start.label else 'Hopf points'} in "
                f"({run.parameter}, {run.parameter2}) over [{lo:g}, {hi:g}] x [{run.range2[0]:g}, "
                f"{run.range2[1]:g}] from {run.start.label}")
        else:
            say(f"run {run.name}: {run.kind} in {run.parameter} over [{lo:g}, {hi:g}] from "
                f"{run.start.label or run.start.kind} at {run.parameter} = {at:g}")
        if run.kind == "curve":
            # The labelled point in this run's problem: its parameter and range are the first ones.
            src = C.ContinuationResult(source.branch, problem, settings)
            label = run.start.label.split(":")[1]
            fn = C.continue_folds if label.startswith("LP") else C.continue_hopf
            try:
                result = fn(src, label, run.parameter2, run.range2, settings, name=run.name,
                            directions=run.directions, progress=say)
            except C.StartError as exc:
                raise SpecError(path, f"{where}.start", str(exc)) from None
            add(result)
        elif run.kind == "cycles" and run.start.kind == "orbit":
            amps = list(run.start.values)
            n_modes = system.dimension // 2
            amps += [0.0] * max(0, n_modes - len(amps))
            y0 = np.zeros(system.dimension)
            y0[0::2] = amps[:n_modes]
            say(f"  integrating the AME from a = {amps[:n_modes]} to a periodic orbit")
            try:
                t_orb, x_orb, period = C.periodic_orbit(system, values, y0, scale=scale)
                result = C.continue_cycles_from_orbit(problem, settings, t_orb, x_orb, period, name=run.name,
                                                      directions=run.directions, progress=say)
            except C.StartError as exc:
                raise SpecError(path, f"{where}.start", str(exc)) from None
            add(result)
        elif run.kind in ("cycles", "switch"):
            # The labelled point in this run's problem (its parameter and range).
            src = C.ContinuationResult(source.branch, problem, settings)
            label = run.start.label.split(":")[1]
            if run.kind == "cycles":
                result = C.continue_cycles(src, label, settings, name=run.name, progress=say,
                                           engine=scene.engine)
            else:
                result = C.switch_branch(src, label, settings, name=run.name, progress=say,
                                         engine=scene.engine)
            add(result)
        else:
            try:
                if run.start.kind == "trivial":
                    x0 = np.zeros(system.dimension)
                elif run.start.kind == "state":
                    if len(run.start.values) != system.dimension:
                        raise SpecError(path, f"{where}.start.state", f"expected {system.dimension} numbers "
                                                                      f"{list(system.variables)}")
                    x0 = np.array(run.start.values)
                elif run.start.kind == "integrate":
                    amps = list(run.start.values)
                    n_modes = system.dimension // 2
                    if len(amps) < n_modes:
                        amps += [0.0] * (n_modes - len(amps))
                    y0 = np.zeros(system.dimension)
                    y0[0::2] = amps[:n_modes]
                    say(f"  integrating the AME from a = {amps[:n_modes]} to a steady state")
                    x0 = C.settle(system, values, y0, scale=scale, engine=scene.engine)
                else:
                    x0 = start_state
                result = C.continue_equilibria(problem, settings, x0, name=run.name,
                                               directions=run.directions, progress=say,
                                               engine=scene.engine)
            except C.StartError as exc:
                raise SpecError(path, f"{where}.start", str(exc)) from None
            add(result)
        follow = {"cycles": 0, "switch": 0}
        if run.kind != "cycles" and run.cycles:
            for h in results[run.name].branch.of_type("H"):
                if h.origin != "autocable":
                    continue
                say(f"  cycles from {h.name}")
                add(C.continue_cycles(results[run.name], h.label, settings, name=f"{run.name}-{h.label}",
                                      progress=say, engine=scene.engine))
                follow["cycles"] += 1
        if run.kind != "cycles" and run.switch:
            for bp in results[run.name].branch.of_type("BP"):
                if bp.origin != "autocable" or bp.label == "BP0":
                    continue
                say(f"  switching branches at {bp.name}")
                add(C.switch_branch(results[run.name], bp.label, settings, name=f"{run.name}-{bp.label}",
                                    progress=say, engine=scene.engine))
                follow["switch"] += 1
        run_times[run.name] = {"wall_s": time.perf_counter() - t_run,
                               **{k: v for k, v in results[run.name].timings.items()},
                               "follow_ups": follow, "state_scale": scale}
    stages["runs"] = run_times
    branches, validity = _with_twist(branches, spec, deriv)
    provenance = {
        "scene": str(scene.path), "scene_name": scene.name, "title": scene.title,
        "scene_text": scene.text, "model": str(scene.model), "model_name": spec.name,
        "model_hash": spec.content_hash(), "ode_hash": deriv.ode.content_hash(), "ame_key": cached.key,
        "ame": scene.ame, "ordering": scene.ordering, "engine": scene.engine, "ode21_engine": _ode21_engine(),
        "ame_advice": None if advice is None else {"requested": "auto", "tol": advice.tol, "chosen": advice.ame,
                                                   "lightest_rung": advice.rung, "reasons": list(advice.reasons)},
        "omega1": omega1, "omega2": float(ame.omegas[1]) if len(ame.omegas) > 1 else None,
        "amplitude_convention": "a_k = sqrt(r_k^2 + s_k^2): peak modal amplitude (peak displacement / l, "
                                "modes normalised to a unit maximum); Omega = omega1 + sigma",
        "stability": "autocable's eigenvalues (equilibria) and Floquet multipliers (cycles), not PyCont's flags",
        "cycle_engine": scene.engine,
        "versions": _versions(), "platform": platform.platform(), "argv": list(sys.argv),
        "resolution": resolution,
        "model_validity": validity,
    }
    res = RunResults(scene.name, tuple(branches), {**provenance, "stages": stages})
    out = Path(out_dir)
    overlay_rows = None
    if scene.overlay is not None:
        t0 = time.perf_counter()
        overlay_rows = _run_overlay(scene, deriv, ame, say, resolution)
        _write_overlay(overlay_rows, out / "overlay.csv")
        # The AME side of the comparison, solved at the overlay's values rather than read off a chord.
        from autocable.methods.equilibria_at import COLUMNS, equilibria_at
        exact = equilibria_at(results, scene.overlay.parameter, [r["value"] for r in overlay_rows])
        _write_overlay(exact, out / "overlay_ame.csv", COLUMNS)
        stages["overlay_s"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    write_results(res, out)
    stages["write_s"] = time.perf_counter() - t0
    compare = read_compare(scene.compare) if scene.compare else None
    if compare and branches:
        write_compare(scene, compare, branches, out)
    if plot and branches:
        t0 = time.perf_counter()
        from autocable.plotting.diagrams import plot_scene
        files = plot_scene(res, out / scene.name, x=scene.plot.x, y=scene.plot.y, title=scene.plot.title,
                           labels=scene.plot.labels, compare=compare,
                           compare_panel=scene.compare.panel if scene.compare else None,
                           compare_label=scene.compare.label if scene.compare else "",
                           overlay=overlay_rows)
        stages["plot_s"] = time.perf_counter() - t0
        if scene.plot.plane and any(b.kind in ("fold", "hopf") for b in branches):
            from autocable.plotting.diagrams import plot_plane
            files += plot_plane(res, out / f"{scene.name}_plane", x=scene.plot.plane[0], y=scene.plot.plane[1],
                                title=scene.plot.title, labels=scene.plot.labels)
            stages["plot_s"] = time.perf_counter() - t0
        say(f"plot: {', '.join(str(f) for f in files)}")
    stages["total_s"] = time.perf_counter() - t_all
    res = RunResults(scene.name, tuple(branches), {**provenance, "stages": stages})
    write_results(res, out)   # again, now with the complete timings
    return res


def _with_twist(branches, spec, deriv):
    """Where the model stops applying (issue 15). Each branch with a2 gets two columns: ``twist``,
    the peak slaved twist max_s |theta2(s)| a2 [rad] (Sect. 3: theta = theta2(s) q2), and
    ``cubic_error``, the error of the cubic load of eq. (14) against the exact quasi-steady load at
    the motion of that point (`aero.CubicLoadError`: twist, and the mid-span velocities
    nu Omega a1, nu Omega a2, at the point's U); the provenance gets the bound `aero.CUBIC_RTOL`,
    the largest twist and error, how many points exceed the bound, and the range of the angle phi
    of eq. (12) the twist sweeps (the lift and drag fits of eq. 13 were measured over a few tens of
    degrees at most)."""
    import numpy as np

    from autocable.model.aero import CUBIC_RTOL, CubicLoadError
    from autocable.model.modes import twist_peak
    per_q2 = twist_peak(*deriv.twist)
    a = spec.aero
    err = CubicLoadError(a.lift, a.drag, deriv.statics.alpha, deriv.beta, deriv.theta0, a.angle_convention,
                         a.load_axes)
    nu, om = deriv.velocity_ratio, deriv.ode.omega1
    out, largest, worst, beyond, total = [], 0.0, 0.0, 0, 0
    for b in branches:
        if "a2" in b.table and "a1" in b.table:
            a1 = np.abs(np.asarray(b.table["a1"], dtype=float))
            a2 = np.abs(np.asarray(b.table["a2"], dtype=float))
            U = np.asarray(b.table["U"], dtype=float) if "U" in b.table else np.zeros_like(a2)
            tw = per_q2 * a2
            ce = np.array([err(t, nu * om * x1, nu * om * x2, u) for t, x1, x2, u in zip(tw, a1, a2, U)])
            ok = np.isfinite(tw)
            largest = max(largest, float(tw[ok].max()) if ok.any() else 0.0)
            fin = ce[np.isfinite(ce)]
            worst = max(worst, float(fin.max()) if fin.size else 0.0)
            beyond += int(np.sum(fin > CUBIC_RTOL))
            total += len(b)
            b = b.replace(table={**b.table, "twist": tw, "cubic_error": ce})
        out.append(b)
    # the cubic fits c_l, c_d of eq. (13) are in phi = phi0 - theta (velocities aside): a twist of
    # radians takes them far outside any measured range of [36], whatever the expansion's error
    phi0 = math.degrees(deriv.static_angle)
    validity = {"twist_per_q2_rad": per_q2, "cubic_rtol": CUBIC_RTOL, "largest_twist_rad": largest,
                "largest_cubic_error": worst, "points_beyond_bound": beyond, "points": total,
                "phi_range_deg": [phi0 - math.degrees(largest), phi0 + math.degrees(largest)]}
    return out, validity


def write_compare(scene: Scene, rows: list[dict], branches, out: Path) -> Path:
    """``compare.json``: per curve label of the digitised points, their distance to the computed
    branches in the compared panel (`autocable.compare`)."""
    from autocable.codegen.cache import atomic_write_json
    from autocable.compare import compare_summary
    try:
        summary = compare_summary(rows, branches, scene.plot.x, scene.compare.panel)
    except ValueError as exc:
        raise SpecError(scene.path, "compare.panel", str(exc)) from None
    return atomic_write_json(out / "compare.json", {"csv": str(scene.compare.csv), "label": scene.compare.label,
                                                    **summary})


def _ode21_engine() -> str:
    """The engine of the scenes' direct integrations of eq. (21) (provenance)."""
    from autocable.methods.integration import SCENE_ENGINE
    return SCENE_ENGINE


def _run_overlay(scene: Scene, deriv, ame, say, resolution: str = "full") -> list[dict]:
    """Sweep the overlay's method up and down over its parameter values (methods/sweeps.py)."""
    import numpy as np

    from autocable.methods.sweeps import sweep, to_rows
    ov = scene.overlay
    values = np.linspace(ov.range[0], ov.range[1], ov.points)
    if resolution == "coarse":
        values = values[::3]        # a subset of the same values, from the first
    fixed = {k: v for k, v in scene.fixed.items() if k != ov.parameter}
    if ov.method == "ode21":
        from autocable.methods.integration import SCENE_ENGINE, Ode21Integrator
        integrator = Ode21Integrator(deriv.ode, engine=SCENE_ENGINE)
    else:
        from autocable.methods.ame_integration import AmeIntegrator
        integrator = AmeIntegrator(ame)
    say(f"overlay: {ov.method} swept in {ov.parameter} over [{ov.range[0]:g}, {ov.range[1]:g}], "
        f"{ov.points} points, {'/'.join(ov.directions)}")

    def tell(p):
        state = "periodic" if p.periodic else ("steady" if p.steady else p.message.split(":")[0])
        say(f"  {p.direction:>4} {ov.parameter} = {p.value:+.5f}: a1 = {p.a1:.4e}, a2 = {p.a2:.4e} ({state})")

    return to_rows(sweep(integrator, ov.parameter, values, fixed, directions=ov.directions,
                         progress=tell, max_time=ov.max_time))


def _write_overlay(rows: list[dict], path: Path, columns=("parameter",)) -> None:
    import csv
    import io

    from autocable.codegen.cache import atomic_write_text
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=list(rows[0]) if rows else list(columns))
    writer.writeheader()
    writer.writerows(rows)
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(path, buf.getvalue())


# ================================================================================================
# time evolutions (Fig. 11)
# ================================================================================================
#: Columns of ``time_series.csv`` (one row per sample; source "ame" or "ode21").
TIME_SERIES_COLUMNS = ("source", "t", "a1", "a2")


def modulation_period(t, a) -> float | None:
    """The period of an amplitude-modulated signal a(t): the mean spacing of its upward crossings
    of the mid-level (min + max)/2, linearly interpolated. None when a(t) is flat (an equilibrium
    of the AME: relative swing below 1e-6) or crosses fewer than three times."""
    import numpy as np

    t, a = np.asarray(t, float), np.asarray(a, float)
    if len(a) < 3 or not np.all(np.isfinite(a)):
        return None
    lo, hi = float(np.min(a)), float(np.max(a))
    if hi - lo <= 1e-6 * max(abs(hi), 1e-300):
        return None
    mid = 0.5 * (lo + hi)
    up = np.nonzero((a[:-1] < mid) & (a[1:] >= mid))[0]
    if len(up) < 3:
        return None
    tc = t[up] + (mid - a[up]) / (a[up + 1] - a[up]) * (t[up + 1] - t[up])
    return float(np.mean(np.diff(tc)))


def _ame_time_series(system, spec: TimeSpec, Omega: float):
    """Integrate the AME (24) over [0, t_end] (autocable's compiled DOP853, `ame_time_series`);
    returns t and the amplitudes a1, a2."""
    import numpy as np

    from autocable.methods.ame_integration import ame_time_series
    y0 = [0.0, 0.0, 1e-6, 0.0] if spec.start is None else [spec.start[0], 0.0, spec.start[1], 0.0]
    tt, ys = ame_time_series(system, {"U": spec.U, "eta": spec.eta, "sigma": spec.sigma}, y0, spec.t_end,
                             (2 * math.pi / Omega) / spec.samples_per_period, rtol=1e-10, atol=1e-16)
    return tt, np.hypot(ys[:, 0], ys[:, 1]), np.hypot(ys[:, 2], ys[:, 3])


def _ode21_envelope(deriv, spec: TimeSpec, Omega: float):
    """Integrate eq. (21) from the same start (q_k = a_k, q_k' = 0: r_k = a_k, s_k = 0 at t = 0) and
    take the half peak-to-peak of q1, q2 over each forcing period, at the period's mid time
    (`Ode21Integrator.envelope`). Returns (t, a1, a2, message); a divergence ends the arrays where
    it happens."""
    from autocable.methods.integration import SCENE_ENGINE, Ode21Integrator
    q = (0.0, 1e-6, 0.0, 0.0) if spec.start is None else (spec.start[0], spec.start[1], 0.0, 0.0)
    return Ode21Integrator(deriv.ode, engine=SCENE_ENGINE).envelope(
        spec.U, spec.eta, spec.sigma, q, spec.t_end, samples_per_period=64, Omega=Omega)


def _summary(t, a1, a2, since: float) -> dict:
    import numpy as np

    sel = t >= since
    if not np.any(sel):
        return {"samples": 0}
    return {"samples": int(sel.sum()), "t_from": float(t[sel][0]), "t_to": float(t[sel][-1]),
            "a1_min": float(a1[sel].min()), "a1_max": float(a1[sel].max()),
            "a2_min": float(a2[sel].min()), "a2_max": float(a2[sel].max()),
            "modulation_period": modulation_period(t[sel], a1[sel])}


def _run_time_scene(scene: Scene, out_dir, say, plot: bool, resolution: str):
    """Fig. 11: a1(t), a2(t) of the AME and the amplitude envelope of eq. (21), on the same axes."""
    import csv
    import io

    from autocable.codegen.cache import atomic_write_json, atomic_write_text
    from autocable.methods.continuation import ame_system
    from autocable.model.ame_cache import derive_ame
    from autocable.model.derive import derive
    from autocable.results import RunResults

    spec = scene.time
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    t_all = time.perf_counter()
    stages: dict[str, Any] = {}
    t0 = time.perf_counter()
    model = load_model(scene.model)
    deriv = derive(model)
    stages["derive_s"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    cached = derive_ame(deriv, ordering=scene.ordering)
    ame = cached.ame
    stages["ame_s"] = time.perf_counter() - t0
    omega1 = float(ame.omegas[0])
    Omega = omega1 + spec.sigma
    if not Omega > 0:
        raise SpecError(scene.path, "time.sigma", f"sigma = {spec.sigma:g} gives a non-positive forcing "
                                                  f"frequency Omega = omega1 + sigma")
    start = "rest (q2 = 1e-6)" if spec.start is None else f"a = {list(spec.start)}"
    say(f"time evolution at U = {spec.U:g}, eta = {spec.eta:g}, sigma = {spec.sigma:g} from {start}, "
        f"t in [0, {spec.t_end:g}]")
    t0 = time.perf_counter()
    system = ame_system(ame, "2dof", wind=True)
    ta, a1, a2 = _ame_time_series(system, spec, Omega)
    stages["ame_integration_s"] = time.perf_counter() - t0
    series = {"ame": (ta, a1, a2)}
    summary: dict[str, Any] = {"ame": {**_summary(ta, a1, a2, spec.summary_from), "diverged": False,
                                       "message": "bounded over [0, t_end]"}}
    say(f"  AME: a1 in [{summary['ame'].get('a1_min', math.nan):.4e}, {summary['ame'].get('a1_max', math.nan):.4e}], "
        f"a2 in [{summary['ame'].get('a2_min', math.nan):.4e}, {summary['ame'].get('a2_max', math.nan):.4e}], "
        f"modulation period {summary['ame'].get('modulation_period')}")
    if spec.ode21:
        t0 = time.perf_counter()
        te, e1, e2, message = _ode21_envelope(deriv, spec, Omega)
        stages["ode21_integration_s"] = time.perf_counter() - t0
        series["ode21"] = (te, e1, e2)
        diverged = message.startswith("eq. (21) diverges")
        summary["ode21"] = {**_summary(te, e1, e2, spec.summary_from), "diverged": diverged,
                            "message": message}
        say(f"  eq. (21): {message}; envelope a1 in [{summary['ode21'].get('a1_min', math.nan):.4e}, "
            f"{summary['ode21'].get('a1_max', math.nan):.4e}], a2 in [{summary['ode21'].get('a2_min', math.nan):.4e}, "
            f"{summary['ode21'].get('a2_max', math.nan):.4e}]")
    summary["window"] = f"t >= {spec.summary_from:g} (summary_from): after the transient"
    summary["ame_settings"] = {"integrator": "compiled DOP853 (autocable.codegen.cintegrate)", "rtol": 1e-10,
                               "atol": 1e-16, "samples_per_period": spec.samples_per_period,
                               "ode21_engine": _ode21_engine()}
    summary["ode21_envelope"] = "half peak-to-peak of q_k over each forcing period (64 samples, parabolic peaks)"
    buf = io.StringIO()
    w = csv.writer(buf)
    w.writerow(TIME_SERIES_COLUMNS)
    for src, (tt, x1, x2) in series.items():
        for row in zip(tt, x1, x2):
            w.writerow([src] + [repr(float(v)) for v in row])
    atomic_write_text(out / "time_series.csv", buf.getvalue())
    files = []
    if plot:
        t0 = time.perf_counter()
        from autocable.plotting.diagrams import plot_time_series
        # A modulation period is tens of time units against a run of tens of thousands: beside the
        # whole run, a window of the last few periods shows the periodic solution itself.
        period = summary.get("ame", {}).get("modulation_period")
        t_last = float(series["ame"][0][-1]) if len(series["ame"][0]) else 0.0
        zoom = ((t_last - 5.0 * period, t_last) if period and math.isfinite(period)
                and 5.0 * period < t_last - spec.summary_from else None)
        files = plot_time_series(series, out / scene.name, y=scene.plot.y, title=scene.plot.title,
                                 zoom=zoom,
                                 ode21_message=summary.get("ode21", {}).get("message", ""),
                                 ode21_diverged=summary.get("ode21", {}).get("diverged", False))
        stages["plot_s"] = time.perf_counter() - t0
        say(f"plot: {', '.join(str(f) for f in files)}")
    stages["total_s"] = time.perf_counter() - t_all
    provenance = {
        "scene": str(scene.path), "scene_name": scene.name, "title": scene.title, "scene_text": scene.text,
        "model": str(scene.model), "model_name": model.name, "model_hash": model.content_hash(),
        "ode_hash": deriv.ode.content_hash(), "ame_key": cached.key, "ame": scene.ame, "ordering": scene.ordering,
        "omega1": omega1,
        "omega2": float(ame.omegas[1]), "Omega": Omega, "kind": "time", "ode21_engine": _ode21_engine(),
        "parameters": {"U": spec.U, "eta": spec.eta, "sigma": spec.sigma, "t_end": spec.t_end,
                       "start": "rest" if spec.start is None else list(spec.start)},
        "resolution": resolution,
        "amplitude_convention": "a_k = sqrt(r_k^2 + s_k^2) (AME); half peak-to-peak of q_k per forcing "
                                "period (eq. 21); Omega = omega1 + sigma",
        "versions": _versions(), "platform": platform.platform(), "argv": list(sys.argv), "stages": stages,
    }
    res = RunResults(scene.name, (), {**provenance, "summary": summary})
    from autocable.results import _finite_or_none
    atomic_write_json(out / "run.json", {"format": "autocable.run/1", "name": scene.name,
                                         "provenance": _finite_or_none(provenance), "branches": [],
                                         "special_points": [], "summary": _finite_or_none(summary)})
    return res


# ================================================================================================
# command line (wired into autocable.cli by the lead)
# ================================================================================================
def add_run_parser(subparsers) -> None:
    """Add ``autocable run SCENE.toml --out DIR [--quiet] [--no-plot]`` to an argparse subparsers."""
    r = subparsers.add_parser("run", help="run a scene file (runs/*.toml): continuation, results, plot")
    r.add_argument("scene", help="scene file (runs/*.toml)")
    r.add_argument("--out", help="output folder (default: out/<scene name>)")
    r.add_argument("--quiet", action="store_true", help="no progress on stderr")
    r.add_argument("--no-plot", action="store_true", help="write the tables only")
    r.add_argument("--resolution", choices=RESOLUTIONS, default="full",
                   help="coarse: longer steps, capped cycle runs, every third overlay value (what the tests run)")
    r.set_defaults(func=cmd_run)


def cmd_run(args) -> int:
    """Run a scene; print a summary (branches, special points, files) on stdout."""
    scene = load_scene(args.scene)
    out = Path(args.out) if getattr(args, "out", None) else Path("out") / scene.name
    # Before the computation, not after it: a folder that cannot be made would lose the results.
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise SpecError("--out", "", f"cannot make the output folder {out}: {exc.strerror or exc}; "
                                     "give a folder that can be created") from None
    quiet = bool(getattr(args, "quiet", False))
    progress = None if quiet else (lambda msg: print(msg, file=sys.stderr, flush=True))
    res = run_scene(scene, out, progress=progress, plot=not getattr(args, "no_plot", False),
                    resolution=getattr(args, "resolution", "full") or "full")
    if not quiet and scene.time is not None:
        print(f"{scene.title}")
        summary = res.provenance["summary"]
        for src in ("ame", "ode21"):
            if src in summary:
                s = summary[src]
                period = s.get("modulation_period")
                print(f"  {src:<6} a1 in [{s.get('a1_min', math.nan):.6e}, {s.get('a1_max', math.nan):.6e}]  "
                      f"a2 in [{s.get('a2_min', math.nan):.6e}, {s.get('a2_max', math.nan):.6e}]  modulation period "
                      + (f"{period:.6g}" if period else "none (steady amplitude)") + f"  ({s['message']})")
        print(f"  results in {out}/ (time_series.csv, run.json"
              + (f", {scene.name}.png, {scene.name}.pdf" if not getattr(args, "no_plot", False) else "") + ")")
    elif not quiet:
        print(f"{scene.title}")
        for b in res.branches:
            ends = "; ".join(f"{e.side}: {e.reason}" + (f" ({e.message})" if e.reason not in ("range",) and e.message else "")
                             for e in b.ends)
            print(f"  {b.name:<12} {b.kind:<11} {len(b):>5} points   {ends}")
            for s in b.special_points:
                conf = {True: "PyCont agrees", False: "PyCont missed it", None: ""}[s.confirmed_by_pycont] \
                    if s.origin == "autocable" else "PyCont only, not confirmed"
                extra = f" l1 = {s.extra['l1']:.4g}" if "l1" in s.extra else ""
                second = f", {s.extra['parameter2']} = {s.extra['value2']: .8g}" if "value2" in s.extra else ""
                print(f"    {s.label:<5} {s.parameter} = {s.value: .8g}{second}  a1 = {s.a1:.6e}  a2 = {s.a2:.6e}"
                      f"{extra}  {conf}")
        plane = scene.plot.plane and any(b.kind in ("fold", "hopf") for b in res.branches)
        print(f"  results in {out}/ (branches.csv, special_points.csv, run.json"
              + (f", {scene.name}.png, {scene.name}.pdf" if not getattr(args, "no_plot", False) else "")
              + (f", {scene.name}_plane.png, {scene.name}_plane.pdf" if plane and not getattr(args, "no_plot", False)
                 else "") + ")")
    return 0
