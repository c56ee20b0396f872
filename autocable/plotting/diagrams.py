"""Bifurcation diagrams in the style of Luongo & Zulli's Figs. 3-10.

Continuous lines: stable equilibria of the AME (period-1 motions of eq. 21); dashed: unstable; filled
squares: Hopf points; thin lines: the min and max of a1 (or a2) over the periodic orbits of the AME
(quasi-periodic motions of eq. 21, as in Fig. 4); open circles: branch points; small crosses: fold,
period-doubling and Neimark-Sacker points of cycles; markers: digitised or direct-integration points
to compare with. Two-parameter curves (folds, Hopf points) are drawn by `plot_plane` in the plane of
their two parameters (solid: the bifurcation happens on an otherwise stable equilibrium; dashed:
not), with their codimension-2 points (CP, BT, GH, ZH, DH) and the one-parameter branches' LP and H
points. Only reads `autocable.results.RunResults`; matplotlib is imported here, lazily, and
drawn on an Agg canvas (no pyplot, no global state). Files are written atomically.
"""
from __future__ import annotations

import contextlib
import logging
import os
import tempfile
from pathlib import Path
from typing import Sequence

import numpy as np

__all__ = ["plot_scene", "plot_plane", "plot_time_series", "AXIS_LABELS"]

#: Axis labels in the paper's symbols (eqs. 17-18: nondimensional quantities).
AXIS_LABELS = {"sigma": r"$\sigma$", "U": r"$U$", "eta": r"$\eta$", "a1": r"$a_1$", "a2": r"$a_2$"}

_THICK, _THIN = 1.5, 0.7


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


#: Resolution of the PNG files (and of anything rasterised in the PDF).
_DPI = 150


def _save_formats(fig, stem: Path) -> list[Path]:
    """``stem``.png and ``stem``.pdf of ``fig`` (laid out by ``tight_layout``), cropped to the same
    tight box. The box is computed once here: savefig's ``bbox_inches="tight"`` would draw the
    figure an extra time for every format (five draws instead of three)."""
    from matplotlib import rcParams
    fig.set_dpi(_DPI)
    fig.draw_without_rendering()    # what savefig does before measuring: legends placed, text laid out
    bbox = fig.get_tightbbox(fig.canvas.get_renderer()).padded(rcParams["savefig.pad_inches"])
    # tight_layout leaves a placeholder layout engine behind, and with any engine set savefig
    # draws the whole figure once more per format before drawing it for real.
    fig.set_layout_engine(None)
    paths = []
    for ext in (".png", ".pdf"):
        p = Path(stem).with_suffix(ext)
        _save(fig, p, bbox)
        paths.append(p)
    return paths


def _save(fig, path: Path, bbox) -> None:
    """savefig to a temporary file in the same folder, then os.replace (readers never see half a file)."""
    from autocable._store import file_mode
    # ".tmp", not the format's suffix: a run's next start recognises and removes what a kill left
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        os.fchmod(fd, file_mode())     # mkstemp's 0o600 would survive the replace
        os.close(fd)
        fig.savefig(tmp, format=path.suffix.lstrip("."), dpi=_DPI, bbox_inches=bbox)
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise


@contextlib.contextmanager
def _matplotlib_quiet():
    """Keep matplotlib's own logging at WARNING for the block. A distutils build (PyDSTool's AUTO
    library) can leave the root logger at DEBUG with a handler, and matplotlib would then print its
    font-matching chatter."""
    logger = logging.getLogger("matplotlib")
    before = logger.level
    logger.setLevel(logging.WARNING)
    try:
        yield
    finally:
        logger.setLevel(before)


