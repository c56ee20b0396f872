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
U, eta and sigma (fixed values and ranges) must lie where eq. (21) applies (docs/model.md, P; a
`PremiseWarning` where it is stretched), a fixed value must be used by some run, start amplitudes are
at most 0.1, and step controls have bounded values (`_STEP_BOUNDS`).

    title = "Fig. 5a: ..."            # optional text
    model = "../models/luongo_zulli_2012.toml"
    ame = "2dof"                      # "2dof" | "1dof" | "1dof-amplitude" (eta = 0, Fig. 3) | "auto":
                                      # the lightest AME within ame_tol (autocable.studies.advise), chosen by
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
    units = "paper"                   # the inputs: "paper" (U*, eta*, sigma of eqs. 17-18) or "si":
                                      # U in m/s, eta in m (the support motion), sigma as the deck
                                      # frequency in Hz, converted on the model's cable (`si_inputs`;
                                      # [plot] units then defaults to "si")
    [fixed]                           # U, eta, sigma shared by every run (default 0)
    [[run]]
    name = "I"                        # branch name; letters, digits, '_' and '-'
    kind = "equilibria"               # "equilibria" | "cycles" (from start = "RUN:Hk", or { orbit = [a1, a2] }:
                                      # the stable periodic orbit integration reaches from there; compiled
                                      # engine) | "switch" (from "RUN:BPk")
                                      # | "curve" (from "RUN:LPk", "RUN:Hk" or "RUN:BPk": a two-parameter
                                      # curve of folds, Hopf points or pitchforks)
    parameter = "sigma"               # the continued parameter: "sigma" | "U" | "eta"
    range = [-0.05, 0.05]
    start = "trivial"                 # "trivial" | { integrate = [a1, a2] } | { state = [r1, s1, r2, s2] } | "RUN:LABEL"
                                      # | { orbit = [a1, a2] } (cycles runs)
                                      # | { search = [v1, v2, ...] }: at each of these values of the
                                      # parameter, every stable equilibrium that Newton finds from a
                                      # fixed grid off the earlier branches starts a branch (NAME,
                                      # NAME_2, ...: isolas, disconnected branches); none: no branch
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
    units = "paper"                   # axes in the paper's nondimensional symbols (a_1, sigma, U*, eta*)
                                      # or "si" (a_k l [m], sigma omega/2pi [Hz], U [m/s], eta [m]);
                                      # `autocable run --units` overrides it
    [compare]                         # optional digitised points to overlay
    csv = "fig05a_digitised.csv"      # columns x, y, curve, stable (path relative to the scene)
    panel = "a1"
    [chart]                           # optional: a stability chart in a parameter plane (`autocable chart`)
    plane = ["U", "eta"]              # x, y (default: plot.plane); the third parameter from [fixed]
    x_range = [0.1, 1.5]              # the chart's extent (default: the curve runs' ranges)
    y_range = [0.0, 6e-4]
    grid = [24, 16]                   # points in x, y where the AME's response is classified
    t_end = 30000.0                   # AME integration per start and point (t* units)
    starts = [[0.0, 1e-6], [5e-3, 1e-6]]   # (a1, a2) starts of the classification
    map = "sweep/sweep.nc"            # optional: a brute-force map of eq. (21) (`autocable sweep`) to overlay

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
``<scene>.png``/``.pdf``. A ``[compare]`` table also writes ``compare.json`` (`autocable.scene.compare`:
distance of the digitised points to the computed branches). ``run_scene(..., resolution="coarse")``
runs a scene with longer steps and capped cycle runs (`coarse_settings`; the tests).

`run_scene(load_scene(path), out_dir)` runs it and writes ``branches.csv``, ``special_points.csv``,
``run.json`` (`autocable.results`) and ``<scene>.png``/``.pdf`` (`autocable.plotting.diagrams`), with
curve runs also ``<scene>_plane.png``/``.pdf``.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Callable, Mapping

# The engine, ordering and step-key lists come from their light homes (no PyDSTool, no sympy), so
# that a scene parses without loading either and cannot disagree with the engines.
from autocable.methods.continuation.settings import ENGINES, INTEGER_STEP_KEYS, STEP_KEYS as _STEP_KEYS
from autocable.model.orderings import ORDERINGS
from autocable.model.premises import MAX_AMPLITUDE, MAX_INTEGRATION_TIME, check_parameters
from autocable.spec import SpecError, finite_number, read_toml, show

