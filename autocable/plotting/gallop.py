"""The picture of `autocable gallop`: the galloping cycles' peak displacements at mid-span against the
wind speed, in-plane and out-of-plane, one colour per damping ratio, stable cycles solid and unstable
ones dashed, the folds of cycles and the Hopf points marked, the design wind as a vertical line; where
the study has one, its sensitivity to the curves' band and blend as a shaded range of the lowest
galloping speed and an error bar at the design wind; stable cycles at the design wind that no branch
drawn holds (`other_stable_cycles`, `off_branch_cycle`) as stars.
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


def _sensitivity(axes, sens: dict, design) -> None:
    """The sensitivity to the curves' band and blend (`autocable.studies.gallop.sensitivity`): the
    range of the lowest galloping speed shaded, the range of each peak at the design wind as an
    error bar about the nominal cycle (a bare bar where the nominal case has no stable cycle there)."""
    if not sens.get("defined") or sens.get("computed") is False:
        return
    low = (sens.get("lowest_galloping_U_m_s") or {}).get("range")
    amp = sens.get("amplitude_at_design_wind_m") or {}
    nominal, ranges = amp.get("nominal"), amp.get("range") or [None, None]
    label = f"band +-{sens['band_deg']:g} deg, blend x" + ", x".join(f"{f:g}" for f in sens["blend_factors"])
    for i, ax in enumerate(axes):
        if low and _finite(low[0]) and _finite(low[1]):
            ax.axvspan(low[0], max(low[1], low[0] + 1e-3), color="C0", alpha=0.13, lw=0,
                       label=f"lowest galloping speed, {label}")
        r = ranges[i]
        if not (_finite(design) and r and _finite(r[0]) and _finite(r[1])):
            continue
        if nominal and _finite(nominal[i]):
            y = nominal[i]
            ax.errorbar([design], [y], yerr=[[y - r[0]], [r[1] - y]], fmt="s", color="k", ms=4, capsize=4,
                        lw=1.2, zorder=5, label=f"at the design wind, {label}")
        else:
            ax.errorbar([design], [0.5 * (r[0] + r[1])], yerr=[[0.5 * (r[1] - r[0])]] * 2, fmt="none", ecolor="k",
                        capsize=4, lw=1.2, zorder=5, label=f"at the design wind, {label} (no nominal cycle)")


def plot_gallop(study: dict, stem: str | Path, title: str = "") -> list[Path]:
    """``stem``.png/.pdf from the dict of `gallop_study` (module docstring)."""
    U_top = study.get("scanned_U_m_s", [0.0, None])[1]
    with styled():
        fig = new_figure((11, 4.4))
        axes = fig.subplots(1, 2)
        keys = (("peak_in_plane_m", "in-plane"), ("peak_out_of_plane_m", "out-of-plane"))
        open_end = False
        off_drawn = False
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
                    beyond = [r for r in rows if r.get("beyond_valid_range")]
                    if beyond:          # where the curves, the twist law or the cubic load no longer hold
                        ax.plot([r["U_m_s"] for r in beyond], [r[key] for r in beyond], "x", color="0.45",
                                ms=3.5, mew=0.8, zorder=3)
                    folds = [r for r in rows if r.get("kind") == "LPC"]
                    if folds:
                        ax.plot([r["U_m_s"] for r in folds], [r[key] for r in folds], "o", color=color, mfc="white",
                                ms=5, zorder=4)
                    if hp.get("lowest_galloping_U_bound") and rows:
                        # the branch is still descending where it ends: its lowest speed is not known,
                        # galloping exists there and may exist lower still (studies.gallop.lowest_bound)
                        ax.plot([rows[-1]["U_m_s"]], [rows[-1][key]], "<", color=color, ms=7, zorder=4,
                                clip_on=False)
                        open_end = True
                    if not _finite(U_top) or hp["hopf_U_m_s"] <= U_top:
                        # unclipped (half of it lies below the axis), so only inside the range drawn
                        ax.plot([hp["hopf_U_m_s"]], [0.0], "^", color=color, ms=6, zorder=4, clip_on=False)
                if first:                       # no stable cycle: the legend still names the damping
                    ax.plot([], [], "--", color=color, label=label)
            # stable cycles at the design wind on no branch drawn (found by integration from larger starts)
            des = study.get("design_wind_m_s")
            off = [o for o in case.get("other_stable_cycles") or [] if not o.get("on_branch")]
            if case.get("off_branch_cycle"):
                off.append(case["off_branch_cycle"])
            for i, (ax, _) in enumerate(zip(axes, keys)):
                ys = [o["peak_m"][i] for o in off if _finite(o["peak_m"][i])]
                if ys and _finite(des):
                    ax.plot([des] * len(ys), ys, "*", color=color, ms=10, mec="k", mew=0.5, zorder=6)
                    off_drawn = True
        design = study.get("design_wind_m_s")
        _sensitivity(axes, study.get("sensitivity") or {}, design)
        for n, (ax, (key, name)) in enumerate(zip(axes, keys)):
            if _finite(design):
                ax.axvline(design, color="0.35", lw=0.9, ls=":", label=f"design wind {design:g} m/s")
            ax.plot([], [], "o", color="0.3", mfc="white", ms=5, label="fold of cycles (LPC)")
            ax.plot([], [], "^", color="0.3", ms=6, label="Hopf point of the rest state")
            ax.plot([], [], "--", color="0.3", lw=1.0, label="unstable cycle")
            ax.plot([], [], "x", color="0.45", ms=3.5, mew=0.8,
                    label="beyond the model's range (phi, twist or cubic load: validity)")
            if off_drawn:
                ax.plot([], [], "*", color="0.3", ms=10, mec="k", mew=0.5,
                        label="stable cycle off the branches at the design wind (reached by integration)")
            if open_end:
                ax.plot([], [], "<", color="0.3", ms=7, label="branch ends still descending: lowest galloping "
                                                            "speed at most there")
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
