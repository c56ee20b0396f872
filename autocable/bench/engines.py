"""`autocable bench engines`: every figure scene run on both continuation engines, PyCont (the
AUTO-style workflow the paper used) and autocable's compiled kernel, and their special points
compared branch by branch (PyCont, the engine the paper's AUTO workflow maps to, stays first-class).

Both engines hand their points to the same analysis (autocable's test functions refine every LP,
BP, H of equilibria and every LPC, PD, NS of cycles on the same AME), so the special points must
agree to the continuation tolerance; branches are matched by name, points by
type and value over the scene. Points only PyCont reports (``origin = "pycont"``: its own labels that autocable's test
functions do not confirm, kept in the results for transparency) are listed apart. Cycles started from an integrated orbit run on the compiled collocation under
either engine (PyCont's LC-C starts only at Hopf points) and are compared all the same.
"""
from __future__ import annotations

import math
import tempfile
import time
from pathlib import Path

#: Largest |difference| of a special point's parameter value between the engines that counts as the
#: same point: the refinement tolerance of equilibria is 1e-10 in the scaled chart; cycles carry
#: the collocation's discretisation error (PyCont's NTST/NCOL against autocable's mesh).
TOLERANCE = {"equilibria": 1e-7, "cycles": 1e-4}
CYCLE_TYPES = ("LPC", "PD", "NS")


def _points(results) -> dict[str, list]:
    """Per branch, the (type, value) of the special points autocable located (a point only PyCont
    reports, ``origin = "pycont"``, is listed apart by `_pycont_only`: the compiled engine has no
    such list)."""
    return {b.name: [(p.type, p.value) for p in b.special_points if p.type not in ("BP0", "EP")
                     and p.origin == "autocable"] for b in results.branches}


def _pycont_only(results) -> list[str]:
    return [f"{b.name}:{p.label} {p.parameter} = {p.value:.8g}" for b in results.branches
            for p in b.special_points if p.origin != "autocable"]


def compare_points(a: dict[str, list], b: dict[str, list]) -> dict:
    """Match the special points of two runs of one scene (`_points`): the same branches, and per
    type the same number of points at the same parameter values (sorted). Values are compared over
    the whole scene, not per branch, because the names of switched branches follow the order in
    which an engine met their branch points (Fig. 6's II-BP1 and II-BP2 trade names); the largest
    |value difference| per kind, and every mismatch in words."""
    worst = {"equilibria": 0.0, "cycles": 0.0}
    problems, matched = [], 0
    for name in sorted(set(a) ^ set(b)):
        problems.append(f"branch {name} only on {'pycont' if name in a else 'compiled'}")
    for t in sorted({t for pts in (*a.values(), *b.values()) for t, _ in pts}):
        va = sorted(v for pts in a.values() for k, v in pts if k == t)
        vb = sorted(v for pts in b.values() for k, v in pts if k == t)
        if len(va) != len(vb):
            problems.append(f"{t}: {len(va)} points against {len(vb)}")
            continue
        kind = "cycles" if t in CYCLE_TYPES else "equilibria"
        for x, y in zip(va, vb):
            d = abs(x - y)
            worst[kind] = max(worst[kind], d)
            matched += 1
            if not d <= TOLERANCE[kind]:
                problems.append(f"{t}: {x:.10g} against {y:.10g} (|d| = {d:.2g})")
    return {"matched": matched, "max_difference": worst, "problems": problems}


def bench_engines(scenes=None, resolution: str = "coarse", log=None) -> dict:
    """Run ``scenes`` (default: every runs/fig*.toml) on both engines at ``resolution``; return the
    comparison per scene and the wall time of each engine."""
    from autocable._paths import RUNS_DIR
    from autocable.scene.runner import run_scene
    from autocable.scene.schema import load_scene
    from autocable.studies.advise import choose_ame

    say = log or (lambda s: None)
    paths = [Path(s) for s in scenes] if scenes else sorted(RUNS_DIR.glob("fig*.toml"))
    out: dict = {"resolution": resolution, "tolerance": TOLERANCE, "scenes": {}}
    for path in paths:
        scene = load_scene(path)
        if scene.time is not None:
            continue                              # a time scene has no continuation
        got, wall = {}, {}
        for engine in ("pycont", "compiled"):
            with tempfile.TemporaryDirectory() as tmp:
                t0 = time.perf_counter()
                res = run_scene(scene, tmp, plot=False, resolution=resolution, engine=engine, choose_ame=choose_ame)
                wall[engine] = time.perf_counter() - t0
            got[engine] = _points(res)
            if engine == "pycont":
                extra = _pycont_only(res)
        cmp = compare_points(got["pycont"], got["compiled"])
        cmp["pycont_only"] = extra
        cmp["wall_s"] = wall
        out["scenes"][scene.name] = cmp
        say(f"{scene.name}: {cmp['matched']} special points matched, max |d| equilibria "
            f"{cmp['max_difference']['equilibria']:.2g}, cycles {cmp['max_difference']['cycles']:.2g}; "
            f"pycont {wall['pycont']:.1f} s, compiled {wall['compiled']:.1f} s"
            + ("" if not cmp["problems"] else "; DIFFER: " + "; ".join(cmp["problems"]))
            + ("" if not extra else f"; PyCont-only points (not confirmed): {', '.join(extra)}"))
    out["agree"] = all(not s["problems"] for s in out["scenes"].values())
    out["matched"] = sum(s["matched"] for s in out["scenes"].values())
    out["max_difference"] = {k: max((s["max_difference"][k] for s in out["scenes"].values()), default=math.nan)
                             for k in TOLERANCE}
    return out
