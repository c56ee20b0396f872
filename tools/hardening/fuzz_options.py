"""Generated hostile inputs on the surfaces added after the first fuzz rounds:
`autocable onset` and `autocable damper` options, model specs given to them (the ``[damper]`` table
too), and the keywords of the Python API (`frequency_response`, `ShootingSolver.steady`,
`plot_branches`) with numbers of every type, None, bools, strings, tuples of the wrong length and
numpy scalars.

Every case is a `tools.hardening.fuzz.Case` run in-process by `tools.hardening.fuzz.Harness`
(``main(argv)`` with captured stdout and stderr, a time limit; API calls through `run_mode`), checked
by `tools.hardening.fuzz.check` and, where an oracle exists, by the case's own ``post`` check: a
result with exit 0 must say what was asked (the damping grid's points and ends, the scanned range
of ``--max-wind``, the design wind, the damper's position and constant, one panel per amplitude of
``plot_branches``), and a user's files already in ``--out`` must be there, unchanged, afterwards.
`run_options` (``python -m tools.hardening options``) classifies each case as ok, refused naming the
field or argument, traceback (or an unforeseen exception), hang, wrong result with exit 0 (an
invalid input accepted, or an oracle failed), unnamed refusal, or a foreign file lost.

A case's generator is a function of a seeded `random.Random`, so a run is reproducible; the few
valid cases that compute for seconds (``--design-wind``, ``--band``, ``--out`` with plots) are drawn
only when ``heavy`` is allowed.
"""
from __future__ import annotations

import io
import json
import math
import random
import time
from fractions import Fraction
from decimal import Decimal
from pathlib import Path

from autocable._paths import SAMPLE_MODEL
from tools.hardening.fuzz import INVALID, MODEL_FILE, ODD, Case, Harness, Raw, SPEC_MUTATIONS, spec_case

__all__ = ["KINDS", "option_case", "cases", "run_mode", "run_options", "classify"]

#: The sample cable: length 121.9 m (a damper below 60.95 m), U_c = 36 m/s (onset scans up to 5 U_c).
HALF_LENGTH = 121.9 / 2
U_MAX = 5 * 36.0
#: A user's file in --out, which no command may overwrite or remove.
FOREIGN = "a user's own notes, not autocable's\n"

_NUMBERS_BAD = ["-1", "0", "nan", "inf", "-inf", "1e9", "abc", "", "1e400", "0x10", " "]


def _pick(rng, seq):
    return seq[rng.randrange(len(seq))]


def _with_damper(position="20.0", constant="2e5", stiffness=None, extra="") -> str:
    text = SAMPLE_MODEL.read_text().rstrip("\n")
    text += f"\n\n[damper]\nposition_m = {position}\nconstant_N_s_m = {constant}\n"
    if stiffness is not None:
        text += f"support_stiffness_N_m = {stiffness}\n"
    return text + extra


