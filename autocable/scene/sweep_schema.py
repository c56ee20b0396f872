"""Sweep files: a grid of parameter points of eq. (21) (or its AME) as data.

    title = "Fig. 5a, brute force"            # optional text
    model = "../models/luongo_zulli_2012.toml" # relative to the sweep file, or absolute
    method = "shooting"                       # "ode21" (transient integration of eq. 21), "shooting"
                                              # (eq. 21 by Newton on the period map), "ame" (the
                                              # Cartesian AME (24) integrated to its steady state)
    q0 = [0.0, 0.0, 1e-6, 0.0]                # optional start (q1, q1', q2, q2'); default rest + q2 seed
    max_time = 60000.0                        # optional: give up on a point after this time (t*)
    follow = "sigma"                          # optional: along this axis each point starts from
    direction = "up"                          # its neighbour's response (the previous point in the
                                              # axis order, "up", or in reverse, "down"): a sweep up
                                              # or down as with a slowly changed parameter
                                              # (shooting: Newton from the neighbour's orbit first;
                                              # ode21: integration from its end state plus q0)
    [grid]
    U = 0.0                                   # a number, a list, or { from = .., to = .., num = .. }
    eta = 8.2e-5
    sigma = { from = -0.05, to = 0.05, num = 21 }
    start = [[0.0, 0.0, 1e-6, 0.0], [0.004, 0.0, 0.004, 0.0]]   # optional: starts as a grid axis

Every axis of ``[grid]`` is optional (default: the single value 0, and one start, ``q0``). The
schema is closed: an unknown key or a bad value raises `autocable.spec.SpecError`, one line naming
the file and the field. Parsing only: the runner is `autocable.studies.sweep`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from autocable.model.premises import MAX_AMPLITUDE, MAX_INTEGRATION_TIME, check_parameters
from autocable.spec import SpecError, finite_number, read_toml, show

#: The methods a sweep can use at every point.
SWEEP_METHODS = ("ode21", "shooting", "ame")
#: The parameter axes, in the order of the dataset's dimensions.
AXES = ("U", "eta", "sigma")
#: The default start, rest with a tiny out-of-plane seed (`ode21.DEFAULT_Q0`, repeated here so the
#: schema stays light; tests/test_sweep.py checks they agree).
DEFAULT_Q0 = (0.0, 0.0, 1e-6, 0.0)
#: A grid larger than this is almost certainly a typo in ``num``: planning a million points takes
#: about 15 s and 0.7 GB (a key hashed per point), and computing them days of CPU; ten million
#: would not fit in memory. Checked from the ``num``s and list lengths before any axis is built.
MAX_POINTS = 1_000_000

_TOP_KEYS = {"title", "model", "method", "q0", "max_time", "grid", "follow", "direction"}
DIRECTIONS = ("up", "down")
_GRID_KEYS = set(AXES) | {"start"}


@dataclass(frozen=True)
class SweepSpec:
    """A parsed sweep file."""

    path: Path
    title: str
    model: Path
    method: str
    U: tuple
    eta: tuple
    sigma: tuple
    starts: tuple               # tuples (q1, q1', q2, q2')
    start_axis: bool            # True when [grid] start was given (the dataset gets a `start` dim)
    max_time: float
    text: str                   # the file as read (provenance)
    follow: str | None = None   # an axis of AXES: points along it start from their neighbour
    direction: str = "up"       # "up": in the axis order; "down": reversed

    @property
    def shape(self) -> tuple:
        return (len(self.U), len(self.eta), len(self.sigma)) + ((len(self.starts),) if self.start_axis else ())

    @property
    def size(self) -> int:
        return math.prod(self.shape)

    def lines(self):
        """With ``follow``: the grid's lines along that axis, each a list of index tuples in sweep
        order (``direction``); without: one line per point."""
        from itertools import product
        if self.follow is None:
            return [[idx] for idx in product(*(range(n) for n in self.shape))]
        ax = AXES.index(self.follow)
        others = [range(n) if k != ax else range(1) for k, n in enumerate(self.shape)]
        order = list(range(self.shape[ax]))
        if self.direction == "down":
            order.reverse()
        out = []
        for base in product(*others):
            out.append([tuple(i if k == ax else b for k, b in enumerate(base)) for i in order])
        return out

    def point(self, idx) -> tuple:
        """(U, eta, sigma, q0) at an index tuple."""
        q0 = self.starts[idx[3]] if self.start_axis else self.starts[0]
        return self.U[idx[0]], self.eta[idx[1]], self.sigma[idx[2]], q0

    def points_order(self):
        """The index tuples in C order (the dataset's)."""
        from itertools import product
        return product(*(range(n) for n in self.shape))

    def points(self):
        """(index tuple, U, eta, sigma, q0) for every grid point, C order."""
        from itertools import product
        for idx in product(*(range(n) for n in self.shape)):
            q0 = self.starts[idx[3]] if self.start_axis else self.starts[0]
            yield idx, self.U[idx[0]], self.eta[idx[1]], self.sigma[idx[2]], q0


def _num(value, path, field) -> float:
    return finite_number(value, path, field)


def _count(value, path, name) -> int:
    """How many values the axis will have, read from ``num`` or the list's length without building
    it (a typo like num = 1e7 on three axes is refused before any memory is spent)."""
    if isinstance(value, dict) and "num" in value:
        num = value["num"]
        if isinstance(num, bool) or not isinstance(num, int) or not 1 <= num <= MAX_POINTS:
            raise SpecError(path, f"grid.{name}.num", f"expected a whole number from 1 to {MAX_POINTS:,}, "
                                                      f"got {show(num)}")
        return num
    return len(value) if isinstance(value, list) else 1


def _axis(value, path, name) -> tuple:
    field = f"grid.{name}"
    if isinstance(value, dict):
        extra = set(value) - {"from", "to", "num"}
        missing = {"from", "to", "num"} - set(value)
        if extra or missing:
            raise SpecError(path, field, "a range is { from = .., to = .., num = .. }"
                            + (f"; unknown key(s) {sorted(extra)}" if extra else "")
                            + (f"; missing {sorted(missing)}" if missing else ""))
        lo, hi = _num(value["from"], path, f"{field}.from"), _num(value["to"], path, f"{field}.to")
        num = value["num"]
        if isinstance(num, bool) or not isinstance(num, int) or not 1 <= num <= MAX_POINTS:
            raise SpecError(path, f"{field}.num", f"expected a whole number from 1 to {MAX_POINTS:,}, got {show(num)}")
        if num == 1:
            vals = (lo,)
        else:
            vals = tuple(lo + (hi - lo) * k / (num - 1) for k in range(num))
    elif isinstance(value, list):
        if not value:
            raise SpecError(path, field, "an empty list: give at least one value")
        vals = tuple(_num(v, path, f"{field}[{k}]") for k, v in enumerate(value))
    else:
        vals = (_num(value, path, field),)
    if len(set(vals)) != len(vals):
        raise SpecError(path, field, "repeated values: each grid value must appear once")
    if name in ("U", "eta") and min(vals) < 0:
        raise SpecError(path, field, f"{name} must be >= 0, got {min(vals)!r}")
    for v in (min(vals), max(vals)):     # the ranges where eq. (21) applies (error or warning)
        check_parameters({name: v}, str(path), {name: field})
    return vals


def _start(value, path, field) -> tuple:
    if not isinstance(value, list) or len(value) != 4:
        raise SpecError(path, field, f"a start is [q1, q1dot, q2, q2dot] (four numbers), got {show(value)}")
    out = tuple(_num(v, path, f"{field}[{k}]") for k, v in enumerate(value))
    for k, v in enumerate(out):
        if abs(v) > MAX_AMPLITUDE:
            raise SpecError(path, f"{field}[{k}]", f"expected a value in [-{MAX_AMPLITUDE:g}, {MAX_AMPLITUDE:g}] (eq. 21's "
                                                   f"coordinates are fractions of the cable length), got {v!r}")
    return out


def parse_sweep(data: dict, path, text: str = "") -> SweepSpec:
    """Validate the TOML table of a sweep file (see the module docstring)."""
    path = Path(path)
    unknown = set(data) - _TOP_KEYS
    if unknown:
        raise SpecError(path, sorted(unknown)[0], f"unknown key; a sweep file has {sorted(_TOP_KEYS)}")
    if "model" not in data:
        raise SpecError(path, "model", "missing: the model file (relative to the sweep file, or absolute)")
    if not isinstance(data["model"], str) or not data["model"].strip():
        raise SpecError(path, "model", f"expected a path, got {data['model']!r}")
    model = Path(data["model"]).expanduser()
    if not model.is_absolute():
        model = (path.parent / model).resolve()
    if not model.is_file():
        what = "not a regular file (a directory, FIFO or device)" if model.exists() else "no such file"
        raise SpecError(path, "model", f"{what} {str(model)!r} (relative paths start at the sweep file)")
    method = data.get("method", "shooting")
    if method not in SWEEP_METHODS:
        raise SpecError(path, "method", f"expected one of {', '.join(repr(m) for m in SWEEP_METHODS)}, got {method!r}")
    title = data.get("title", path.stem)
    if not isinstance(title, str):
        raise SpecError(path, "title", f"expected text, got {title!r}")
    max_time = _num(data.get("max_time", 60000.0), path, "max_time")
    if not 0 < max_time <= MAX_INTEGRATION_TIME:
        raise SpecError(path, "max_time", f"expected a time in (0, {MAX_INTEGRATION_TIME:g}] (t* units), "
                                          f"got {max_time!r}")
    q0 = _start(data["q0"], path, "q0") if "q0" in data else DEFAULT_Q0
    grid = data.get("grid", {})
    if not isinstance(grid, dict):
        raise SpecError(path, "grid", "expected a table [grid] with U, eta, sigma (and start)")
    unknown = set(grid) - _GRID_KEYS
    if unknown:
        raise SpecError(path, f"grid.{sorted(unknown)[0]}", f"unknown axis; the axes are {', '.join(AXES)} "
                        "and start")
    counts = [_count(grid.get(name, 0.0), path, name) for name in AXES]
    if isinstance(grid.get("start"), list):
        counts.append(len(grid["start"]))
    if math.prod(counts) > MAX_POINTS:
        raise SpecError(path, "grid", f"{math.prod(counts):,} points is more than {MAX_POINTS:,}; check num")
    axes = {name: _axis(grid.get(name, 0.0), path, name) for name in AXES}
    start_axis = "start" in grid
    if start_axis:
        if "q0" in data:
            raise SpecError(path, "grid.start", "give either q0 (one start) or grid.start (a list), not both")
        if not isinstance(grid["start"], list) or not grid["start"]:
            raise SpecError(path, "grid.start", "expected a list of starts [[q1, q1dot, q2, q2dot], ...]")
        starts = tuple(_start(v, path, f"grid.start[{k}]") for k, v in enumerate(grid["start"]))
    else:
        starts = (q0,)
    follow = data.get("follow")
    if follow is not None and follow not in AXES:
        raise SpecError(path, "follow", f"expected one of {', '.join(repr(a) for a in AXES)}, got {follow!r}")
    if follow is not None and method == "ame":
        raise SpecError(path, "follow", 'following a neighbour needs method = "shooting" or "ode21"')
    direction = data.get("direction", "up")
    if direction not in DIRECTIONS:
        raise SpecError(path, "direction", f"expected \"up\" or \"down\", got {direction!r}")
    if "direction" in data and follow is None:
        raise SpecError(path, "direction", "only with follow (the axis swept up or down)")
    # At least one forcing period at every point (omega1 >= 1 in t* units, so 2 pi/(1 + sigma) is
    # the longest period): a shorter run integrates nothing and would pass an empty window for a result.
    longest = 2 * math.pi / (1 + min(axes["sigma"]))
    if max_time < longest:
        raise SpecError(path, "max_time", f"expected at least one forcing period, 2 pi/(1 + sigma) = {longest:.4g} "
                                          f"at sigma = {min(axes['sigma']):g}, got {max_time!r}")
    spec = SweepSpec(path=path, title=title, model=model, method=method, starts=starts,
                     start_axis=start_axis, max_time=max_time, text=text, follow=follow,
                     direction=direction, **axes)
    if spec.size > MAX_POINTS:
        raise SpecError(path, "grid", f"{spec.size:,} points is more than {MAX_POINTS:,}; check num")
    return spec


def load_sweep(path) -> SweepSpec:
    """Read and validate a sweep file; errors are one-line `SpecError`s."""
    path = Path(path)
    data, text = read_toml(path)
    return parse_sweep(data, path, text)
