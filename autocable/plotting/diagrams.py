"""Bifurcation diagrams in the style of Luongo & Zulli's Figs. 3-10, and time histories.

Continuous lines: stable equilibria of the AME (period-1 motions of eq. 21); dashed: unstable; thin
lines: the min and max of a1 (or a2) over the periodic orbits of the AME (quasi-periodic motions of
eq. 21, as in Fig. 4); filled squares: Hopf points (H); filled circles: folds (LP, the jumps of a
frequency response); open circles: branch points (BP); crosses: fold, period-doubling and
Neimark-Sacker points of cycles (LPC, PD, NS); markers: digitised or direct-integration points to
compare with, with the comparison's RMS and largest distance written in the panel. Every special
point is labelled, no label on another, on a marker or on a tick label (`style.place_labels`), and a
legend names every line style and marker drawn. Two-parameter curves (folds, Hopf points) are drawn
by `plot_plane` in the plane of their two parameters (solid: the bifurcation happens on an otherwise
stable equilibrium; dashed: not), with their codimension-2 points (CP, BT, GH, ZH, DH) and the
one-parameter branches' LP and H points.

Axes read in the paper's symbols (a_1, sigma, U*, eta*), or in SI units with ``units =
si_scales(...)`` (`autocable.plotting.units`). Every function returns the matplotlib Figure (to
restyle, show inline or save) and draws into ``ax=`` when given; `save_figure` writes ``<stem>.png``
and the vector ``<stem>.pdf``. Only reads `autocable.results.RunResults`; matplotlib is imported
lazily and drawn on an Agg canvas (no pyplot, no global state beyond the style's context).
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np

from autocable.plotting.style import new_figure, place_labels, save_figure, styled
from autocable.plotting.units import PAPER_LABELS, SI_AXES, SiWordScales, axis_scale, cable_of, x_axis

__all__ = ["plot_scene", "plot_plane", "plot_time_series", "plot_simulation", "save_figure", "AXIS_LABELS",
           "MARKERS"]

#: Axis labels in the paper's symbols (eqs. 17-18: nondimensional quantities, starred U*, eta*).
AXIS_LABELS = PAPER_LABELS

_THICK, _THIN = 1.5, 0.7

#: How each type of special point of a one-parameter branch is drawn, and its legend text.
MARKERS = {
    "H": (dict(marker="s", color="black", ms=5, ls="none"), "Hopf point (H)"),
    "LP": (dict(marker="o", color="black", ms=4.5, ls="none"), "fold (LP)"),
    "BP": (dict(marker="o", mfc="white", mec="black", ms=5, ls="none"), "branch point (BP)"),
    "LPC": (dict(marker="x", color="black", ms=5, ls="none"), "fold of cycles (LPC)"),
    "PD": (dict(marker="+", color="black", ms=6, ls="none"), "period doubling (PD)"),
    "NS": (dict(marker="1", color="black", ms=7, ls="none"), "Neimark-Sacker (NS)"),
}
#: The end of a branch cut short by its point budget (an `EndPoint` "max_points": not the range's end).
TRUNCATED_MARKER = (dict(marker="X", color="tab:red", ms=7, ls="none"), "branch cut at max_points")


def _label_text(s) -> str:
    """A special point's label; a Hopf point's with its criticality and l1 (``H1 (subcritical,
    l1 = 2.3e+04)``): which of the two a Hopf point is decides whether the response jumps."""
    text = getattr(s, "hopf_text", "")
    return f"{s.label} ({text})" if text else s.label


def _resolve_x(results, x: str, units):
    """(column, factor, offset, label) of the x axis (`autocable.plotting.units.x_axis`): an SI
    axis of `SI_AXES` (or sigma, U, eta with ``units = "si"`` given as the word) from the cable the
    results carry, else ``units``' linear scale."""
    si_word = isinstance(units, SiWordScales) or units == "si"
    cable = cable_of(results) if (x in SI_AXES or (si_word and x in SI_AXES.values())) else None
    return x_axis(x, units, cable)


