"""Stability charts: the fold (LP), Hopf (H) and pitchfork (BP) curves of the AME (24) in a parameter
plane, the regions of the AME's response labelled where they lie, and the classes of a brute-force
map of eq. (21) (`autocable sweep`'s ``sweep.nc``) as markers, so that a reader sees where the AME's
chart and eq. (21) agree. Reads results only.

The map's format (``sweep.nc``, xarray/NetCDF): dimensions and coordinates named ``U``, ``eta``,
``sigma`` (any of them; a dimension of length one is a fixed value), and a data variable
``response`` holding either the class names (``rest``, ``period-1``, ``period-2``,
``quasi-periodic``, ``diverged``) or integer codes with their names in an attribute: ``legend``
(a list of names indexed by code, a JSON object {code: name}, or the text "0: rest, 1: period-1,
...") or the CF pair ``flag_values``/``flag_meanings`` (preferred when both are there; CF's
underscores read as hyphens, ``period_1`` is ``period-1``; ``not_computed`` points are left out).
Other dimensions (e.g. ``start``: several starts per point) are folded: a point's classes are joined
with " + ". With a data variable ``bimodal`` (same dimensions; 1: a2 not slaved to a1, decided by
structure when the sweep ran, `autocable.studies.sweep.bimodal_flag`) a period-1 point so flagged is
``period-1 bi-modal``, the class the AME's bi-modal regions predict. A map without it (older sweeps)
draws every period-1 point as ``period-1``: a threshold on a2 / a1 would call the forced response of
a coupled cable bi-modal."""
from __future__ import annotations

import json
import math
import re
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np

from autocable.plotting.style import new_figure, save_figure, styled
from autocable.plotting.units import axis_scale
from autocable.results import CURVE_KINDS
from autocable.spec import SpecError

__all__ = ["read_response_map", "plot_chart", "MAP_CLASSES", "AME_TO_MAP"]

#: The classes of eq. (21)'s steady responses in a sweep; "period-1 bi-modal" is a period-1 point
#: whose a2 is not slaved to a1 (the map's ``bimodal`` variable, decided by structure when the sweep
#: ran: `autocable.studies.sweep.bimodal_flag`), as the AME's regions say it.
MAP_CLASSES = ("rest", "period-1", "period-1 bi-modal", "period-2", "autonomous-periodic", "quasi-periodic",
               "diverged")
#: What eq. (21) should show where the AME settles on each kind of attractor (the AME's equilibria
#: are period-1 motions of eq. (21), its cycles quasi-periodic ones; the small forced response is
#: period-1, or rest when eta = 0; galloping at eta = 0 is a cycle of the autonomous eq. (21) with
#: its own period, and unlocked from the support at eta > 0 a quasi-periodic motion).
AME_TO_MAP = {"small": ("rest", "period-1"), "mono-modal": ("period-1",), "bi-modal": ("period-1 bi-modal",),
              "galloping": ("autonomous-periodic", "quasi-periodic"), "modulated": ("quasi-periodic",),
              "diverged": ("diverged",)}

_MAP_STYLE = {"rest": dict(marker="o", mfc="white", mec="0.35", ms=3.5),
              "period-1": dict(marker="o", mfc="black", mec="black", ms=3.5),
              "period-1 bi-modal": dict(marker="o", mfc="tab:green", mec="darkgreen", ms=4),
              "period-2": dict(marker="s", mfc="tab:purple", mec="tab:purple", ms=3.5),
              "autonomous-periodic": dict(marker="o", mfc="tab:purple", mec="indigo", ms=4),
              "quasi-periodic": dict(marker="^", mfc="tab:orange", mec="tab:orange", ms=4),
              "diverged": dict(marker="x", mfc="none", mec="tab:red", ms=4)}
_REGION_COLORS = {"small": "#e8f1fa", "mono-modal": "#cfe3c4", "bi-modal": "#f6d7a8",
                  "galloping": "#d9c8ec", "modulated": "#f3c2c2", "diverged": "#bdbdbd"}
_CURVE_STYLE = {"fold": dict(color="black", ls="-", label="folds (LP)"),
                "hopf": dict(color="tab:blue", ls="-", label="Hopf points (H)"),
                "branch_point": dict(color="tab:green", ls="-.", label="pitchforks (BP)")}
_CODIM2 = {"CP": "^", "BT": "D", "GH": "v", "ZH": "P", "DH": "X", "LP": "o"}