__all__ = [
    "Scene",
    "RunSpec",
    "StartSpec",
    "PlotSpec",
    "ChartSpec",
    "CompareSpec",
    "OverlaySpec",
    "TimeSpec",
    "load_scene",
    "parse_scene",
    "read_compare",
    "ENGINES",
    "ORDERINGS",
    "PARAMETERS",
    "PLOT_UNITS",
    "RESOLUTIONS",
]

PARAMETERS = ("sigma", "U", "eta")
_NAME = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_\-]*$")
_LABEL = re.compile(r"^([A-Za-z0-9_\-]+):([A-Z]+[0-9]+)$")
_TOP_KEYS = ("title", "description", "model", "ame", "ame_tol", "ordering", "engine", "state_scale", "fixed", "run",
             "plot", "compare", "overlay", "time", "chart", "units")
_CHART_KEYS = ("plane", "x_range", "y_range", "grid", "t_end", "starts", "map")
_RUN_KEYS = ("name", "kind", "parameter", "range", "start", "at", "directions", "cycles", "switch",
             "fixed", "steps", "parameter2", "range2")
_PLOT_KEYS = ("x", "y", "title", "labels", "plane", "units")
#: `[plot] units`: the axes in the paper's nondimensional quantities or in SI (autocable.plotting.units).
PLOT_UNITS = ("paper", "si")
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
#: State variables of each AME's continuation system: (r1, s1, r2, s2), (r1, s1), (a1) of eq. (23).
_STATE_SIZE = {"2dof": 4, "1dof": 2, "1dof-amplitude": 1}


@dataclass(frozen=True)
class StartSpec:
    """Where a run starts: ``kind`` is "trivial", "integrate" (amplitudes a_k, phases 0), "state"
    (a state vector refined by Newton), "label" (``label`` = "RUN:LABEL"), "orbit" (amplitudes
    a_k, phases 0: the periodic orbit the AME settles on from there, for a cycles run) or "search"
    (``values``: values of the run's parameter; at each, every stable equilibrium that Newton finds
    from a fixed grid of starts off every branch of the scene so far starts a branch: isolas and
    disconnected branches without a start tuned to one model, `autocable.scene.runner.run_search`)."""

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
    units: str = "paper"                        # "paper" (eqs. 17-18, nondimensional) or "si"


@dataclass(frozen=True)
class ChartSpec:
    """A stability chart (``[chart]``): the curve runs drawn in the (x, y) plane over the ranges, the
    AME's response classified on a grid x grid (`autocable.methods.regions`) and its regions
    labelled, and optionally the classes of a brute-force map of eq. (21) (``map``: a sweep.nc)."""
    x: str
    y: str
    x_range: tuple[float, float]
    y_range: tuple[float, float]
    grid: tuple[int, int]
    t_end: float
    starts: tuple[tuple[float, float], ...]
    map: Path | None = None


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
    chart: ChartSpec | None = None     # a stability chart in a parameter plane
    units: str = "paper"               # the file's inputs: "paper" (U*, eta*, sigma) or "si" (converted here)


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
    return finite_number(value, path, where, what)


def _amplitudes(values, path, where) -> None:
    for v in values:
        if abs(v) > MAX_AMPLITUDE:
            raise SpecError(path, where, f"amplitudes must lie in [-{MAX_AMPLITUDE:g}, {MAX_AMPLITUDE:g}] "
                                         f"(fractions of the cable length), got {v!r}")


def _premises(values: Mapping[str, float], path, fields: Mapping[str, str]) -> None:
    """U, eta, sigma against the ranges where eq. (21) applies (`check_parameters`: an error
    outside, a `PremiseWarning` where stretched), each named by its field in the scene."""
    check_parameters(values, str(path), fields)


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
    _premises(out, path, {k: f"{where}.{k}" for k in out})
    return out