def _segments(x: np.ndarray, y: np.ndarray, stable: np.ndarray):
    """Maximal runs of consecutive points with one stability, joined end to end (no gaps): a
    segment between two points is stable when both are."""
    n = len(x)
    if n == 0:
        return
    if n == 1:
        yield x, y, bool(stable[0])
        return
    seg_stable = stable[:-1] & stable[1:]
    start = 0
    for i in range(1, n - 1 + 1):
        if i == n - 1 or seg_stable[i] != seg_stable[start]:
            yield x[start:i + 1], y[start:i + 1], bool(seg_stable[start])
            start = i


def _axes_grid(ax, n: int, figsize, ncol: int = 1, sharex=True):
    """(figure, axes array of shape (n, ncol), whether we made the figure): ``ax`` given (one Axes, or
    a sequence of n * ncol) or a new figure."""
    if ax is None:
        fig = new_figure(figsize)
        grid = fig.subplots(n, ncol, sharex=sharex, squeeze=False)
        return fig, grid, True
    axes = np.atleast_1d(np.asarray(ax, dtype=object)).ravel()
    if len(axes) != n * ncol:
        raise ValueError(f"ax: expected {n * ncol} Axes (one per panel), got {len(axes)}")
    return axes[0].figure, axes.reshape(n, ncol), False


def _finish(fig, made: bool, legend_ax, handles, place) -> None:
    """Legend beside the top panel (outside the data), then the layout, then the labels (placed once
    the axes have their final size)."""
    if handles:
        legend_ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0)
    if made:
        fig.tight_layout()
    for ax, items, avoid in place:
        place_labels(ax, items, avoid=avoid)


def _line_handles(stable: bool, unstable: bool, cycles: bool) -> list:
    from matplotlib.lines import Line2D
    out = []
    if stable:
        out.append(Line2D([], [], color="black", lw=_THICK, ls="-", label="stable"))
    if unstable:
        out.append(Line2D([], [], color="black", lw=_THICK, ls="--", label="unstable"))
    if cycles:
        out.append(Line2D([], [], color="black", lw=_THIN, ls="-", label="periodic orbits: min, max"))
    return out


def plot_scene(results, stem: str | Path | None = None, *, x: str, y: Sequence[str] = ("a1",), title: str = "",
               labels: bool = True, compare: Sequence[dict] | None = None, compare_panel: str | None = None,
               compare_label: str = "digitised", overlay: Sequence[dict] | None = None,
               compare_stats: Mapping | None = None, units: Mapping | None = None, ax=None):
    """Draw every branch of ``results`` as amplitude(s) ``y`` against parameter ``x``, one panel per
    amplitude; return the Figure (and write ``<stem>.png`` and ``<stem>.pdf`` when ``stem`` is
    given). ``overlay`` rows (methods/sweeps.py) are drawn as the paper's empty boxes (Figs. 9-10),
    with a vertical bar over the envelope of a response that is not period-1; ``compare`` rows
    (digitised points) as red circles, with ``compare_stats`` (compare.json: RMS and largest
    distance per curve) written in their panel. ``units``: `autocable.plotting.units.si_scales`
    for SI axes (default: the paper's nondimensional symbols). ``ax``: an Axes (or one per panel)
    to draw into; ``units = "si"`` takes the scales the results carry (a run's or a
    `frequency_response`'s), ``"paper"`` the paper's symbols. Bad arguments are refused before
    drawing (`autocable.model.premises.ArgumentError` naming the argument: an unknown column, a
    ``y`` given as one string is one panel). ``x`` may be ``"Omega_Hz"`` (the deck frequency
    (omega1 + sigma) omega / 2 pi), ``"U_m_s"`` or ``"eta_m"``, drawn from sigma, U, eta with the
    cable the results carry; with ``units = "si"`` an x of sigma, U or eta is drawn so. A Hopf
    point's label says whether it is super- or subcritical, with l1; the end of a branch cut short
    at its point budget (``max_points``) is marked by a red cross."""
    y, units = check_plot_arguments("plot_scene", results, x, y, units, ax)
    with styled():
        fig = _plot_scene(results, x=x, y=y, title=title, labels=labels, compare=compare,
                          compare_panel=compare_panel, compare_label=compare_label, overlay=overlay,
                          compare_stats=compare_stats, units=units, ax=ax)
        if stem is not None:
            save_figure(fig, stem)
    return fig