def plot_scene(results, stem: str | Path, *, x: str, y: Sequence[str] = ("a1",), title: str = "",
               labels: bool = True, compare: Sequence[dict] | None = None, compare_panel: str | None = None,
               compare_label: str = "digitised", overlay: Sequence[dict] | None = None) -> list[Path]:
    """Draw every branch of ``results`` as amplitude(s) ``y`` against parameter ``x``; write
    ``<stem>.png`` and ``<stem>.pdf``. Returns the two paths. ``overlay`` rows (methods/sweeps.py)
    are drawn as the paper's empty boxes (Figs. 9-10), with a vertical bar over the envelope of a
    response that is not period-1."""
    with _matplotlib_quiet():
        return _plot_scene(results, stem, x=x, y=y, title=title, labels=labels, compare=compare,
                           compare_panel=compare_panel, compare_label=compare_label, overlay=overlay)


def _plot_overlay(ax, rows, x: str, amp: str) -> None:
    mine = [r for r in rows if r["parameter"] == x]
    shown = [r for r in mine if r["steady"] and np.isfinite(r[amp])]
    # A diverged integration has no amplitude: never a box; a caret on the top edge instead.
    diverged = sorted({r["value"] for r in mine if not np.isfinite(r[amp])})
    if not mine:
        return
    name = "eq. (21)" if mine[0]["method"] == "ode21" else "the AME"
    if shown:
        ax.plot([r["value"] for r in shown], [r[amp] for r in shown], ls="none", marker="s", ms=5,
                mfc="none", mec="tab:blue", label=f"integration of {name}")
    for r in shown:
        if not r["periodic"]:
            ax.plot([r["value"]] * 2, [r[f"{amp}_min"], r[f"{amp}_max"]], color="tab:blue", lw=_THIN)
    if diverged:
        ax.plot(diverged, [1.0] * len(diverged), ls="none", marker="v", ms=5, color="tab:red",
                transform=ax.get_xaxis_transform(), clip_on=False,
                label=f"{name} diverges ({len(diverged)} values)")
    ax.legend(fontsize=7, frameon=False)


def _plot_scene(results, stem, *, x, y, title, labels, compare, compare_panel, compare_label,
                overlay=None) -> list[Path]:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    stem = Path(stem)
    stem.parent.mkdir(parents=True, exist_ok=True)
    panels = list(y)
    fig = Figure(figsize=(6.0, 3.4 * len(panels)))
    FigureCanvasAgg(fig)
    axes = fig.subplots(len(panels), 1, sharex=True, squeeze=False)[:, 0]
    for ax, amp in zip(axes, panels):
        for b in results.branches:
            if x not in b.table or len(b) == 0:
                continue
            xs = np.asarray(b.table[x])
            if b.kind in ("fold", "hopf", "branch_point"):
                continue  # two-parameter curves: see plot_plane
            if b.kind == "equilibrium":
                if amp not in b.table:
                    continue
                for sx, sy, st in _segments(xs, np.asarray(b.table[amp]), np.asarray(b.stable)):
                    ax.plot(sx, sy, color="black", lw=_THICK, ls="-" if st else "--")
                top = int(np.nanargmax(b.table[amp])) if np.any(np.isfinite(b.table[amp])) else 0
                ax.annotate(b.name, (xs[top], b.table[amp][top]), textcoords="offset points",
                            xytext=(3, 4), fontsize=8)
            else:
                for col in (f"{amp}_min", f"{amp}_max"):
                    if col not in b.table:
                        continue
                    for sx, sy, st in _segments(xs, np.asarray(b.table[col]), np.asarray(b.stable)):
                        ax.plot(sx, sy, color="black", lw=_THIN, ls="-" if st else "--")
            for s in b.special_points:
                if x not in s.parameters:
                    continue
                px = s.parameters[x]
                py = s.a1 if amp == "a1" else s.a2
                if b.kind == "cycle" and f"{amp}_max" in b.table and 0 <= s.index < len(b):
                    py = b.table[f"{amp}_max"][s.index]
                if not np.isfinite(py):
                    continue
                if s.type == "H":
                    ax.plot(px, py, "s", color="black", ms=5)
                elif s.type == "BP":
                    ax.plot(px, py, "o", mfc="white", mec="black", ms=5)
                elif s.type in ("LPC", "PD", "NS"):
                    ax.plot(px, py, "x", color="black", ms=5)
                else:
                    continue
                if labels and s.label != "BP0":
                    ax.annotate(s.label, (px, py), textcoords="offset points", xytext=(4, -9), fontsize=7)
        if compare and (compare_panel or panels[0]) == amp:
            curves = sorted({r["curve"] for r in compare})
            for k, c in enumerate(curves):
                pts = [r for r in compare if r["curve"] == c]
                for st in (True, False):
                    sel = [r for r in pts if r["stable"] == st]
                    if sel:
                        ax.plot([r["x"] for r in sel], [r["y"] for r in sel], ls="none", marker="o",
                                ms=4, mec="tab:red", mfc="tab:red" if st else "white",
                                label=f"{compare_label} {c}".strip() if st or not any(r["stable"] for r in pts) else None)
            ax.legend(fontsize=7, frameon=False)
        if overlay:
            _plot_overlay(ax, overlay, x, amp)
        ax.set_ylabel(AXIS_LABELS.get(amp, amp))
        ax.margins(y=0.1)      # room for the branch names above the highest point
        ax.set_ylim(bottom=0.0)
        ax.tick_params(direction="in", top=True, right=True, labelsize=8)
        ax.ticklabel_format(axis="y", style="sci", scilimits=(-3, 3))
    axes[-1].set_xlabel(AXIS_LABELS.get(x, x))
    if title:
        axes[0].set_title(title, fontsize=9)
    fig.tight_layout()
    return _save_formats(fig, stem)


