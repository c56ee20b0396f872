"""The failure map as files: failure_map.md (the 2 % statement, the reading, one table row per grid
point) and one figure per plane, failure_map_<k>.png, with panels (a) AME error, (b) stability
disagreements, (c) where the methods struggle; the 5 % AME-error boundary is drawn on every panel.
The numbers come from `autocable.studies.failure_map.run_failure_map`; nothing here computes physics."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from autocable.studies.failure_map import STIFF_RATIO, point_class
from autocable.plotting.style import styled

_SHORT = {"same-branch": "same", "different-branch": "diff. branch", "no-ame-branch": "no AME branch",
          "quasi-periodic-21": "(21) quasi-periodic", "ame-not-equilibrium": "AME not equilibrium",
          "diverged-both": "both diverge", "diverged-21": "(21) diverges", "diverged-ame": "AME diverges"}
#: Labels of the statuses on panel (a) (explained in its title).
_TAG = {"same-branch": "", "different-branch": "diff", "no-ame-branch": "no br", "quasi-periodic-21": "qp",
        "ame-not-equilibrium": "AME qp", "diverged-both": "div", "diverged-21": "div", "diverged-ame": "AME div"}
#: Marker and colour of each stability verdict in panel (b).
_VERDICT_STYLE = {"agree": ("o", "tab:green"), "AME unstable, (21) stable": ("v", "tab:red"),
                  "AME stable, (21) unstable": ("^", "tab:purple"),
                  "no AME equilibrium at (21)'s response": ("X", "tab:orange"),
                  "AME stable, no (21) orbit found": ("s", "tab:brown"),
                  "agree (neither period-1)": ("o", "tab:olive"), "n/a": (".", "0.6")}


def write_failure_map(result: dict, folder, command: str) -> list:
    """failure_map.md and the figures into ``folder``; returns the paths written."""
    from autocable._store import atomic_write_text

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    pngs = []
    for k, plane in enumerate(result["planes"], start=1):
        path = folder / f"failure_map_{k}.png"
        plot_plane(plane, result, path)
        pngs.append(path)
    md = folder / "failure_map.md"
    atomic_write_text(md, markdown(result, [p.name for p in pngs], command))
    return [md, *pngs]


def _grid(plane: dict, key):
    """(sigma, values) mesh and ``key(row)`` on it (NaN where it gives None)."""
    s, v = plane["sigmas"], plane["values"]
    Z = np.full((len(v), len(s)), np.nan)
    for r in plane["rows"]:
        i, j = v.index(r[plane["axis"]]), s.index(r["sigma"])
        x = key(r)
        Z[i, j] = np.nan if x is None else x
    X, Y = np.meshgrid(s, v)
    return X, Y, Z


def _error_field(r):
    """log10 of the relative a1 error; a point with no error to show (no AME branch, divergence of
    the AME) counts as failed (10x); where eq. (21) diverges the field is undefined."""
    if r["status"] in ("diverged-21", "diverged-both"):
        return None
    if r["rel_a1"] is None or r["rel_a1"] <= 0:
        return 1.0
    return math.log10(r["rel_a1"])


def _boundary(ax, plane, result):
    X, Y, Z = _grid(plane, _error_field)
    if min(Z.shape) < 2 or np.all(np.isnan(Z)):
        return
    for level, style in ((result["contour"], "-"), (result["tolerance"], ":")):
        lv = math.log10(level)
        if np.nanmin(Z) < lv < np.nanmax(Z):
            cs = ax.contour(X, Y, np.ma.masked_invalid(Z), levels=[lv], colors="k", linestyles=style,
                            linewidths=1.4 if style == "-" else 0.9)
            ax.clabel(cs, fmt={lv: f"{100 * level:g} %"}, fontsize=7)


@styled()      # the package's one look (autocable.plotting.style)
def plot_plane(plane: dict, result: dict, path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ax_name = plane["axis"]
    fixed = ", ".join(f"{k} = {v:g}" for k, v in plane["fixed"].items())
    fig, axes = plt.subplots(1, 3, figsize=(17, 6.2), constrained_layout=True)
    rows = plane["rows"]
    sig = [r["sigma"] for r in rows]
    val = [r[ax_name] for r in rows]

    # (a) the AME error.
    ax = axes[0]
    err = [r["rel_a1"] if r["rel_a1"] is not None else np.nan for r in rows]
    good = [point_class(r, result["tolerance"]) for r in rows]
    sc = ax.scatter(sig, val, c=np.log10(np.maximum(err, 1e-12)), cmap="viridis", vmin=-5, vmax=0,
                    s=140, marker="s", edgecolors=["k" if g == "within" else "none" for g in good])
    fig.colorbar(sc, ax=ax, label="log10 |a1 AME - a1 (21)| / a1 (21)")
    for r in rows:
        if r["status"] != "same-branch":
            ax.annotate(_TAG[r["status"]], (r["sigma"], r[ax_name]), fontsize=6, ha="center",
                        va="bottom", xytext=(0, 6), textcoords="offset points", color="r")
        if r["status"] in ("diverged-21", "diverged-both"):
            ax.plot(r["sigma"], r[ax_name], "rx", ms=9)
    ax.set_title(f"(a) AME relative a1 error, same start (framed: same branch, <= "
                 f"{100 * result['tolerance']:g} %)\ndiff: other branch, no br: no AME branch, qp: (21) "
                 "quasi-periodic, AME qp: AME not at equilibrium, div: (21) diverges", fontsize=8)

    # (b) stability: Floquet multipliers of (21) against the AME eigenvalues.
    ax = axes[1]
    seen = set()
    for r in rows:
        v = r["stability"]["verdict"]
        m, col = _VERDICT_STYLE[v]
        ax.plot(r["sigma"], r[ax_name], m, color=col, ms=9, label=None if v in seen else v)
        seen.add(v)
    ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=2)
    ax.set_title("(b) stability: Floquet multipliers of (21) vs AME eigenvalues", fontsize=9)

    # (c) where the methods struggle.
    ax = axes[2]
    steps = [r["steps"]["steps_dop853"] if r["steps"]["steps_dop853"] else np.nan for r in rows]
    sc = ax.scatter(sig, val, c=steps, cmap="magma_r", s=140, marker="o")
    fig.colorbar(sc, ax=ax, label="DOP853 steps per forcing period of (21)")
    for r in rows:
        if r["diverged_at"] is not None:
            ax.plot(r["sigma"], r[ax_name], "rx", ms=11, mew=2)
        if r["stiff"]:
            ax.plot(r["sigma"], r[ax_name], "o", mfc="none", mec="b", ms=16)
    for c in plane["continuation"]:
        y = c[ax_name]
        if c["stalled"]:
            ax.plot(c["end_sigma"], y, ">", color="r", ms=12)
            ax.annotate(c["end_reason"], (c["end_sigma"], y), fontsize=6, xytext=(4, -10),
                        textcoords="offset points", color="r")
        for s in c["special"]:
            ax.annotate(s["type"], (s["sigma"], y), fontsize=6, xytext=(0, 8), textcoords="offset points",
                        ha="center", color="0.35")
    ax.plot([], [], "rx", mew=2, label="(21) diverges")
    ax.plot([], [], ">", color="r", label="AME continuation stalls")
    ax.plot([], [], "o", mfc="none", mec="b", label=f"stiff: DOP853 > {STIFF_RATIO:g}x Radau steps")
    ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=2)
    ax.set_title("(c) struggles: continuation stalls (LP/H/BP: special points), steps, divergence",
                 fontsize=9)
    s_lo, s_hi = min(plane["sigmas"]), max(plane["sigmas"])
    v_lo, v_hi = min(plane["values"]), max(plane["values"])
    pad = 0.06 * (s_hi - s_lo)
    for ax in axes:
        _boundary(ax, plane, result)
        # The contours would otherwise set the limits and clip the edge rows of markers.
        ax.set_xlim(s_lo - pad, s_hi + pad)
        if ax_name == "eta":
            ax.set_ylim(v_lo / 1.5, v_hi * 1.5)
        else:
            ax.set_ylim(v_lo - 0.08 * (v_hi - v_lo), v_hi + 0.12 * (v_hi - v_lo))
        ax.set_xlabel("sigma (Omega = omega1 + sigma)")
        ax.set_ylabel(ax_name + "*")
        if ax_name == "eta":
            ax.set_yscale("log")
        ax.grid(True, alpha=0.3)
    fig.suptitle(f"Where methods fail, {fixed}: 2-dof AME (24) vs eq. (21) (solid: 5 % AME error, "
                 "dotted: 2 %)", fontsize=11)
    fig.savefig(path, dpi=100)
    plt.close(fig)


def _e(x, d=2) -> str:
    return "—" if x is None else f"{x:.{d}e}"


def _f(x, d) -> str:
    return "—" if x is None else f"{x:.{d}f}"


def _counts(rows, key) -> str:
    out = {}
    for r in rows:
        k = key(r)
        out[k] = out.get(k, 0) + 1
    return ", ".join(f"{k}: {v}" for k, v in sorted(out.items(), key=lambda kv: -kv[1]))


def markdown(result: dict, pngs, command: str) -> str:
    planes = result["planes"]
    allrows = [r for p in planes for r in p["rows"]]
    uniq = list({(r["U"], r["eta"], r["sigma"]): r for r in allrows}.values())
    lines = [
        "# Where methods fail: the 2-dof AME against eq. (21) over (sigma, eta) and (sigma, U)",
        "",
        f"Generated by `{command}` (do not edit by hand). Model `{result['model']}` (eq. 21 hash "
        f"`{result['ode_hash']}`); {len(uniq)} grid points, wall time {result['wall_s']:.0f} s "
        f"(CPU {result.get('cpu_s', math.nan):.0f} s in one process, on a shared machine).",
        "Omega = omega1 + sigma; a_k is the peak modal amplitude (docs/model.md, C1). At every point the "
        "AME (24) and eq. (21) start from the same state (rest, q2 = 1e-6) and are classified as in "
        "`docs/ame_vs_ode21.md` (`compare_with_ode21`). 'Within' a tolerance means: both on the same AME "
        "branch and |a1 AME - a1 (21)| / a1 (21) <= tolerance.",
        "",
        "## The region where the 2-dof AME is within 2 %",
        "",
    ]
    lines += [f"- {s}" for s in result["statement"]]
    thr = result.get("galloping_threshold_U")
    if thr is not None:
        lines.append(f"- Galloping threshold of eq. (21) (linear in-plane damping zero): U = {thr:.6g}. "
                     "Where eq. (21) diverges (finite-time blow-up of the cubic model with this "
                     "calibration) there is nothing to check the AME against: its answer there is "
                     "unchecked, not validated.")
    lines += ["", "## Reading the maps", ""]
    verdicts = _counts(uniq, lambda r: r["stability"]["verdict"])
    lines.append(f"- **Stability (b).** Verdicts over the grid: {verdicts}. "
                 "Where eq. (21) is period-1 its multipliers are those of the monodromy over one forcing "
                 "period from the response; where it is not, the period-1 orbit of (21) next to the "
                 "AME's stable equilibrium was sought by shooting (Newton on the stroboscopic map).")
    dis = [r for r in uniq if not r["stability"]["verdict"].startswith("agree") and r["stability"]["verdict"] != "n/a"]
    if dis:
        lines.append("  Disagreements at: " + "; ".join(
            f"(U = {r['U']:g}, eta = {r['eta']:g}, sigma = {r['sigma']:+.4g}): {r['stability']['verdict']}"
            + (f", max |mu| = {r['stability']['max_modulus']:.4f}" if r["stability"]["max_modulus"]
               is not None else "")
            + (f", AME max Re(lambda) = {r['stability']['ame_max_real']:.2e}"
               if r["stability"]["ame_max_real"] is not None else "")
            for r in sorted(dis, key=lambda r: (r["U"], r["eta"], r["sigma"]))) + ".")
    st = [r["steps"]["steps_dop853"] for r in uniq if r["steps"]["steps_dop853"]]
    sr = [r["steps"]["steps_radau"] for r in uniq if r["steps"]["steps_radau"]]
    ms = [r["ode21_ms_per_period"] for r in uniq if r["ode21_ms_per_period"] and r["diverged_at"] is None]
    stiff = [r for r in uniq if r["stiff"]]
    ratios = [r["steps"]["steps_dop853"] / r["steps"]["steps_radau"] for r in uniq
              if r["steps"]["steps_dop853"] and r["steps"]["steps_radau"]]
    if st:
        lines.append(f"- **Integration effort (c).** Over one forcing period of the steady response at "
                     f"rtol 1e-10: DOP853 {min(st)}-{max(st)} steps (median {int(np.median(st))}), "
                     f"Radau (exact Jacobian) {min(sr)}-{max(sr)} steps. "
                     + (f"Stiff (DOP853 > {STIFF_RATIO:g}x Radau steps) at {len(stiff)} points: " + ", ".join(
                         f"(U = {r['U']:g}, eta = {r['eta']:g}, sigma = {r['sigma']:+.4g})" for r in stiff)
                        if stiff else "No point is stiff by that test: DOP853 needs at most "
                                      f"{max(ratios):.2f}x the steps of Radau (it needs fewer: the "
                                      "higher order wins on this smooth, lightly damped oscillator), so "
                                      "no stiff handling is needed wherever eq. (21) stays bounded.")
                     + (f" Compiled integration wall time per forcing period: {min(ms):.3f}-{max(ms):.3f} ms."
                        if ms else ""))
    div = [r for r in uniq if r["diverged_at"] is not None]
    if div:
        lines.append(f"- **Divergence (c).** Eq. (21) diverges at {len(div)} points (the compiled "
                     "integrator's step collapses on a finite-time blow-up), after t = "
                     + ", ".join(sorted({f"{r['diverged_at']:.0f}" for r in div}, key=float))
                     + " (t* units, a whole number of 100-period chunks before the one that failed).")
    cont = list({(c["U"], c["eta"]): (p["name"], c) for p in planes for c in p["continuation"]}.values())
    stalls = [(n, c) for n, c in cont if c["stalled"]]
    lines.append(f"- **Continuation (c).** Coarse EP-C of the AME equilibria in sigma on every row, forward "
                 f"from the small forced response at the lower end: {len(cont)} rows, "
                 + (f"{len(stalls)} stall(s) (the branch ended inside the range): " + "; ".join(
                     f"U = {c['U']:g}, eta = {c['eta']:g}: {c['end_reason']} at sigma = {c['end_sigma']:+.4g} "
                     f"after {c['points']} points ({c['message'][:90]})" for _, c in stalls)
                    if stalls else "no stall: every branch reached the end of the range")
                 + "".join(f". U = {c['U']:g}, eta = {c['eta']:g}: not a stall, but the branch turned back "
                           f"at a fold and left the range at sigma = {c['end_sigma']:+.4g} (the rest of the "
                           "row needs another start)" for _, c in cont if c.get("turned_back"))
                 + ". Special points met (LP fold, H Hopf, BP branch point): " + "; ".join(
                     f"U = {c['U']:g}, eta = {c['eta']:g}: " + (", ".join(
                         f"{s['type']} {s['sigma']:+.4f}" for s in c["special"]) or "none")
                     for _, c in cont) + ".")
    for k, (p, png) in enumerate(zip(planes, pngs), start=1):
        fixed = ", ".join(f"{a} = {v:g}" for a, v in p["fixed"].items())
        lines += ["", f"## Map {k}: sigma against {p['axis']}, {fixed}", "", f"![failure map {k}]({png})", "",
                  f"Statuses: {_counts(p['rows'], lambda r: _SHORT[r['status']])}.", "",
                  f"| {p['axis']} | sigma | status | a1 (21) | a1 AME | rel. err a1 | 2 % | stability "
                  "| max \\|mu\\| (21) | AME max Re | DOP853 / Radau steps | ms/period | note |",
                  "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
        for r in p["rows"]:
            s = r["stability"]
            note = ""
            if r["diverged_at"] is not None:
                note = f"(21) diverged after t = {r['diverged_at']:.0f}"
            elif s.get("note"):
                note = s["note"][:60]
            steps = r["steps"]
            lines.append(
                f"| {r[p['axis']]:g} | {r['sigma']:+.4f} | {_SHORT[r['status']]} | {_e(r['a1_ode21'], 3)} | "
                f"{_e(r['a1_ame'], 3)} | {_e(r['rel_a1'])} | {point_class(r, result['tolerance'])} | "
                f"{s['verdict']} | {_f(s['max_modulus'], 5)} | "
                f"{_e(s['ame_max_real'])} | "
                f"{steps['steps_dop853'] or '—'} / {steps['steps_radau'] or '—'} | "
                f"{_f(r['ode21_ms_per_period'], 3)} | "
                f"{note.replace('|', '/')} |")
        lines += ["", "Continuation rows:", "", f"| {p['axis']} | points | end | at sigma | special points |",
                  "|---|---|---|---|---|"]
        for c in p["continuation"]:
            lines.append(f"| {c[p['axis']]:g} | {c['points']} | {c['end_reason']} | {c['end_sigma']:+.4f} | "
                         + (", ".join(f"{s['type']} {s['sigma']:+.4f}" for s in c["special"]) or "—") + " |")
    return "\n".join(lines) + "\n"