def check_plot_arguments(function: str, results, x, y, units, ax) -> tuple:
    """(y as a tuple of panels, units) of `plot_scene`, or `ArgumentError` naming the argument:
    ``x`` and each ``y`` a column of the branches (an amplitude, a parameter, the min/max pair of a
    cycle branch's amplitude) or, for ``x``, an SI axis of `autocable.plotting.units.SI_AXES`;
    ``units`` None, "paper" (None), "si" (the scales of the cable the results carry, as
    `SiWordScales`; refused naming the fix when they carry none) or an `si_scales` mapping; ``ax``
    None, an Axes or a sequence of them. A ``y`` given as one string is one panel."""
    from autocable.model.premises import ArgumentError, check_type
    from autocable.plotting.units import SI_AXES, SiWordScales, cable_of, scales_of
    from autocable.spec import show
    branches = getattr(results, "branches", ())
    columns = {"sigma", "U", "eta", "a1", "a2"}
    for b in branches:
        table = getattr(b, "table", {})
        columns |= set(table) | {k[:-4] for k in table if k.endswith("_min")}
    check_type(function, "x", x, str, "a column name, e.g. \"sigma\"")
    if x not in columns and x not in SI_AXES:
        raise ArgumentError(function, "x", f"no column {x!r} in these branches; one of "
                                           f"{', '.join(sorted(columns | set(SI_AXES)))}")
    panels = (y,) if isinstance(y, str) else y
    if isinstance(panels, (bytes, Mapping)) or not isinstance(panels, Sequence) or not panels:
        raise ArgumentError(function, "y", f"expected a column name or a sequence of them, e.g. (\"a1\", \"a2\"), "
                                           f"got {show(y)}")
    for k, amp in enumerate(panels):
        if not isinstance(amp, str) or amp not in columns:
            raise ArgumentError(function, "y" if isinstance(y, str) else f"y[{k}]",
                                f"no column {show(amp)} in these branches; one of {', '.join(sorted(columns))}")
    if isinstance(units, str):
        if units == "paper":
            units = None
        elif units == "si":
            cable = cable_of(results)
            if cable is None:
                raise ArgumentError(function, "units", "'si' needs the cable's scales, which these branches do not "
                                                       "carry: give units=ac.si_scales(length_m, omega_rad_s, "
                                                       "critical_wind_speed_m_s)")
            units = SiWordScales(scales_of(cable[0]))
        else:
            raise ArgumentError(function, "units", f"expected 'paper', 'si' or ac.si_scales(...), got {show(units)}")
    elif units is not None and not (isinstance(units, Mapping) and all(
            isinstance(v, tuple) and len(v) == 2 for v in units.values())):
        raise ArgumentError(function, "units", f"expected 'paper', 'si' or ac.si_scales(...), got {show(units)}")
    if ax is not None:
        axes = np.atleast_1d(np.asarray(ax, dtype=object)).ravel()
        if not len(axes) or any(not (hasattr(a, "figure") and hasattr(a, "plot")) for a in axes):
            raise ArgumentError(function, "ax", f"expected a matplotlib Axes (or one per panel), got {show(ax)}")
    return tuple(panels), units


