"""Hostile inputs on the surfaces added after model specs and scenes: sweep files, chart tables,
targets and search-space files, ``--map`` files and calls of the Python API (`python -m tools.hardening fuzz`
with ``--surfaces`` and ``--api``). Cases are `tools.hardening.fuzz.Case` s, checked by the same
`tools.hardening.fuzz.check`: no traceback or unforeseen exception, no acceptance of an invalid
input, every refusal naming the file, field, option or argument, no write outside the case's
folders, no hang; API calls also never return NaN as a result.

Each file kind is read the way its command reads it, without the long computation after it:
`load_sweep` (``autocable sweep``), `load_scene` of a chart scene (``autocable chart``),
`load_targets` + `load_goal` + `check_scenes` (``autocable calibrate``), `load_space`
(``calibrate --space``), and the chart's map check (``chart --map``, `scene.runner.read_chart_map`).
"""
from __future__ import annotations

import io
import json
import math
import random
import tomllib

from autocable._paths import RUNS_DIR, SAMPLE_MODEL
from tools.hardening.fuzz import (INVALID, MODEL_FILE, ODD, SCENE_FILE, Case, InlineTable, Raw, _inline,
                                  dump_toml)

__all__ = ["SURFACE_KINDS", "surface_case", "api_case", "run_mode", "cases", "strategies"]

SWEEP_FILE = "sweep.toml"
TARGETS_FILE = "t.targets.toml"
SPACE_FILE = "s.search.toml"
MAP_FILE = "map.nc"
TARGETS = SAMPLE_MODEL.with_suffix("").with_suffix(".targets.toml")
CHART_SCENE = RUNS_DIR / "chart_U_eta.toml"

_BAD_NUMBERS = [Raw("nan"), Raw("inf"), Raw("-inf"), Raw("1e300"), Raw("-1e300"), "abc", True, [1.0], -1.0, 0.0]


def _pick(rng, seq):
    return seq[rng.randrange(len(seq))]


# -- sweep files -----------------------------------------------------------------------------------
def _sweep_doc() -> dict:
    doc = _inline(tomllib.loads((RUNS_DIR / "sweep_U_eta.toml").read_text()))
    doc["model"] = MODEL_FILE
    return doc


def sweep_case(rng: random.Random) -> Case:
    doc = _sweep_doc()
    what = rng.randrange(9)
    if what == 0:
        key, v = _pick(rng, ["max_time", "q0"]), _pick(rng, _BAD_NUMBERS + [Raw("1e-9"), Raw("2e6")])
        doc[key] = v
        label, names, expect = f"{key} = {v!r}", (key,), INVALID
    elif what == 1:
        ax, part = _pick(rng, ["U", "eta", "sigma"]), _pick(rng, ["from", "to", "num"])
        # 0.0 is a valid end of every axis (and so within the accepted ranges)
        v = _pick(rng, [x for x in _BAD_NUMBERS if not (part != "num" and x == 0.0)]
                  + [Raw("10000000"), Raw("1" + "0" * 40)])
        doc["grid"][ax] = InlineTable({"from": 0.1, "to": 0.5, "num": 5, part: v})
        label, names, expect = f"grid.{ax}.{part} = {v!r}", (f"grid.{ax}", "grid"), INVALID
    elif what == 2:
        n = _pick(rng, [1001, 5000, 100000])
        doc["grid"] = {a: InlineTable({"from": 0.01, "to": 0.02, "num": n}) for a in ("U", "eta", "sigma")}
        label, names, expect = f"three axes of num = {n}", ("grid",), INVALID
    elif what == 3:
        ax = _pick(rng, ["U", "eta", "sigma"])
        v = _pick(rng, {"U": [50.0, -3.0], "eta": [0.9, -3.0], "sigma": [9.0, -3.0]}[ax])
        doc["grid"][ax] = [0.01, v]
        label, names, expect = f"grid.{ax} = [0.01, {v}]", (f"grid.{ax}", ax), INVALID
    elif what == 4:
        key = _pick(rng, ["follow", "direction", "method", "bogus", "title"])
        doc[key] = _pick(rng, ["U", "sideways", "magic", 3, ""])
        label, names = f"{key} = {doc[key]!r}", (key, "follow", "direction")
        expect = ODD if (key == "follow" and doc[key] == "U") or (key == "title" and isinstance(doc[key], str)) \
            else INVALID
        if key == "follow" and doc[key] == "U":
            doc["method"] = "ode21"
    elif what == 5:
        doc["model"] = _pick(rng, ["", "none.toml", "../../etc/passwd", ".", "{base}"])
        label, names, expect = f"model = {doc['model']!r}", ("model",), INVALID
    elif what == 6:
        doc["grid"]["start"] = _pick(rng, [[], [[0.0, 0.0]], [[0.0, 0.0, 5.0, 0.0]], "rest", [[Raw("nan"), 0, 0, 0]]])
        label, names, expect = f"grid.start = {doc['grid']['start']!r}", ("grid.start", "start"), INVALID
    elif what == 7:
        doc["grid"] = {"U": [0.2, 0.3], "eta": 1e-4, "sigma": _pick(rng, [0.0, [-0.1, 0.1]])}
        doc["max_time"] = _pick(rng, [100.0, 1e6])
        label, names, expect = "a small valid grid", (), ODD
    else:
        text = dump_toml(doc)
        cut = rng.randrange(1, len(text))
        return Case("sweep", f"sweep file cut at {cut}", ODD, ("sweep",), {MODEL_FILE: SAMPLE_MODEL.read_text(),
                                                                          SWEEP_FILE: text[:cut]}, mode="load_sweep")
    return Case("sweep", label, expect, tuple(names), {MODEL_FILE: SAMPLE_MODEL.read_text(),
                                                      SWEEP_FILE: dump_toml(doc)}, mode="load_sweep")


