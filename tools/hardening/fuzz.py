"""Hostile-input fuzzing of autocable: mutated model specs, mutated scenes and abusive argument
vectors, each run through the command line, and what a user must be able to rely on checked.

Every case is labelled when it is built: ``INVALID`` (must be rejected: exit status != 0 and a
message naming the file, the field or the option) or ``ODD`` (valid but unusual: a result with
exit 0, strict JSON where JSON is asked for, or a clean rejection). For every case:

* no traceback (``Traceback`` on stderr, an exception escaping ``main``, or the catch-all line
  ``autocable: error (SomeException): ...`` that stands for an unforeseen one);
* INVALID never exits 0; a rejection names a file of the case, a field or an option;
* exit 0 with ``--json``: stdout parses as strict JSON (no ``NaN``/``Infinity``);
* no file appears outside the case's ``--out`` folder and the cache (a snapshot of the tree);
* no hang (a time limit; the long real runs in a subprocess).

A generator is a function of a `random.Random`; `strategies()` wraps each one for hypothesis
(``st.randoms(use_true_random=False)``, so hypothesis drives and shrinks the draws), and
`run_fuzz` (``python -m tools.hardening fuzz``) draws from seeded generators in a plain loop.
"""
from __future__ import annotations

import contextlib
import hashlib
import io
import json
import math
import os
import random
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

from autocable._paths import RUNS_DIR, SAMPLE_MODEL

__all__ = ["INVALID", "ODD", "Case", "Outcome", "Harness", "SPEC_MUTATIONS", "SCENE_MUTATIONS",
           "ARG_CASES", "spec_case", "scene_case", "args_case", "strategies", "run_fuzz"]

INVALID = "invalid"
ODD = "odd"
MODEL_FILE = "model.toml"
SCENE_FILE = "scene.toml"
CSV_FILE = "compare.csv"
FIFO = object()          # a file entry that is a named pipe
DIRECTORY = object()     # a file entry that is a folder


@dataclass
class Case:
    """One hostile input: files to write, a command line to run, what must happen."""

    family: str                       # "spec" | "scene" | "args"
    label: str                        # what was done to the input, e.g. "cable.axial_stiffness_N = 1.0"
    expect: str                       # INVALID | ODD
    names: tuple[str, ...]            # a rejection naming any of these (or a file of the case) is named
    files: dict = field(default_factory=dict)   # relative name -> str | bytes | FIFO | DIRECTORY
    argv: tuple[str, ...] = ()        # "{case}" and "{out}" are replaced; empty: load_scene only
    subprocess: bool = False          # run in a child process (real runs, blocking files)
    timeout: float = 60.0
    mode: str = "cli"                 # "cli": the command line; "load_scene": the scene schema only;
    #                                   the surfaces of `fuzz_surfaces` ("load_sweep", "api", ...)
    call: tuple = ()                  # mode "api": (function, arguments)
    out_files: dict = field(default_factory=dict)   # a user's files already in {out} before the run
    post: Callable | None = None      # (input folder, output folder, outcome) -> more (kind, what) problems

    def key(self) -> str:
        """A content hash of the case (files and command), to run identical expensive cases once."""
        h = hashlib.sha256(repr(self.argv).encode())
        for name in sorted(self.files):
            v = self.files[name]
            text = v if isinstance(v, (str, bytes)) else ("<fifo>" if v is FIFO else "<folder>")
            h.update(name.encode() + (text if isinstance(text, bytes) else text.encode()))
        return h.hexdigest()[:16]

    def describe(self) -> dict:
        shown = {}
        for name, v in self.files.items():
            if v is FIFO or v is DIRECTORY:
                shown[name] = "<fifo>" if v is FIFO else "<folder>"
            elif isinstance(v, bytes):
                shown[name] = f"<{len(v)} bytes> " + v[:160].decode("utf-8", "backslashreplace")
            elif name == CSV_FILE or len(v) < 240:
                shown[name] = v[:240]
            else:
                shown[name] = f"<{len(v)} chars>"
        return {"family": self.family, "label": self.label, "expect": self.expect,
                "argv": list(self.argv) if self.mode == "cli" else [self.mode, SCENE_FILE if self.mode == "load_scene"
                                                                      else repr(self.call)[:200]],
                "files": shown}


@dataclass
class Outcome:
    exit: int | None                  # None: no exit (hang)
    stdout: str
    stderr: str
    seconds: float
    escaped: list[str]
    problems: list[tuple[str, str]]   # (kind, what is wrong)


# ================================================================================================
# TOML writing (the mutations edit the parsed document, then write it back)
# ================================================================================================
class Raw(str):
    """A value written into the TOML text as is (e.g. ``nan``, a 400-digit integer)."""


def _short(v) -> str:
    """A value as written in TOML, long ones (400-digit integers) abbreviated for labels."""
    t = _val(v)
    return t if len(t) <= 60 else f"<{len(t)}-character value {t[:12]}...>"


def _key(k: str) -> str:
    return k if k and all(c.isalnum() or c in "_-" for c in k) and k.isascii() else json.dumps(k)


def _val(v) -> str:
    if isinstance(v, Raw):
        return str(v)
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=False)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_val(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{_key(k)} = {_val(x)}" for k, x in v.items()) + " }"
    raise TypeError(f"no TOML for {type(v).__name__}")


def _table(lines: list[str], prefix: str, table: dict, header: str | None) -> None:
    if header is not None:
        lines += ["", header]
    nested = []
    for k, v in table.items():
        if isinstance(v, dict) and not isinstance(v, InlineTable):
            nested.append((k, v))
        elif isinstance(v, list) and v and all(isinstance(x, dict) and not isinstance(x, InlineTable) for x in v):
            nested.append((k, v))
        else:
            lines.append(f"{_key(k)} = {_val(v)}")
    for k, v in nested:
        name = f"{prefix}{_key(k)}"
        if isinstance(v, list):
            for item in v:
                _table(lines, name + ".", item, f"[[{name}]]")
        else:
            _table(lines, name + ".", v, f"[{name}]")


class InlineTable(dict):
    """A table written inline (``start = { integrate = [...] }``)."""


def dump_toml(doc: dict) -> str:
    lines: list[str] = []
    _table(lines, "", doc, None)
    return "\n".join(lines) + "\n"


def _inline(doc):
    """Inline tables of a parsed scene (start = {...}) stay inline when written back."""
    if isinstance(doc, dict):
        return {k: (InlineTable(_inline(v)) if k == "start" and isinstance(v, dict) else _inline(v))
                for k, v in doc.items()}
    if isinstance(doc, list):
        return [_inline(x) for x in doc]
    return doc


# ================================================================================================
# model specs
# ================================================================================================
def _base_spec() -> dict:
    return tomllib.loads(SAMPLE_MODEL.read_text())


_POSITIVE = {"cable": ("length_m", "horizontal_tension_N", "mass_per_length_kg_m", "diameter_m",
                       "axial_stiffness_N", "bending_stiffness_Nm2", "torsional_stiffness_Nm2",
                       "gravity_m_s2"),
             "aero": ("air_density_kg_m3", "critical_wind_speed_m_s")}
_REQUIRED = {"cable": ("length_m", "chord_slope_deg", "horizontal_tension_N", "mass_per_length_kg_m",
                       "diameter_m", "axial_stiffness_N", "bending_stiffness_Nm2", "torsional_stiffness_Nm2",
                       "damping_ratio"),
             "aero": ("air_density_kg_m3", "rivulet_diameter_ratio", "lift", "drag", "critical_wind_speed_m_s",
                      "yaw_deg", "rivulet_angle_deg")}
