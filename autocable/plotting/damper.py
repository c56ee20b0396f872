"""The universal curve of `autocable damper`: the added damping ratio over x_d/L against the damper
parameter kappa = c k pi x_d / (L sqrt(T m)), one exact curve per mode (taut string), Krenk's
asymptotic kappa / (1 + kappa^2) beside them, each mode's optimum and the given constant marked,
and the design target when there is one. Reads the report's rows only (damper.json)."""
from __future__ import annotations

from pathlib import Path

from autocable.plotting.style import new_figure, save_figure, styled


def plot_damper(report: dict, stem: str | Path, title: str = "") -> list[Path]:
    """``stem``.png/.pdf from the dict `autocable.cli.damper` writes as damper.json."""
    import numpy as np

    with styled():
        fig = new_figure((6.4, 4.2))
        ax = fig.subplots()
        support = report["damper"].get("support_stiffness_N_m")
        first = True
        for j, curve in enumerate(report.get("curves", [])):
            rows = curve["rows"]
            color = f"C{j % 10}"
            ax.plot([r["kappa"] for r in rows], [r["zeta_over_r"] for r in rows], "-", color=color, lw=1.2,
                    label=f"mode {curve['k']}, exact (taut string)")
            opt, given = curve["optimum"], curve["given"]
            ax.plot(opt["kappa"], opt["zeta_over_r"], "o", color=color, ms=5, mfc="none",
                    label="optimum" if first else None)
            ax.plot(given["kappa"], given["zeta_over_r"], "x", color=color, ms=7,
                    label=f"c = {report['damper']['constant_N_s_m']:.4g} N s/m" if first else None)
            first = False
        if report.get("curves"):
            rows = report["curves"][0]["rows"]
            ax.plot([r["kappa"] for r in rows], [r["asymptotic_over_r"] for r in rows], "k--", lw=1.0,
                    label=r"Krenk (2000): $\kappa\,/\,(1+\kappa^2)$" + (", support spring" if support else ""))
        ds = report.get("design")
        if ds and ds.get("target_added_damping", 0) > 0:
            # the target is met by the design value (bending and sag), not by the bare string's cross
            md = next((m for m in report.get("modes", []) if m["k"] == ds["mode"]), None)
            if md is not None:
                ax.plot(md["kappa"], md["added_damping_corrected"] / report["damper"]["position_ratio"], "+",
                        color="C3", ms=9, label=f"mode {ds['mode']} with bending and sag (design value)")
            y = ds["target_added_damping"] / report["damper"]["position_ratio"]
            ax.axhline(y, color="C3", lw=0.8, ls=":",
                       label=f"design wind {ds['design_wind_m_s']:g} m/s: mode {ds['mode']} needs "
                             f"{100 * ds['target_added_damping']:.3g} %")
        ax.set_xscale("log")
        ax.set_xlabel(r"damper parameter $\kappa = c\,k\pi\,x_d / (L\sqrt{Tm})$")
        ax.set_ylabel(r"added damping ratio $\zeta_k\,/\,(x_d/L)$")
        ys = [r["zeta_over_r"] for c in report.get("curves", []) for r in c["rows"]] + [0.5]
        if ds and ds.get("target_added_damping", 0) > 0:
            ys.append(ds["target_added_damping"] / report["damper"]["position_ratio"])
        ax.set_ylim(0, 1.15 * float(np.nanmax(ys)))
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=7, loc="upper left")
        if title:
            ax.set_title(title, fontsize=9)
        fig.tight_layout()
        paths = save_figure(fig, Path(stem))
    return paths