# -- onset options ---------------------------------------------------------------------------------
def _onset_option(rng, heavy: bool):
    """(option, argv items, valid: True/False/None (either), heavy, oracle) for one onset option."""
    opt = _pick(rng, ["--max-wind", "--damping", "--design-wind", "--set", "--checks", "--pair", "--load",
                      "--modes-below", "--band", "--uc", "--refit", "--out"])
    if opt == "--max-wind":
        v = _pick(rng, ["20", "60", "170", "180", "180.5", "300"] + _NUMBERS_BAD)
        valid = None if v in ("180.5", "300") else (v in ("20", "60", "170", "180"))
        return opt, [f"{opt}={v}"], valid, False, ("max_wind", v)
    if opt == "--damping":
        v = _pick(rng, ["0.001:0.01", "0.001:0.01:5", "1e-3:2e-2:7", "0.002:0.003:2", "0.001:0.01:nan",
                        "0.001:0.01:inf", "0.001:0.01:-inf", "0.001:0.01:2.5", "0.001:0.01:1", "0.001:0.01:10001",
                        "0:0.01", "0.01:0.001", "0.001:1", "nan:0.01", "0.001:inf", "a:b", ":", "0.001::0.01",
                        "0.001:0.01:5:6", "", "0.001", "-0.01:0.01", "0.001:0.01:1e9"])
        valid = v in ("0.001:0.01", "0.001:0.01:5", "1e-3:2e-2:7", "0.002:0.003:2")
        return opt, [f"{opt}={v}"], valid, False, ("damping", v)
    if opt == "--design-wind":
        v = _pick(rng, (["20", "40", "170"] if heavy else []) + _NUMBERS_BAD + ["200"])
        # 200 m/s: past 5 U_c, refused, but inside --band's range of U_c up to 100 m/s (up to 500 m/s)
        valid = True if v in ("20", "40", "170") else None if v == "200" else False
        return opt, [f"{opt}={v}"], valid, valid is not False, ("design_wind", v)
    if opt == "--set":
        field = _pick(rng, ["damping_ratio", "horizontal_tension_N", "diameter_m", "mass_per_length_kg_m",
                            "length_m", "gravity_m_s2", "bogus", "DAMPING_RATIO"])
        v = _pick(rng, ["0.005", "1.1", "0.2", "2e6", "1e-200", "1e300", "0", "-1", "nan", "inf", "x", "",
                        "0.130", "1e9"])
        item = _pick(rng, [f"cable.{field}={v}", f"{field}={v}", f"cable.{field}", f" cable.{field} = {v} "])
        known = field in ("damping_ratio", "horizontal_tension_N", "diameter_m", "mass_per_length_kg_m", "length_m")
        x = float(v) if v not in ("x", "") else math.nan
        number = math.isfinite(x) and x > 0 and not (field == "damping_ratio" and x >= 1)
        well_formed = "=" in item and item.strip().startswith("cable.")
        ok = known and number and well_formed
        # a positive change may still make a cable eq. (21) cannot describe: a named refusal then
        return opt, ["--set", item], (None if ok else False), False, None
    if opt == "--checks":
        v = _pick(rng, ["0", "1", "2", "-1", "21", "1.5", "x", "1e3"])
        return opt, [f"{opt}={v}"], v in ("0", "1", "2"), False, None
    if opt == "--pair":
        v = _pick(rng, ["1", "0", "-1", "51", "x", "1.0", "2"] if heavy else ["1", "0", "-1", "51", "x", "1.0"])
        return opt, [f"{opt}={v}"], (True if v == "1" else None if v == "2" else False), v == "2", None
    if opt == "--load":
        v = _pick(rng, ["cubic", "bogus", "", "CUBIC"] + (["exact"] if heavy else []))
        return opt, [f"{opt}={v}"], v in ("cubic", "exact"), v == "exact", None
    if opt == "--modes-below":
        v = _pick(rng, ["1", "2.5", "0", "-2", "nan", "inf", "1001", "x"] + (["5"] if heavy else []))
        return opt, [f"{opt}={v}"], v in ("1", "2.5", "5"), v == "5", None
    if opt == "--band":
        return opt, ["--band"], (True if heavy else None), True, None
    if opt == "--uc":
        v = _pick(rng, ["7:13", "30", "0:10", "13:7", "nan:1", "1:200", "x", ""])
        return opt, [f"{opt}={v}"], None if v in ("7:13", "30") else False, False, None
    if opt == "--refit":
        return opt, ["--refit"], None, False, None
    return opt, ["--out", "{out}"], True, True, None


