"""Work-precision bench of the method ladder (`autocable bench --out DIR`), in the manner of diffrax's
benchmarks: for each figure setting (Figs. 5a, 6, 9 of Luongo & Zulli, from ``runs/*.toml``) a
reference diagram at tight tolerance, then every rung of `autocable.studies.ladder` over its knob
ladder, each scored by

* error: the largest relative distance, over the reference's steady period-1 responses at common
  sigma points, between the reference response and the nearest response the method gives there
  (a1 relative to itself; a2 relative to itself where it is at least 1 % of a1, else against 1 % of
  a1). A continuation is read at a sigma point by linear interpolation along its branches; a sweep
  only at its own sigma points;
* found / missed: reference responses with a method response within 10 % (for a continuation, on a
  stable stretch of branch); coexisting responses (up and down sweeps disagree) and the coexistence
  boundaries (folds or pitchforks of the attractors, located between two sigma points) found;
* cost: the computation's wall time after a warm-up, best of repeats, and the one-off builds
  (compiled libraries, PyCont set-up) separately.

The reference is brute-force integration of eq. (21) swept up and down at tight tolerance
(`registry.REFERENCE_KNOBS`); where the periodic-orbit continuation of eq. (21) is available it is
run too and cross-checked against that reference.

Writes ``DIR/bench.json``, ``DIR/work_precision.png`` and ``DIR/work_precision.md``.
"""
from __future__ import annotations

import json
import math
import platform
import time
from dataclasses import replace
from pathlib import Path
from types import MappingProxyType

import numpy as np

from autocable._paths import RUNS_DIR, SAMPLE_MODEL
from autocable.studies import ladder as R
from autocable.plotting.style import styled

MATCH_TOL = 0.10            # a reference response is "found" within 10 %
DEFAULT_SCENES = ("fig05a", "fig06", "fig09", "fig10")
QUICK_SCENES = ("fig05a",)
#: The one-minute bench: the cheap settings of the core rungs (the optional rungs are left out).
QUICK_LADDERS = MappingProxyType({
    "ame-1dof": ({"max_step": 0.05, "engine": "compiled"}, {"max_step": 0.02, "engine": "compiled"}),
    "ame-2dof": ({"max_step": 0.05, "engine": "compiled"}, {"max_step": 0.02, "engine": "compiled"},
                 {"max_step": 0.02}),
    "ame-sweep": ({"rtol": 1e-6, "points": 6},),
    "ode21-sweep": ({"rtol": 1e-6, "points": 11},),
})


#: Figure settings the paper gives but no scene file holds yet (Fig. 10 caption: "when U = 1.3 and
#: eta = 1.4e-3"), over the sigma range of the other figures.
PAPER_ONLY = MappingProxyType({
    "fig10": R.Setting("fig10", "Fig. 10: U = 1.3, eta = 1.4e-3 (paper caption)",
                       SAMPLE_MODEL,
                       1.3, 1.4e-3, (-0.05, 0.05), ""),
})


def _runs_dir() -> Path:
    return RUNS_DIR


def crossings(result: R.MethodResult, sigma: float) -> list[tuple[float, float, bool, str]]:
    """The method's responses at ``sigma``: (a1, a2, stable, branch).

    Continuations: linear interpolation on every segment of every branch that spans sigma (the
    O(h^2) read-out of the registry's declared accuracy). Sweeps: their points at that sigma."""
    v, a1, a2, st, br = result.values, result.a1, result.a2, result.stable, result.branch
    if _is_sweep(result):
        tol = 1e-9 * max(1.0, abs(sigma))
        return [(float(a1[i]), float(a2[i]), bool(st[i]), br[i]) for i in range(len(v))
                if abs(v[i] - sigma) <= tol and result.ok[i]]
    out = []
    for i in range(len(v) - 1):
        if br[i] != br[i + 1]:
            continue
        lo, hi = v[i], v[i + 1]
        if min(lo, hi) <= sigma <= max(lo, hi) and hi != lo:
            t = (sigma - lo) / (hi - lo)
            out.append((float(a1[i] + t * (a1[i + 1] - a1[i])), float(a2[i] + t * (a2[i + 1] - a2[i])),
                        bool(st[i] and st[i + 1]), br[i]))
        elif hi == lo == sigma:
            out.append((float(a1[i]), float(a2[i]), bool(st[i]), br[i]))
    return out


def _is_sweep(result: R.MethodResult) -> bool:
    return bool(result.branch) and set(result.branch) <= {"up", "down"}