_OPTIONAL = {"cable": ("gravity_m_s2", "twist_ends"),
             "aero": ("load_length", "angle_convention", "load_axes", "calibration_root")}
_CHOICES = {"cable.twist_ends", "aero.load_length", "aero.angle_convention", "aero.load_axes",
            "aero.calibration_root"}
_NUMERIC = [(s, k) for s in ("cable", "aero") for k in _REQUIRED[s] + _OPTIONAL[s]
            if f"{s}.{k}" not in _CHOICES and k not in ("lift", "drag")]
HUGE_INT = Raw("1" + "0" * 399)                       # 400 digits
_WRONG_TYPES = ["abc", True, [1.0, 2.0], InlineTable(a=1), "1.0", ""]
_NONFINITE = [Raw("nan"), Raw("inf"), Raw("-inf")]
_STRINGS_ODD = ["a/b", "..", "../../escaped", "line\nbreak", "câble–ß∂", "x" * 300, " ", "tab\there",
                "{base}/abs-escape", "../" * 8 + "deep-escape", "nul\x00byte"]

# Physically impossible cables (model premises: nearly taut, small static strain and delta, near
# 1:1 internal resonance, slender section), each with the quantity a rejection should name.
_IMPOSSIBLE = [
    ("cable", "axial_stiffness_N", 1.0, ("axial_stiffness_N", "EA", "strain")),
    ("cable", "axial_stiffness_N", 1e3, ("axial_stiffness_N", "EA", "strain")),
    ("cable", "diameter_m", 200.0, ("diameter_m", "slender", "D/l")),
    ("cable", "diameter_m", 121.9, ("diameter_m", "slender", "D/l")),
    ("cable", "gravity_m_s2", 1e5, ("gravity_m_s2", "delta", "sag", "resonance")),
    ("cable", "horizontal_tension_N", 1e12, ("horizontal_tension_N", "strain", "tension")),
    ("cable", "horizontal_tension_N", 1.0, ("horizontal_tension_N", "delta", "sag", "taut")),
    ("cable", "length_m", 1e-6, ("length_m", "slender", "D/l")),
    ("cable", "length_m", 1e6, ("length_m", "delta", "sag", "resonance")),
    ("cable", "mass_per_length_kg_m", 1e6, ("mass_per_length_kg_m", "delta", "sag", "resonance")),
    ("aero", "critical_wind_speed_m_s", 1e6, ("critical_wind_speed_m_s", "U_c")),
    ("aero", "air_density_kg_m3", 1e6, ("air_density_kg_m3", "density")),
    ("aero", "drag", [1e300, -0.65, -0.08, 6.81], ("drag",)),
    ("aero", "lift", [1e300, 0.84, 4.69, 0.86], ("lift",)),
    ("cable", "chord_slope_deg", 89.999999, ("chord_slope_deg",)),
]
_SCALES = (0.5, 2.0, 10.0, 0.1)


def _m_drop_required(rng, doc):
    s = rng.choice(("cable", "aero"))
    k = rng.choice(_REQUIRED[s])
    del doc[s][k]
    return INVALID, f"drop {s}.{k}", (k,)


def _m_drop_optional(rng, doc):
    s = rng.choice(("cable", "aero"))
    k = rng.choice(_OPTIONAL[s])
    doc[s].pop(k, None)
    return ODD, f"drop optional {s}.{k}", (k,)


def _m_drop_section(rng, doc):
    s = rng.choice(("cable", "aero"))
    del doc[s]
    return INVALID, f"drop [{s}]", (s,)


def _m_unknown_key(rng, doc):
    where = rng.choice(("", "cable", "aero"))
    k = rng.choice(("colour", "length", "EA", "yaw", "lift_coefficients", "Length_m", "damping"))
    (doc[where] if where else doc)[k] = rng.choice((1.0, "x", True))
    return INVALID, f"unknown key {where + '.' if where else ''}{k}", (k,)


def _m_rename(rng, doc):
    s = rng.choice(("cable", "aero"))
    k = rng.choice(_REQUIRED[s])
    new = rng.choice([n for n in (k.upper(), k + "_", k.replace("_", "-"), " " + k) if n != k])
    doc[s][new] = doc[s].pop(k)
    return INVALID, f"rename {s}.{k} -> {new!r}", (k, new.strip())


def _m_wrong_type(rng, doc):
    s, k = rng.choice(_NUMERIC + [("aero", "lift"), ("aero", "drag")])
    v = rng.choice(_WRONG_TYPES)
    if k in ("yaw_deg", "rivulet_angle_deg") and v == "calibrate":
        v = "abc"
    doc[s][k] = v
    return INVALID, f"{s}.{k} = {_short(v)}", (k,)


def _m_nonfinite(rng, doc):
    s, k = rng.choice(_NUMERIC)
    v = rng.choice(_NONFINITE)
    doc[s][k] = v
    return INVALID, f"{s}.{k} = {v}", (k,)


def _m_nonpositive(rng, doc):
    s = rng.choice(("cable", "aero"))
    k = rng.choice(_POSITIVE[s])
    v = rng.choice((0.0, -1.0, -1e-300, Raw("-" + HUGE_INT), 0))
    doc[s][k] = v
    return INVALID, f"{s}.{k} = {_short(v)}", (k,)


def _m_huge_int(rng, doc):
    s, k = rng.choice(_NUMERIC)
    doc[s][k] = HUGE_INT
    return INVALID, f"{s}.{k} = <400-digit integer>", (k,)


def _m_list_length(rng, doc):
    k = rng.choice(("lift", "drag"))
    n = rng.choice((0, 1, 3, 5, 40))
    doc["aero"][k] = [0.5] * n
    return INVALID, f"aero.{k} with {n} numbers", (k,)


def _m_list_item(rng, doc):
    k = rng.choice(("lift", "drag"))
    i = rng.randrange(4)
    v = rng.choice(_NONFINITE + [HUGE_INT, "x", True])
    doc["aero"][k] = [v if j == i else x for j, x in enumerate(doc["aero"][k])]
    return INVALID, f"aero.{k}[{i}] = {_short(v)}", (k,)


def _m_angle(rng, doc):
    k, lo, hi = rng.choice((("chord_slope_deg", -90.0, 90.0), ("yaw_deg", -90.0, 90.0),
                            ("rivulet_angle_deg", -180.0, 180.0)))
    v = rng.choice((hi + 1e-9, lo - 1.0, 1e3, -1e5, 3 * hi, 720.0))
    doc["cable" if k == "chord_slope_deg" else "aero"][k] = v
    return INVALID, f"{k} = {v!r} outside [{lo:g}, {hi:g}]", (k,)


def _m_range(rng, doc):
    k, v = rng.choice((("damping_ratio", 1.0), ("damping_ratio", -0.1), ("damping_ratio", 5.0),
                       ("rivulet_diameter_ratio", 1.5), ("rivulet_diameter_ratio", -0.1)))
    doc["cable" if k == "damping_ratio" else "aero"][k] = v
    return INVALID, f"{k} = {v!r}", (k,)


def _m_choice(rng, doc):
    key = rng.choice(sorted(_CHOICES))
    s, k = key.split(".")
    v = rng.choice(("EQ12", "", "literal", 1, "eq12 ", "natural\n"))
    doc[s][k] = v
    return INVALID, f"{key} = {_short(v)}", (k,)