def _start(value, path, where) -> StartSpec:
    if value == "trivial":
        return StartSpec("trivial")
    if isinstance(value, str):
        if not _LABEL.match(value):
            raise SpecError(path, where, f'expected "trivial", "RUN:LABEL" (e.g. "I:H1"), '
                                         f'{{integrate = [a1, a2]}}, {{state = [...]}}, {{orbit = [a1, a2]}} or '
                                         f'{{search = [values]}}, got {value!r}')
        return StartSpec("label", label=value)
    if isinstance(value, dict):
        _check_keys(value, ("integrate", "state", "orbit", "search"), path, where)
        if len(value) != 1:
            raise SpecError(path, where, "give exactly one of integrate = [a1, a2], state = [r1, s1, ...], "
                                         "orbit = [a1, a2] or search = [values of the parameter]")
        (kind, vals), = value.items()
        if not isinstance(vals, list) or not vals:
            raise SpecError(path, f"{where}.{kind}", f"expected a list of numbers, got {vals!r}")
        nums = tuple(_num(v, path, f"{where}.{kind}") for v in vals)
        if kind == "search":
            return StartSpec(kind, nums)      # checked against the run's range by the run's parser
        if kind in ("integrate", "orbit") and any(v < 0 for v in nums):
            raise SpecError(path, f"{where}.{kind}", "amplitudes must be >= 0")
        _amplitudes(nums, path, f"{where}.{kind}")
        return StartSpec(kind, nums)
    raise SpecError(path, where, f'expected "trivial", "RUN:LABEL", {{integrate = [...]}}, '
                                 f'{{state = [...]}}, {{orbit = [...]}} or {{search = [...]}}, got {value!r}')


#: The accepted values of the step controls (lo, hi, what). Steps are in chart units (the range
#: spans 1, the state is over state_scale; a cycle branch may take steps of a few units); a tolerance below 1e-14 cannot be met in double
#: precision (tol = 1e-300 gave a one-point branch) and one above 1e-2 accepts anything; counts
#: are bounded so that a typo cannot ask for a run of days. ``max_points`` is checked between
#: chunks of ``chunk`` points, so it cannot be smaller than ``chunk``.
_STEP_BOUNDS = {
    **{k: (0.0, 10.0, "a step in chart units (the range spans 1), in (0, 10]")
       for k in ("step", "min_step", "max_step", "cycle_step", "cycle_max_step", "switch_step", "curve_step",
                 "curve_max_step")},
    **{k: (1e-14, 1e-2, "a tolerance from 1e-14 to 1e-2") for k in ("tol", "test_tol", "newton_tol",
                                                                      "curve_check_tol")},
    "max_period_ratio": (1.0, 1e4, "a period ratio above 1 and at most 1e4"),
    "max_points": (None, 1_000_000, "points per direction"),
    "chunk": (1, 1000, "points per PyCont call"),
    "cycle_max_points": (2, 100_000, "cycles per branch"),
    "curve_max_points": (2, 100_000, "points per curve direction"),
    "ntst": (4, 1000, "collocation intervals"),
    "ncol": (2, 7, "collocation points per interval"),
    "max_corrector_iters": (1, 100, "corrector iterations"),
    # budgets of the settling integration and the orbit search (a long computation stops with a message)
    "settle_seconds": (0.0, 86400.0, "a wall-time budget in seconds, in (0, 86400]"),
    "settle_evaluations": (1, 1e10, "a budget of right-hand side evaluations, from 1 to 1e10"),
    "orbit_seconds": (0.0, 86400.0, "a wall-time budget in seconds, in (0, 86400]"),
}