def onset_args_case(rng: random.Random, heavy: bool = True) -> Case:
    """One to three onset options on the sample model (or one with a [damper]); a user's file in
    --out some of the time."""
    picked, seen = [], set()
    good = rng.random() < 0.4          # these cases draw only values each option accepts on its own
    for _ in range(1 + rng.randrange(3)):
        for _try in range(30):
            o = _onset_option(rng, heavy)
            if not good or o[2] is not False:
                break
        if o[0] not in seen:
            seen.add(o[0])
            picked.append(o)
    opts = {o[0] for o in picked}
    argv = ["onset", "{model}", "--json"]
    files, out_files = {}, {}
    if rng.random() < 0.15:
        files[MODEL_FILE] = _with_damper()
        argv[1] = "{case}/" + MODEL_FILE
    invalid, either, oracles, is_heavy = [], [], [], False
    foreign = "--out" in opts and rng.random() < 0.5
    for opt, items, valid, hv, oracle in picked:
        argv += items
        if valid is False:
            invalid.append(opt)
        elif valid is None:
            either.append(opt)
        if valid is not False and hv and not (opt == "--out" and foreign):
            is_heavy = True
        if oracle and valid:
            oracles.append(oracle)
    # rules between options (docs/guide/cli.md, docs/band.md): what one option asks of another
    if "--refit" in opts and "--set" not in opts:
        invalid.append("--refit")
    if "--uc" in opts and "--band" not in opts:
        invalid.append("--uc")
    if "--band" in opts:
        for o in ("--damping", "--set", "--refit", "--pair", "--modes-below"):
            if o in opts:
                invalid.append(o)
        if "--load" in opts and "--design-wind" not in opts:
            invalid.append("--load")        # the band's load chooses its galloping amplitude's equation only
    elif "--modes-below" in opts:
        for o in ("--pair", "--damping", "--out"):
            if o in opts:
                invalid.append(o)
    if foreign:
        out_files = {_pick(rng, ["damping.csv", "onset.png", "notes.txt", "onset.json"]): FOREIGN}
        invalid.append("--out")        # a folder holding a user's files is refused, never overwritten
    if is_heavy and not heavy:
        return onset_args_case(rng, heavy)
    expect = INVALID if invalid else ODD
    # a refusal may name another option it met first, or (--set) the cable field the change made impossible
    # (the premises' refusals write the keys as "check [cable] length_m, ...")
    names = tuple(invalid + either) + (("cable.", "[cable]") if "--set" in opts else ())
    if "--max-wind" in opts and "--design-wind" in opts:
        names += ("--max-wind", "--design-wind")
    if not invalid:
        names = tuple(o[0] for o in picked) + ("cable.", "[cable]")
    label = "onset " + " ".join(a for a in argv[3:])
    return Case("onset_args", label, expect, names, files, tuple(argv), timeout=120.0 if is_heavy else 30.0,
                out_files=out_files, post=_onset_post(oracles, out_files, names if invalid else ()))


def _foreign_kept(out: Path, out_files: dict) -> list:
    lost = []
    for name, text in out_files.items():
        p = out / name
        if not p.is_file() or p.read_text(errors="replace") != text:
            lost.append(("foreign_file_lost", f"{name} in --out was {'changed' if p.exists() else 'removed'}"))
    return lost


def _named(o, names) -> list:
    """A refusal of an invalid input names what was wrong (an option, a field, an argument), not
    only the file (the stricter half of `tools.hardening.fuzz.check`'s rule)."""
    if o.exit != 2 or not names:          # exit 3 is a computation that failed, saying why
        return []
    from tools.hardening.fuzz import _message
    msg = _message(o.stderr)
    if any(n.lower() in msg.lower() for n in names):
        return []
    return [("unnamed_rejection", f"names none of {', '.join(names)}: {msg[:240]}")]


def _onset_post(oracles, out_files, names=()):
    def post(inp, out, o):
        problems = _foreign_kept(out, out_files) + _named(o, names)
        if o.exit != 0 or not oracles:
            return problems
        try:
            rep = json.loads(o.stdout)
        except ValueError:
            return problems                    # `check` reports JSON that does not parse
        for what, v in oracles:
            if what == "damping":
                parts = [float(p) for p in v.split(":")]
                n = int(parts[2]) if len(parts) == 3 else 50
                rows = rep.get("damping") or []
                ratios = [r.get("damping_ratio") for r in rows]
                if len(rows) != n or not ratios or abs(ratios[0] - parts[0]) > 1e-12 or abs(ratios[-1] - parts[1]) > 1e-12:
                    problems.append(("wrong_result", f"--damping {v}: {len(rows)} rows from {ratios[:1]} to "
                                                     f"{ratios[-1:]}, asked {n} from {parts[0]:g} to {parts[1]:g}"))
            if what == "max_wind" and "scanned_U_m_s" in rep:
                m = float(v)
                hi = rep["scanned_U_m_s"][1]
                above = [x.get("U_cr_m_s") for x in rep.get("onsets", [])
                         if isinstance(x.get("U_cr_m_s"), float) and x["U_cr_m_s"] > m * (1 + 1e-9)]
                if abs(hi - m) > 1e-9 * m or above:
                    problems.append(("wrong_result", f"--max-wind {v}: scanned up to {hi}, onsets above it {above}"))
            if what == "design_wind" and "design" in rep:
                got = rep["design"].get("design_wind_m_s")
                if got is None or abs(got - float(v)) > 1e-9 * float(v):
                    problems.append(("wrong_result", f"--design-wind {v}: the report's design wind is {got}"))
        return problems
    return post