def _m_both_calibrate(rng, doc):
    doc["aero"]["yaw_deg"] = "calibrate"
    doc["aero"]["rivulet_angle_deg"] = "calibrate"
    return INVALID, 'yaw_deg and rivulet_angle_deg both "calibrate"', ("yaw_deg", "rivulet_angle_deg")


def _m_name(rng, doc):
    v = rng.choice(_STRINGS_ODD + ["", 5, ["a"]])
    doc["name"] = v
    if v == "" or not isinstance(v, str):
        return INVALID, f"name = {_short(v)}", ("name",)
    return ODD, f"name = {_short(v)}", ("name",)


def _m_description(rng, doc):
    v = rng.choice(_STRINGS_ODD + [3.0])
    doc["description"] = v
    return (INVALID if not isinstance(v, str) else ODD), f"description = {_short(v)}", ("description",)


def _m_impossible(rng, doc):
    s, k, v, names = rng.choice(_IMPOSSIBLE)
    doc[s][k] = v
    return INVALID, f"impossible cable: {s}.{k} = {_short(v)}", names


def _m_scale(rng, doc):
    s = rng.choice(("cable", "aero"))
    k = rng.choice(_POSITIVE[s])
    f = rng.choice(_SCALES)
    doc[s][k] = doc[s].get(k, 9.81) * f
    return ODD, f"{s}.{k} x {f:g}", (k,)


def _m_angle_edge(rng, doc):
    k, v = rng.choice((("yaw_deg", 90.0), ("yaw_deg", -90.0), ("rivulet_angle_deg", 180.0),
                       ("rivulet_angle_deg", 0.0), ("chord_slope_deg", 0.0), ("damping_ratio", 0.99),
                       ("damping_ratio", 1e-12), ("rivulet_diameter_ratio", 0.999)))
    if k == "rivulet_angle_deg":                 # one of yaw and Theta0 must stay "calibrate"
        doc["aero"]["yaw_deg"] = "calibrate"
    doc["cable" if k in ("chord_slope_deg", "damping_ratio") else "aero"][k] = v
    return ODD, f"edge value {k} = {v!r}", (k,)


# Text-level mutations: the document is no longer a dict.
def _t_empty(rng, text):
    return INVALID, "empty file", (), rng.choice(("", "\n", "# only a comment\n"))


def _t_non_utf8(rng, text):
    i = text.index("[cable]")
    junk = rng.choice((b"\xff\xfe", b"\xc3\x28", b"\x80", b"caf\xe9"))
    return INVALID, f"non-UTF-8 bytes {junk!r}", (), text[:i].encode() + b"# " + junk + b"\n" + text[i:].encode()


def _t_duplicate_table(rng, text):
    s = rng.choice(("[cable]", "[aero]"))
    return INVALID, f"duplicate table {s}", (s.strip("[]"),), text + f"\n{s}\nlength_m = 1.0\n"


def _t_duplicate_key(rng, text):
    return INVALID, "duplicate key cable.length_m", ("length_m",), text.replace(
        "[cable]\n", "[cable]\nlength_m = 10.0\n", 1)


def _t_truncate(rng, text):
    cut = rng.randrange(0, text.index("critical_wind_speed_m_s"))
    return INVALID, f"truncated at byte {cut}", (), text[:cut]


def _t_garbage(rng, text):
    junk = rng.choice(("[[cable]]\n", "= 1\n", "cable = 5\n", "\x00\x01\x02", "[cable\n", '"""\n', "{\n"))
    return INVALID, f"malformed TOML {junk!r}", (), junk + text


def _t_bom(rng, text):
    return ODD, "UTF-8 byte-order mark", (), "\ufeff" + text


SPEC_MUTATIONS: dict[str, Callable] = {f.__name__[3:]: f for f in (
    _m_drop_required, _m_drop_optional, _m_drop_section, _m_unknown_key, _m_rename, _m_wrong_type,
    _m_nonfinite, _m_nonpositive, _m_huge_int, _m_list_length, _m_list_item, _m_angle, _m_range,
    _m_choice, _m_both_calibrate, _m_name, _m_description, _m_impossible, _m_scale, _m_angle_edge,
    _t_empty, _t_non_utf8, _t_duplicate_table, _t_duplicate_key, _t_truncate, _t_garbage, _t_bom)}


def spec_case(kind: str, rng: random.Random) -> Case:
    """A mutated sample model (`SPEC_MUTATIONS[kind]`) given to ``autocable derive --json``."""
    fn = SPEC_MUTATIONS[kind]
    if fn.__name__.startswith("_t_"):
        expect, label, names, content = fn(rng, SAMPLE_MODEL.read_text())
    else:
        doc = _base_spec()
        expect, label, names = fn(rng, doc)
        content = dump_toml(doc)
    return Case("spec", label, expect, tuple(names), {MODEL_FILE: content},
                ("derive", f"{{case}}/{MODEL_FILE}", "--json"))


# ================================================================================================
# scenes
# ================================================================================================
_SCENES = ("fig03", "fig05a", "fig05b", "fig06", "fig07", "fig09", "fig11", "chart_U_eta", "folds_sigma_eta",
           "island_1dof")


def _base_scene(name: str) -> dict:
    doc = _inline(tomllib.loads((RUNS_DIR / f"{name}.toml").read_text()))
    doc["model"] = MODEL_FILE
    doc.pop("compare", None)          # its digitised csv stays in the repository
    return doc


def _runs(doc):
    return doc.get("run") or []


def _s_unknown_key(rng, doc):
    where = rng.choice(("", "run", "plot", "fixed", "overlay"))
    k = rng.choice(("colour", "tol", "max_points", "Range", "sigma_", "ranges"))
    if where == "run" and _runs(doc):
        rng.choice(_runs(doc))[k] = 1.0
    elif where and isinstance(doc.get(where), dict):
        doc[where][k] = 1.0
    else:
        doc[k] = 1.0
    return INVALID, f"unknown scene key {k!r} in {where or 'top level'}", (k,)


def _s_range(rng, doc):
    runs = [r for r in _runs(doc) if "range" in r]
    if not runs:
        doc["title"] = 5
        return INVALID, "title = 5", ("title",)
    r = rng.choice(runs)
    lo, hi = r["range"]
    v = rng.choice(([hi, lo], [lo, lo], [lo], [lo, hi, hi], [Raw("nan"), hi], [lo, Raw("inf")],
                    ["a", hi], [lo, HUGE_INT], []))
    r["range"] = v
    return INVALID, f"run {r.get('name')} range = {_short(v)}", ("range",)


def _s_premise_range(rng, doc):
    """Continuation ranges outside the parameters' ranges where eq. (21) applies."""
    runs = [r for r in _runs(doc) if "range" in r and r.get("kind", "equilibria") != "curve"]
    if not runs:
        return _s_fixed(rng, doc)
    r = rng.choice(runs)
    p = r.get("parameter")
    v = {"sigma": [[-1.0, 1.0], [-5.0, 0.0], [0.0, 1e9]], "U": [[0.1, 10.0], [0.1, 1e6]],
         "eta": [[0.0, 1.0], [0.0, 1e3]]}.get(p, [[-1.0, 1.0]])
    r["range"] = rng.choice(v)
    r.pop("at", None)
    return INVALID, f"run {r.get('name')} ({p}) range = {_short(r['range'])}", ("range", p or "range")