def _steps(table, path, where) -> dict[str, float]:
    from autocable.methods.continuation.settings import ContinuationSettings
    _check_keys(table, _STEP_KEYS, path, where)
    ints = set(INTEGER_STEP_KEYS)
    chunk = table.get("chunk", ContinuationSettings.chunk)
    out: dict[str, Any] = {}
    for k, v in table.items():
        lo, hi, what = _STEP_BOUNDS[k]
        if k in ints:
            lo = chunk if k == "max_points" and isinstance(chunk, int) and not isinstance(chunk, bool) else lo
            rule = f"a whole number from {lo} to {hi} ({what}" + \
                   (", at least steps.chunk: the budget is checked between chunks)" if k == "max_points" else ")")
            if isinstance(v, bool) or not isinstance(v, int) or not lo <= v <= hi:
                raise SpecError(path, f"{where}.{k}", f"expected {rule}, got {show(v)}")
            out[k] = v
            continue
        x = _num(v, path, f"{where}.{k}", what)
        inside = lo < x <= hi if lo == 0.0 or k == "max_period_ratio" else lo <= x <= hi
        if not inside:
            raise SpecError(path, f"{where}.{k}", f"expected {what}, got {x!r}")
        out[k] = x
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
    if not data["model"] or any(ord(c) < 32 for c in data["model"]):
        raise SpecError(path, "model", f"expected a file path without control characters, got {show(data['model'])}")
    model = (path.parent / data["model"]).resolve()
    if not model.is_file():
        what = "not a regular file (a directory, FIFO or device)" if model.exists() else "no such file"
        raise SpecError(path, "model", f"{what}: {model}")
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
    units = data.get("units", "paper")
    if units not in PLOT_UNITS:
        raise SpecError(path, "units", f"the units of the file's inputs: expected "
                                       f"{' or '.join(repr(u) for u in PLOT_UNITS)}, got {show(units)}")
    if units == "si":
        data = si_inputs(data, path, model)
    fixed = _params(data.get("fixed", {}), path, "fixed")
    if "time" in data:
        return replace(_time_scene(data, path, text, model, ame, scale), ordering=ordering, units=units)
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
        _premises({parameter: lo}, path, {parameter: f"{where}.range"})
        _premises({parameter: hi}, path, {parameter: f"{where}.range"})
        start = _start(r.get("start", "trivial"), path, f"{where}.start")
        if start.kind == "state" and ame in _STATE_SIZE and len(start.values) != _STATE_SIZE[ame]:
            raise SpecError(path, f"{where}.start.state", f'ame = "{ame}" has {_STATE_SIZE[ame]} state '
                                                          f"variables, got {len(start.values)} numbers")
        if start.kind == "search":
            if kind != "equilibria":
                raise SpecError(path, f"{where}.start", '{ search = [...] } starts an "equilibria" run')
            if ame == "1dof-amplitude":
                raise SpecError(path, f"{where}.start", '{ search = [...] } needs the Cartesian AME: use ame = '
                                                        '"2dof" or "1dof" (or give a { state = [...] } start)')
            if "at" in r:
                raise SpecError(path, f"{where}.at", "not allowed with start = { search = [...] }: the "
                                                     "search values say where the run may start")
            for v in start.values:
                if not lo <= v <= hi:
                    raise SpecError(path, f"{where}.start.search", f"{parameter} = {v:g} is outside the run's "
                                                                   f"range [{lo:g}, {hi:g}]")
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
            if not (start.kind == "label" and re.search(r":(LP|H|BP)[0-9]+$", start.label)):
                raise SpecError(path, f"{where}.start", 'a "curve" run starts from a fold, a Hopf point or a '
                                                        'branch point, e.g. "I:LP1", "I:H1" or "I:BP1"')
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
            _premises({parameter2: lo2}, path, {parameter2: f"{where}.range2"})
            _premises({parameter2: hi2}, path, {parameter2: f"{where}.range2"})
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
        run_fixed = _params(r.get("fixed", {}), path, f"{where}.fixed")
        for p in (parameter, parameter2):
            if p in run_fixed:
                raise SpecError(path, f"{where}.fixed.{p}", f"{p} is continued by this run (over its range), so a "
                                                            f"fixed value would be ignored; remove it")
        runs.append(RunSpec(
            name=name, kind=kind, parameter=parameter, range=(lo, hi), start=start, at=at,
            directions=directions, cycles=_bool(r.get("cycles", False), path, f"{where}.cycles"),
            switch=_bool(r.get("switch", False), path, f"{where}.switch"),
            fixed=run_fixed,
            steps=_steps(r.get("steps", {}), path, f"{where}.steps"), index=i,
            parameter2=parameter2, range2=range2))
    for p in fixed:
        # A run from a labelled point takes its values from that point; any other run uses [fixed]
        # unless it continues the parameter. A value no run uses is a mistake, not a default.
        if not any(r.start.kind != "label" and p not in (r.parameter, r.parameter2) for r in runs):
            raise SpecError(path, f"fixed.{p}", f"{p} is continued by every run that starts from [fixed] "
                                                f"(each over its range), so this value would be ignored; remove it")
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
    plot_units = _plot_units(plot, path)
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
            what = "not a regular file (a directory, FIFO or device)" if csv_path.exists() else "no such file"
            raise SpecError(path, "compare.csv", f"{what}: {csv_path}")
        panel = c.get("panel", y[0])
        if panel not in y:
            raise SpecError(path, "compare.panel", f"expected one of the plotted amplitudes {y}, got {panel!r}")
        compare = CompareSpec(csv_path, panel, str(c.get("label", "digitised")))
    overlay = _overlay(data["overlay"], path, x, runs) if "overlay" in data else None
    chart = _chart(data["chart"], path, plane, runs, fixed) if "chart" in data else None
    return Scene(path=path, name=path.stem, title=title, description=data.get("description", ""),
                 model=model, ame=ame, state_scale=scale, fixed=fixed, runs=tuple(runs),
                 plot=PlotSpec(x, tuple(y), ptitle, labels, plane, plot_units), compare=compare, text=text,
                 overlay=overlay, engine=engine, ame_tol=float(ame_tol), ordering=ordering, chart=chart,
                 units=units)