# -- model specs given to onset ----------------------------------------------------------------------
def onset_spec_case(rng: random.Random, heavy: bool = True) -> Case:
    """A mutated sample model (`tools.hardening.fuzz.SPEC_MUTATIONS`) given to ``onset --json``."""
    kinds = sorted(SPEC_MUTATIONS)
    kind = _pick(rng, kinds)
    c = spec_case(kind, rng)
    # a text that is not TOML is named by its line and column (the field is not known yet)
    strict = c.expect == INVALID and not SPEC_MUTATIONS[kind].__name__.startswith("_t_")
    return Case("onset_spec", c.label, c.expect, c.names, c.files,
                ("onset", f"{{case}}/{MODEL_FILE}", "--json", "--checks", "0"), timeout=120.0,
                post=lambda inp, out, o: _named(o, c.names if strict else ()))


# -- damper options and the [damper] table ----------------------------------------------------------
def damper_args_case(rng: random.Random, heavy: bool = True) -> Case:
    """``autocable damper`` options on the sample model (no [damper]) or one with a [damper]."""
    table = rng.random() < 0.4
    argv = ["damper", "{case}/" + MODEL_FILE if table else "{model}", "--json"]
    files = {MODEL_FILE: _with_damper()} if table else {}
    invalid, oracle, out_files, is_heavy = [], {}, {}, False
    good = rng.random() < 0.5          # half the cases draw only values that should be accepted
    pos = _pick(rng, ["2", "20.5", "1e-300"] + (["2", "20.5"] if table else []) if good else
                [None, "2", "20.5", "60.9", "60.95", "61", "0", "-3", "nan", "inf", "x", "1e-300", "1e9"])
    const = _pick(rng, ["1e5", "2.5e5"] + ([None] if table else []) if good else
                  [None, "1e5", "2.5e5", "0", "-1", "nan", "inf", "x", "1e-300", "1e300"])
    maxf = _pick(rng, [None, None, "3", "10"] if good else
                 [None, None, "3", "10", "0.5", "0", "-1", "nan", "inf", "1001", "x", "200"])
    dw = _pick(rng, ([None] * 6 + (["40"] if heavy else [])) if good else
               [None, None, None, "-1", "nan", "inf", "x", "0", "1e9"] + (["40"] if heavy else []))
    either = [o for o, v in (("--position", pos), ("--constant", const), ("--max-frequency", maxf))
              if v in ("60.9", "1e-300", "1e300", "0.5", "200")]
    for opt, v in (("--position", pos), ("--constant", const), ("--max-frequency", maxf), ("--design-wind", dw)):
        if v is not None:
            argv.append(f"{opt}={v}")
    if pos is None and not table:
        invalid.append("--position")
    elif pos is not None:
        if pos in ("2", "20.5", "60.9", "1e-300"):
            oracle["position_m"] = float(pos)
        else:
            invalid.append("--position")
    if const is None and dw is None and not table:
        invalid.append("--constant")
    elif const is not None:
        if const in ("1e5", "2.5e5", "1e-300", "1e300"):
            oracle["constant_N_s_m"] = float(const)
        else:
            invalid.append("--constant")
    if maxf is not None:
        if maxf in ("0", "-1", "nan", "inf", "1001", "x"):
            invalid.append("--max-frequency")
    if dw is not None:
        if dw == "40":
            is_heavy = True
        else:
            invalid.append("--design-wind")
    if rng.random() < 0.15:
        argv += ["--out", "{out}"]
        if rng.random() < 0.5:
            out_files = {_pick(rng, ["damper.json", "damper.png", "notes.txt"]): FOREIGN}
            invalid.append("--out")
        else:
            is_heavy = True
    if is_heavy and not heavy:
        return damper_args_case(rng, heavy)
    expect = INVALID if invalid else ODD
    names = tuple(invalid + either) if invalid else ("--position", "--constant", "--max-frequency", "--design-wind",
                                                     "damper")
    return Case("damper_args", "damper " + " ".join(argv[3:]), expect, names, files, tuple(argv),
                timeout=120.0 if is_heavy else 30.0, out_files=out_files,
                post=_damper_post(oracle, out_files, names if invalid else ()))