# -- chart tables ----------------------------------------------------------------------------------
def chart_case(rng: random.Random) -> Case:
    doc = _inline(tomllib.loads(CHART_SCENE.read_text()))
    doc["model"] = MODEL_FILE
    ch = doc["chart"]
    key = _pick(rng, ["t_end", "grid", "x_range", "y_range", "starts", "plane", "map", "bogus"])
    v = _pick(rng, {"t_end": _BAD_NUMBERS + [Raw("1.0000001e6"), 5000.0],
                    "grid": [[1, 1], [401, 2], [Raw("nan"), 4], [4], "abc", [6, 4]],
                    "x_range": [[0.0, 1.0], [-1.0, 1.0], [0.1, 50.0], [Raw("nan"), 1.0], [0.5]],
                    "y_range": [[-1e-3, 1e-4], [0.0, 0.9], [Raw("inf"), 0.0]],
                    "starts": [[], [[0.5, 0.5]], [[Raw("nan"), 0.0]], "rest", [[1e-3, 1e-6]]],
                    "plane": [["U", "U"], ["U", "rho"], ["U"], "U"],
                    "map": [3, "", "../../x.nc"], "bogus": [1]}[key])
    ch[key] = v
    valid = (key == "t_end" and v == 5000.0) or (key == "grid" and v == [6, 4]) or \
        (key == "starts" and v == [[1e-3, 1e-6]]) or (key == "map" and v in ("../../x.nc",))
    return Case("chart", f"chart.{key} = {v!r}", ODD if valid else INVALID, (f"chart.{key}", "chart", key),
                {MODEL_FILE: SAMPLE_MODEL.read_text(), SCENE_FILE: dump_toml(doc)}, mode="load_scene")