def _pair(table, key, path, where, default):
    value = table.get(key, list(default) if default else None)
    if not (isinstance(value, list) and len(value) == 2):
        raise SpecError(path, where, f"expected [lo, hi], got {value!r}")
    lo, hi = (_num(v, path, where) for v in value)
    if not lo < hi:
        raise SpecError(path, where, f"expected lo < hi, got [{lo}, {hi}]")
    return lo, hi


def _chart(table, path: Path, plane, runs, fixed) -> ChartSpec:
    """The [chart] table: the plane, its extent, the classification grid, an optional map."""
    if not isinstance(table, dict):
        raise SpecError(path, "chart", "expected a table")
    _check_keys(table, _CHART_KEYS, path, "chart")
    axes = table.get("plane", list(plane) if plane else None)
    if not (isinstance(axes, list) and len(axes) == 2 and all(v in PARAMETERS for v in axes) and axes[0] != axes[1]):
        raise SpecError(path, "chart.plane", f"expected two different parameters of {', '.join(PARAMETERS)}, "
                                             f"got {axes!r}")
    x, y = axes

    def span(name):
        found = [r.range for r in runs if r.kind == "curve" and r.parameter == name] + \
                [r.range2 for r in runs if r.kind == "curve" and r.parameter2 == name]
        return (min(f[0] for f in found), max(f[1] for f in found)) if found else None
    xr = _pair(table, "x_range", path, "chart.x_range", span(x))
    yr = _pair(table, "y_range", path, "chart.y_range", span(y))
    for name, (lo, _), key in ((x, xr, "x_range"), (y, yr, "y_range")):
        if name == "U" and lo <= 0:
            raise SpecError(path, f"chart.{key}", "U must stay > 0 on the chart (the aerodynamic terms carry 1/U)")
        if name == "eta" and lo < 0:
            raise SpecError(path, f"chart.{key}", "eta must stay >= 0")
    for name, rng, key in ((x, xr, "x_range"), (y, yr, "y_range")):
        for v in rng:
            _premises({name: v}, path, {name: f"chart.{key}"})
    grid = table.get("grid", [20, 16])
    if not (isinstance(grid, list) and len(grid) == 2 and all(isinstance(g, int) and not isinstance(g, bool)
                                                               and 2 <= g <= 400 for g in grid)):
        raise SpecError(path, "chart.grid", f"expected two whole numbers from 2 to 400 (points in x, y), got {grid!r}")
    t_end = _num(table.get("t_end", 30000.0), path, "chart.t_end")
    _duration(t_end, path, "chart.t_end")
    starts = table.get("starts", [[0.0, 1e-6], [5e-3, 1e-6]])
    if not (isinstance(starts, list) and starts and all(isinstance(a, list) and len(a) == 2 for a in starts)):
        raise SpecError(path, "chart.starts", f"expected a list of [a1, a2] pairs, got {starts!r}")
    starts = tuple(tuple(_num(v, path, "chart.starts") for v in a) for a in starts)
    for a in starts:
        _amplitudes(a, path, "chart.starts")
    map_path = None
    if "map" in table:
        if not isinstance(table["map"], str) or not table["map"].strip():
            raise SpecError(path, "chart.map", "expected the path of a sweep.nc (relative to the scene)")
        map_path = (path.parent / table["map"]).resolve()
    return ChartSpec(x, y, xr, yr, (int(grid[0]), int(grid[1])), float(t_end), starts, map_path)