def _s_steps(rng, doc):
    runs = _runs(doc)
    if not runs:
        return _s_time(rng, doc)
    r = rng.choice(runs)
    k, v, expect = rng.choice((("tol", 1e-300, INVALID), ("tol", 0.0, INVALID), ("tol", -1.0, INVALID),
                               ("tol", Raw("nan"), INVALID), ("tol", 1e3, INVALID),
                               ("max_points", 0, INVALID), ("max_points", -3, INVALID),
                               ("max_points", 1.5, INVALID), ("max_points", HUGE_INT, INVALID),
                               ("max_points", "10", INVALID), ("step", 1e-300, INVALID),
                               ("max_step", Raw("inf"), INVALID), ("min_step", 1.0, INVALID),
                               ("ntst", 100000, ODD), ("max_points", 1, ODD), ("max_points", 2, ODD),
                               ("tol", 1e-6, ODD), ("chunk", 1, ODD)))
    r.setdefault("steps", {})[k] = v
    return expect, f"run {r.get('name')} steps.{k} = {_short(v)}", (k,)


def _s_fixed(rng, doc):
    if "time" in doc:
        return _s_time(rng, doc)
    k, v, expect = rng.choice((("eta", Raw("nan"), INVALID), ("eta", -1e-4, INVALID), ("eta", 0.5, INVALID),
                               ("eta", 1e3, INVALID), ("U", -1.0, INVALID), ("U", 100.0, INVALID),
                               ("sigma", 0.7, INVALID), ("sigma", Raw("-inf"), INVALID), ("U", "0.7", INVALID),
                               ("U", HUGE_INT, INVALID), ("eta", 0.01, ODD), ("U", 2.5, ODD), ("sigma", 0.3, ODD)))
    where = rng.choice(("fixed", "run"))
    if where == "run" and _runs(doc):
        r = rng.choice(_runs(doc))
        r.setdefault("fixed", {})[k] = v
        return expect, f"run {r.get('name')} fixed.{k} = {_short(v)}", (k,)
    doc.setdefault("fixed", {})[k] = v
    return expect, f"fixed.{k} = {_short(v)}", (k,)


def _s_fixed_continued(rng, doc):
    """[fixed] of the very parameter a run continues: silently ignored unless warned of."""
    runs = [r for r in _runs(doc) if r.get("kind", "equilibria") in ("equilibria", "switch")]
    if not runs or "time" in doc:
        return _s_fixed(rng, doc)
    r = rng.choice(runs)
    p = r["parameter"]
    v = {"sigma": 0.02, "U": 0.5, "eta": 1e-4}[p]
    doc.setdefault("fixed", {})[p] = v
    return ODD, f"fixed.{p} = {v} while run {r.get('name')} continues {p}", (p,)


def _s_start(rng, doc):
    runs = [r for r in _runs(doc) if r.get("kind", "equilibria") == "equilibria"]
    if not runs:
        return _s_fixed(rng, doc)
    r = rng.choice(runs)
    v, expect = rng.choice(((InlineTable(integrate=[-1.0, 0.0]), INVALID),
                            (InlineTable(integrate=[Raw("nan"), 0.0]), INVALID),
                            (InlineTable(integrate=[]), INVALID), (InlineTable(integrate="x"), INVALID),
                            (InlineTable(integrate=[1.0, 2.0], state=[0.0]), INVALID),
                            (InlineTable(state=[0.0, 0.0, 0.0]), INVALID),
                            (InlineTable(integrate=[HUGE_INT, 0.0]), INVALID),
                            ("I:XX", INVALID), ("nobody:H1", INVALID), ("trivial ", INVALID), (5, INVALID),
                            (InlineTable(orbit=[1e-3, 0.0]), INVALID)))
    r["start"] = v
    return expect, f"run {r.get('name')} start = {_short(v)}", ("start",)


def _s_model(rng, doc):
    v = rng.choice(("missing.toml", "", ".", "..", 5, "/", "nul\x00.toml", "../" * 30 + "x.toml"))
    doc["model"] = v
    return INVALID, f"model = {_short(v)}", ("model",)


def _s_choice(rng, doc):
    k, v = rng.choice((("ame", "3dof"), ("ame", 2), ("engine", "fast"), ("ordering", "Paper"),
                       ("state_scale", 0.0), ("state_scale", -1.0), ("state_scale", Raw("nan")),
                       ("ame_tol", 0.5)))
    doc[k] = v
    return INVALID, f"{k} = {_short(v)}", (k,)


def _s_plot(rng, doc):
    k, v = rng.choice((("y", ["a3"]), ("y", []), ("x", "omega"), ("labels", "yes"), ("title", 5)))
    doc.setdefault("plot", {})[k] = v
    return INVALID, f"plot.{k} = {_short(v)}", (k,)


def _s_overlay(rng, doc):
    if "time" in doc:
        return _s_time(rng, doc)
    k, v = rng.choice((("points", 0), ("points", 10 ** 6), ("points", 2.5), ("method", "euler"),
                       ("max_time", -1.0), ("max_time", Raw("inf")), ("range", [1.0, 0.0]),
                       ("directions", ["sideways"])))
    doc.setdefault("overlay", {})[k] = v
    return INVALID, f"overlay.{k} = {_short(v)}", (k,)


def _s_time(rng, doc):
    if "time" not in doc:
        return _s_overlay(rng, doc)
    k, v, expect = rng.choice((("t_end", -1.0, INVALID), ("t_end", Raw("nan"), INVALID), ("U", 0.0, INVALID),
                               ("samples_per_period", 0, INVALID), ("summary_from", 1e9, INVALID),
                               ("start", InlineTable(amplitudes=[-1.0, 0.0]), INVALID),
                               ("eta", 0.5, INVALID), ("sigma", 3.0, INVALID),
                               ("start", InlineTable(amplitudes=[1e6, 0.0]), ODD)))
    doc["time"][k] = v
    return expect, f"time.{k} = {_short(v)}", (k,)


def _s_duplicate_names(rng, doc):
    runs = _runs(doc)
    if len(runs) < 2:
        return _s_unknown_key(rng, doc)
    runs[1]["name"] = runs[0].get("name", "R1")
    return INVALID, f"two runs named {runs[0].get('name')!r}", ("name",)


def _s_text(rng, doc):
    text = dump_toml(doc)
    kind = rng.choice(("empty", "bytes", "dup", "truncate"))
    if kind == "empty":
        return INVALID, "empty scene file", ("model",), ""
    if kind == "bytes":
        return INVALID, "non-UTF-8 byte in a comment", (), b"# \xff\n" + text.encode()
    if kind == "dup":
        return INVALID, "duplicate [plot] table", ("plot",), text + "\n[plot]\nx = \"sigma\"\n"
    cut = rng.randrange(0, max(1, text.index("\n", text.index("model"))))
    return INVALID, f"truncated at byte {cut}", ("model",), text[:cut]


# Mutations that need a real run of Fig. 5a to show (they pass the schema today, or should fail at
# the run): (label, expect, names, mutate(doc, files)).
def _r_compare(rng, doc, files):
    csv, expect, what = rng.choice((
        ("x,y\n0.0,abc\n", INVALID, "a non-number"), ("a,b\n1,2\n", INVALID, "no x, y columns"),
        (b"x,y\n\xff\xfe,1\n", INVALID, "non-UTF-8 bytes"), ("", INVALID, "an empty file"),
        (None, INVALID, "a missing file"), ("x,y\nnan,inf\n", INVALID, "non-finite values"),
        ("x,y,curve,stable\n0.0,1e-4,I,1\n", ODD, "one good row")))
    doc["compare"] = {"csv": CSV_FILE, "panel": "a1"}
    if csv is not None:
        files[CSV_FILE] = csv
    return expect, f"[compare] csv with {what}", ("compare", "csv", CSV_FILE)