def _damper_post(oracle, out_files, names=()):
    def post(inp, out, o):
        problems = _foreign_kept(out, out_files) + _named(o, names)
        if o.exit != 0 or not oracle:
            return problems
        try:
            got = json.loads(o.stdout)["damper"]
        except (ValueError, KeyError, TypeError):
            return problems
        for k, v in oracle.items():
            if got.get(k) != v:
                problems.append(("wrong_result", f"{k}: asked {v!r}, the report says {got.get(k)!r}"))
        return problems
    return post


_DAMPER_VALUES = {"position_m": ["20.0", "60.9", "60.95", "61.0", "0", "-1", "nan", "inf", '"20"', "true", "[20]",
                                 "1e300", "1" + "0" * 400],
                  "constant_N_s_m": ["2e5", "0", "-1", "nan", "inf", '"x"', "false", "{a = 1}", "1e300", "1e-300"],
                  "support_stiffness_N_m": ["1e7", "0", "-5", "nan", "inf", '"stiff"', "1e300"]}
_DAMPER_OK = {"position_m": ("20.0", "60.9"), "constant_N_s_m": ("2e5", "1e300", "1e-300"),
              "support_stiffness_N_m": ("1e7", "1e300")}


def damper_spec_case(rng: random.Random, heavy: bool = True) -> Case:
    """The [damper] table of a model mutated, given to ``damper --json`` or ``onset --json``."""
    what = rng.randrange(6)
    fields = {"position": "20.0", "constant": "2e5", "stiffness": None}
    names: tuple = ()
    extra = ""
    if what <= 2:
        key = _pick(rng, sorted(_DAMPER_VALUES))
        v = _pick(rng, _DAMPER_VALUES[key])
        fields[{"position_m": "position", "constant_N_s_m": "constant", "support_stiffness_N_m": "stiffness"}[key]] = v
        expect = ODD if v in _DAMPER_OK[key] else INVALID
        label, names = f"damper.{key} = {v[:30]}", (f"damper.{key}",)
        text = _with_damper(fields["position"], fields["constant"], fields["stiffness"])
    elif what == 3:
        key = _pick(rng, ["position_m", "constant_N_s_m"])
        text = _with_damper()
        text = "\n".join(ln for ln in text.splitlines() if not ln.startswith(key)) + "\n"
        expect, label, names = INVALID, f"damper.{key} missing", (f"damper.{key}",)
    elif what == 4:
        extra = _pick(rng, ["bogus = 1\n", "position = 3\n", "Position_m = 3\n"])
        text = _with_damper(extra=extra)
        expect, label, names = INVALID, f"[damper] with {extra.strip()}", ("damper.",)
    else:
        text = SAMPLE_MODEL.read_text().rstrip("\n") + "\n" + _pick(rng, ["damper = 3\n", "damper = \"x\"\n",
                                                                       "[damper]\n", "[[damper]]\nposition_m = 2\n"])
        expect, label, names = INVALID, "damper not a table of position and constant", ("damper",)
    cmd = _pick(rng, [("damper", "{case}/" + MODEL_FILE, "--json"),
                      ("onset", "{case}/" + MODEL_FILE, "--json", "--checks", "0")])
    return Case("damper_spec", f"{cmd[0]}: {label}", expect, names, {MODEL_FILE: text}, cmd, timeout=120.0,
                post=lambda inp, out, o: _named(o, names if expect == INVALID else ()))


# -- the Python API's keywords -------------------------------------------------------------------------
class _Opaque:
    """An object of no useful type, with a repr that is the same in every run (cases are compared)."""

    def __repr__(self) -> str:
        return "<opaque object>"


def _values():
    import numpy as np
    return [0, 1, 0.5, 1e-4, -1, 1e9, 1e-300, math.nan, math.inf, -math.inf, True, False, None, "0.1", "",
            b"1", (0.1,), (-0.02, 0.02), (0.1, 0.2, 0.3), [-0.02, 0.02], (0.02, -0.02), np.float32(1e-4),
            np.float64(0.2), np.int64(0), np.int32(1), np.bool_(True), np.array(1e-4), np.array([-0.02, 0.02]),
            Decimal("0.1"), Fraction(1, 10), complex(0.1, 0), _Opaque()]