def _plot_overlay(ax, rows, x: str, amp: str, fx: float, fy: float) -> list:
    from matplotlib.lines import Line2D
    mine = [r for r in rows if r["parameter"] == x]
    shown = [r for r in mine if r["steady"] and np.isfinite(r[amp])]
    # A diverged integration has no amplitude: never a box; a caret on the top edge instead.
    diverged = sorted({r["value"] for r in mine if not np.isfinite(r[amp])})
    if not mine:
        return []
    name = "eq. (21)" if mine[0]["method"] == "ode21" else "the AME"
    handles = []
    box = dict(ls="none", marker="s", ms=5, mfc="none", mec="tab:blue")
    if shown:
        ax.plot([r["value"] * fx for r in shown], [r[amp] * fy for r in shown], zorder=6, **box)
        handles.append(Line2D([], [], label=f"integration of {name}", **box))
    for r in shown:
        if not r["periodic"]:
            ax.plot([r["value"] * fx] * 2, [r[f"{amp}_min"] * fy, r[f"{amp}_max"] * fy], color="tab:blue", lw=_THIN)
    if diverged:
        caret = dict(ls="none", marker="v", ms=5, color="tab:red")
        ax.plot([v * fx for v in diverged], [1.0] * len(diverged), transform=ax.get_xaxis_transform(),
                clip_on=False, **caret)
        handles.append(Line2D([], [], label=f"{name} diverges ({len(diverged)} values)", **caret))
    return handles


def _compare_text(stats: Mapping) -> str:
    """The comparison's numbers (compare.json) as the panel's note: per curve, RMS and largest
    distance in % of the plot (the distance's normalisation: `autocable.scene.compare`)."""
    curves = stats.get("curves") or {}
    lines = ["distance to the computed branches (% of the plot):"]
    for name, c in curves.items():
        lines.append(f"{name or 'points'}: RMS {100 * c['rms_distance']:.2g} %, max {100 * c['max_distance']:.2g} % "
                     f"(n = {c['n_points']})")
    return "\n".join(lines)