def reference_points(ref: R.MethodResult) -> list[dict]:
    """Steady period-1 responses of the reference, one per (sigma, direction)."""
    return [{"sigma": float(s), "a1": float(a), "a2": float(b), "direction": d}
            for s, a, b, d, ok in zip(ref.values, ref.a1, ref.a2, ref.branch, ref.ok) if ok]


def compare(result: R.MethodResult, ref: R.MethodResult) -> dict:
    """Score ``result`` against the reference diagram ``ref`` (module docstring)."""
    pts = reference_points(ref)
    span = float(np.ptp(ref.values)) or 1.0
    errors, found, missed, unstable_match, per_point = [], 0, 0, 0, []
    sweep = _is_sweep(result)
    for p in pts:
        cands = crossings(result, p["sigma"])
        if sweep and not cands and not np.any(np.abs(result.values - p["sigma"]) <= 1e-9 * span):
            continue                   # not a common sigma point
        if not cands:
            missed += 1
            per_point.append({**p, "error": None})
            continue
        d = [R._distance(c[0], c[1], p["a1"], p["a2"]) for c in cands]
        k = int(np.argmin(d))
        stable_d = [x for x, c in zip(d, cands) if c[2]]
        best_stable = min(stable_d) if stable_d else math.inf
        errors.append(d[k])
        per_point.append({**p, "error": d[k], "nearest_stable": bool(cands[k][2])})
        if best_stable <= MATCH_TOL:
            found += 1
        else:
            missed += 1
            if d[k] <= MATCH_TOL:
                unstable_match += 1
    # coexisting responses: up and down reference sweeps differ at the same sigma
    by_sigma: dict = {}
    for p in pts:
        by_sigma.setdefault(round(p["sigma"], 12), []).append(p)
    coexist_total = coexist_found = 0
    for s, group in by_sigma.items():
        if len(group) == 2 and R._distance(group[0]["a1"], group[0]["a2"], group[1]["a1"], group[1]["a2"]) > 0.05:
            cands = crossings(result, group[0]["sigma"])
            if sweep and not np.any(np.abs(result.values - group[0]["sigma"]) <= 1e-9 * span):
                continue
            coexist_total += 1
            ok = all(any(c[2] and R._distance(c[0], c[1], g["a1"], g["a2"]) <= MATCH_TOL for c in cands)
                     for g in group)
            coexist_found += int(ok)
    # coexistence boundaries (folds / pitchforks of the attractors)
    step = span / max(len(set(np.round(ref.values, 12))) - 1, 1)
    own_step = step
    if sweep:
        own_step = float(np.ptp(result.values)) / max(len(set(np.round(result.values, 12))) - 1, 1)
    special_found = special_missed = 0
    for j in ref.special:
        lo, hi = j["lo"] - max(step, own_step), j["hi"] + max(step, own_step)
        hit = any(lo <= s["sigma"] <= hi for s in result.special
                  if s["type"] in ("LP", "BP", "jump", "LPC", "PD", "NS", "BPC"))
        special_found += int(hit)
        special_missed += int(not hit)
    finite = [e for e in errors if math.isfinite(e)]
    return {"error": max(finite) if finite else None,
            "median_error": float(np.median(finite)) if finite else None,
            "compared": len(errors) + sum(1 for q in per_point if q["error"] is None),
            "found": found, "missed": missed, "matched_unstable": unstable_match,
            "coexisting": coexist_total, "coexisting_found": coexist_found,
            "special_found": special_found, "special_missed": special_missed,
            "per_point": per_point}


