"""The damping picture of `autocable onset --damping`: U_cr against the Scruton number (with the
design recommendations' Sc rules drawn as the empirical reference they are) and the post-critical
amplitude at mid-span against U for a few damping ratios. Reads the study's rows only."""
from __future__ import annotations

import math
from pathlib import Path

from autocable.plotting.style import new_figure, save_figure, styled


def plot_onset(study: dict, stem: str | Path, title: str = "") -> list[Path]:
    """``stem``.png/.pdf from the dict `autocable.cli.onset` writes as onset.json."""
    with styled():
        fig = new_figure((11, 4.2))
        ax1, ax2 = fig.subplots(1, 2)
        rows = study.get("damping", [])
        styles = {"supercritical": ("o", "C0"), "subcritical": ("s", "C3")}
        for crit, (marker, color) in styles.items():
            pts = [(r["scruton"], r["U_cr_m_s"]) for r in rows
                   if r["criticality"] == crit and r["U_cr_m_s"] is not None and math.isfinite(r["U_cr_m_s"])]
            if pts:
                ax1.plot(*zip(*pts), marker, ms=3, color=color, label=f"eq. (21) onset, {crit}")
        none = [r["scruton"] for r in rows if r["U_cr_m_s"] is None or not math.isfinite(r["U_cr_m_s"])]
        scan_top = study.get("scanned_U_m_s", [0, 1])[1]
        if none:
            ax1.plot(none, [scan_top] * len(none), "^", ms=3, color="0.5",
                     label=f"stable up to {scan_top:.3g} m/s (the scan)")
        top = max([r["U_cr_m_s"] for r in rows if r["U_cr_m_s"] is not None
                   and math.isfinite(r["U_cr_m_s"])] + [study.get("scanned_U_m_s", [0, 1])[1]])
        for Sc, label in study.get("scruton_rules", []):
            ax1.axvline(Sc, color="0.4", ls="--" if Sc >= 10 else ":", lw=1, label=label)
        d = study.get("design")
        if d:
            ax1.axhline(d["design_wind_m_s"], color="C2", lw=0.8,
                        label=f"design wind {d['design_wind_m_s']:g} m/s: Sc >= {d['scruton']:.3g}")
        ax1.set_xlabel("Scruton number Sc = m xi / (rho_a D^2)")
        ax1.set_ylabel("onset wind speed U_cr [m/s]")
        ax1.set_ylim(0, top * 1.05)
        ax1.legend(fontsize=7, loc="best")
        ax1.grid(alpha=0.3)
        for k, curve in enumerate(study.get("amplitude", [])):
            pts = [(r["U_m_s"], r["peak_in_plane_m"], r["stable"]) for r in curve["rows"]
                   if r["peak_in_plane_m"] is not None]
            color = f"C{k}"
            for stable, ls in ((True, "-"), (False, "--")):
                xs = [p[0] if p[2] is stable else math.nan for p in pts]
                ys = [p[1] if p[2] is stable else math.nan for p in pts]
                if any(not math.isnan(x) for x in xs):
                    ax2.plot(xs, ys, ls, color=color,
                             label=f"xi = {100 * curve['damping_ratio']:.3g} % (AME){'' if stable else ', unstable'}")
            chk = [(c["U_m_s"], c["peak_in_plane_m_eq21"]) for c in curve.get("eq21_checks", [])
                   if c.get("peak_in_plane_m_eq21") is not None]
            if chk:
                ax2.plot(*zip(*chk), "x", color=color, ms=7, label="eq. (21), integrated")
            hys = [(c["U_m_s"], c["a1_unstable_cycle"] * study["length_m"]) for c in curve.get("hysteresis_checks", [])
                   if c.get("hysteresis")]
            if hys and "length_m" in study:
                ax2.plot(*zip(*hys), "d", color=color, ms=6, mfc="none",
                         label="eq. (21): decays from below, grows from above")
        ax2.set_xlabel("wind speed U [m/s]")
        ax2.set_ylabel("in-plane peak displacement at mid-span [m]")
        ax2.legend(fontsize=7, loc="best")
        ax2.grid(alpha=0.3)
        if title:
            fig.suptitle(title, fontsize=10)
        fig.tight_layout()
        paths = save_figure(fig, Path(stem))
    return paths