def _plot_scene(results, *, x, y, title, labels, compare, compare_panel, compare_label, overlay=None,
                compare_stats=None, units=None, ax=None):
    from matplotlib.lines import Line2D

    panels = list(y)
    fig, grid, made = _axes_grid(ax, len(panels), (6.0, 3.2 * len(panels)))
    axes = grid[:, 0]
    x, fx, x0, xlabel = _resolve_x(results, x, units)
    seen = {"stable": False, "unstable": False, "cycles": False}
    types_drawn: list[str] = []
    extra_handles: list = []
    place = []
    for ax_, amp in zip(axes, panels):
        fy, ylabel = axis_scale(amp, units)
        items, names, avoid = [], [], []     # special points' labels placed first, branch names after
        for b in results.branches:
            if x not in b.table or len(b) == 0 or b.kind in ("fold", "hopf", "branch_point"):
                continue      # two-parameter curves: see plot_plane
            xs = np.asarray(b.table[x], float) * fx + x0
            if b.kind == "equilibrium":
                if amp not in b.table:
                    continue
                ys = np.asarray(b.table[amp], float) * fy
                for sx, sy, st in _segments(xs, ys, np.asarray(b.stable)):
                    ax_.plot(sx, sy, color="black", lw=_THICK, ls="-" if st else "--")
                    seen["stable" if st else "unstable"] = True
                if np.any(np.isfinite(ys)):        # the branch's name, labels or not (as before)
                    top = int(np.nanargmax(ys))
                    names.append((xs[top], ys[top], b.name))
            else:
                for col in (f"{amp}_min", f"{amp}_max"):
                    if col not in b.table:
                        continue
                    for sx, sy, st in _segments(xs, np.asarray(b.table[col], float) * fy, np.asarray(b.stable)):
                        ax_.plot(sx, sy, color="black", lw=_THIN, ls="-" if st else "--")
                        seen["cycles"] = True
                        seen["stable" if st else "unstable"] = True
            ycol = amp if b.kind == "equilibrium" else f"{amp}_max"
            for e in getattr(b, "truncated", ()):       # an end at max_points: not the range's end
                i = b.end_index(e)
                if ycol in b.table and 0 <= i < len(b) and np.isfinite(b.table[ycol][i]):
                    ax_.plot(xs[i], b.table[ycol][i] * fy, zorder=8, **TRUNCATED_MARKER[0])
                    if "truncated" not in types_drawn:
                        types_drawn.append("truncated")
            for s in b.special_points:
                if x not in s.parameters or s.type not in MARKERS:
                    continue
                px = s.parameters[x]
                py = s.a1 if amp == "a1" else s.a2
                if b.kind == "cycle" and f"{amp}_max" in b.table and 0 <= s.index < len(b):
                    py = b.table[f"{amp}_max"][s.index]
                if not (np.isfinite(px) and np.isfinite(py)):
                    continue
                style, _ = MARKERS[s.type]
                ax_.plot(px * fx + x0, py * fy, zorder=7, **style)
                if s.type not in types_drawn:
                    types_drawn.append(s.type)
                if labels and s.label != "BP0":
                    items.append((px * fx + x0, py * fy, _label_text(s)))
                else:
                    avoid.append((px * fx + x0, py * fy))
        if compare and (compare_panel or panels[0]) == amp:
            curves = sorted({r["curve"] for r in compare})
            for c in curves:
                pts = [r for r in compare if r["curve"] == c]
                for st in (True, False):
                    sel = [r for r in pts if r["stable"] == st]
                    if sel:
                        style = dict(ls="none", marker="o", ms=4, mec="tab:red", mfc="tab:red" if st else "white")
                        ax_.plot([r["x"] * fx for r in sel], [r["y"] * fy for r in sel], zorder=6, **style)
                        extra_handles.append(Line2D([], [], label=f"{compare_label} {c}".strip()
                                                    + ("" if all(r["stable"] for r in pts) and st else
                                                       (" (stable)" if st else " (unstable)")), **style))
            if compare_stats:
                ax_.text(0.98, 0.97, _compare_text(compare_stats), transform=ax_.transAxes, ha="right", va="top",
                         fontsize=6.5, color="tab:red", zorder=11,
                         bbox=dict(boxstyle="round,pad=0.25", fc="white", ec="none", alpha=0.85))
        if overlay:
            for h in _plot_overlay(ax_, overlay, x, amp, fx, fy):
                if h.get_label() not in [e.get_label() for e in extra_handles]:
                    extra_handles.append(h)
        ax_.set_ylabel(ylabel)
        ax_.margins(y=0.12)      # room for the labels above the highest point
        ax_.set_ylim(bottom=0.0)
        ax_.ticklabel_format(axis="y", style="sci", scilimits=(-3, 3))
        place.append((ax_, items + names, avoid))
    axes[-1].set_xlabel(xlabel)
    if title:
        axes[0].set_title(title)
    handles = _line_handles(seen["stable"], seen["unstable"], seen["cycles"])
    handles += [Line2D([], [], label=MARKERS[t][1], **MARKERS[t][0]) for t in MARKERS if t in types_drawn]
    if "truncated" in types_drawn:
        handles.append(Line2D([], [], label=TRUNCATED_MARKER[1], **TRUNCATED_MARKER[0]))
    handles += extra_handles
    _finish(fig, made, axes[0], handles, place)
    return fig


def plot_plane(results, stem: str | Path | None = None, *, x: str, y: str, title: str = "", labels: bool = True,
               units: Mapping | None = None, ax=None):
    """Draw the two-parameter curves (kinds "fold", "hopf", "branch_point") of ``results`` in the
    (``x``, ``y``) parameter plane with their labelled points, and the LP/H points of the
    one-parameter branches that lie in it; return the Figure (and write ``<stem>.png``/``.pdf``
    when ``stem`` is given)."""
    with styled():
        fig = _plot_plane(results, x=x, y=y, title=title, labels=labels, units=units, ax=ax)
        if stem is not None:
            save_figure(fig, stem)
    return fig


#: Markers of the codimension-2 points on two-parameter curves, and of the one-parameter branches'
#: LP and H points in a parameter plane (open).
PLANE_MARKERS = {"CP": "^", "BT": "D", "GH": "v", "ZH": "P", "DH": "X", "LP": "o", "H": "s"}
_CURVE_NAMES = {"fold": "folds (LP)", "hopf": "Hopf points (H)", "branch_point": "pitchforks (BP)"}
_CURVE_COLORS = {"fold": "black", "hopf": "tab:blue", "branch_point": "tab:green"}