def _r_integrate(rng, doc, files):
    v = rng.choice(([1e6, 0.0], [10.0, 10.0], [1e3, 1e3]))
    doc["run"][0]["start"] = InlineTable(integrate=v)
    return ODD, f"run I start = {{ integrate = {_val(v)} }} (huge settling integration)", ("start", "integrate")


def _r_tol(rng, doc, files):
    k, v, expect = rng.choice((("tol", 1e-300, INVALID), ("max_points", 1, ODD), ("tol", 1e-15, ODD)))
    doc["run"][0].setdefault("steps", {})[k] = v
    return expect, f"run I steps.{k} = {v!r}", (k,)


def _r_range(rng, doc, files):
    v = rng.choice(([-1.0, 1.0], [-0.5, 0.5]))
    doc["run"][0]["range"] = v
    return (INVALID if v[0] < -0.5 else ODD), f"run I range = {v}", ("range", "sigma")


def _r_fixed_eta(rng, doc, files):
    v = rng.choice((0.5, 1e3, 0.01))
    doc["fixed"]["eta"] = v
    return (INVALID if v > 0.05 else ODD), f"fixed.eta = {v!r}", ("eta",)


def _r_bad_model(rng, doc, files):
    content, what = rng.choice(((b"name = \"x\"\n\xff\n", "non-UTF-8 bytes"), ("", "an empty file"),
                                ("name = 5\n", "name = 5"), (None, "a folder")))
    files[MODEL_FILE] = DIRECTORY if content is None else content
    return INVALID, f"scene model file with {what}", ("model", MODEL_FILE)


_RUN_MUTATIONS = (_r_compare, _r_integrate, _r_tol, _r_range, _r_fixed_eta, _r_bad_model)

SCENE_MUTATIONS: dict[str, Callable] = {f.__name__[3:]: f for f in (
    _s_unknown_key, _s_range, _s_premise_range, _s_steps, _s_fixed, _s_fixed_continued, _s_start, _s_model,
    _s_choice, _s_plot, _s_overlay, _s_time, _s_duplicate_names, _s_text)}
SCENE_MUTATIONS.update({"run_" + f.__name__[3:]: f for f in _RUN_MUTATIONS})


def scene_case(kind: str, rng: random.Random) -> Case:
    """A mutated figure scene: loaded with `load_scene` (``run_*`` kinds: a real coarse run of
    Fig. 5a on the compiled engine, in a subprocess with a time limit)."""
    fn = SCENE_MUTATIONS[kind]
    files: dict = {MODEL_FILE: SAMPLE_MODEL.read_text()}
    if kind.startswith("run_"):
        doc = _base_scene("fig05a")
        doc.pop("overlay", None)                  # the overlay's 22 integrations are not the point
        expect, label, names = fn(rng, doc, files)
        files[SCENE_FILE] = dump_toml(doc)
        argv = ("run", f"{{case}}/{SCENE_FILE}", "--out", "{out}", "--no-plot", "--quiet",
                "--resolution", "coarse", "--engine", "compiled")
        return Case("scene", f"fig05a: {label}", expect, tuple(names), files, argv, subprocess=True,
                    timeout=120.0)
    base = rng.choice(_SCENES)
    doc = _base_scene(base)
    got = fn(rng, doc)
    if len(got) == 4:
        expect, label, names, content = got
    else:
        (expect, label, names), content = got, dump_toml(doc)
    files[SCENE_FILE] = content
    return Case("scene", f"{base}: {label}", expect, tuple(names), files, mode="load_scene")


# ================================================================================================
# argument vectors
# ================================================================================================
def _simulate(*extra, json_=True):
    return ("simulate", "{model}", "--max-time", "200", "--quiet") + (("--json",) if json_ else ()) + extra


_BAD_FLOATS = ("nan", "inf", "-inf", "-5", "1e9", "", "1e400", "0x10", "one")
# (label, expect, names, argv, files, subprocess)
ARG_CASES: list[tuple] = []
for _opt in ("--U", "--eta", "--sigma"):
    for _v in _BAD_FLOATS:
        # "--U=-inf": argparse would take a lone "-inf" for an option
        ARG_CASES.append((f"simulate {_opt}={_v}", INVALID, (_opt,), _simulate(f"{_opt}={_v}"), {}, False))
for _v in ("-5", "0", "nan", "inf", "", "-inf"):
    ARG_CASES.append((f"simulate --max-time={_v}", INVALID, ("--max-time", "max_time"),
                      ("simulate", "{model}", "--json", "--quiet", f"--max-time={_v}"), {}, False))
for _m in ("ame", "shooting"):
    for _opt, _v in (("--eta", "nan"), ("--U", "inf"), ("--sigma", "1e9")):
        ARG_CASES.append((f"simulate --method {_m} {_opt} {_v}", INVALID, (_opt,),
                          _simulate("--method", _m, _opt, _v), {}, False))
