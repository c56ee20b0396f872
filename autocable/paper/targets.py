"""The checkable statements of Sect. 5 of Luongo & Zulli (2012) as data, and the one code that
decides them.

A targets file (``models/luongo_zulli_2012.targets.toml``) lists three kinds of entries:

* ``[[statement]]``: what Sect. 5 says about one figure, decided from the scene's output folder
  by the report's decision code (`scene_statements`, which `autocable.paper.report` uses for its tables
  and `autocable calibrate` for its full evaluation: the two cannot disagree); its optional ``source``
  says whether the paper prints it ("paper", the default), or it is autocable's own check beside a
  printed figure ("check") or a result beyond Sect. 5 ("beyond") (`SOURCES`);
* ``[[number]]``: a printed number against the model (U_c through the onset at U* = 1, omega1 =
  1.004, rho = -0.004), from eq. (21) itself (`ode_numbers`) or from the output folders
  (`scene_numbers`), decided by `decide_number`;
* ``[[screen]]``: a cheap quantity of the calibration's screen (zeta8 of eq. 25, boundedness of
  eq. (21) from rest at points of Figs. 3, 8, 10, the Fig. 10 / Fig. 6 a2 ratio), decided by
  `decide_screen`.

A bad file raises `TargetsError` (a `SpecError`): one line naming the file, the entry and field,
and what is accepted.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path

from autocable.model.premises import check_parameters
from autocable.spec import SpecError, read_toml

#: Verdicts, best first (the report's words).
SHOWN = ("yes", "partly", "no")
OPS = {"<": lambda a, b: a < b, "<=": lambda a, b: a <= b, ">": lambda a, b: a > b,
       ">=": lambda a, b: a >= b}
NUMBER_QUANTITIES = ("U_onset", "omega1", "rho")
SCREEN_QUANTITIES = ("zeta8", "onset_error_21", "bounded_fraction", "ame_a2_ratio", "ode21_a2_ratio")
KINDS = ("statement", "number", "screen")
#: Where a statement comes from (a statement's optional ``source``; "paper" when not given), and what
#: that means for the calibration's bound (`autocable.paper.bound`), which prunes with "paper" only.
SOURCES = {
    "paper": "printed in the paper (Sect. 5 or the figure)",
    "check": "autocable's own check beside a printed figure, not printed in the paper",
    "beyond": "beyond Sect. 5: a result the paper's figures do not draw",
}


#: A scene is named by its file's stem: no folders, no dots (a name never leaves runs/).
_SCENE_NAME = re.compile(r"[A-Za-z0-9_-]{1,64}")


class TargetsError(SpecError):
    """A bad targets file: ``str(err)`` is one line, ``file: field: what is expected``."""


@dataclass(frozen=True)
class Target:
    """One entry of a targets file (see the module docstring)."""

    id: str
    kind: str                       # "statement" | "number" | "screen"
    says: str                       # the paper's statement (for statements: the report's text start)
    scene: str = ""                 # the scene (figure) that decides it
    quantity: str = ""
    threshold: object = None        # text (statements) or number (screen)
    value: float = math.nan         # numbers: the paper's value
    tolerance: float = math.nan     # numbers
    op: str = ""                    # screen
    points: tuple = ()              # screen: ((U*, eta*, sigma), ...)
    sigmas: tuple = ()              # screen: sigma values of the a2 ratios
    source: str = "paper"           # statements: a key of SOURCES


@dataclass(frozen=True)
class Verdict:
    """A target decided: its value (a number, or the report's text), shown yes/partly/no, why."""

    id: str
    shown: str
    value: object = None
    evidence: str = ""
    extra: dict = field(default_factory=dict, compare=False)


_FIELDS = {
    "statement": {"id": str, "scene": str, "says": str, "quantity": str, "threshold": str, "source": str},
    "number": {"id": str, "says": str, "quantity": str, "value": float, "tolerance": float},
    "screen": {"id": str, "scene": str, "says": str, "quantity": str, "op": str, "threshold": float,
               "points": list, "sigmas": list},
}
_OPTIONAL = {"screen": {"points", "sigmas", "scene"}, "number": set(), "statement": {"source"}}


def _typed(value, kind, path, where):
    if kind is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise TargetsError(path, where, f"expected a finite number, got {value!r}")
        return float(value)
    if not isinstance(value, kind):
        raise TargetsError(path, where, f"expected a {kind.__name__}, got {value!r}")
    return value


def parse_targets(data: dict, path="<targets>") -> tuple[Target, ...]:
    """Validate a parsed targets document (module docstring)."""
    for key in data:
        if key not in KINDS and key != "goal":
            raise TargetsError(path, key, f"unknown entry kind; allowed: {', '.join(f'[[{k}]]' for k in KINDS)}"
                                          ", [goal]")
    out, seen = [], set()
    for kind in KINDS:
        entries = data.get(kind, [])
        if not isinstance(entries, list):
            raise TargetsError(path, kind, f"expected an array of tables [[{kind}]]")
        rules = _FIELDS[kind]
        for i, entry in enumerate(entries):
            where = f"{kind}[{i}]"
            if not isinstance(entry, dict):
                raise TargetsError(path, where, "expected a table")
            for key in entry:
                if key not in rules:
                    raise TargetsError(path, f"{where}.{key}", f"unknown field; allowed: {', '.join(rules)}")
            vals = {}
            for key, typ in rules.items():
                if key not in entry:
                    if key in _OPTIONAL[kind]:
                        continue
                    raise TargetsError(path, f"{where}.{key}", "missing")
                vals[key] = _typed(entry[key], typ, path, f"{where}.{key}")
            tid = vals["id"]
            if not tid or tid in seen:
                raise TargetsError(path, f"{where}.id", f"expected a non-empty id not used before, got {tid!r}")
            seen.add(tid)
            if "scene" in vals and not _SCENE_NAME.fullmatch(vals["scene"]):
                raise TargetsError(path, f"{where}.scene", f"expected a scene name (the stem of a runs/fig*.toml "
                                                           f"file, e.g. fig06), got {vals['scene']!r}")
            if kind == "statement" and vals.get("source", "paper") not in SOURCES:
                raise TargetsError(path, f"{where}.source",
                                   f"expected one of {', '.join(SOURCES)}, got {vals['source']!r}")
            if kind == "number" and vals["quantity"] not in NUMBER_QUANTITIES:
                raise TargetsError(path, f"{where}.quantity",
                                   f"expected one of {', '.join(NUMBER_QUANTITIES)}, got {vals['quantity']!r}")
            if kind == "number" and not vals["tolerance"] > 0:
                raise TargetsError(path, f"{where}.tolerance", f"expected a positive number, got {vals['tolerance']}")
            if kind == "screen":
                if vals["quantity"] not in SCREEN_QUANTITIES:
                    raise TargetsError(path, f"{where}.quantity",
                                       f"expected one of {', '.join(SCREEN_QUANTITIES)}, got {vals['quantity']!r}")
                if vals["op"] not in OPS:
                    raise TargetsError(path, f"{where}.op", f"expected one of {', '.join(OPS)}, got {vals['op']!r}")
                pts = vals.get("points", [])
                if vals["quantity"] == "bounded_fraction" and not pts:
                    raise TargetsError(path, f"{where}.points", "expected a list of [U*, eta*, sigma] triples")
                for j, p in enumerate(pts):
                    if not (isinstance(p, list) and len(p) == 3):
                        raise TargetsError(path, f"{where}.points[{j}]", f"expected [U*, eta*, sigma], got {p!r}")
                    for x in p:
                        _typed(x, float, path, f"{where}.points[{j}]")
                    # every point where eq. (21) applies (the premises the command line applies)
                    check_parameters(dict(zip(("U", "eta", "sigma"), p)), str(path),
                                     {k: f"{where}.points[{j}] ({k})" for k in ("U", "eta", "sigma")})
                vals["points"] = tuple(tuple(float(x) for x in p) for p in pts)
                sig = vals.get("sigmas", [])
                if vals["quantity"] in ("ame_a2_ratio", "ode21_a2_ratio") and not sig:
                    raise TargetsError(path, f"{where}.sigmas", "expected a non-empty list of sigma values")
                vals["sigmas"] = tuple(_typed(x, float, path, f"{where}.sigmas") for x in sig)
                for j, x in enumerate(vals["sigmas"]):
                    check_parameters({"sigma": x}, str(path), {"sigma": f"{where}.sigmas[{j}]"})
            out.append(Target(kind=kind, **vals))
    if not out:
        raise TargetsError(path, "", "no targets: add [[statement]], [[number]] or [[screen]] entries")
    return tuple(out)


@dataclass(frozen=True)
class Goal:
    """What a calibrated model must show (the targets file's ``[goal]``): at least ``statements_yes``
    statements "yes", and eq. (21)'s boxes within the AME-vs-(21) study's bound at a share of at
    least ``boxes_share`` of the overlay points of ``boxes_scenes`` taken together."""

    statements_yes: int
    boxes_share: float
    boxes_scenes: tuple


def parse_goal(data: dict, path="<targets>") -> Goal | None:
    """The ``[goal]`` table of a parsed targets document, or None without one; one-line errors."""
    g = data.get("goal")
    if g is None:
        return None
    if not isinstance(g, dict):
        raise TargetsError(path, "goal", "expected a table [goal]")
    allowed = ("statements_yes", "boxes_share", "boxes_scenes")
    for key in g:
        if key not in allowed:
            raise TargetsError(path, f"goal.{key}", f"unknown field; allowed: {', '.join(allowed)}")
    for key in allowed:
        if key not in g:
            raise TargetsError(path, f"goal.{key}", "missing")
    n, share, scenes = g["statements_yes"], g["boxes_share"], g["boxes_scenes"]
    if isinstance(n, bool) or not isinstance(n, int) or n < 0:
        raise TargetsError(path, "goal.statements_yes", f"expected a whole number >= 0, got {n!r}")
    if isinstance(share, bool) or not isinstance(share, (int, float)) or not 0 <= share <= 1:
        raise TargetsError(path, "goal.boxes_share", f"expected a share between 0 and 1, got {share!r}")
    if not isinstance(scenes, list) or not all(isinstance(x, str) and _SCENE_NAME.fullmatch(x) for x in scenes):
        raise TargetsError(path, "goal.boxes_scenes", f"expected a list of scene names, got {scenes!r}")
    return Goal(n, float(share), tuple(scenes))


def check_scenes(targets, goal: Goal | None, runs_dir, path) -> None:
    """Refuse (`TargetsError` naming the entry) a statement's scene or a ``goal.boxes_scenes`` entry
    that is not a scene file ``<name>.toml`` of ``runs_dir``: a typo (fig99) would otherwise be
    decided "no" after hours of computation."""
    have = {p.stem for p in Path(runs_dir).glob("fig*.toml")}
    index = {k: 0 for k in KINDS}
    for t in targets:
        i = index[t.kind]
        index[t.kind] += 1
        if t.kind == "statement" and t.scene not in have:
            raise TargetsError(path, f"statement[{i}].scene", f"no scene {t.scene!r} in {runs_dir} (it has "
                                                              f"{', '.join(sorted(have))})")
    for j, name in enumerate(goal.boxes_scenes if goal else ()):
        if name not in have:
            raise TargetsError(path, f"goal.boxes_scenes[{j}]", f"no scene {name!r} in {runs_dir} (it has "
                                                                f"{', '.join(sorted(have))})")


def load_goal(path) -> Goal | None:
    """The ``[goal]`` of a targets file (None without one); a bad one raises a one-line `TargetsError`."""
    try:
        data, _ = read_toml(path)
    except SpecError as exc:
        raise TargetsError(path, exc.field, str(exc).split(": ", 2)[-1]) from None
    return parse_goal(data, Path(path))


def load_targets(path) -> tuple[Target, ...]:
    """Read and validate a targets file; a bad one raises a one-line `TargetsError`."""
    try:
        data, _ = read_toml(path)
    except SpecError as exc:
        raise TargetsError(path, exc.field, str(exc).split(": ", 2)[-1]) from None
    return parse_targets(data, Path(path))


# ------------------------------------------------------------------------------------------------
# deciding
# ------------------------------------------------------------------------------------------------
def scene_statements(scene, scenes: dict) -> list[tuple[str, str, str]]:
    """(statement, yes/partly/no, evidence) of one scene's output: the report's decision code,
    the single source of both the report's tables and the calibration's full evaluation."""
    from autocable.paper import report
    return report._features(scene, scenes)


def decide_statements(targets, scenes: dict, statements: dict | None = None) -> list[Verdict]:
    """Decide every ``[[statement]]`` target from the scenes' output folders (`SceneData` by name).
    ``statements``: `scene_statements` of some of these scenes already made (by name), and where
    the ones made here are kept (report.md's tables decide the same)."""
    out = []
    cache: dict[str, list] = {} if statements is None else statements
    for t in targets:
        if t.kind != "statement":
            continue
        d = scenes.get(t.scene)
        if d is None or not d.ok:
            why = "scene not run" if d is None else f"scene failed: {d.error or d.status}"
            out.append(Verdict(t.id, "no", "", why))
            continue
        if t.scene not in cache:
            cache[t.scene] = scene_statements(d, scenes)
        hit = [f for f in cache[t.scene] if f[0].startswith(t.says)]
        if not hit:
            out.append(Verdict(t.id, "no", "", "the decision code produced no such statement for this scene"))
        else:
            out.append(Verdict(t.id, hit[0][1], hit[0][0], hit[0][2]))
    return out


def decide_number(t: Target, value: float) -> Verdict:
    """|value - paper value| <= tolerance."""
    ok = math.isfinite(value) and abs(value - t.value) <= t.tolerance
    return Verdict(t.id, "yes" if ok else "no", value,
                   f"{t.quantity} = {value:.6g} against {t.value:g} (tolerance {t.tolerance:g})")


def decide_screen(t: Target, value: float, evidence: str = "") -> Verdict:
    """value `op` threshold; a value that could not be computed (nan) is "no"."""
    ok = isinstance(value, (int, float)) and math.isfinite(value) and OPS[t.op](value, t.threshold)
    return Verdict(t.id, "yes" if ok else "no", value,
                   f"{t.quantity} = {value:.4g} ({t.op} {t.threshold:g} needed)" + (f"; {evidence}" if evidence else ""))


def onset_speed(ode, U_max: float = 3.0) -> tuple[float, str]:
    """(U*, mode) where the trivial solution of eq. (21) at eta = 0 first loses stability, from the
    eigenvalues of its linear part (`TwoModeODE.linear_matrix`); mode is "in-plane" or
    "out-of-plane" by the larger displacement component of the critical eigenvector; (nan, "")
    if it stays stable up to ``U_max``."""
    import numpy as np

    def growth(U):
        lam, vec = np.linalg.eig(ode.linear_matrix(U))
        i = int(np.argmax(lam.real))
        return lam[i].real, vec[:, i]

    grid = np.linspace(1e-3, U_max, 301)
    g = [growth(u)[0] for u in grid]
    for u0, u1, g0, g1 in zip(grid[:-1], grid[1:], g[:-1], g[1:]):
        if g0 < 0 <= g1:
            for _ in range(60):
                um = 0.5 * (u0 + u1)
                (u0, u1) = (um, u1) if growth(um)[0] < 0 else (u0, um)
            v = growth(u1)[1]
            return 0.5 * (u0 + u1), "in-plane" if abs(v[0]) >= abs(v[1]) else "out-of-plane"
        if g0 >= 0:
            return float(u0), "in-plane" if abs(growth(u0)[1][0]) >= abs(growth(u0)[1][1]) else "out-of-plane"
    return math.nan, ""


def mono_modal_onset(ode) -> float:
    """U* at which the in-plane equation alone (A2 = 0, q2 = 0) loses its damping:
    2 xi_s omega1 + zeta11 U = 0 (Appendix A, Gamma_{1,1} at eta = 0), i.e. where eq. (25)'s
    branch starts (docs/model.md, M5: the reading of its numerator). nan if zeta11 >= 0."""
    z11 = sum(t.coefficient for t in ode.terms if t.name == "zeta11")
    damping = sum(t.coefficient for t in ode.terms if t.equation == 1 and t.origin == "damping")
    return -damping / z11 if z11 < 0 else math.nan


def ode_numbers(ode) -> dict[str, float]:
    """The ``[[number]]`` quantities of eq. (21) itself: U_onset, the mono-modal galloping onset
    that Fig. 3 and eq. (25) show ("the classic mono-modal galloping occurs at U = 1",
    `mono_modal_onset`); omega1; rho = omega2 - omega1."""
    return {"U_onset": mono_modal_onset(ode), "omega1": ode.omega1, "rho": ode.omega2 - ode.omega1}


def onset_error_21(ode) -> float:
    """|U* - 1| at the onset of eq. (21)'s trivial solution (both modes and their linear couplings,
    `onset_speed`), nan if the critical mode is out-of-plane or there is none below U* = 3."""
    U, mode = onset_speed(ode)
    return abs(U - 1.0) if mode == "in-plane" else math.nan


def scene_numbers(scenes: dict) -> dict[str, float]:
    """The same quantities from the figures' output folders: omega1, omega2 from run.json's
    provenance; U_onset where fig03's trivial branch loses stability (fig03 draws the in-plane
    AME with A2 = 0: the mono-modal onset, as `ode_numbers`)."""
    out = {"U_onset": math.nan, "omega1": math.nan, "rho": math.nan}
    for d in scenes.values():
        prov = d.provenance() if d.ok else {}
        if "omega1" in prov and "omega2" in prov:
            out["omega1"] = float(prov["omega1"])
            out["rho"] = float(prov["omega2"]) - float(prov["omega1"])
            break
    d = scenes.get("fig03")
    if d is not None and d.ok:
        from autocable.paper.report import AT_REST, _num
        # the zero of the largest real part of the eigenvalues (branches.csv's max_real) along the
        # trivial branches (a1 at rest throughout; the scene continues it in pieces), interpolated linearly between the two points around it
        pts = []
        for b in d.branches():
            rows = d.branch_rows(b["name"])
            if b.get("kind") == "equilibrium" and max((abs(_num(x["a1"])) for x in rows), default=1) < AT_REST:
                pts += [(_num(r["U"]), _num(r.get("max_real"))) for r in rows]
        # the growth rates of the amplitude equations are O(xi_s) = 1e-3; a row at a branch point
        # can carry a spurious O(1) value (seen at PyCont's BP rows): left out
        pts = sorted(p for p in pts if math.isfinite(p[0]) and math.isfinite(p[1]) and abs(p[1]) < 0.1)
        for (u0, g0), (u1, g1) in zip(pts, pts[1:]):
            if g0 < 0 <= g1 and u1 > u0:
                out["U_onset"] = u0 - g0 * (u1 - u0) / (g1 - g0)
                break
    return out


def decide_numbers(targets, numbers: dict) -> list[Verdict]:
    return [decide_number(t, numbers.get(t.quantity, math.nan)) for t in targets if t.kind == "number"]


def count_shown(verdicts) -> dict[str, int]:
    """How many verdicts are yes / partly / no."""
    return {s: sum(v.shown == s for v in verdicts) for s in SHOWN}


def beyond_expansion(targets, scenes: dict) -> dict[str, dict]:
    """The statements decided in a scene where the cubic load of eq. (14) leaves its stated bound:
    statement id -> {scene, largest_cubic_error, points_beyond_bound, points, cubic_rtol}, read from
    the scene's run.json (``model_validity``, `autocable.scene.runner`). A statement listed here is
    decided where the expansion's error at some point of its scene exceeds ``cubic_rtol`` of the load
    change it carries (with natural twist ends the slaved twist is about -477 rad per unit q2, far
    outside a cubic in theta); a scene without the record is left out, not counted as within."""
    out = {}
    for t in targets:
        if t.kind != "statement":
            continue
        d = scenes.get(t.scene)
        v = d.provenance().get("model_validity") if d is not None and d.ok else None
        if v and v.get("points_beyond_bound", 0) > 0:
            out[t.id] = {"scene": t.scene, "largest_cubic_error": v.get("largest_cubic_error"),
                         "points_beyond_bound": v["points_beyond_bound"], "points": v.get("points"),
                         "cubic_rtol": v.get("cubic_rtol")}
    return out