def _plot_plane(results, *, x, y, title, labels, units=None, ax=None):
    from matplotlib.lines import Line2D

    fig, grid, made = _axes_grid(ax, 1, (6.0, 4.2))
    ax_ = grid[0, 0]
    fx, xlabel = axis_scale(x, units)
    fy, ylabel = axis_scale(y, units)
    drawn, dashed, kinds_pts = [], False, []
    items = []
    for b in results.branches:
        if b.kind in ("fold", "hopf", "branch_point") and x in b.table and y in b.table and len(b):
            for sx, sy, st in _segments(np.asarray(b.table[x]) * fx, np.asarray(b.table[y]) * fy, np.asarray(b.stable)):
                ax_.plot(sx, sy, lw=_THICK, ls="-" if st else "--", color=_CURVE_COLORS[b.kind])
                dashed |= not st
            if b.kind not in drawn:
                drawn.append(b.kind)
            i = len(b) // 2
            if labels:
                items.append((b.table[x][i] * fx, b.table[y][i] * fy, b.name))
        for s in b.special_points:
            if x not in s.parameters or y not in s.parameters:
                continue
            if b.kind in ("fold", "hopf", "branch_point"):
                if s.type not in PLANE_MARKERS:
                    continue
                filled = s.origin == "autocable"
                key = (s.type, "curve", filled)
            elif s.type in ("LP", "H"):
                filled = False
                key = (s.type, "branch", False)
            else:
                continue
            px, py = s.parameters[x] * fx, s.parameters[y] * fy
            ax_.plot(px, py, PLANE_MARKERS[s.type], color="black", mfc="black" if filled else "white", ms=5,
                     zorder=8 if key[1] == "curve" else 7)
            if key not in kinds_pts:
                kinds_pts.append(key)
            if labels and b.kind in ("fold", "hopf", "branch_point"):
                items.insert(0, (px, py, s.label))
    handles = [Line2D([], [], color=_CURVE_COLORS[k], lw=_THICK, label=_CURVE_NAMES[k]) for k in drawn]
    if dashed:
        handles.append(Line2D([], [], color="black", lw=_THICK, ls="--", label="on an unstable equilibrium"))
    for t, where, filled in kinds_pts:
        text = (f"{t} (codim 2)" if t not in ("LP", "H") else t) if where == "curve" else f"{t} of a one-parameter branch"
        if where == "curve" and not filled:
            text += ", PyCont only"
        handles.append(Line2D([], [], ls="none", marker=PLANE_MARKERS[t], color="black",
                              mfc="black" if filled else "white", label=text))
    ax_.set_xlabel(xlabel)
    ax_.set_ylabel(ylabel)
    ax_.margins(0.06)
    ax_.ticklabel_format(style="sci", scilimits=(-3, 3))
    if title:
        ax_.set_title(title)
    _finish(fig, made, ax_, handles, [(ax_, items, [])])
    return fig


def _time_panel(ax, series, amp: str, window, ode21_diverged: bool, ft: float, fa: float) -> None:
    """One amplitude against time, over the whole run or over ``window`` = (t0, t1)."""
    k = 1 if amp == "a1" else 2

    def part(t, a):
        t = np.asarray(t, dtype=float)
        a = np.asarray(a, dtype=float)
        if window is not None:
            keep = (t >= window[0]) & (t <= window[1])
            t, a = t[keep], a[keep]
        return t * ft, a * fa

    if "ame" in series:
        t, *a = series["ame"]
        ax.plot(*part(t, a[k - 1]), color="black", lw=_THICK, label="AME (24)")
    if "ode21" in series:
        t, *a = series["ode21"]
        if len(t):
            ax.plot(*part(t, a[k - 1]), color="tab:blue", lw=_THIN, label="eq. (21): envelope")
        if ode21_diverged and window is None:
            t_div = float(t[-1]) if len(t) else 0.0
            ax.plot([t_div * ft], [1.0], marker="v", ms=6, color="tab:red", ls="none",
                    transform=ax.get_xaxis_transform(), clip_on=False,
                    label=f"eq. (21) diverges (t = {t_div * ft:.4g})")
    ax.set_ylim(bottom=0.0)
    ax.ticklabel_format(axis="y", style="sci", scilimits=(-3, 3))