ARG_CASES += [
    ("simulate --q0 nan 0 0 0", INVALID, ("--q0",), _simulate("--q0", "nan", "0", "0", "0"), {}, False),
    ("simulate --q0 1 2 3 (three values)", INVALID, ("--q0",), _simulate("--q0", "1", "2", "3"), {}, False),
    ("simulate --q0 1e6 0 0 0", ODD, ("--q0",), _simulate("--q0", "1e6", "0", "0", "0"), {}, False),
    ("simulate --U 1.5 (diverging) --csv", ODD, ("--csv",),
     _simulate("--U", "1.5", "--csv", "{out}/h.csv"), {}, False),
    ("simulate --csv into a folder", INVALID, ("--csv",), _simulate("--csv", "{case}/adir"),
     {"adir": DIRECTORY}, False),
    ("simulate --csv into a missing folder", ODD, ("--csv",), _simulate("--csv", "{out}/no/such/h.csv"), {}, False),
    ("simulate --modes 0", INVALID, ("--modes",), _simulate("--modes", "0"), {}, False),
    ("simulate --modes -3", INVALID, ("--modes",), _simulate("--modes", "-3"), {}, False),
    ("simulate --modes 1000", ODD, ("--modes",), _simulate("--modes", "1000"), {}, True),
    ("simulate --max-time 1e9 --U 0", ODD, ("--max-time",),
     ("simulate", "{model}", "--json", "--quiet", "--max-time", "1e9"), {}, True),
    ("derive: missing file", INVALID, (), ("derive", "{case}/none.toml", "--json"), {}, False),
    *((f"onset {_o}={_v}", INVALID, (_o,), ("onset", "{model}", "--json", f"{_o}={_v}"), {}, False)
      for _o, _v in (("--damping", "0:0.01"), ("--damping", "nan:0.01"), ("--damping", "0.01:0.001"),
                     ("--damping", "0.001:0.01:1e9"), ("--damping", "a:b"), ("--design-wind", "-3"),
                     ("--design-wind", "1e9"), ("--design-wind", "nan"), ("--max-wind", "inf"),
                     ("--set", "cable.damping_ratio=2"), ("--set", "cable.gravity_m_s2=3"), ("--set", "bogus"),
                     ("--checks", "-1"))),
    ("onset --refit without --set", INVALID, ("--refit",), ("onset", "{model}", "--refit"), {}, False),
    ("derive: a folder", INVALID, (), ("derive", "{case}/adir", "--json"), {"adir": DIRECTORY}, False),
    ("derive: a FIFO", INVALID, (), ("derive", "{case}/pipe.toml", "--json"), {"pipe.toml": FIFO}, True),
    ("derive: empty path", INVALID, ("model",), ("derive", "", "--json"), {}, False),
    ("derive --ordering bogus", INVALID, ("--ordering",), ("derive", "{model}", "--ordering", "bogus"), {}, False),
    ("run: missing scene", INVALID, (), ("run", "{case}/none.toml", "--out", "{out}"), {}, True),
    ("run: a FIFO scene", INVALID, (), ("run", "{case}/pipe.toml", "--out", "{out}"), {"pipe.toml": FIFO}, True),
    ("run --out ''", INVALID, ("--out",), ("run", "{scene}", "--out", "", "--no-plot", "--quiet",
                                          "--resolution", "coarse", "--engine", "compiled"), {}, True),
    ("run --out an existing file", INVALID, ("--out",),
     ("run", "{scene}", "--out", "{case}/afile", "--no-plot", "--quiet"), {"afile": "x\n"}, True),
    ("run --resolution bogus", INVALID, ("--resolution",), ("run", "{scene}", "--resolution", "bogus"), {}, False),
    ("run --engine bogus", INVALID, ("--engine",), ("run", "{scene}", "--engine", "bogus"), {}, False),
    ("sweep: missing file", INVALID, (), ("sweep", "{case}/none.toml", "--out", "{out}"), {}, True),
    ("sweep --workers -5", INVALID, ("--workers",),
     ("sweep", "{sweep}", "--out", "{out}", "--workers", "-5", "--quiet"), {}, True),
    ("sweep --chunk 0", INVALID, ("--chunk",), ("sweep", "{sweep}", "--out", "{out}", "--chunk", "0", "--quiet"),
     {}, True),
    ("sweep --out ''", INVALID, ("--out",), ("sweep", "{sweep}", "--out", "", "--workers", "0", "--quiet"), {}, True),
    ("advise --tol nan", INVALID, ("--tol",), ("advise", "{scene}", "--tol", "nan", "--json"), {}, False),
    ("advise --tol -5", INVALID, ("--tol",), ("advise", "{scene}", "--tol", "-5", "--json"), {}, False),
    ("advise --tol 1e9", INVALID, ("--tol",), ("advise", "{scene}", "--tol", "1e9", "--json"), {}, False),
    ("advise --tol ''", INVALID, ("--tol",), ("advise", "{scene}", "--tol", "", "--json"), {}, False),
    ("advise: missing scene", INVALID, (), ("advise", "{case}/none.toml", "--json"), {}, False),
    ("chart: scene without [chart]", INVALID, ("chart",), ("chart", "{scene}", "--out", "{out}", "--quiet"), {}, True),
    ("chart --map missing", INVALID, ("--map",),
     ("chart", "{chart}", "--out", "{out}", "--map", "{case}/none.nc", "--quiet"), {}, True),
    ("figures --workers -5", INVALID, ("--workers",), ("figures", "--out", "{out}", "--only", "fig05a",
                                                       "--workers", "-5", "--quiet"), {}, True),
    ("figures --workers 999", INVALID, ("--workers",), ("figures", "--out", "{out}", "--only", "fig05a",
                                                        "--workers", "999", "--quiet"), {}, True),
    ("figures --scheduler refused", INVALID, ("--scheduler",), ("figures", "--out", "{out}", "--only", "fig05a",
                                                                "--scheduler", "tcp://127.0.0.1:1", "--quiet"),
     {}, True),
    ("figures --timeout nan", INVALID, ("--timeout",),
     ("figures", "--out", "{out}", "--only", "fig05a", "--timeout", "nan", "--quiet"), {}, True),
    ("figures --timeout -5", INVALID, ("--timeout",),
     ("figures", "--out", "{out}", "--only", "fig05a", "--timeout", "-5", "--quiet"), {}, True),
    ("figures --only bogus", INVALID, ("--only", "bogus"), ("figures", "--out", "{out}", "--only", "bogus",
                                                            "--quiet"), {}, True),
    ("figures --runs missing folder", INVALID, ("--runs",),
     ("figures", "--out", "{out}", "--runs", "{case}/none", "--only", "fig05a", "--quiet"), {}, True),
    ("figures --out ''", INVALID, ("--out",), ("figures", "--out", "", "--only", "fig05a", "--quiet"), {}, True),
    ("no command", INVALID, ("command",), (), {}, False),
    ("unknown command", INVALID, ("bogus",), ("bogus",), {}, False),
]


def args_case(index: int, rng: random.Random | None = None) -> Case:
    """`ARG_CASES[index]` as a `Case` ({model}, {scene}, ... are the repository's files)."""
    label, expect, names, argv, files, sub = ARG_CASES[index % len(ARG_CASES)]
    slow = argv[:1] in (("run",), ("figures",), ("chart",), ("sweep",))
    return Case("args", label, expect, tuple(names), dict(files), tuple(argv), subprocess=sub,
                timeout=90.0 if slow else 30.0)


# ================================================================================================
# running a case
# ================================================================================================
class _Hang(BaseException):
    """Raised by the alarm in an in-process run past its time limit (not an Exception: `main`
    must not catch it)."""


def _strict_json(text: str):
    def refuse(c):
        raise ValueError(f"non-standard JSON constant {c}")
    return json.loads(text, parse_constant=refuse)


def _tree(root: Path, skip: tuple[Path, ...]) -> set[str]:
    found = set()
    for dirpath, dirnames, filenames in os.walk(root):
        d = Path(dirpath)
        dirnames[:] = [n for n in dirnames if d / n not in skip]
        for n in filenames + dirnames:
            found.add(str((d / n).relative_to(root)))
    return found