def _is_number(v) -> bool:
    import numbers

    import numpy as np
    return isinstance(v, numbers.Real) and not isinstance(v, (bool, np.bool_))


def _in(v, lo, hi) -> bool:
    return _is_number(v) and math.isfinite(float(v)) and lo <= float(v) <= hi


def _pair(v, lo, hi) -> bool:
    return isinstance(v, (tuple, list)) and len(v) == 2 and all(_in(x, lo, hi) for x in v) and float(v[0]) < float(v[1])


#: function -> {keyword: (the value of a valid call, validity of a value or None: either)}
def _api_table():
    return {
        "frequency_response": {
            "U": (0.0, lambda v: _in(v, 0, 5) or (None if isinstance(v, (Decimal, Fraction)) or
                                                 getattr(v, "shape", None) == () else False)),
            "eta": (8.2e-5, lambda v: (None if _in(v, 0, 0.05) or isinstance(v, (Decimal, Fraction)) or
                                       getattr(v, "shape", None) == () else False)),
            "sigma": ((-0.02, 0.02), lambda v: None if _pair(v, -0.5, 0.5) or getattr(v, "shape", None) == (2,)
                      else False),
            "ame": ("2dof", lambda v: v in ("2dof", "1dof") if isinstance(v, str) else False),
            "ordering": ("paper", lambda v: None if v in ("paper", "natural") else False),
            "switch": (False, lambda v: True if isinstance(v, bool) else (None if v in (0, 1) else False)),
            "engine": ("compiled", lambda v: None if v in ("compiled", "pycont") else False),
            "settings": (None, lambda v: True if v is None else False),
            "progress": (None, lambda v: True if v is None else False),
        },
        "ShootingSolver.steady": {
            "U": (0.0, lambda v: None if _in(v, 0, 5) or getattr(v, "shape", None) == () or
                  isinstance(v, (Decimal, Fraction)) else False),
            "eta": (8.2e-5, lambda v: None if _in(v, 0, 0.05) or getattr(v, "shape", None) == () or
                    isinstance(v, (Decimal, Fraction)) else False),
            "sigma": (0.0, lambda v: None if _in(v, -0.5, 0.5) or getattr(v, "shape", None) == () or
                      isinstance(v, (Decimal, Fraction)) else False),
            "q0": ((0.0, 0.0, 1e-6, 0.0), lambda v: None if isinstance(v, (tuple, list)) and len(v) == 4 else False),
            "guess": (None, lambda v: True if v is None else None if isinstance(v, (tuple, list)) and len(v) == 4
                      else False),
            "max_time": (200.0, lambda v: None if _in(v, 7, 1e6) or getattr(v, "shape", None) == () or
                         isinstance(v, (Decimal, Fraction)) else False),
            "rest_floor": (None, lambda v: True if v is None else None if _in(v, 1e-300, 1) else None),
        },
        "plot_branches": {
            "x": ("sigma", lambda v: True if v == "sigma" else None if v in ("U", "eta", "a1") else False),
            "y": (("a1",), lambda v: (True if v in ("a1", ("a1",), ("a1", "a2"), ["a1", "a2"], "a2") else
                                      None if isinstance(v, (tuple, list)) and v and all(c in ("a1", "a2") for c in v)
                                      else False)),
            "units": (None, lambda v: True if v in (None, "si", "paper") and not isinstance(v, bool) else False),
            "labels": (True, lambda v: True if isinstance(v, bool) else None),
            "title": ("", lambda v: True if isinstance(v, str) else None),
            "ax": (None, lambda v: True if v is None else False),
        },
    }


_EXTRA = {"x": ["sigma", "U", "bogus", "", 3, None, ("sigma",)], "y": ["a1", "a2", ("a1", "a2"), ["a1", "a2"], "a1a2",
                                                                    ("a1", "zz"), (), "bogus", None, 3, ("a1",)],
          "units": [None, "si", "paper", "SI", "imperial", 1, True, ""], "ame": ["2dof", "1dof", "3dof", "", None, 2],
          "ordering": ["paper", "natural", "x", None], "engine": ["compiled", "pycont", "auto", None, 0],
          "settings": [None, "x", 3, {}], "progress": [None, "x", 3], "ax": [None, "x", 3],
          "title": ["", "t", None, 3], "labels": [True, False, None, "no", 0],
          "q0": [(0.0, 0.0, 1e-6, 0.0), (1, 2, 3), (math.nan, 0, 0, 0), (0, 0, 5, 0), "abcd", 3, None, [0, 0, 0, 0]],
          "guess": [None, (0, 0, 0), (0, 0, 0, 0), "x", (math.inf, 0, 0, 0)]}


