"""The band of `autocable onset --band`: one row per combination of the inputs nobody knows (onset
speed U_c, angle reading, the yaw's sign, calibration root), its onset speed and, with a design
wind, its least damping ratio (and the least damper constant with a ``[damper]``) as points, the
band [lo, hi] shaded and its two ends ringed; a combination without an admissible calibration is a
row with a cross and no value. Below the panels, the galloping amplitude at the design wind over
the band and the curves' band and blend (`autocable.studies.band.amplitude_band`), with the
combination and curves setting each end, or why the curves are not varied. Reads the ``band``
object only (onset.json)."""
from __future__ import annotations

from pathlib import Path

from autocable.plotting.style import new_figure, save_figure, styled

#: (key of a case, axis label, scale of the value on the axis)
PANELS = (("onset_U_m_s", "onset speed [m/s]", 1.0),
          ("least_damping", "least damping ratio [%]", 100.0),
          ("damper_constant_N_s_m", "least damper constant [N s/m]", 1.0))


def plot_band(band: dict, stem: str | Path, title: str = "") -> list[Path]:
    """``stem``.png/.pdf of a `autocable.studies.band.band_study` result."""
    cases = band["cases"]
    panels = [p for p in PANELS if p[0] in band]
    with styled():
        fig = new_figure((3.2 * len(panels) + 2.6, 0.9 + 0.22 * max(len(cases), 4)))
        axes = fig.subplots(1, len(panels), sharey=True, squeeze=False)[0]
        ys = list(range(len(cases)))[::-1]
        colors = {"eq12": "C0", "mirrored": "C1"}
        for ax, (key, label, scale) in zip(axes, panels):
            rng = band.get(key)
            if rng is not None:
                ax.axvspan(rng[0] * scale, rng[1] * scale, color="0.88", zorder=0, label="band")
            for y, c in zip(ys, cases):
                v = c.get(key)
                if c["status"] != "ok" or v is None:
                    if ax is axes[0] and c["status"] != "ok":
                        ax.text(0.02, y, "no admissible calibration" if c["status"] == "no calibration" else "failed",
                                transform=ax.get_yaxis_transform(),
                                va="center", fontsize=6, color="0.4")
                    elif key == "onset_U_m_s" and c["status"] == "ok":
                        # no onset over the case's scan: said at the right edge, not left blank
                        ax.text(0.98, y, f"stable to {c['scanned_U_m_s']:.3g} m/s >",
                                transform=ax.get_yaxis_transform(), va="center", ha="right", fontsize=6, color="0.4")
                    continue
                ax.plot(v * scale, y, "o", ms=3.5, color=colors.get(c["inputs"]["angle_convention"], "k"))
            if rng is not None:
                for end in ("lo", "hi"):
                    by = band["set_by"][key][end]["label"]
                    i = next(k for k, c in enumerate(cases) if c["label"] == by)
                    ax.plot(rng[0 if end == "lo" else 1] * scale, ys[i], "o", ms=8, mfc="none", color="C3")
            vals = [c[key] for c in cases if c.get(key) is not None]
            if key == "damper_constant_N_s_m" and vals and min(vals) > 0 and max(vals) > 100 * min(vals):
                ax.set_xscale("log")      # constants of cases that need almost nothing and of those that need much
            ax.set_xlabel(label, fontsize=8)
            ax.grid(alpha=0.3, axis="x")
        axes[0].set_yticks(ys)
        axes[0].set_yticklabels([c["label"] for c in cases], fontsize=6)
        axes[0].set_ylim(-0.7, len(cases) - 0.3)
        handles = [axes[0].plot([], [], "o", ms=3.5, color=col, label=f'"{conv}" reading')[0]
                   for conv, col in colors.items()]
        handles.append(axes[0].plot([], [], "o", ms=8, mfc="none", color="C3", label="end of the band")[0])
        fig.legend(handles=handles, loc="upper center", ncol=3, fontsize=7, frameon=False,
                   bbox_to_anchor=(0.5, 1.0))
        note = amplitude_note(band)
        if note:
            fig.text(0.01, 0.0, note, fontsize=6.5, va="top", ha="left", color="0.2")
        if title:
            fig.suptitle(title, fontsize=9, y=1.04)
        fig.tight_layout(rect=(0, 0, 1, 0.95))
        paths = save_figure(fig, Path(stem))
    return paths


def amplitude_note(band: dict) -> str:
    """The lines under the panels on the galloping amplitude of the band ("" where not asked)."""
    if "amplitude_at_design_wind_m" not in band:
        return ""
    amp = band["amplitude_at_design_wind_m"]
    if amp is None:
        return f"galloping amplitude: {band.get('amplitude_note', 'not computed')}"
    lines = [f"largest stable galloping cycle at {band['design_wind_m_s']:g} m/s ({amp['load']} load), over "
             f"{len(amp['cases'])} combination(s) x nominal curves, valid range "
             f"+-{amp['curves_varied']['band_deg']:g} deg, blend x"
             + ", x".join(f"{f:g}" for f in amp["curves_varied"]["blend_factors"]) + ":"]
    for key, name in (("in_plane", "in-plane"), ("out_of_plane", "out-of-plane")):
        if amp[key] is None:
            lines.append(f"  {name}: no stable cycle")
            continue
        ends = []
        for end in ("lo", "hi"):
            b = amp["set_by"][key][end]
            flag = " [beyond valid range]" if b["beyond_valid_range"] else ""
            ends.append(f"{end} {b['combination']}, {b['curves']}{flag}")
        lines.append(f"  {name}: {amp[key][0]:.3g} - {amp[key][1]:.3g} m  ({'; '.join(ends)})")
    if band.get("least_damping_global") is not None:
        g = band["least_damping_global"]
        lines.append(f"  global least damping: {100 * g[0]:.3g} - {100 * g[1]:.3g} %")
    return "\n".join(lines)