def plot_time_series(series, stem: str | Path | None = None, *, y: Sequence[str] = ("a1", "a2"), title: str = "",
                     ode21_message: str = "", ode21_diverged: bool = False,
                     zoom: tuple[float, float] | None = None, units: Mapping | None = None, ax=None):
    """Fig. 11: a1(t), a2(t) of the AME (thick) and the amplitude envelope of eq. (21) (thin, half
    peak-to-peak per forcing period) on the same axes, one panel per amplitude. ``series`` maps
    "ame" / "ode21" to (t, a1, a2) arrays. A divergence of eq. (21) is marked where it happens
    (a caret on the top edge) and named in the legend. ``zoom = (t0, t1)`` adds a right-hand column
    with that window (a few modulation periods). Returns the Figure (and writes ``<stem>.png`` and
    ``<stem>.pdf`` when ``stem`` is given); ``ax``: one Axes per panel (row-major with ``zoom``)."""
    with styled():
        panels = list(y)
        ncol = 2 if zoom else 1
        fig, grid, made = _axes_grid(ax, len(panels), (6.5 if ncol == 1 else 10.0, 2.6 * len(panels)), ncol,
                                     sharex="col")
        ft, tlabel = axis_scale("t", units)
        for col in range(ncol):
            window = zoom if col == 1 else None
            for ax_, amp in zip(grid[:, col], panels):
                fa, alabel = axis_scale(amp, units)
                _time_panel(ax_, series, amp, window, ode21_diverged, ft, fa)
                ax_.set_ylabel(alabel)
            grid[-1, col].set_xlabel(tlabel)
        if zoom:
            grid[0, 1].set_title(f"last {(zoom[1] - zoom[0]) * ft:.4g} {'s' if units else 'time units'}")
        axes = grid[:, 0]
        if title:
            (fig.suptitle if zoom else axes[0].set_title)(title)
        handles, seen = [], set()
        for a in grid.ravel():
            for h in a.get_legend_handles_labels()[0]:
                if h.get_label() not in seen:
                    seen.add(h.get_label())
                    handles.append(h)
        _finish(fig, made, grid[0, -1], handles, [])
        if stem is not None:
            save_figure(fig, stem)
    return fig


def poincare_section(t, q, Omega: float, t_from: float = 0.0) -> np.ndarray:
    """The stroboscopic (Poincare) section of a time history: the state ``q`` (rows of samples,
    columns of coordinates) at t = t_from + k 2 pi / Omega, k = 0, 1, ... (linear interpolation
    between the samples around each time). A period-1 response is one point, a period-n response n
    points, a quasi-periodic one a closed curve."""
    t = np.asarray(t, float)
    q = np.asarray(q, float)
    if q.ndim == 1:
        q = q[:, None]
    period = 2 * math.pi / Omega
    if len(t) < 2:
        return np.zeros((0, q.shape[1]))
    start = max(t_from, t[0])
    times = start + period * np.arange(int(math.floor((t[-1] - start) / period)) + 1)
    return np.column_stack([np.interp(times, t, q[:, j]) for j in range(q.shape[1])])