def agreement(ame: R.MethodResult, periodic: R.MethodResult, valid=None, tol: float = 0.02) -> dict:
    """The AME's equilibria against the periodic orbits of eq. (21) (issue: "on the Fig. 6 settings
    the periodic orbits of (21) and the AME agree where the AME is valid"): at every point of the
    periodic branch, the nearest AME response at that sigma (distance as in `compare`) and whether
    their stability (Floquet multipliers of 21 against AME eigenvalues) agrees. ``valid``: the
    reference responses (sigma, a1) the AME matches within ``tol``; an orbit is where the AME is
    valid when one of them lies within one grid step in sigma and 5 % in a1 of it."""
    rows = []
    for s, a1, a2, st in zip(periodic.values, periodic.a1, periodic.a2, periodic.stable):
        cands = crossings(ame, float(s))
        ok = valid is None or any(abs(vs - s) <= step and abs(va - a1) <= 0.05 * va for vs, va, step in valid)
        if not cands:
            rows.append({"sigma": float(s), "a1": float(a1), "error": None, "stable_21": bool(st),
                         "stable_ame": None, "ame_valid": ok})
            continue
        d = [R._distance(c[0], c[1], float(a1), float(a2)) for c in cands]
        k = int(np.argmin(d))
        rows.append({"sigma": float(s), "a1": float(a1), "error": float(d[k]), "stable_21": bool(st),
                     "stable_ame": bool(cands[k][2]), "ame_valid": ok})
    inside = [r for r in rows if r["ame_valid"]]
    errs = [r["error"] for r in inside if r["error"] is not None]
    same = [r for r in inside if r["error"] is not None and r["stable_21"] == r["stable_ame"]]
    sig = [r["sigma"] for r in inside]
    return {"points": len(rows), "points_where_ame_valid": len(inside),
            "sigma_where_ame_valid": [min(sig), max(sig)] if sig else None,
            "max_error_where_ame_valid": max(errs) if errs else None,
            "within_tol": sum(e <= tol for e in errs), "no_ame_response": sum(r["error"] is None for r in inside),
            "stability_agrees": len(same), "rows": rows}


def _valid_responses(per_point, step: float, tol: float = 0.02) -> list[tuple[float, float, float]]:
    """(sigma, a1, grid step) of the reference responses a method matches within ``tol``."""
    return [(p["sigma"], p["a1"], step) for p in per_point if p["error"] is not None and p["error"] <= tol]


def _timed(method, setting, knobs, tools, repeats: int) -> R.MethodResult:
    """Warm-up, then best of ``repeats`` (one run when a single run takes over 3 s)."""
    best = R.run(method, setting, knobs, tools)
    first_build = best.build_seconds
    if best.seconds < 3.0:
        for _ in range(repeats):
            r = R.run(method, setting, knobs, tools)
            if r.seconds < best.seconds:
                best = r
    else:
        best = replace(best, info={**best.info, "repeats": "one run (over 3 s): no repeat"})
    return replace(best, build_seconds=first_build)


def _scene_paths(names) -> list[Path]:
    out = []
    for n in names:
        p = Path(n)
        if p.suffix != ".toml":
            p = _runs_dir() / f"{n}.toml"
        if p.exists():
            out.append(p)
    return out