def _legend_map(attrs: Mapping) -> dict[int, str]:
    if "flag_values" in attrs and "flag_meanings" in attrs:
        values = np.atleast_1d(attrs["flag_values"]).tolist()
        names = str(attrs["flag_meanings"]).split()
        return {int(v): n for v, n in zip(values, names)}
    legend = attrs.get("legend")
    if legend is None:
        return {}
    if isinstance(legend, (list, tuple, np.ndarray)):
        return {i: str(n) for i, n in enumerate(np.atleast_1d(legend).tolist())}
    text = str(legend).strip()
    try:
        data = json.loads(text)
    except ValueError:
        data = None
    if isinstance(data, dict):
        return {int(k): str(v) for k, v in data.items()}
    if isinstance(data, list):
        return {i: str(n) for i, n in enumerate(data)}
    return {int(k): v.strip() for k, v in re.findall(r"(-?\d+)\s*[:=]\s*([^,;]+)", text)}


def read_response_map(path: str | Path, x: str, y: str, fixed: Mapping[str, float]) -> dict:
    """The classes of a brute-force map (module docstring) in the (x, y) plane at the chart's
    ``fixed`` value of the third parameter (the nearest one the map has).

    Returns {"x": array, "y": array, "response": list of class names, "fixed": {name: value used},
    "requested": {name: value asked}}. Raises `SpecError` naming the file for a map that lacks the
    axes or the variable, or whose integer codes have no legend."""
    import xarray as xr

    path = Path(path)
    if not path.is_file():
        raise SpecError(path, "", "no such file; give the sweep.nc that `autocable sweep` wrote")
    with xr.open_dataset(path) as ds:
        ds = ds.load()
    if "response" not in ds.data_vars:
        raise SpecError(path, "response", f"missing; the map needs a data variable 'response' (has {list(ds.data_vars)})")
    da = ds["response"]
    for name in (x, y):
        if name not in da.dims:
            raise SpecError(path, name, f"the chart's axis {name!r} is not a dimension of 'response' {da.dims}")
    used, requested = {}, {}
    for name, value in fixed.items():
        if name in (x, y):
            continue
        if name in da.dims:
            requested[name] = float(value)
            da = da.sel({name: float(value)}, method="nearest")
            used[name] = float(da[name])
        elif name in ds.coords and ds[name].size == 1:
            used[name] = float(ds[name])
        elif name in ds.attrs:
            used[name] = float(ds.attrs[name])
    da = da.transpose(y, x, ...)
    values = da.values
    if values.dtype.kind in "iu":
        legend = _legend_map({**ds.attrs, **da.attrs})
        missing = sorted({int(v) for v in np.unique(values)} - set(legend))
        if missing:
            raise SpecError(path, "response.legend", f"integer codes {missing} have no name; give the attribute "
                                                     f"'legend' (e.g. '0: rest, 1: period-1') or flag_values/flag_meanings")
        names = np.vectorize(lambda v: legend[int(v)], otypes=[object])(values)
    else:
        names = np.vectorize(lambda v: v.decode() if isinstance(v, bytes) else str(v), otypes=[object])(values)
    # CF flag_meanings are single words (period_1); a point not computed (yet) is left out.
    names = np.vectorize(lambda v: str(v).strip().replace("_", "-"), otypes=[object])(names)
    if "bimodal" in ds.data_vars:
        # A period-1 response with a2 not slaved to a1 (decided by structure when the sweep ran,
        # not by a ratio a2 / a1): bi-modal, as the AME's classes distinguish it.
        b = ds["bimodal"]
        for name in used:
            if name in b.dims:
                b = b.sel({name: used[name]})
        flag = np.asarray(b.transpose(*da.dims).values)
        if flag.shape == names.shape:
            names = np.where((names == "period-1") & (flag == 1), "period-1 bi-modal", names)
    X, Y, R = [], [], []
    xs, ys = np.asarray(da[x], float), np.asarray(da[y], float)
    for j in range(len(ys)):
        for i in range(len(xs)):
            cell = np.atleast_1d(names[j, i]).ravel().tolist()
            kinds = sorted({c for c in cell if c and c not in ("nan", "not-computed")},
                           key=lambda c: MAP_CLASSES.index(c) if c in MAP_CLASSES else len(MAP_CLASSES))
            if not kinds:
                continue
            X.append(xs[i])
            Y.append(ys[j])
            R.append(" + ".join(kinds))
    return {"x": np.asarray(X), "y": np.asarray(Y), "response": R, "fixed": used, "requested": requested}


