"""The lightest model a scene needs (`autocable advise SCENE.toml [--tol 0.02]`).

Cheap probes on the scene's setting (its fixed U, eta and sigma range, `registry.setting_from_scene`):

1. the 2-dof AME (24) continued in sigma at coarse resolution, with branch switching at every branch
   point: the largest a2 on any branch relative to the largest a1 (does the out-of-plane mode ever
   take part?), and the branch points on the mono-modal branch (where A2 = 0 loses stability);
2. the 1-dof (A2 = 0) branch against the 2-dof one at common sigma points: a1 and stability (the
   reduction keeps a1 of a mono-modal response exactly, but calls it stable where the out-of-plane
   mode is parametrically excited: the pitchfork instability of Sect. 5, Fig. 6);
3. a few integrations of eq. (21) itself at probe sigma values (from rest, q2 = 1e-6) against the
   nearest AME equilibrium (the AME's own error, O(eta^2) relative: docs/ame_vs_ode21.md).

Then the lightest rung that passes at the tolerance: ``1dof`` (a2 stays below tol x a1 everywhere,
1-dof and 2-dof agree, eq. (21) is matched within tol), else ``2dof`` (eq. 21 matched within tol by
the 2-dof AME), else ``ode21`` (no AME is within tol of eq. (21) at some probe: integrate eq. (21) or
continue its periodic orbits). `Advice.ame` is the lightest amplitude equation that is qualitatively
right (the one a scene's ``ame = "auto"`` should use), `Advice.rung` the lightest method within tol.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from autocable.model.aero import CUBIC_RTOL
from autocable.studies import ladder as R

__all__ = ["Advice", "choose_ame", "advice_report"]


@dataclass(frozen=True)
class Advice:
    rung: str                         # "1dof" | "2dof" | "ode21"
    ame: str                          # "1dof" | "2dof": the lightest AME that is qualitatively right
    tol: float
    scene: str
    reasons: tuple[str, ...]
    evidence: Mapping[str, Any] = field(default_factory=dict)

    def report(self) -> str:
        """The readable advice (`advice_report`)."""
        return advice_report(self)


def _crossings_at(result: R.MethodResult, sigma: float, only=None):
    from autocable.studies.work_precision import crossings
    out = crossings(result, sigma)
    return [c for c in out if only is None or c[3] in only]


def _continuation(tools, dof, setting, max_step):
    """Coarse continuation: the compiled engine when it works, PyCont otherwise."""
    try:
        return R.run(f"ame-{dof}", setting, {"max_step": max_step, "engine": "compiled"}, tools), "compiled"
    except Exception:          # the compiled kernel is optional: PyCont gives the same records
        return R.run(f"ame-{dof}", setting, {"max_step": max_step}, tools), "pycont"


def choose_ame(scene_path_or_scene, tol: float = 0.02, *, tools: R.Tools | None = None,
               probes: int = 5, max_step: float = 0.01) -> Advice:
    """Run the probes on a scene (a path or a loaded `Scene`) and pick the lightest rung."""
    if not (isinstance(tol, (int, float)) and 0 < tol < 1):
        raise ValueError(f"--tol must be a relative tolerance in (0, 1), got {tol!r}")
    path = getattr(scene_path_or_scene, "path", scene_path_or_scene)
    setting = R.setting_from_scene(Path(path))
    ordering = getattr(scene_path_or_scene, "ordering", None)
    if ordering is None:
        from autocable.scene.runner import load_scene
        ordering = load_scene(Path(path)).ordering
    tools = tools or R.Tools(setting.model, ordering=ordering)
    lo, hi = setting.sigma_range
    two, engine2 = _continuation(tools, "2dof", setting, max_step)
    one, engine1 = _continuation(tools, "1dof", setting, max_step)

    # 1. out-of-plane participation in the 2-dof diagram
    a1max = float(np.max(two.a1)) if len(two.a1) else 0.0
    a2max = float(np.max(two.a2)) if len(two.a2) else 0.0
    a2_ratio = a2max / a1max if a1max > 0 else 0.0
    bp_on_mono = [dict(s) for s in two.special if s["type"] == "BP" and s["branch"] in ("I", "I+")]

    # 2. 1-dof against 2-dof on the mono-modal branch
    grid = np.linspace(lo, hi, 41)
    worst_a1, stab_disagree = 0.0, []
    for s in grid:
        c1 = _crossings_at(one, s)
        c2 = [c for c in _crossings_at(two, s) if c[1] <= 1e-6 * max(c[0], 1e-30)]   # a2 = 0 responses
        for a in c1:
            if not c2:
                continue
            b = min(c2, key=lambda c: abs(c[0] - a[0]))
            worst_a1 = max(worst_a1, abs(a[0] - b[0]) / max(b[0], 1e-30))
            if a[2] and not b[2]:
                stab_disagree.append(round(float(s), 6))

    # 3. eq. (21) at probe sigma values against the nearest AME equilibrium
    integ = tools.ode21(1e-10)
    probe_rows, responses = [], []
    for s in np.linspace(lo, hi, probes):
        r = integ.simulate(setting.U, setting.eta, float(s))
        responses.append(r)
        row = {"sigma": float(s), "a1_21": r.a1, "a2_21": r.a2, "periodic": bool(r.steady and r.periodic),
               "message": r.message}
        for name, res in (("1dof", one), ("2dof", two)):
            cands = _crossings_at(res, float(s))
            if row["periodic"] and cands:
                d = [R._distance(c[0], c[1], r.a1, r.a2) for c in cands]
                k = int(np.argmin(d))
                row[f"err_{name}"] = float(d[k])
                row[f"a1_{name}"] = cands[k][0]
            else:
                row[f"err_{name}"] = math.inf if row["periodic"] else None
        probe_rows.append(row)

    validity = _probe_validity(tools.derivation, integ, responses, probe_rows)

    def worst(name):
        errs = [p[f"err_{name}"] for p in probe_rows if p[f"err_{name}"] is not None]
        return max(errs) if errs else math.nan

    not_periodic = [p["sigma"] for p in probe_rows if not p["periodic"]]
    a2_21 = max((p["a2_21"] / p["a1_21"] for p in probe_rows if p["periodic"] and p["a1_21"] > 0), default=0.0)
    err1, err2 = worst("1dof"), worst("2dof")
    evidence = {"setting": {"U": setting.U, "eta": setting.eta, "sigma_range": [lo, hi]},
                "a2_over_a1_2dof": a2_ratio, "max_a1_2dof": a1max, "max_a2_2dof": a2max,
                "branches_2dof": list(two.info.get("branches", [])),
                "branch_points_on_mono_modal": bp_on_mono,
                "max_rel_a1_1dof_vs_2dof": worst_a1,
                "sigma_1dof_stable_2dof_unstable": stab_disagree,
                "a2_over_a1_eq21_probes": a2_21, "max_err_1dof_vs_eq21": err1, "max_err_2dof_vs_eq21": err2,
                "eq21_not_period1_sigma": not_periodic, "probes": probe_rows,
                "engines": {"1dof": engine1, "2dof": engine2}, "max_step": max_step,
                "seconds": {"1dof": one.seconds, "2dof": two.seconds}, "validity": validity}

    reasons = []
    mono = a2_ratio <= tol and not bp_on_mono and not stab_disagree and a2_21 <= tol
    if mono:
        reasons.append(f"a2 stays 0: max a2 / max a1 = {a2_ratio:.2g} on the 2-dof diagram, "
                       f"{a2_21:.2g} in eq. (21) at the probes, no branch point on the mono-modal branch")
        reasons.append(f"the 1-dof branch equals the 2-dof one: max rel. a1 difference {worst_a1:.2g}, "
                       "same stability")
    else:
        if a2_ratio > tol or bp_on_mono:
            where = ", ".join(f"{b['sigma']:+.4f}" for b in bp_on_mono) or "-"
            reasons.append(f"bi-modal: the 2-dof diagram has {len(bp_on_mono)} branch point(s) on the mono-modal "
                           f"branch (sigma = {where}) and "
                           f"branches with max a2 / max a1 = {a2_ratio:.2g} > tol {tol:g}")
        if stab_disagree:
            reasons.append(f"the 1-dof branch is stable where the 2-dof one is not (out-of-plane instability) at "
                           f"{len(stab_disagree)} of 41 sigma points ({min(stab_disagree):+.4f} .. "
                           f"{max(stab_disagree):+.4f})")
        if a2_21 > tol:
            reasons.append(f"eq. (21) itself responds out of plane at the probes: a2 / a1 up to {a2_21:.2g}")
    ame = "1dof" if mono else "2dof"
    err = err1 if mono else err2
    if not_periodic:
        reasons.append(f"eq. (21) is not period-1 (no AME equilibrium to compare) at sigma = "
                       f"{', '.join(f'{s:+.4f}' for s in not_periodic)}")
    if math.isfinite(err) and err <= tol and not not_periodic:
        rung = ame
        reasons.append(f"the {ame} AME is within {err:.2g} of eq. (21) at {len(probe_rows)} probe sigma values "
                       f"(tol {tol:g})")
    else:
        rung = "ode21"
        reasons.append(f"the {ame} AME errs by up to {_g(err)} against eq. (21) at the probes (tol {tol:g}): "
                       "integrate eq. (21) (or continue its periodic orbits) to check the diagram")
    reasons += _load_reasons(validity)
    return Advice(rung=rung, ame=ame, tol=float(tol), scene=setting.scene, reasons=tuple(reasons),
                  evidence=evidence)


def _probe_validity(d, integ, responses, probe_rows) -> dict:
    """The load rungs the probes need (`autocable.model.validity`): each probe response of eq. (21),
    sampled over 20 forcing periods from its final state, measured for the angle it sweeps, its
    twist and the cubic load's error against the exact load."""
    from autocable.model.symbolic import parameter_values
    from autocable.model.validity import motion_validity
    worst = {"phi_swept_deg": 0.0, "twist_max_deg": 0.0, "cubic_load_error": 0.0, "beyond_curves": [],
             "beyond_cubic": []}
    for row, r in zip(probe_rows, responses):
        s = row["sigma"]
        if not all(map(math.isfinite, r.final_state)) or max(abs(r.a1), abs(r.a2)) > 0.1:
            continue
        T = 2 * math.pi / r.Omega
        run = integ.run_compiled(r.final_state, r.t_end, r.t_end + 20 * T, T / 64, parameter_values(r.U, r.eta, r.Omega))
        v = motion_validity(d, run.y, r.U, r.eta * r.Omega * np.cos(r.Omega * run.t))
        row["validity"] = v
        for key in ("phi_swept_deg", "twist_max_deg", "cubic_load_error"):
            if v.get(key) is not None:
                worst[key] = max(worst[key], v[key])
        if any("valid range" in why for why in v["reasons"]):
            worst["beyond_curves"].append(float(s))
        if v.get("cubic_load_error") is not None and v["cubic_load_error"] > CUBIC_RTOL:
            worst["beyond_cubic"].append(float(s))
    return worst