def _duration(value: float, path, field: str) -> None:
    """An integration length: positive and at most `MAX_INTEGRATION_TIME` (every compiled call
    then returns within about a second, and a typo like 1e300 is not a run that never ends)."""
    if not 0 < value <= MAX_INTEGRATION_TIME:
        raise SpecError(path, field, f"expected a time in (0, {MAX_INTEGRATION_TIME:g}] (t* units), got {value!r}")


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
    for v in (lo, hi):
        _premises({parameter: v}, path, {parameter: "overlay.range"})
    points = table.get("points", 11)
    if isinstance(points, bool) or not isinstance(points, int) or not 1 <= points <= 201:
        raise SpecError(path, "overlay.points", f"expected a whole number from 1 to 201, got {points!r}")
    directions = table.get("directions", ["up", "down"])
    if not (isinstance(directions, list) and directions and set(directions) <= {"up", "down"}):
        raise SpecError(path, "overlay.directions", f'expected a list of "up" and/or "down", got {directions!r}')
    max_time = _num(table.get("max_time", 30000.0), path, "overlay.max_time")
    _duration(max_time, path, "overlay.max_time")
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
    _duration(t_end, path, "time.t_end")
    start = t.get("start", "rest")
    if start == "rest":
        start = None
    elif isinstance(start, dict) and set(start) == {"amplitudes"} and isinstance(start["amplitudes"], list) \
            and len(start["amplitudes"]) == 2:
        start = tuple(_num(v, path, "time.start.amplitudes") for v in start["amplitudes"])
        if min(start) < 0:
            raise SpecError(path, "time.start.amplitudes", "amplitudes must be >= 0")
        _amplitudes(start, path, "time.start.amplitudes")
    else:
        raise SpecError(path, "time.start", f'expected "rest" or {{amplitudes = [a1, a2]}}, got {start!r}')
    summary_from = _num(t.get("summary_from", t_end / 2), path, "time.summary_from")
    if not 0 <= summary_from < t_end:
        raise SpecError(path, "time.summary_from", f"expected a time in [0, t_end = {t_end:g}), got {summary_from!r}")
    spp = t.get("samples_per_period", 2)
    if isinstance(spp, bool) or not isinstance(spp, int) or not 1 <= spp <= 64:
        raise SpecError(path, "time.samples_per_period", f"expected a whole number from 1 to 64, got {spp!r}")
    plot = data.get("plot", {})
    _check_keys(plot, ("title", "y", "units"), path, "plot")
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
                 plot=PlotSpec("t", tuple(y), ptitle, False, units=_plot_units(plot, path)), text=text, time=spec)


def _plot_units(plot: Mapping, path) -> str:
    units = plot.get("units", "paper")      # an SI scene's [plot] defaults to "si" (`si_inputs`)
    if units not in PLOT_UNITS:
        raise SpecError(path, "plot.units", f"expected {' or '.join(repr(u) for u in PLOT_UNITS)}, got {show(units)}")
    return units