def api_keyword_case(rng: random.Random, heavy: bool = True) -> Case:
    """A call of `frequency_response`, `ShootingSolver.steady` or `plot_branches` with one keyword
    drawn from a pool of every type (one in six calls has every keyword valid)."""
    table = _api_table()
    fn = _pick(rng, sorted(table))
    args = {k: v[0] for k, v in table[fn].items()}
    if rng.random() < 1 / 6:
        return Case("api_keywords", f"{fn} valid", ODD, (fn,), call=(fn, args, None), mode="api_keywords")
    name = _pick(rng, sorted(args))
    pool = _EXTRA.get(name, _values())
    value = _pick(rng, pool) if name in _EXTRA and rng.random() < 0.7 else _pick(rng, _values())
    args[name] = value
    try:
        valid = table[fn][name][1](value)
    except Exception:  # noqa: BLE001 - an array compared with a string: the oracle does not know
        valid = None
    expect = INVALID if valid is False else ODD
    return Case("api_keywords", f"{fn} {name} = {_short(value)}", expect, (name,), call=(fn, args, name),
                mode="api_keywords")


def _short(v) -> str:
    text = f"{type(v).__name__}({v!r})" if type(v).__module__ == "numpy" else repr(v)
    return text if len(text) < 60 else text[:57] + "..."


_STATE: dict = {}


def _sample():
    if not _STATE:
        import warnings

        from autocable.methods.frequency_response import frequency_response
        from autocable.methods.integration.shooting import ShootingSolver
        from autocable.model.derive import derive
        d = derive(SAMPLE_MODEL)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            fr = frequency_response(d, eta=8.2e-5, sigma=(-0.02, 0.02), switch=False)
        _STATE.update(d=d, shoot=ShootingSolver(d.ode), results=fr)
    return _STATE