def _load_reasons(v: dict) -> list[str]:
    """What the probes' validity asks of the model (item: the ladder's load and curve rungs)."""
    out = []
    if v["beyond_cubic"]:
        out.append(f"the cubic load of eq. (14) errs by up to {100 * v['cubic_load_error']:.0f} % against the exact "
                   f"load along the probe responses (bound {100 * CUBIC_RTOL:.0f} %) at sigma = "
                   f"{', '.join(f'{s:+.4f}' for s in v['beyond_cubic'])}: use aero.load = \"exact\"")
    if v["beyond_curves"]:
        out.append(f"phi sweeps up to +-{v['phi_swept_deg']:.0f} deg (twist up to {v['twist_max_deg']:.0f} deg), beyond "
                   f"the aerodynamic curves' valid range at sigma = "
                   f"{', '.join(f'{s:+.4f}' for s in v['beyond_curves'])}: give curves that hold there (a table or "
                   "a bounded extension, docs/aero-curves.md) and the exact load")
    return out


def _g(x) -> str:
    return "inf (eq. 21's response has no AME equilibrium nearby)" if x is not None and math.isinf(x) else f"{x:.3g}"


def advice_report(advice: Advice) -> str:
    e = advice.evidence
    names = {"1dof": "1-dof AME (A2 = 0)", "2dof": "2-dof AME (24)", "ode21": "eq. (21) itself"}
    lines = [f"{advice.scene}: {names[advice.rung]} suffices at tol {advice.tol:g}"
             + ("" if advice.rung == advice.ame else f" (lightest qualitatively right AME: {names[advice.ame]})"),
             ""] + [f"  - {r}" for r in advice.reasons] + [
        "", "evidence:",
        f"  2-dof AME ({e['engines']['2dof']}, max_step {e['max_step']:g}): branches {', '.join(e['branches_2dof'])}; "
        f"max a1 = {e['max_a1_2dof']:.4g}, max a2 = {e['max_a2_2dof']:.4g}",
        f"  1-dof vs 2-dof: max rel. a1 difference {e['max_rel_a1_1dof_vs_2dof']:.3g}; 1-dof stable / 2-dof "
        f"unstable at {len(e['sigma_1dof_stable_2dof_unstable'])} sigma points",
        "  eq. (21) probes (from rest, q2 = 1e-6):",
        "    sigma       a1 (21)     a2 (21)     err 1-dof   err 2-dof"]
    for p in e["probes"]:
        lines.append(f"    {p['sigma']:+.4f}   {p['a1_21']:.4e}  {p['a2_21']:.4e}  {_e(p['err_1dof'])}  "
                     f"{_e(p['err_2dof'])}" + ("" if p["periodic"] else "   (not period-1)"))
    v = e.get("validity")
    if v:
        lines.append(f"  validity of the probe responses: phi swept up to +-{v['phi_swept_deg']:.3g} deg, twist up to "
                     f"{v['twist_max_deg']:.3g} deg, cubic load error up to {100 * v['cubic_load_error']:.2g} % "
                     f"(beyond the curves' range at {len(v['beyond_curves'])} probe(s), beyond the cubic's at "
                     f"{len(v['beyond_cubic'])})")
    return "\n".join(lines)


def _e(x) -> str:
    if x is None:
        return "    -     "
    return f"{x:10.3e}" if math.isfinite(x) else "  no eq.  "


def cmd_advise(args) -> int:
    from autocable.spec import SpecError
    if not 0 < args.tol < 1:
        raise SpecError("--tol", "", f"a relative tolerance in (0, 1), got {args.tol}")
    adv = choose_ame(args.scene, args.tol)
    if args.json:
        import json
        print(json.dumps({"rung": adv.rung, "ame": adv.ame, "tol": adv.tol, "scene": adv.scene,
                          "reasons": list(adv.reasons), "evidence": adv.evidence}, indent=1,
                         default=lambda x: x.item() if hasattr(x, "item") else str(x)))
    else:
        print(advice_report(adv))
    return 0