# -- targets and search-space files ---------------------------------------------------------------
def targets_case(rng: random.Random) -> Case:
    text = TARGETS.read_text()
    doc = tomllib.loads(text)
    what = rng.randrange(6)
    if what == 0:
        i = rng.randrange(len(doc["statement"]))
        doc["statement"][i]["scene"] = v = _pick(rng, ["fig99", "../../etc/passwd", "", "fig 03", "x" * 100])
        label, names = f"statement[{i}].scene = {v!r}", ("scene",)
    elif what == 1:
        screens = [k for k, t in enumerate(doc["screen"]) if t.get("points")]
        i = _pick(rng, screens)
        p = list(doc["screen"][i]["points"][0])
        j = rng.randrange(3)
        p[j] = _pick(rng, [50.0, 0.9, 9.0, -1.0, Raw("nan"), "a"][j::3] + [Raw("inf")])
        doc["screen"][i]["points"][0] = p
        label, names = f"screen[{i}].points[0][{j}] = {p[j]!r}", ("points",)
    elif what == 2:
        doc["goal"]["boxes_scenes"] = v = _pick(rng, [["fig99"], ["../x"], [], [3], "fig08"])
        label, names = f"goal.boxes_scenes = {v!r}", ("goal.boxes_scenes", "boxes_scenes")
        if v == []:
            return Case("targets", label, ODD, names, {TARGETS_FILE: _dump(doc)}, mode="load_targets")
    elif what == 3:
        key = _pick(rng, ["statements_yes", "boxes_share"])
        # 0.0 is a share (boxes_share = 0 asks nothing of the boxes), not a count
        doc["goal"][key] = v = _pick(rng, [x for x in _BAD_NUMBERS if not (key == "boxes_share" and x == 0.0)]
                                     + [Raw("2.5")])
        label, names = f"goal.{key} = {v!r}", (f"goal.{key}",)
    elif what == 4:
        screens = [k for k, t in enumerate(doc["screen"]) if t.get("sigmas")]
        i = _pick(rng, screens)
        doc["screen"][i]["sigmas"] = v = [_pick(rng, [9.0, Raw("nan"), "x", -2.0])]
        label, names = f"screen[{i}].sigmas = {v!r}", ("sigmas",)
    else:
        cut = rng.randrange(1, len(text))
        return Case("targets", f"targets file cut at {cut}", ODD, ("targets",), {TARGETS_FILE: text[:cut]},
                    mode="load_targets")
    return Case("targets", label, INVALID, tuple(names), {TARGETS_FILE: _dump(doc)}, mode="load_targets")


def _dump(doc) -> str:
    """A targets document as TOML (arrays of tables written one by one)."""
    return dump_toml(_inline(doc))


def space_case(rng: random.Random) -> Case:
    key = _pick(rng, ["air_density_kg_m3", "yaw_deg", "rivulet_angle_deg", "full", "twist_ends", "bogus"])
    v = _pick(rng, {"air_density_kg_m3": [[Raw("inf")], [Raw("nan")], [Raw("1e300")], [0.0], [-1.25], [11.0],
                                          [1.25, 1.2], []],
                    "yaw_deg": [[91.0], [Raw("nan")], InlineTable({"from": 0, "to": -5, "step": 1}),
                                InlineTable({"from": 0, "to": 5, "step": 0}), [0.0, 5.0]],
                    "rivulet_angle_deg": ["bogus", [200.0], ["calibrate"], [Raw("inf")]],
                    "full": [-1, 1.5, "x", 2],
                    "twist_ends": [["natural"], ["sideways"], [], "natural"],
                    "bogus": [1]}[key])
    valid = v in ([1.25, 1.2], [0.0, 5.0], ["calibrate"], 2, ["natural"])
    return Case("space", f"{key} = {v!r}", ODD if valid else INVALID, (key,),
                {SPACE_FILE: dump_toml({key: v})}, mode="load_space")


# -- --map files -----------------------------------------------------------------------------------
def _map_bytes(rng: random.Random, kind: str) -> bytes:
    import numpy as np
    import xarray as xr

    from autocable.spec import load_model
    U = {"off": [2.5, 3.0], "part": [0.5, 2.5]}.get(kind, [0.3, 0.9, 1.4])
    eta = [1e-4, 3e-4]
    codes = np.ones((len(U), len(eta), 1), dtype=np.int8)
    attrs = {"legend": json.dumps(["rest", "period-1", "period-2", "quasi-periodic", "diverged"])}
    if kind == "float":
        codes = codes.astype(float) + 0.5
    if kind == "unknown class":
        codes[0, 0, 0] = 9
        attrs["legend"] = json.dumps({"1": "period-1", "9": "banana"})
    if kind == "no legend":
        attrs = {}
    data = {"response": (("U", "eta", "sigma"), codes, attrs)} if kind != "no response" else \
        {"other": (("U", "eta", "sigma"), codes)}
    ds = xr.Dataset(data, coords={"U": U, "eta": eta, "sigma": [0.03 if kind == "sigma" else 0.01]},
                    attrs={"model_hash": "0" * 64 if kind == "model" else load_model(SAMPLE_MODEL).content_hash()})
    buf = ds.to_netcdf(engine="scipy")
    return bytes(buf)


MAP_KINDS = ("valid", "part", "off", "float", "unknown class", "no legend", "no response", "sigma", "model",
             "truncated", "empty", "text", "random bytes")


