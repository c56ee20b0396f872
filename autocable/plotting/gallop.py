"""The picture of `autocable gallop`: the galloping cycles' peak displacements at mid-span against the
wind speed, in-plane and out-of-plane, one colour per damping ratio, stable cycles solid and unstable
ones dashed, the folds of cycles and the Hopf points marked, the design wind as a vertical line.
Reads the study's dict only (`autocable.studies.gallop.gallop_study`, as gallop.json holds it)."""
from __future__ import annotations

import math
from pathlib import Path

from autocable.plotting.style import new_figure, save_figure, styled


def _runs(rows):
    """Consecutive rows of one stability, each run extended by the next run's first row so that the
    curve stays connected; the Hopf row (stable None) joins the run after it."""
    runs, cur, style = [], [], None
    for r in rows:
        s = r.get("stable")
        s = style if s is None else bool(s)
        if cur and s != style and style is not None:
            runs.append((style, cur + [r]))
            cur = []
        cur.append(r)
        style = s if s is not None else style
    if cur:
        runs.append((bool(style), cur))
    return runs


def _finite(x) -> bool:
    return x is not None and isinstance(x, (int, float)) and math.isfinite(x)


def plot_gallop(study: dict, stem: str | Path, title: str = "") -> list[Path]:
    """``stem``.png/.pdf from the dict of `gallop_study` (module docstring)."""
    U_top = study.get("scanned_U_m_s", [0.0, None])[1]
    with styled():
        fig = new_figure((11, 4.4))
        axes = fig.subplots(1, 2)
        keys = (("peak_in_plane_m", "in-plane"), ("peak_out_of_plane_m", "out-of-plane"))
        for k, case in enumerate(study.get("cases", [])):
            color = f"C{k}"
            label = f"damping {100 * case['damping_ratio']:.3g} % (Sc = {case['scruton']:.3g})"
            for ax, (key, _) in zip(axes, keys):
                first = True
                for hp in case.get("hopf_points", []):
                    rows = [r for r in hp["rows"] if _finite(r.get("U_m_s")) and _finite(r.get(key))]
                    for stable, run in _runs(rows):
                        ax.plot([r["U_m_s"] for r in run], [r[key] for r in run], "-" if stable else "--",
                                color=color, lw=1.4 if stable else 1.0, label=label if first and stable else None)
                        first = first and not stable
                    folds = [r for r in rows if r.get("kind") == "LPC"]
                    if folds:
                        ax.plot([r["U_m_s"] for r in folds], [r[key] for r in folds], "o", color=color, mfc="white",
                                ms=5, zorder=4)
                    if not _finite(U_top) or hp["hopf_U_m_s"] <= U_top:
                        # unclipped (half of it lies below the axis), so only inside the range drawn
                        ax.plot([hp["hopf_U_m_s"]], [0.0], "^", color=color, ms=6, zorder=4, clip_on=False)
                if first:                       # no stable cycle: the legend still names the damping
                    ax.plot([], [], "--", color=color, label=label)
        design = study.get("design_wind_m_s")
        for n, (ax, (key, name)) in enumerate(zip(axes, keys)):
            if _finite(design):
                ax.axvline(design, color="0.35", lw=0.9, ls=":", label=f"design wind {design:g} m/s")
            ax.plot([], [], "o", color="0.3", mfc="white", ms=5, label="fold of cycles (LPC)")
            ax.plot([], [], "^", color="0.3", ms=6, label="Hopf point of the rest state")
            ax.plot([], [], "--", color="0.3", lw=1.0, label="unstable cycle")
            ax.set_xlabel("wind speed U [m/s]")
            ax.set_ylabel(f"{name} peak displacement at mid-span [m]")
            if _finite(U_top):
                ax.set_xlim(0.0, U_top)
            ax.set_ylim(bottom=0.0)
            ax.grid(alpha=0.3)
            if n == 0:          # one legend: both panels draw the same curves
                ax.legend(fontsize=7, loc="upper left")
        if title:
            fig.suptitle(title, fontsize=10)
        fig.tight_layout()
        paths = save_figure(fig, Path(stem))
    return paths