def si_inputs(data: Mapping, path, model: Path) -> dict:
    """A scene document with ``units = "si"`` in the paper's quantities (eqs. 17-18,
    `autocable.model.units`): every U [m/s] -> U* = U/U_c, eta [m] -> eta* = eta/l, and sigma,
    given as the deck (support) frequency f [Hz], -> sigma = 2 pi f/omega - omega1, on the cable of
    ``model`` (its statics and `autocable.model.mode_pairs.pair_info`; no derivation). The fields: ``[fixed]``, each run's ``range``, ``at``,
    ``range2``, ``[run.fixed]`` and ``start.search`` values, ``[overlay] range``, ``[chart]
    x_range, y_range`` and ``[time]`` U, eta, sigma. A value outside eq. (21)'s premises is refused
    naming its field, with the range in SI; a value that is not a number is left for the
    schema to refuse. ``[plot] units`` defaults to "si"."""
    import copy

    from autocable.model.mode_pairs import pair_info
    from autocable.model.premises import parameter_from_si
    from autocable.model.statics import cable_statics
    from autocable.model.units import units_of
    from autocable.spec import load_model
    # the cable's scales and its pair's in-plane frequency (the ode's omega1) without deriving eq. (21)
    spec = load_model(model)
    st = cable_statics(spec.cable)
    units, omega1 = units_of(spec, st), pair_info(st, spec.cable.mode_pair).in_plane.omega
    out = copy.deepcopy(dict(data))

    def one(name, value, field):
        if name not in PARAMETERS or isinstance(value, bool) or not isinstance(value, (int, float)):
            return value
        return parameter_from_si(str(path), name, value, units, omega1, field)

    def many(name, values, field):
        if not isinstance(values, list):
            return values
        return [one(name, v, f"{field}[{k}]") for k, v in enumerate(values)]

    def params(table, where):
        if isinstance(table, dict):
            for k in list(table):
                table[k] = one(k, table[k], f"{where}.{k}")

    params(out.get("fixed"), "fixed")
    params(out.get("time"), "time")
    runs = out.get("run") if isinstance(out.get("run"), list) else []
    for i, r in enumerate(runs):
        if not isinstance(r, dict):
            continue
        where, p, p2 = f"run[{i}]", r.get("parameter"), r.get("parameter2")
        if "range" in r:
            r["range"] = many(p, r["range"], f"{where}.range")
        if "at" in r:
            r["at"] = one(p, r["at"], f"{where}.at")
        if "range2" in r:
            r["range2"] = many(p2, r["range2"], f"{where}.range2")
        params(r.get("fixed"), f"{where}.fixed")
        start = r.get("start")
        if isinstance(start, dict) and "search" in start:
            start["search"] = many(p, start["search"], f"{where}.start.search")
    plot = out.get("plot") if isinstance(out.get("plot"), dict) else None
    overlay = out.get("overlay")
    if isinstance(overlay, dict) and "range" in overlay:
        x = overlay.get("parameter") or (plot or {}).get("x") or next(
            (r.get("parameter") for r in runs if isinstance(r, dict)), None)
        overlay["range"] = many(x, overlay["range"], "overlay.range")
    chart = out.get("chart")
    if isinstance(chart, dict):
        plane = chart.get("plane") or (plot or {}).get("plane") or next(
            ([r.get("parameter"), r.get("parameter2")] for r in runs if isinstance(r, dict)
             and r.get("kind") == "curve"), None)
        for k, key in enumerate(("x_range", "y_range")):
            if key in chart and isinstance(plane, list) and len(plane) == 2:
                chart[key] = many(plane[k], chart[key], f"chart.{key}")
    if "plot" not in out:
        out["plot"] = {}
    if isinstance(out["plot"], dict):
        out["plot"].setdefault("units", "si")
    return out


def load_scene(path: str | Path) -> Scene:
    """Read and validate a scene file; errors are one-line `SpecError`s."""
    path = Path(path)
    data, text = read_toml(path)
    return parse_scene(data, path, text)


def read_compare(spec: CompareSpec) -> list[dict]:
    """The digitised points of ``spec.csv``: dicts with x, y (floats), curve (str), stable (bool)."""
    import csv
    rows = []
    try:
        with open(spec.csv, newline="", encoding="utf-8") as fh:
            reader = csv.DictReader(fh)
            missing = {"x", "y"} - set(reader.fieldnames or ())
            if missing:
                raise SpecError(spec.csv, "", f"missing columns {sorted(missing)}; expected x, y, curve, stable")
            for k, r in enumerate(reader):
                try:
                    x, y = float(r["x"]), float(r["y"])
                except (TypeError, ValueError):
                    raise SpecError(spec.csv, f"row {k + 2}", "x and y must be numbers") from None
                if not (math.isfinite(x) and math.isfinite(y)):
                    raise SpecError(spec.csv, f"row {k + 2}", f"x and y must be finite numbers, got {x}, {y}")
                rows.append({"x": x, "y": y, "curve": r.get("curve", "") or "",
                             "stable": str(r.get("stable", "1")).strip().lower() in ("1", "true", "yes", "s")})
    except UnicodeDecodeError as exc:
        raise SpecError(spec.csv, "", f"not UTF-8 text (byte {exc.start}); write the CSV as UTF-8") from None
    except OSError as exc:
        raise SpecError(spec.csv, "", f"cannot read: {exc.strerror}") from None
    return rows