def agreement(regions_rows: Sequence[Mapping], x: str, y: str, response_map: Mapping) -> dict:
    """How often the map's class at a point is one that the AME's class at the nearest grid point
    predicts (`AME_TO_MAP`): {"points", "agree", "fraction"}. A rough score for the chart's caption."""
    if not regions_rows or not len(response_map["x"]):
        return {"points": 0, "agree": 0, "fraction": math.nan}
    gx = np.array([r[x] for r in regions_rows], float)
    gy = np.array([r[y] for r in regions_rows], float)
    sx = max(np.ptp(gx), 1e-300)
    sy = max(np.ptp(gy), 1e-300)
    agree = 0
    for px, py, cls in zip(response_map["x"], response_map["y"], response_map["response"]):
        k = int(np.argmin(((gx - px) / sx) ** 2 + ((gy - py) / sy) ** 2))
        want = set()
        for kind in str(regions_rows[k]["class"]).split(" + "):
            want.update(AME_TO_MAP.get(kind, ()))
        agree += any(c in want for c in cls.split(" + "))
    n = len(response_map["x"])
    return {"points": n, "agree": agree, "fraction": agree / n}


def plot_chart(results, regions_rows: Sequence[Mapping], regions, stem: str | Path | None = None, *, x: str, y: str,
               x_range, y_range, title: str = "", response_map: Mapping | None = None,
               min_label_cells: int | None = None, units: Mapping | None = None, ax=None):
    """Draw the chart: regions (coloured cells of the classification grid, labelled at their
    centroids when they hold at least ``min_label_cells`` cells; default 1 % of the grid, at least 2), the two-parameter curves of
    ``results`` (kinds fold, hopf, branch_point) with their codimension-2 points, the LP/H/BP
    points of the one-parameter branches lying in the plane (open markers, drawn under the
    codimension-2 points so that none hides a GH or BT) and the map's classes, with a legend entry
    for every marker. Returns the Figure (and writes ``<stem>.png`` and ``<stem>.pdf`` when
    ``stem`` is given). ``units``: `autocable.plotting.units.si_scales` for SI axes; ``ax``: an
    Axes to draw into."""
    with styled():
        fig = _plot_chart(results, regions_rows, regions, x=x, y=y, x_range=x_range, y_range=y_range,
                          title=title, response_map=response_map, min_label_cells=min_label_cells,
                          units=units, ax=ax)
        if stem is not None:
            save_figure(fig, stem)
    return fig


def _short(cls: str) -> str:
    return cls.replace("small", "small forced").replace(" + ", " +\n")


#: The one-parameter branches' points in the chart's plane: open markers, and their legend text.
_BRANCH_POINTS = {"LP": ("o", "LP of a one-parameter branch"), "H": ("s", "H of a one-parameter branch"),
                  "BP": ("d", "BP of a one-parameter branch")}