def _api_call(case: Case, inp: Path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    import autocable as ac
    fn, a, _ = case.call
    s = _sample()
    if fn == "frequency_response":
        return ac.frequency_response(s["d"], **a)
    if fn == "ShootingSolver.steady":
        return s["shoot"].steady(a["U"], a["eta"], a["sigma"], a["q0"], guess=a["guess"], max_time=a["max_time"],
                                 rest_floor=a["rest_floor"])
    try:
        fig = ac.plot_branches(s["results"], **a)
        panels = len(fig.axes)
        y = a["y"]
        want = 1 if isinstance(y, str) else len(y) if isinstance(y, (tuple, list)) else None
        return ("figure", panels, want)
    finally:
        plt.close("all")


def run_mode(case: Case, inp) -> tuple[int, str, str]:
    """(exit status, stdout, stderr) of an API call: exit 2 with the error's one line for a
    `SpecError` (the package's own refusal), the command line's catch-all line for anything else
    (an unforeseen exception); "NaN result" or a wrong panel count on stdout for a result the
    oracle refuses. Other modes: `tools.hardening.fuzz_surfaces.run_mode`."""
    if case.mode != "api_keywords":
        from tools.hardening.fuzz_surfaces import run_mode as surfaces
        return surfaces(case, inp)
    import warnings

    from autocable.errors import ComputationError
    from autocable.spec import SpecError
    out, err = io.StringIO(), io.StringIO()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            r = _api_call(case, inp)
    except SpecError as exc:
        err.write(f"autocable: error: {exc}\n")
        return 2, "", err.getvalue()
    except ComputationError as exc:     # the package's own failure, with its reason: the CLI's exit 3
        err.write(f"autocable: failed: {exc}\n")
        return 3, "", err.getvalue()
    except Exception as exc:  # noqa: BLE001 - what the command line's catch-all would print
        first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        err.write(f"autocable: error ({type(exc).__name__}): {first}\n")
        return 2, "", err.getvalue()
    if isinstance(r, tuple) and r[:1] == ("figure",):
        if r[2] is not None and r[1] != r[2]:
            out.write(f"wrong result: {r[1]} panels for y = {case.call[1]['y']!r}\n")
    elif hasattr(r, "a1") and isinstance(r.a1, float) and math.isnan(r.a1):
        out.write("NaN result\n")
    elif hasattr(r, "branches") and not r.branches:
        out.write("wrong result: no branch\n")
    return 0, out.getvalue(), err.getvalue()


def _api_post(inp, out, o):
    return [("wrong_result", ln) for ln in o.stdout.splitlines() if ln.startswith("wrong result")]


KINDS = {"onset_args": onset_args_case, "onset_specs": onset_spec_case, "damper_args": damper_args_case,
         "damper_specs": damper_spec_case, "api_keywords": api_keyword_case}


def option_case(kind: str, rng: random.Random, heavy: bool = True) -> Case:
    c = KINDS[kind](rng, heavy)
    if c.mode == "api_keywords":
        c.post = _api_post
    return c


def cases(n: int, seed: int = 0, kinds=tuple(KINDS), heavy: bool = True):
    """(kind, case) pairs: ``n`` seeded cases of each kind."""
    for kind in kinds:
        for i in range(n):
            yield kind, option_case(kind, random.Random(f"{seed}:{kind}:{i}"), heavy)


#: The columns of the table `run_options` returns, in order.
CLASSES = ("ok", "refused_named", "failed", "traceback", "hang", "wrong_exit0", "unnamed_refusal",
           "foreign_file_lost", "escaped_write")
_CLASS_OF = {"traceback": "traceback", "unforeseen_exception": "traceback", "hang": "hang",
             "exit0_invalid": "wrong_exit0", "wrong_result": "wrong_exit0", "nan_result": "wrong_exit0",
             "bad_json": "wrong_exit0", "unnamed_rejection": "unnamed_refusal", "long_message": "unnamed_refusal",
             "foreign_file_lost": "foreign_file_lost", "escaped_write": "escaped_write"}


def classify(o) -> str:
    """The one class of an outcome: its worst problem (in `CLASSES` order), else ok or refused."""
    found = {_CLASS_OF[k] for k, _ in o.problems}
    for c in CLASSES[3:]:
        if c in found:
            return c
    return "ok" if o.exit == 0 else "failed" if o.exit == 3 else "refused_named"


def run_options(n: int = 1000, seed: int = 0, kinds=tuple(KINDS), heavy: bool = True, base=None, main=None,
                log=None, max_timeout: float = 300.0) -> dict:
    """``n`` cases of each kind run in-process (``main``: `autocable.cli.main`), classified; the
    table {kind: {class: count}}, the seconds per kind and the first problems of each kind."""
    import shutil
    import tempfile
    if main is None:
        from autocable.cli import main
    say = log or (lambda s: None)
    tmp = None
    if base is None:
        tmp = base = tempfile.mkdtemp(prefix="autocable-options-")
    h = Harness(main, Path(base), runner=run_mode, max_timeout=max_timeout)
    table, seconds, examples = {}, {}, {}
    try:
        for kind in kinds:
            row = dict.fromkeys(CLASSES, 0)
            t0 = time.perf_counter()
            for i in range(n):
                case = option_case(kind, random.Random(f"{seed}:{kind}:{i}"), heavy)
                o = h.run(case)
                c = classify(o)
                row[c] += 1
                if c not in ("ok", "refused_named") and len(examples.setdefault(kind, [])) < 12:
                    examples[kind].append({"class": c, "case": case.label, "expect": case.expect, "exit": o.exit,
                                           "problems": [f"{k}: {w}"[:300] for k, w in o.problems]})
                if (i + 1) % 100 == 0:
                    say(f"{kind} {i + 1}/{n} ({time.perf_counter() - t0:.0f} s) {row}")
            table[kind], seconds[kind] = row, round(time.perf_counter() - t0, 1)
            say(f"{kind}: {row} in {seconds[kind]} s")
    finally:
        if tmp:
            shutil.rmtree(tmp, ignore_errors=True)
    return {"seed": seed, "cases_per_kind": n, "table": table, "seconds": seconds, "examples": examples}