def run_bench(out_dir, *, scenes=None, quick: bool = False, repeats: int = 2, log=None) -> dict:
    """Run the work-precision bench and write its files into ``out_dir``; returns the summary."""
    say = log or (lambda s: None)
    t_all = time.perf_counter()
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    wanted = scenes or (QUICK_SCENES if quick else DEFAULT_SCENES)
    settings, skipped = [], []
    for n in wanted:
        found = _scene_paths([n])
        if found:
            settings.append(R.setting_from_scene(found[0]))
        elif n in PAPER_ONLY:
            settings.append(PAPER_ONLY[n])
        else:
            skipped.append(n)
    if not settings:
        raise ValueError(f"no scene file found for {list(wanted)} (looked in runs/)")
    methods = R.available_methods()
    tools = R.Tools(settings[0].model)
    ref_knobs = dict(R.REFERENCE_KNOBS, points=11) if quick else dict(R.REFERENCE_KNOBS)
    records, references, notes, kept = [], {}, [], {}
    if skipped:
        notes.append(f"no scene file for {', '.join(skipped)}: not benched")
    for st in settings:
        if not st.source:
            notes.append(f"{st.scene}: no scene file in runs/; its setting is taken from the paper's caption "
                         f"({st.title})")
    for st in settings:
        say(f"[{st.scene}] reference: eq. (21) sweeps up and down, {ref_knobs}")
        ref = R.run("ode21-sweep", st, ref_knobs, tools)
        references[st.scene] = {"method": "ode21-sweep", "knobs": ref_knobs, "seconds": ref.seconds,
                                "message": ref.message,
                                "points": reference_points(ref),
                                "coexistence_boundaries": [dict(j) for j in ref.special]}
        say(f"  {ref.message} ({ref.seconds:.1f} s)")
        for name, m in methods.items():
            if quick and name not in QUICK_LADDERS:
                continue
            ladder = QUICK_LADDERS[name] if quick else m.ladder
            for knobs in ladder:
                try:
                    r = _timed(m, st, knobs, tools, 0 if quick else repeats)
                except Exception as exc:   # a rung failing on a setting is a result of the bench
                    say(f"  {name} {dict(knobs)}: failed: {exc}")
                    records.append({"scene": st.scene, "method": name, "setting": dict(knobs),
                                    "error": None, "seconds": None, "build_seconds": None, "found": 0,
                                    "missed": None, "message": f"failed: {exc}"})
                    continue
                c = compare(r, ref)
                if (name, dict(knobs)) in (("ame-2dof", {"max_step": 0.02, "engine": "compiled"}),
                                           ("ame-2dof", {"max_step": 0.02}), ("ode21-periodic", {"ntst": 20})):
                    kept.setdefault(st.scene, {}).setdefault(name, (r, c))
                rec = {"scene": st.scene, "method": name, "setting": dict(knobs), "error": c["error"],
                       "median_error": c["median_error"], "seconds": r.seconds,
                       "build_seconds": r.build_seconds, "found": c["found"], "missed": c["missed"],
                       "compared": c["compared"], "matched_unstable": c["matched_unstable"],
                       "coexisting": c["coexisting"], "coexisting_found": c["coexisting_found"],
                       "special_found": c["special_found"], "special_missed": c["special_missed"],
                       "special_points": [dict(s) for s in r.special], "points": int(len(r.values)),
                       "message": r.message, "per_point": c["per_point"],
                       "U": st.U, "eta": st.eta, "sigma_range": list(st.sigma_range)}
                records.append(rec)
                say(f"  {name} {dict(knobs)}: error {_f(c['error'])}, {r.seconds:.3g} s "
                    f"(build {r.build_seconds:.3g} s), found {c['found']}, missed {c['missed']}, "
                    f"boundaries {c['special_found']}/{c['special_found'] + c['special_missed']}")
    summary = _summary(records, settings)
    for scene, got in kept.items():
        if "ame-2dof" in got and "ode21-periodic" in got:
            (ame, c_ame), (per, c_per) = got["ame-2dof"], got["ode21-periodic"]
            grid = sorted({round(p["sigma"], 12) for p in c_ame["per_point"]})
            step = (grid[-1] - grid[0]) / max(len(grid) - 1, 1)
            valid = _valid_responses(c_ame["per_point"], step)
            summary.setdefault(scene, {})["ame_vs_periodic21"] = agreement(ame, per, valid)
            summary[scene]["periodic21_vs_sweeps"] = {"error": c_per["error"], "median_error": c_per["median_error"],
                                                      "found": c_per["found"], "missed": c_per["missed"]}
    result = {"records": records, "references": references, "summary": summary, "notes": notes,
              "builds": dict(tools.builds), "quick": quick, "repeats": repeats,
              "methods": {n: _method_json(m) for n, m in methods.items()},
              "settings": [{"scene": s.scene, "title": s.title, "U": s.U, "eta": s.eta,
                            "sigma_range": list(s.sigma_range),
                            "source": Path(s.source).name if s.source else "paper caption"}
                           for s in settings],
              "wall_seconds": time.perf_counter() - t_all, "platform": platform.platform()}
    from autocable._store import atomic_write_json, atomic_write_text
    atomic_write_json(out / "bench.json", _finite(json.loads(json.dumps(result, default=_json_default))))
    plot_work_precision(records, settings, out / "work_precision.png")
    atomic_write_text(out / "work_precision.md", markdown(result))
    return result


def _finite(x):
    """JSON has no NaN or infinity: non-finite numbers (a diverged response) become null."""
    if isinstance(x, float) and not math.isfinite(x):
        return None
    if isinstance(x, dict):
        return {k: _finite(v) for k, v in x.items()}
    if isinstance(x, list):
        return [_finite(v) for v in x]
    return x


def _json_default(x):
    if isinstance(x, (np.floating, np.integer)):
        return x.item()
    if isinstance(x, np.bool_):
        return bool(x)
    return str(x)


def _method_json(m: R.Method) -> dict:
    return {"solves": m.solves, "accuracy": m.accuracy, "order": m.order, "order_knob": m.order_knob,
            "cost_drivers": list(m.cost_drivers), "model_error": m.model_error,
            "knobs": {k.name: {"default": k.default, "meaning": k.meaning} for k in m.knobs},
            "ladder": [dict(k) for k in m.ladder]}


def _ranges(values, step: float = 0.0025) -> str:
    """Sorted sigma values as runs "a .. b" of consecutive grid points."""
    v = sorted(set(round(x, 10) for x in values))
    if not v:
        return "none"
    out, lo, prev = [], v[0], v[0]
    for x in v[1:]:
        if x - prev > 1.5 * step:
            out.append((lo, prev))
            lo = x
        prev = x
    out.append((lo, prev))
    return ", ".join(f"{a:+.4f}" if a == b else f"{a:+.4f} .. {b:+.4f}" for a, b in out)