def _plot_chart(results, regions_rows, regions, *, x, y, x_range, y_range, title, response_map,
                min_label_cells, units=None, ax=None):
    from matplotlib.colors import ListedColormap
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    fx, xlabel = axis_scale(x, units)
    fy, ylabel = axis_scale(y, units)
    if ax is None:
        fig = new_figure((8.6, 5.4))
        ax = fig.add_axes([0.09, 0.11, 0.6, 0.8])
        legend_at = dict(loc="center left", bbox_to_anchor=(0.71, 0.5))
        legend_on = fig
    else:
        fig = ax.figure
        legend_at = dict(loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0)
        legend_on = ax
    handles = []
    one_param = []
    if min_label_cells is None:
        min_label_cells = max(2, len(regions_rows) // 100)
    if regions_rows:
        xs = np.unique([r[x] for r in regions_rows])
        ys = np.unique([r[y] for r in regions_rows])
        classes = sorted({r["class"] for r in regions_rows})
        code = {c: k for k, c in enumerate(classes)}
        grid = np.full((len(ys), len(xs)), -1)
        for r in regions_rows:
            grid[np.searchsorted(ys, r[y]), np.searchsorted(xs, r[x])] = code[r["class"]]

        def colour(cls):
            parts = cls.split(" + ")
            if len(parts) == 1:
                return _REGION_COLORS.get(cls, "white")
            # Coexistence: the mean of the parts' colours, a little darker.
            from matplotlib.colors import to_rgb
            rgb = np.mean([to_rgb(_REGION_COLORS.get(p, "white")) for p in parts], axis=0) * 0.9
            return tuple(rgb)
        cmap = ListedColormap([colour(c) for c in classes])
        ex = np.concatenate([[xs[0] - (xs[1] - xs[0]) / 2 if len(xs) > 1 else xs[0] - 0.5],
                             (xs[1:] + xs[:-1]) / 2, [xs[-1] + (xs[-1] - xs[-2]) / 2 if len(xs) > 1 else xs[0] + 0.5]])
        ey = np.concatenate([[ys[0] - (ys[1] - ys[0]) / 2 if len(ys) > 1 else ys[0] - 0.5],
                             (ys[1:] + ys[:-1]) / 2, [ys[-1] + (ys[-1] - ys[-2]) / 2 if len(ys) > 1 else ys[0] + 0.5]])
        ax.pcolormesh(ex * fx, ey * fy, np.ma.masked_less(grid, 0), cmap=cmap, vmin=-0.5, vmax=len(classes) - 0.5,
                      shading="flat", rasterized=True)
        for reg in regions:
            if reg.cells >= min_label_cells:
                ax.text(reg.x * fx, reg.y * fy, _short(reg.label), ha="center", va="center", fontsize=7, zorder=9,
                        bbox=dict(boxstyle="round,pad=0.2", fc="white", ec="0.6", alpha=0.8, lw=0.5))
        handles += [Patch(fc=colour(c), ec="0.6", lw=0.5, label=f"AME: {c.replace('small', 'small forced')}")
                    for c in classes]
    drawn = set()
    for b in results.branches:
        if b.kind in CURVE_KINDS and x in b.table and y in b.table and len(b):
            st = _CURVE_STYLE[b.kind]
            ax.plot(np.asarray(b.table[x]) * fx, np.asarray(b.table[y]) * fy, color=st["color"], ls=st["ls"], lw=1.6,
                    zorder=4)
            if b.kind not in drawn:
                handles.append(Line2D([], [], color=st["color"], ls=st["ls"], lw=1.6, label=st["label"]))
                drawn.add(b.kind)
        for s in b.special_points:
            if x not in s.parameters or y not in s.parameters:
                continue
            px, py = s.parameters[x] * fx, s.parameters[y] * fy
            if b.kind in CURVE_KINDS and s.type in _CODIM2 and s.origin == "autocable":
                # above everything else: a one-parameter H at the same place must not hide a GH
                ax.plot(px, py, _CODIM2[s.type], color="black", ms=6, zorder=10)
                ax.annotate(f"{s.type}", (px, py), textcoords="offset points", xytext=(4, 4), fontsize=7, zorder=10)
            elif b.kind not in CURVE_KINDS and b.kind != "cycle" and s.type in _BRANCH_POINTS \
                    and s.origin == "autocable":
                ax.plot(px, py, _BRANCH_POINTS[s.type][0], color="black", mfc="none", ms=7, mew=1.0, zorder=8.5)
                if s.type not in one_param:
                    one_param.append(s.type)
    if response_map is not None and len(response_map["x"]):
        seen = set()
        # Markers shrink on a dense map (a 40 x 40 map at full size hides the regions).
        shrink = min(1.0, 20.0 / math.sqrt(len(response_map["x"])))
        # Coexisting classes at one point (several starts) sit side by side across a third of the
        # map's spacing in x.
        ux = np.unique(response_map["x"])
        dx = 0.3 * (float(np.min(np.diff(ux))) if len(ux) > 1 else 0.0)
        for px, py, cls in zip(response_map["x"], response_map["y"], response_map["response"]):
            parts = cls.split(" + ")
            for k, part in enumerate(parts):
                style = dict(_MAP_STYLE.get(part, dict(marker="*", mfc="magenta", mec="magenta", ms=4)))
                style["ms"] = max(1.5, style["ms"] * shrink)
                off = (k - (len(parts) - 1) / 2) * dx / max(len(parts) - 1, 1)
                ax.plot((px + off) * fx, py * fy, ls="none", zorder=8, mew=0.8, **style)
                seen.add(part)
        fixed = ", ".join(f"{k} = {v:g}" for k, v in response_map.get("fixed", {}).items())
        handles += [Line2D([], [], ls="none", **_MAP_STYLE.get(c, dict(marker="*", mfc="magenta", mec="magenta")),
                           label=f"eq. (21): {c}") for c in MAP_CLASSES if c in seen]
        if fixed:
            handles.append(Line2D([], [], ls="none", label=f"(map at {fixed})"))
    ax.set_xlim(x_range[0] * fx, x_range[1] * fx)
    ax.set_ylim(y_range[0] * fy, y_range[1] * fy)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.ticklabel_format(style="sci", scilimits=(-3, 3))
    if title:
        ax.set_title(title)
    handles += [Line2D([], [], ls="none", marker=m, color="black", label=f"{t} (codim 2)")
                for t, m in _CODIM2.items() if t != "LP" and any(
                    s.type == t and s.origin == "autocable" and b.kind in CURVE_KINDS for b in results.branches for s in b.special_points)]
    handles += [Line2D([], [], ls="none", marker=_BRANCH_POINTS[t][0], color="black", mfc="none", ms=7,
                       label=_BRANCH_POINTS[t][1]) for t in _BRANCH_POINTS if t in one_param]
    legend_on.legend(handles=handles, fontsize=7, frameon=False, **legend_at)
    return fig