def plot_plane(results, stem: str | Path, *, x: str, y: str, title: str = "", labels: bool = True) -> list[Path]:
    """Draw the two-parameter curves (kinds "fold", "hopf") of ``results`` in the (``x``, ``y``)
    parameter plane with their labelled points, and the LP/H points of the one-parameter branches
    that lie in it; write ``<stem>.png`` and ``<stem>.pdf``. Returns the two paths."""
    with _matplotlib_quiet():
        return _plot_plane(results, stem, x=x, y=y, title=title, labels=labels)


def _plot_plane(results, stem, *, x, y, title, labels) -> list[Path]:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    stem = Path(stem)
    stem.parent.mkdir(parents=True, exist_ok=True)
    fig = Figure(figsize=(6.0, 4.2))
    FigureCanvasAgg(fig)
    ax = fig.subplots()
    styles = {"fold": dict(color="black"), "hopf": dict(color="tab:blue"), "branch_point": dict(color="tab:green")}
    markers = {"CP": "^", "BT": "D", "GH": "v", "ZH": "P", "DH": "X", "LP": "o", "H": "s"}
    drawn = set()
    for b in results.branches:
        if b.kind in ("fold", "hopf", "branch_point") and x in b.table and y in b.table and len(b):
            for sx, sy, st in _segments(np.asarray(b.table[x]), np.asarray(b.table[y]), np.asarray(b.stable)):
                ax.plot(sx, sy, lw=_THICK, ls="-" if st else "--",
                        label=None if b.kind in drawn else {"fold": "folds (LP)", "hopf": "Hopf points (H)",
                                                             "branch_point": "pitchforks (BP)"}[b.kind],
                        **styles[b.kind])
                drawn.add(b.kind)
            i = len(b) // 2
            ax.annotate(b.name, (b.table[x][i], b.table[y][i]), textcoords="offset points", xytext=(3, 4), fontsize=8)
        for s in b.special_points:
            if x not in s.parameters or y not in s.parameters:
                continue
            if b.kind in ("fold", "hopf", "branch_point"):
                if s.type not in markers:
                    continue
                filled = s.origin == "autocable"
            elif s.type in ("LP", "H"):
                filled = False
            else:
                continue
            px, py = s.parameters[x], s.parameters[y]
            ax.plot(px, py, markers[s.type], color="black", mfc="black" if filled else "white", ms=5)
            if labels and b.kind in ("fold", "hopf", "branch_point"):
                ax.annotate(s.label, (px, py), textcoords="offset points", xytext=(4, -9), fontsize=7)
    if drawn:
        ax.legend(fontsize=7, frameon=False)
    ax.set_xlabel(AXIS_LABELS.get(x, x))
    ax.set_ylabel(AXIS_LABELS.get(y, y))
    ax.margins(0.05)
    ax.tick_params(direction="in", top=True, right=True, labelsize=8)
    ax.ticklabel_format(style="sci", scilimits=(-3, 3))
    if title:
        ax.set_title(title, fontsize=9)
    fig.tight_layout()
    return _save_formats(fig, stem)