@dataclass
class Harness:
    """Runs cases in a private folder tree (``base``), with its own cache inside it, so that files
    written anywhere under ``base`` outside the case's ``out`` and the cache are seen.

    ``main`` is `autocable.cli.main` (passed in, so that a test can hand in a stand-in)."""

    main: Callable
    base: Path
    runs_left: int = 1 << 30          # real runs (subprocess cases) allowed; the others are skipped
    max_timeout: float = 1e9          # caps every case's time limit (the tests: a hang costs less)
    runner: Callable | None = None    # (case, input folder) -> (exit, stdout, stderr) of the other modes
    _count: int = 0
    _seen: dict = field(default_factory=dict)

    def __post_init__(self):
        self.base = Path(self.base).resolve()
        # the cache sits four levels down, so that a name like "../../x" lands inside `base`
        self.cache = self.base / "c1" / "c2" / "c3" / "cache"
        self.cache.mkdir(parents=True, exist_ok=True)
        self.cases = self.base / "cases"
        self.cases.mkdir(exist_ok=True)

    def env(self) -> dict:
        env = dict(os.environ, AUTOCABLE_CACHE=str(self.cache))
        env.pop("AUTOCABLE_DEBUG", None)
        return env

    def _materialise(self, case: Case) -> tuple[Path, Path, Path, list[str]]:
        self._count += 1
        where = self.cases / f"{self._count:05d}"
        inp, out, cwd = where / "in", where / "out", where / "cwd"
        for d in (inp, cwd):
            d.mkdir(parents=True)
        for name, v in case.files.items():
            p = inp / name
            if v is FIFO:
                os.mkfifo(p)
            elif v is DIRECTORY:
                p.mkdir()
            elif isinstance(v, bytes):
                p.write_bytes(v)
            else:
                p.write_text(v.replace("{base}", str(self.base)))
        if case.out_files:
            out.mkdir(parents=True)
            for name, v in case.out_files.items():
                (out / name).write_text(v)
        subs = {"{case}": str(inp), "{out}": str(out), "{model}": str(SAMPLE_MODEL),
                "{scene}": str(RUNS_DIR / "fig05a.toml"), "{chart}": str(RUNS_DIR / "chart_U_eta.toml"),
                "{sweep}": str(RUNS_DIR / "sweep_fig05a.toml")}
        argv = []
        for a in case.argv:
            for k, v in subs.items():
                a = a.replace(k, v)
            argv.append(a)
        return inp, out, cwd, argv

    def run(self, case: Case) -> Outcome | None:
        """Run one case and check it; None when a real run was skipped (budget spent)."""
        if case.subprocess:
            key = case.key()
            if key in self._seen:
                return self._seen[key]
            if self.runs_left <= 0:
                return None
            self.runs_left -= 1
        inp, out, cwd, argv = self._materialise(case)
        skip = (self.cache, out)
        before = _tree(self.base, skip)
        t0 = time.perf_counter()
        limit = min(case.timeout, self.max_timeout)
        if case.subprocess:
            code, so, se = self._child(argv, cwd, limit)
        elif case.mode == "load_scene":
            code, so, se = self._load_scene(inp / SCENE_FILE, cwd, limit)
        elif case.mode != "cli":
            code, so, se = self._surface(case, inp, cwd, limit)
        else:
            code, so, se = self._inprocess(argv, cwd, limit)
        seconds = time.perf_counter() - t0
        escaped = sorted(_tree(self.base, skip) - before)
        outcome = Outcome(code, so, se, seconds, escaped, [])
        outcome.problems = check(case, outcome, argv, limit)
        if case.post is not None and outcome.exit is not None:
            outcome.problems += case.post(inp, out, outcome)
        if case.subprocess:
            self._seen[case.key()] = outcome
        # a case's folders are not needed after the checks (FIFOs and modes would trouble rmtree)
        shutil.rmtree(inp.parent, ignore_errors=True)
        return outcome

    @contextlib.contextmanager
    def _in(self, cwd: Path, timeout: float):
        old_cwd, old_cache = os.getcwd(), os.environ.get("AUTOCABLE_CACHE")
        debug = os.environ.pop("AUTOCABLE_DEBUG", None)

        def alarm(signum, frame):
            raise _Hang()
        old_handler = signal.signal(signal.SIGALRM, alarm)
        os.chdir(cwd)
        os.environ["AUTOCABLE_CACHE"] = str(self.cache)
        signal.setitimer(signal.ITIMER_REAL, timeout)
        try:
            yield
        finally:
            signal.setitimer(signal.ITIMER_REAL, 0)
            signal.signal(signal.SIGALRM, old_handler)
            os.chdir(old_cwd)
            if old_cache is None:
                os.environ.pop("AUTOCABLE_CACHE", None)
            else:
                os.environ["AUTOCABLE_CACHE"] = old_cache
            if debug is not None:
                os.environ["AUTOCABLE_DEBUG"] = debug

    def _inprocess(self, argv, cwd, timeout):
        so, se = io.StringIO(), io.StringIO()
        code = None
        try:
            with self._in(cwd, timeout), contextlib.redirect_stdout(so), contextlib.redirect_stderr(se):
                try:
                    code = self.main(argv)
                except SystemExit as exc:          # argparse
                    code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 2)
        except _Hang:
            code = None
        except Exception as exc:                     # escaped main: a traceback for the user
            import traceback
            se.write("Traceback (most recent call last): escaped autocable.cli.main\n"
                     + "".join(traceback.format_exception_only(type(exc), exc)))
            code = 1
        return code, so.getvalue(), se.getvalue()

    def _load_scene(self, path, cwd, timeout):
        from autocable.scene.schema import load_scene
        from autocable.spec import SpecError
        se = io.StringIO()
        code = 0
        try:
            with self._in(cwd, timeout), contextlib.redirect_stderr(se):
                load_scene(path)
        except _Hang:
            code = None
        except SpecError as exc:
            se.write(f"autocable: error: {exc}\n")
            code = 2
        except Exception as exc:
            # what `autocable run` would print through its catch-all: an unforeseen exception
            first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            se.write(f"autocable: error ({type(exc).__name__}): {first}\n")
            code = 2
        return code, "", se.getvalue()

    def _surface(self, case, inp, cwd, timeout):
        if self.runner is None:
            raise ValueError(f"a case of mode {case.mode!r} needs the harness's runner "
                             "(tools.hardening.fuzz_surfaces.run_mode)")
        try:
            with self._in(cwd, timeout):
                return self.runner(case, inp)
        except _Hang:
            return None, "", ""

    def _child(self, argv, cwd, timeout):
        cmd = [sys.executable, "-m", "autocable.cli", *argv]
        try:
            p = subprocess.run(cmd, cwd=cwd, env=self.env(), capture_output=True, timeout=timeout,
                               stdin=subprocess.DEVNULL)
        except subprocess.TimeoutExpired as exc:
            return None, (exc.stdout or b"").decode(errors="replace"), (exc.stderr or b"").decode(errors="replace")
        return p.returncode, p.stdout.decode(errors="replace"), p.stderr.decode(errors="replace")


def _message(stderr: str) -> str:
    """The rejection line: the last line that says error/failed (argparse: its "error:" line)."""
    lines = [ln.strip() for ln in stderr.replace("\r", "\n").splitlines() if ln.strip()]
    for ln in reversed(lines):
        if "error" in ln.lower() or "failed" in ln.lower():
            return ln
    return lines[-1] if lines else ""


def check(case: Case, o: Outcome, argv: list[str], limit: float) -> list[tuple[str, str]]:
    """The properties every case must have; a list of (kind, what is wrong)."""
    problems = []
    if o.exit is None:
        problems.append(("hang", f"no exit within {limit:g} s"))
        return problems
    text = o.stdout + o.stderr
    msg = _message(o.stderr)
    if "Traceback" in text or (o.exit < 0):
        problems.append(("traceback", (msg or f"killed by signal {-o.exit}")[:300]))
    elif o.exit != 0 and msg.startswith("autocable: error (") and "AUTOCABLE_DEBUG" in msg:
        problems.append(("unforeseen_exception", msg[:300]))
    elif o.exit != 0 and case.mode != "cli" and msg.startswith("autocable: error ("):
        problems.append(("unforeseen_exception", msg[:300]))
    if "NaN result" in o.stdout:
        problems.append(("nan_result", case.label[:300]))
    if o.exit == 0 and case.expect == INVALID:
        problems.append(("exit0_invalid", (o.stdout.strip()[:200] or ("accepted by load_scene"
                                                                       if case.mode == "load_scene" else "(no output)"))
                         + (f" | stderr: {o.stderr.strip()[-200:]}" if o.stderr.strip() else "")))
    if o.exit != 0:
        tokens = [t.lower() for t in case.names if t] + [n.lower() for n in case.files]
        tokens += [os.path.basename(a.rstrip("/")).lower() for a in argv if os.sep in a]
        # a spec's rejection may name the field it blames as "section.key" (e.g. a calibration
        # that fails names aero.rivulet_angle_deg, not the value that made it fail)
        field_named = case.family == "spec" and re.search(r"\b(cable|aero)\.[a-z_0-9]+", msg)
        if not msg or not (field_named or any(t in msg.lower() for t in tokens)):
            problems.append(("unnamed_rejection", msg[:300] or "(empty stderr)"))
        elif len(msg) > 600:
            problems.append(("long_message", f"{len(msg)} characters: {msg[:200]}..."))
    if o.exit == 0 and ("--json" in case.argv or case.argv[:1] == ("sweep",)):
        try:
            _strict_json(o.stdout)
        except ValueError as exc:
            problems.append(("bad_json", f"{exc}: {o.stdout.strip()[:200]}"))
    if o.escaped:
        problems.append(("escaped_write", ", ".join(o.escaped[:5])))
    return problems