def map_case(rng: random.Random) -> Case:
    kind = _pick(rng, MAP_KINDS)
    if kind in ("valid", "part"):
        data, expect = _map_bytes(rng, kind), ODD
    elif kind == "truncated":
        whole = _map_bytes(rng, "valid")
        data, expect = whole[:rng.randrange(1, len(whole))], INVALID
    elif kind == "empty":
        data, expect = b"", INVALID
    elif kind == "text":
        data, expect = b"U,eta,response\n0.5,1e-4,period-1\n", INVALID
    elif kind == "random bytes":
        data, expect = bytes(rng.randrange(256) for _ in range(rng.randrange(1, 4000))), INVALID
    else:
        data, expect = _map_bytes(rng, kind), INVALID
    return Case("map", f"--map: {kind}", expect, ("--map",), {MAP_FILE: data}, mode="read_map")


SURFACE_KINDS = {"sweep": sweep_case, "chart": chart_case, "targets": targets_case, "space": space_case,
                 "map": map_case}


def surface_case(kind: str, rng: random.Random) -> Case:
    return SURFACE_KINDS[kind](rng)


# -- API calls -------------------------------------------------------------------------------------
_API_FUNCTIONS = ("Ode21Integrator.simulate", "ShootingSolver.steady", "AmeIntegrator.simulate",
                  "Ode21Integrator.envelope", "run_sweep", "load_model", "Ode21Integrator")
_API_BAD = {"U": [math.nan, math.inf, -1.0, 50.0, "a", None], "eta": [math.nan, 0.9, -1e-3, "x"],
            "sigma": [math.inf, -2.0, 9.0, [0.0]], "max_time": [-5.0, 0.0, 1e-9, math.inf, math.nan, 2e6, "10"],
            "q0": [(1, 2, 3), (math.nan, 0, 0, 0), (0, 0, 5, 0), "abcd", 3],
            "t_end": [-1.0, 0.0, 1e300, math.nan], "y0": [(0.0,), (0, math.inf, 0, 0)],
            "workers": [-1, 1.5, "2"], "chunk": [0, -3], "path": [None, 123, ""], "engine": ["x", 3]}


def api_case(rng: random.Random) -> Case:
    """A call of the Python API: mostly with one bad argument (must raise a `SpecError` naming it);
    one in five valid with random in-range values (must return finite amplitudes or a divergence)."""
    fn = _pick(rng, _API_FUNCTIONS)
    args = {"U": 0.0, "eta": 8.2e-5, "sigma": 0.0, "max_time": 200.0, "q0": (0.0, 0.0, 1e-6, 0.0)}
    if fn == "Ode21Integrator.envelope":
        args = {"U": 0.0, "eta": 8.2e-5, "sigma": 0.0, "y0": (0.0, 1e-6, 0.0, 0.0), "t_end": 200.0}
    elif fn == "run_sweep":
        args = {"workers": 0, "chunk": None}
    elif fn == "load_model":
        args = {"path": str(SAMPLE_MODEL)}
    elif fn == "Ode21Integrator":
        args = {"engine": "compiled"}
    if fn not in ("run_sweep", "load_model", "Ode21Integrator") and rng.random() < 0.2:
        args.update(U=round(rng.uniform(0.0, 1.2), 3), eta=round(rng.uniform(0.0, 2e-3), 6),
                    sigma=round(rng.uniform(-0.1, 0.1), 3))
        return Case("api", f"{fn} valid {args}", ODD, (fn,), call=(fn, args), mode="api")
    name = _pick(rng, sorted(args))
    args[name] = _pick(rng, _API_BAD[name])
    return Case("api", f"{fn} {name} = {args[name]!r}", INVALID, (name,), call=(fn, args), mode="api")


# -- running a case --------------------------------------------------------------------------------
_SOLVERS: dict = {}


def _solvers():
    if not _SOLVERS:
        from autocable.methods.integration.ame import AmeIntegrator
        from autocable.methods.integration.ode21 import Ode21Integrator
        from autocable.methods.integration.shooting import ShootingSolver
        from autocable.model.ame_cache import derive_ame
        from autocable.model.derive import derive
        d = derive(SAMPLE_MODEL)
        _SOLVERS.update(ode=d.ode, ode21=Ode21Integrator(d.ode, engine="compiled"), shoot=ShootingSolver(d.ode),
                        ame=AmeIntegrator(derive_ame(d).ame))
    return _SOLVERS