def _time_panel(ax, series, amp: str, window, ode21_diverged: bool) -> None:
    """One amplitude against time, over the whole run or over ``window`` = (t0, t1)."""
    k = 1 if amp == "a1" else 2

    def part(t, a):
        t = np.asarray(t, dtype=float)
        a = np.asarray(a, dtype=float)
        if window is None:
            return t, a
        keep = (t >= window[0]) & (t <= window[1])
        return t[keep], a[keep]

    if "ame" in series:
        t, *a = series["ame"]
        ax.plot(*part(t, a[k - 1]), color="black", lw=_THICK, label="AME (24)")
    if "ode21" in series:
        t, *a = series["ode21"]
        if len(t):
            ax.plot(*part(t, a[k - 1]), color="tab:blue", lw=_THIN, label="eq. (21): envelope")
        if ode21_diverged and window is None:
            t_div = float(t[-1]) if len(t) else 0.0
            ax.plot([t_div], [1.0], marker="v", ms=6, color="tab:red", ls="none",
                    transform=ax.get_xaxis_transform(), clip_on=False,
                    label=f"eq. (21) diverges (t = {t_div:.4g})")
    ax.set_ylabel(AXIS_LABELS.get(amp, amp))
    ax.set_ylim(bottom=0.0)
    ax.tick_params(direction="in", top=True, right=True, labelsize=8)
    ax.ticklabel_format(axis="y", style="sci", scilimits=(-3, 3))
    if window is None:
        ax.legend(fontsize=7, frameon=False, loc="best")


def plot_time_series(series, stem: str | Path, *, y: Sequence[str] = ("a1", "a2"), title: str = "",
                     ode21_message: str = "", ode21_diverged: bool = False,
                     zoom: tuple[float, float] | None = None) -> list[Path]:
    """Fig. 11: a1(t), a2(t) of the AME (thick) and the amplitude envelope of eq. (21) (thin, half
    peak-to-peak per forcing period) on the same axes, one panel per amplitude. ``series`` maps
    "ame" / "ode21" to (t, a1, a2) arrays. A divergence of eq. (21) is marked where it happens
    (a caret on the top edge) and named in the legend. ``zoom = (t0, t1)`` adds a right-hand column
    with that window (a few modulation periods). Writes ``<stem>.png`` and ``<stem>.pdf``."""
    with _matplotlib_quiet():
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        stem = Path(stem)
        stem.parent.mkdir(parents=True, exist_ok=True)
        panels = list(y)
        ncol = 2 if zoom else 1
        fig = Figure(figsize=(6.5 if ncol == 1 else 10.0, 2.8 * len(panels)))
        FigureCanvasAgg(fig)
        grid = fig.subplots(len(panels), ncol, sharex="col", squeeze=False)
        for col in range(ncol):
            window = zoom if col == 1 else None
            for ax, amp in zip(grid[:, col], panels):
                _time_panel(ax, series, amp, window, ode21_diverged)
            grid[-1, col].set_xlabel(r"$t$")
        if zoom:
            grid[0, 1].set_title(f"last {zoom[1] - zoom[0]:.4g} time units", fontsize=8)
        axes = grid[:, 0]
        if title:
            (fig.suptitle if zoom else axes[0].set_title)(title, fontsize=9)
        fig.tight_layout()
        return _save_formats(fig, stem)