def _f(x) -> str:
    return "-" if x is None or (isinstance(x, float) and not math.isfinite(x)) else f"{x:.3g}"


def _summary(records, settings) -> dict:
    """The issue's figures: the AME diagram's cost against the brute-force sweeps' (per engine, at
    max_step 0.02), and where the 2-dof AME agrees with eq. (21) within 2 %."""
    out = {}
    for st in settings:
        rs = [r for r in records if r["scene"] == st.scene and r["seconds"] is not None]
        brute = [r for r in rs if r["method"] == "ode21-sweep"]
        entry = {"ame_2dof_seconds": {}, "ratio_sweep_over_ame": {}}
        for engine in ("compiled", "pycont"):
            ame = [r for r in rs if r["method"] == "ame-2dof" and r["setting"].get("max_step") == 0.02
                   and r["setting"].get("engine", "pycont") == engine]
            if not ame:
                continue
            a = ame[0]["seconds"]
            entry["ame_2dof_seconds"][engine] = a
            for b in brute:
                key = f"{engine}: rtol={b['setting']['rtol']:g}, points={b['setting']['points']}"
                entry["ratio_sweep_over_ame"][key] = b["seconds"] / a if a > 0 else None
            if "ame_2dof_within_2pct_sigma" not in entry:
                good = [p["sigma"] for p in ame[0]["per_point"] if p["error"] is not None and p["error"] <= 0.02]
                bad = [p["sigma"] for p in ame[0]["per_point"] if p["error"] is None or p["error"] > 0.02]
                entry["ame_2dof_within_2pct_n"] = len(good)
                entry["ame_2dof_responses_n"] = len(good) + len(bad)
                entry["ame_2dof_within_2pct_sigma"] = sorted(set(good))
                entry["ame_2dof_beyond_2pct_sigma"] = sorted(set(bad))
        out[st.scene] = entry
    return out