def _call(case: Case, inp):
    fn, a = case.call
    s = _solvers()
    if fn == "Ode21Integrator.simulate":
        return s["ode21"].simulate(a["U"], a["eta"], a["sigma"], a["q0"], max_time=a["max_time"])
    if fn == "ShootingSolver.steady":
        return s["shoot"].steady(a["U"], a["eta"], a["sigma"], a["q0"], max_time=a["max_time"])
    if fn == "AmeIntegrator.simulate":
        return s["ame"].simulate(a["U"], a["eta"], a["sigma"], a["q0"], max_time=a["max_time"])
    if fn == "Ode21Integrator.envelope":
        return s["ode21"].envelope(a["U"], a["eta"], a["sigma"], a["y0"], a["t_end"])
    if fn == "run_sweep":
        from autocable.scene.sweep_schema import load_sweep
        from autocable.studies.sweep import run_sweep
        out = inp.parent / "out"            # the case's output folder: a write there is allowed
        out.mkdir(exist_ok=True)
        path = out / SWEEP_FILE
        path.write_text(f'model = "{SAMPLE_MODEL.as_posix()}"\nmax_time = 200.0\n[grid]\neta = 8.2e-5\n')
        return run_sweep(load_sweep(path), out / "o", workers=a["workers"], chunk=a["chunk"])
    if fn == "load_model":
        from autocable.spec import load_model
        return load_model(a["path"])
    from autocable.methods.integration.ode21 import Ode21Integrator
    return Ode21Integrator(s["ode"], engine=a["engine"])


def _nan_result(r) -> bool:
    values = []
    if isinstance(r, tuple):                  # envelope: (t, a1, a2, message)
        import numpy as np
        values = [float(x) for arr in r[1:3] for x in np.asarray(arr).ravel()]
    else:
        values = [getattr(r, k) for k in ("a1", "a2") if isinstance(getattr(r, k, None), float)]
    return any(math.isnan(v) for v in values)


def run_mode(case: Case, inp) -> tuple[int, str, str]:
    """(exit status, stdout, stderr) of a case read the way its command reads it (module docstring):
    a `SpecError` is exit 2 with its one line, anything else escaping is the command line's
    catch-all line (an unforeseen exception)."""
    from autocable.spec import SpecError
    out, err = io.StringIO(), io.StringIO()
    try:
        if case.mode == "load_sweep":
            from autocable.scene.sweep_schema import load_sweep
            load_sweep(inp / SWEEP_FILE)
        elif case.mode == "load_targets":
            from autocable.paper import targets as tg
            path = inp / TARGETS_FILE
            tg.check_scenes(tg.load_targets(path), tg.load_goal(path), RUNS_DIR, path)
        elif case.mode == "load_space":
            from autocable.paper.calibration import load_space
            load_space(inp / SPACE_FILE)
        elif case.mode == "read_map":
            from autocable.scene.runner import read_chart_map
            from autocable.scene.schema import load_scene
            read_chart_map(load_scene(CHART_SCENE), inp / MAP_FILE)
        elif case.mode == "api":
            import warnings
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                r = _call(case, inp)
            if _nan_result(r):
                out.write("NaN result\n")
        else:
            raise ValueError(f"unknown mode {case.mode!r}")
    except SpecError as exc:
        err.write(f"autocable: error: {exc}\n")
        return 2, out.getvalue(), err.getvalue()
    except Exception as exc:  # noqa: BLE001 - what the command line's catch-all would print
        first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        err.write(f"autocable: error ({type(exc).__name__}): {first}\n")
        return 2, out.getvalue(), err.getvalue()
    return 0, out.getvalue(), err.getvalue()


def cases(surfaces: int, api: int, seed: int = 0):
    """(count key, case) pairs for `tools.hardening.fuzz.run_fuzz`'s ``extra``: ``surfaces`` cases of
    each kind of `SURFACE_KINDS`, then ``api`` calls (seeded generators)."""
    for kind in SURFACE_KINDS:
        for i in range(surfaces):
            yield kind, surface_case(kind, random.Random(f"{seed}:{kind}:{i}"))
    for i in range(api):
        yield "api", api_case(random.Random(f"{seed}:api:{i}"))


def strategies():
    """Hypothesis strategies of surface cases and API calls (hypothesis imported lazily)."""
    from hypothesis import strategies as st
    rnd = st.randoms(use_true_random=False)
    return {"surfaces": st.builds(surface_case, st.sampled_from(sorted(SURFACE_KINDS)), rnd),
            "api": st.builds(api_case, rnd)}