# ================================================================================================
# hypothesis strategies and the long run
# ================================================================================================
def strategies():
    """Hypothesis strategies of spec, scene and argument cases (imported lazily: hypothesis is
    needed only by the fuzzing)."""
    from hypothesis import strategies as st
    rnd = st.randoms(use_true_random=False)
    specs = st.builds(spec_case, st.sampled_from(sorted(SPEC_MUTATIONS)), rnd)
    scenes = st.builds(scene_case, st.sampled_from(sorted(k for k in SCENE_MUTATIONS if not k.startswith("run_"))),
                       rnd)
    runs = st.builds(scene_case, st.sampled_from(sorted(k for k in SCENE_MUTATIONS if k.startswith("run_"))), rnd)
    args = st.builds(args_case, st.integers(0, len(ARG_CASES) - 1))
    # the vectors that end before any long computation (no run, figures, chart or sweep)
    quick = st.builds(args_case, st.sampled_from([i for i, c in enumerate(ARG_CASES)
                                                  if c[3][:1] not in (("run",), ("figures",), ("chart",), ("sweep",))]))
    return {"specs": specs, "scenes": scenes, "scene_runs": runs, "args": args, "quick_args": quick}


def run_fuzz(main: Callable, specs: int = 1000, scenes: int = 300, args: int = 60, seed: int = 0,
             out: str | os.PathLike | None = None, real_runs: int = 16, log=None, extra=(),
             runner: Callable | None = None) -> dict:
    """The long fuzz run (``python -m tools.hardening fuzz``): ``specs`` mutated models through ``derive --json``,
    ``scenes`` mutated scenes through `load_scene` (of which up to ``real_runs`` real coarse runs),
    ``args`` argument vectors, then the ``extra`` cases ((count key, case) pairs: the sweep files,
    chart tables, targets and search-space files, --map files and API calls of
    `tools.hardening.fuzz_surfaces`, run by ``runner``); counts and the first problems."""
    say = log or (lambda s: None)
    t0 = time.perf_counter()
    tmp = None
    if out is None:
        tmp = tempfile.mkdtemp(prefix="autocable-fuzz-")
        base = Path(tmp)
    else:
        base = Path(out) / "fuzz-tree"
        if base.exists():
            shutil.rmtree(base)
        base.mkdir(parents=True)
    h = Harness(main, base, runs_left=real_runs, runner=runner)
    counts = {"specs": 0, "scenes": 0, "scene_real_runs": 0, "args": 0, "invalid": 0, "odd": 0,
              "rejected": 0, "accepted": 0, "tracebacks": 0, "unforeseen_exceptions": 0, "exit0_invalid": 0,
              "unnamed_rejections": 0, "long_messages": 0, "bad_json": 0, "escaped_writes": 0, "hangs": 0,
              "nan_results": 0, "foreign_files_lost": 0, "wrong_results": 0, "skipped_real_runs": 0,
              "surfaces": {}}
    kind_count = {"traceback": "tracebacks", "unforeseen_exception": "unforeseen_exceptions",
                  "exit0_invalid": "exit0_invalid", "unnamed_rejection": "unnamed_rejections",
                  "long_message": "long_messages", "bad_json": "bad_json", "escaped_write": "escaped_writes",
                  "hang": "hangs", "nan_result": "nan_results", "foreign_file_lost": "foreign_files_lost",
                  "wrong_result": "wrong_results"}
    problems, groups, odd_accepted = [], {}, {}

    def record(case, o):
        if o is None:
            counts["skipped_real_runs"] += 1
            return
        counts[case.expect] += 1
        counts["rejected" if o.exit != 0 else "accepted"] += 1
        if o.exit == 0 and case.expect == ODD:
            odd_accepted.setdefault(case.label.split(":")[0] if case.family == "scene" else case.label, 0)
        for kind, what in o.problems:
            counts[kind_count[kind]] += 1
            gkey = (case.family, kind, _group(case.label))
            g = groups.setdefault(gkey, {"family": case.family, "kind": kind, "input": _group(case.label),
                                         "cases": 0, "example": case.label, "output": what})
            g["cases"] += 1
            if len(problems) < 20:
                problems.append({"problem": kind, "what": what, "exit": o.exit, **case.describe()})

    kinds = sorted(SPEC_MUTATIONS)
    for i in range(specs):
        rng = random.Random(f"{seed}:spec:{i}")
        case = spec_case(kinds[i % len(kinds)], rng)
        counts["specs"] += 1
        record(case, h.run(case))
        if (i + 1) % 100 == 0:
            say(f"specs {i + 1}/{specs} ({time.perf_counter() - t0:.0f} s)")
    skinds = sorted(SCENE_MUTATIONS)
    for i in range(scenes):
        rng = random.Random(f"{seed}:scene:{i}")
        case = scene_case(skinds[i % len(skinds)], rng)
        counts["scenes"] += 1
        o = h.run(case)
        if case.subprocess and o is not None:
            counts["scene_real_runs"] += 1
        record(case, o)
        if (i + 1) % 50 == 0:
            say(f"scenes {i + 1}/{scenes} ({time.perf_counter() - t0:.0f} s)")
    h.runs_left = 1 << 30                # every argument vector runs
    n = len(ARG_CASES)
    for i in range(args):
        # fewer vectors than ARG_CASES: spread over the list (every command), more: cycle
        case = args_case(i * n // args if args < n else i)
        counts["args"] += 1
        record(case, h.run(case))
    say(f"arguments {args} ({time.perf_counter() - t0:.0f} s)")
    for key, case in extra:
        counts["surfaces"][key] = counts["surfaces"].get(key, 0) + 1
        record(case, h.run(case))
    if extra:
        say(f"surfaces {dict(counts['surfaces'])} ({time.perf_counter() - t0:.0f} s)")
    if tmp:
        shutil.rmtree(tmp, ignore_errors=True)
    n_problems = sum(counts[k] for k in kind_count.values())
    return {**counts, "seed": seed, "problem_count": n_problems, "wall_seconds": round(time.perf_counter() - t0, 1),
            "problems": problems,
            "problem_groups": sorted(groups.values(), key=lambda g: (g["family"], g["kind"], g["input"])),
            "accepted_odd_inputs": sorted(odd_accepted)}


def _group(label: str) -> str:
    """A label without its numbers: cases differing only by value group together."""
    return re.sub(r"-?\d[\d.e+-]*", "N", label)[:120]
