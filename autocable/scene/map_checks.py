"""A brute-force map (`autocable chart --map`, a chart's ``map``) checked against the chart it is
drawn on, before anything is computed.

`autocable.plotting.chart.read_response_map` reads any map in the documented format; a map that
reads is not yet a map *of this chart*. Its agreement score is meaningful only when

* the file is a readable netCDF file (not a text file, not a truncated one);
* its ``response`` holds class names or integer codes whose names are classes of eq. (21)
  (float codes are not classes: a code 1.5 has no name);
* it was computed for the chart's model (``model_hash``, which `autocable sweep` writes, equal to
  the scene's model's content hash when the map has one);
* it holds the chart's third parameter at the chart's value (a dimension or a one-valued
  coordinate or attribute within `THIRD_TOLERANCE` of the parameter's range);
* some of its points lie in the chart's ranges (the points outside are left out and counted).

Each failure is a one-line `SpecError` ``--map FILE: field: what is wrong`` (or ``SCENE: chart.map
FILE: ...`` for a scene's own map).
"""
from __future__ import annotations

from pathlib import Path
from typing import Mapping

import numpy as np

from autocable.model.premises import PARAMETER_RANGES
from autocable.spec import SpecError

__all__ = ["check_map", "THIRD_TOLERANCE"]

#: How far (a fraction of the parameter's accepted range, `PARAMETER_RANGES`) the map's value of
#: the chart's third parameter may lie from the chart's: round-off of the values written, no more.
THIRD_TOLERANCE = 1e-6


def _refuse(where: str, path: Path, field: str, message: str) -> SpecError:
    """The error naming the option or scene field (``where``), the map file and the map's field:
    ``--map FILE: field: message``."""
    return SpecError(f"{where} {path}", field, message)


def _open(path: Path, where: str):
    import xarray as xr
    try:
        with xr.open_dataset(path) as ds:
            return ds.load()
    except Exception as exc:  # noqa: BLE001 - any backend failure: the file is not a readable map
        first = (str(exc).strip().splitlines() or [type(exc).__name__])[0][:120]
        raise _refuse(where, path, "", f"not a readable netCDF file ({type(exc).__name__}: {first}); give the "
                                   "sweep.nc that `autocable sweep` wrote") from None


def check_map(path, where: tuple, model_hash: str, x: str, y: str, x_range, y_range,
              fixed: Mapping[str, float], read) -> dict:
    """The map at ``path`` read by ``read(path, x, y, third)`` (`read_response_map`), checked
    against the chart (module docstring): the reader's dict with only the points in the chart's
    ranges, and ``outside`` (how many were left out). ``where``: the option or scene field to
    name, e.g. "--map"."""
    from autocable.plotting.chart import MAP_CLASSES

    path = Path(path)
    if not path.is_file():
        raise _refuse(where, path, "", "no such file; give the sweep.nc that `autocable sweep` wrote")
    ds = _open(path, where)
    if "response" in ds.data_vars and ds["response"].dtype.kind == "f":
        raise _refuse(where, path, "response", "float class codes; a map holds integer codes with a legend "
                                   "or the class names")
    theirs = ds.attrs.get("model_hash")
    if theirs is not None and str(theirs) != model_hash:
        raise _refuse(where, path, "model_hash", f"the map was computed for another model ({str(theirs)[:16]}...; "
                                   f"the chart's is {model_hash[:16]}...); sweep the chart's model")
    third = {k: v for k, v in fixed.items() if k not in (x, y)}
    try:
        m = read(path, x, y, third)
    except SpecError as exc:
        text = str(exc).replace(f"{path}: ", "", 1)
        if exc.field and text.startswith(f"{exc.field}: "):
            text = text[len(exc.field) + 2:]
        raise _refuse(where, path, exc.field, text) from None
    except Exception as exc:  # noqa: BLE001 - a map the reader cannot make sense of
        first = (str(exc).strip().splitlines() or [type(exc).__name__])[0][:120]
        raise _refuse(where, path, "", f"cannot be read as a map ({type(exc).__name__}: {first})") from None
    for name, value in third.items():
        if name not in PARAMETER_RANGES:
            continue
        lo, hi = PARAMETER_RANGES[name][:2]
        if name not in m["fixed"]:
            raise _refuse(where, path, name, f"the map does not give its {name} (a dimension, a one-valued "
                                       f"coordinate or an attribute); the chart is at {name} = {value:g}")
        got = m["fixed"][name]
        if not abs(got - value) <= THIRD_TOLERANCE * (hi - lo):
            raise _refuse(where, path, name, f"the map's nearest {name} is {got:g}, the chart is at {name} = "
                                       f"{value:g}; sweep at the chart's {name}")
    for cls in m["response"]:
        unknown = [c for c in cls.split(" + ") if c not in MAP_CLASSES]
        if unknown:
            raise _refuse(where, path, "response", f"class {unknown[0]!r} is not one of {', '.join(MAP_CLASSES)}")
    xs, ys = np.asarray(m["x"], float), np.asarray(m["y"], float)

    def inside(v, rng, name):
        lo, hi = PARAMETER_RANGES[name][:2] if name in PARAMETER_RANGES else (0.0, 0.0)
        slack = THIRD_TOLERANCE * (hi - lo)
        return (v >= min(rng) - slack) & (v <= max(rng) + slack)

    keep = inside(xs, x_range, x) & inside(ys, y_range, y)
    if len(xs) and not keep.any():
        raise _refuse(where, path, "", f"no point of the map lies on the chart ({x} in [{min(x_range):g}, "
                                   f"{max(x_range):g}], {y} in [{min(y_range):g}, {max(y_range):g}]; the map "
                                   f"spans {x} in [{xs.min():g}, {xs.max():g}], {y} in [{ys.min():g}, {ys.max():g}])")
    return dict(m, x=xs[keep], y=ys[keep], response=[r for r, k in zip(m["response"], keep) if k],
                outside=int((~keep).sum()))