def plot_simulation(history, stem: str | Path | None = None, *, Omega: float, response: str = "",
                    steady_from: float | None = None, title: str = "", units: Mapping | None = None, ax=None,
                    period_name: str = "forcing period"):
    """`autocable simulate --plot`: the time history of q_1 and q_2 of eq. (21) with their envelope
    (the max and min of q_k per forcing period), the phase plane (q_1, q_2) over the steady part,
    and the stroboscopic Poincare section of the steady part at the
    forcing period (`poincare_section`) in the (q_1, q_2) plane: one point for a period-1 response,
    n for period-n, a closed curve for a quasi-periodic one.

    ``history`` = (t, q1, q2, q1', q2') arrays. ``steady_from``: the time after which the response
    is taken as steady (default: the last half). ``Omega`` = 2 pi / the period of the envelope and
    the section, named ``period_name`` (an autonomous response at eta* = 0 has no forcing: give
    its own period and "cycle's own period"). Returns the Figure (and writes ``<stem>.png`` /
    ``.pdf`` when ``stem`` is given). ``ax``: 4 Axes (q1(t), q2(t), phase plane, section)."""
    with styled():
        t, q1, q2, v1, v2 = (np.asarray(c, float) for c in history)
        if steady_from is None:
            steady_from = float(t[0] + 0.5 * (t[-1] - t[0])) if len(t) else 0.0
        if ax is None:
            fig = new_figure((9.0, 6.0))
            gs = fig.add_gridspec(2, 2)
            axes = [fig.add_subplot(gs[0, 0]), fig.add_subplot(gs[1, 0]), fig.add_subplot(gs[0, 1]),
                    fig.add_subplot(gs[1, 1])]
            made = True
        else:
            axes = list(np.atleast_1d(np.asarray(ax, dtype=object)).ravel())
            if len(axes) != 4:
                raise ValueError(f"ax: expected 4 Axes (q1(t), q2(t), phase plane, section), got {len(axes)}")
            fig, made = axes[0].figure, False
        ft, tlabel = axis_scale("t", units)
        period = 2 * math.pi / Omega if Omega > 0 else (t[-1] - t[0] if len(t) else 1.0)
        for a, q, name in ((axes[0], q1, "q1"), (axes[1], q2, "q2")):
            fq, qlabel = axis_scale(name, units)
            a.plot(t * ft, q * fq, color="0.55", lw=0.3, rasterized=len(t) > 20000, label=f"{qlabel.split(' [')[0]}")
            if len(t) > 1:
                edges = np.arange(t[0], t[-1] + period, period)
                k = np.clip(np.searchsorted(edges, t, side="right") - 1, 0, max(len(edges) - 1, 0))
                top = np.full(len(edges), np.nan)
                bot = np.full(len(edges), np.nan)
                np.fmax.at(top, k, q)
                np.fmin.at(bot, k, q)
                mid = edges + period / 2
                ok = np.isfinite(top)
                a.plot(mid[ok] * ft, top[ok] * fq, color="black", lw=_THIN, label=f"envelope (max, min per {period_name})")
                a.plot(mid[ok] * ft, bot[ok] * fq, color="black", lw=_THIN)
            a.axvline(steady_from * ft, color="tab:blue", lw=0.6, ls=":", label="steady part from here")
            a.set_ylabel(qlabel)
            a.ticklabel_format(axis="y", style="sci", scilimits=(-3, 3))
        axes[1].set_xlabel(tlabel)
        axes[0].legend(loc="upper left", bbox_to_anchor=(0.0, 1.32), ncol=2, fontsize=7)
        keep = t >= steady_from
        f1, l1 = axis_scale("q1", units)
        f2, l2 = axis_scale("q2", units)
        axes[2].plot(q1[keep] * f1, q2[keep] * f2, color="black", lw=0.4, rasterized=int(keep.sum()) > 20000)
        axes[2].set_xlabel(l1)
        axes[2].set_ylabel(l2)
        axes[2].set_title("phase plane (steady part)")
        sec = poincare_section(t, np.column_stack([q1, q2]), Omega, steady_from) if Omega > 0 else np.zeros((0, 2))
        if len(sec):
            axes[3].plot(sec[:, 0] * f1, sec[:, 1] * f2, ls="none", marker=".", ms=3, color="black")
        axes[3].set_xlabel(l1)
        axes[3].set_ylabel(l2)
        kind = f" ({response})" if response else ""
        axes[3].set_title(f"Poincare section at the {period_name}{kind}: {len(sec)} points")
        for a in axes[2:]:
            a.ticklabel_format(style="sci", scilimits=(-3, 3))
        if title:
            fig.suptitle(title)
        if made:
            fig.tight_layout()
        if stem is not None:
            save_figure(fig, stem)
    return fig