@styled()      # the package's one look (autocable.plotting.style)
def plot_work_precision(records, settings, path: Path) -> None:
    """Error against warm wall time, log-log, one curve per method, one panel per scene."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    n = len(settings)
    fig, axes = plt.subplots(1, n, figsize=(4.6 * n, 4.2), squeeze=False)
    markers = {"ame-1dof": "o", "ame-2dof": "s", "ame-sweep": "^", "ode21-sweep": "D",
               "ode21-periodic": "v", "ode21-nmode": "P"}
    for ax, st in zip(axes[0], settings):
        rs = [r for r in records if r["scene"] == st.scene and r["seconds"] is not None and r["error"] is not None]
        def curve(r):
            return r["method"] + (" (compiled)" if r["setting"].get("engine") == "compiled" else "")
        for name in dict.fromkeys(curve(r) for r in rs):
            mine = sorted((r for r in rs if curve(r) == name), key=lambda r: r["seconds"])
            x = [r["seconds"] for r in mine]
            y = [max(r["error"], 1e-12) for r in mine]
            line, = ax.loglog(x, y, marker=markers.get(name.split()[0], "x"), label=name,
                              ls="--" if "compiled" in name else "-")
            worst = max(mine, key=lambda r: r["missed"] or 0)
            if worst["missed"]:
                ax.annotate(f"{worst['missed']} missed", (worst["seconds"], max(worst["error"], 1e-12)), fontsize=6,
                            color=line.get_color(), xytext=(3, 3), textcoords="offset points")
        ax.axhline(0.02, color="0.6", lw=0.8, ls=":")
        ax.set_title(f"{st.scene}: U = {st.U:g}, eta = {st.eta:g}", fontsize=9)
        ax.set_xlabel("warm wall time [s]")
        ax.set_ylabel("max rel. error vs eq. (21) reference")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def markdown(result: dict) -> str:
    """The generated summary (docs/work_precision.md)."""
    lines = ["# Work-precision of the method ladder", "",
             "Generated by `autocable bench --out DIR` (do not edit by hand): "
             f"{'quick run, ' if result['quick'] else ''}wall time {result['wall_seconds']:.0f} s on "
             f"`{result['platform']}`, best of {result['repeats']} repeats after a warm-up "
             "(one run for computations over 3 s).", "",
             "![work-precision](work_precision.png)", "",
             "Reference: eq. (21) integrated (compiled DOP853, rtol 1e-11) to its steady state at "
             f"{result['references'][next(iter(result['references']))]['knobs']['points']} sigma points, swept up and down "
             "(the periodic-orbit continuation of eq. (21) was "
             + ("run and cross-checked" if "ode21-periodic" in result["methods"] else "not available when this ran")
             + "). Error: the largest relative distance between a reference steady period-1 response "
             "and the nearest response of the method at the same sigma (a1 relative; a2 relative where "
             ">= 1 % of a1). Found: reference responses matched within 10 % by a stable response. "
             "Boundaries: the ends of the sigma intervals where the up and down sweeps disagree.", ""]
    for note in result["notes"]:
        lines.append(f"*Note:* {note}")
    lines += ["", "## Methods", "", "| method | solves | declared accuracy | order (knob) | cost drivers |",
              "|---|---|---|---|---|"]
    for n, m in result["methods"].items():
        order = f"{m['order']:g} ({m['order_knob']})" if m["order"] is not None else "-"
        lines.append(f"| {n} | {m['solves']} | {m['accuracy']} | {order} | {'; '.join(m['cost_drivers'])} |")
    lines += ["", "Cold builds (this process; compiled libraries are cached on disk across runs): "
              + ", ".join(f"{k} {v:.2f} s" for k, v in result["builds"].items()), ""]
    for st in result["settings"]:
        lines += [f"## {st['scene']}: U = {st['U']:g}, eta = {st['eta']:g}, sigma in "
                  f"[{st['sigma_range'][0]:g}, {st['sigma_range'][1]:g}] ({st['source']})", "",
                  "| method | knobs | max rel. error | median | warm s | build s | found | missed | coexisting found | boundaries found |",
                  "|---|---|---|---|---|---|---|---|---|---|"]
        for r in (r for r in result["records"] if r["scene"] == st["scene"]):
            knobs = ", ".join(f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}" for k, v in r["setting"].items())
            if r["seconds"] is None:
                lines.append(f"| {r['method']} | {knobs} | failed: {r['message']} | | | | | | | |")
                continue
            lines.append(f"| {r['method']} | {knobs} | {_f(r['error'])} | {_f(r['median_error'])} | "
                         f"{r['seconds']:.3g} | {r['build_seconds']:.3g} | {r['found']} | {r['missed']} | "
                         f"{r['coexisting_found']}/{r['coexisting']} | "
                         f"{r['special_found']}/{r['special_found'] + r['special_missed']} |")
        s = result["summary"].get(st["scene"], {})
        if s.get("ratio_sweep_over_ame"):
            lines += ["", "Cost of the 2-dof AME diagram (max_step 0.02, with branch switching): "
                      + ", ".join(f"{k} {v:.3g} s" for k, v in s["ame_2dof_seconds"].items())
                      + ". Brute-force eq. (21) sweep (up and down) / AME diagram: "
                      + ", ".join(f"{k}: {_f(v)}x" for k, v in s["ratio_sweep_over_ame"].items()) + "."]
        if "ame_vs_periodic21" in s:
            a = s["ame_vs_periodic21"]
            where = (f"sigma {a['sigma_where_ame_valid'][0]:+.4f} .. {a['sigma_where_ame_valid'][1]:+.4f}"
                     if a["sigma_where_ame_valid"] else "nowhere")
            lines += ["", f"Periodic orbits of eq. (21) (ntst 20, {a['points']} orbits) against the 2-dof AME where the "
                      f"AME is within 2 % of the eq. (21) sweeps (orbits within one sigma step and 5 % in a1 of such a "
                      f"response: {a['points_where_ame_valid']}, {where}): max distance "
                      f"{_f(a['max_error_where_ame_valid'])}, {a['within_tol']} within 2 %, {a['no_ame_response']} "
                      f"without an AME response at their sigma, stability agreeing at {a['stability_agrees']}."]
        if "ame_2dof_within_2pct_sigma" in s:
            good, bad = s["ame_2dof_within_2pct_sigma"], s["ame_2dof_beyond_2pct_sigma"]
            lines += ["", f"2-dof AME (compiled, max_step 0.02) within 2 % of eq. (21) at {s['ame_2dof_within_2pct_n']} of "
                      f"{s['ame_2dof_responses_n']} reference responses (sigma with at least one such response: "
                      f"{_ranges(good)}; with at least one response beyond 2 % or missed: {_ranges(bad)})."]
        lines.append("")
    return "\n".join(lines) + "\n"
