"""The method ladder: every way autocable computes the frequency
response diagrams of Sect. 5 (a1, a2 against sigma, Figs. 5-10), behind one interface.

A `Method` is a frozen record of one rung: what it solves, its declared accuracy (and the order of
its error in its accuracy knob, when it has one), what its cost grows with, and its knobs with their
default ladders. A `Setting` is a figure's fixed parameters (U, eta) and sigma range, read from a
scene file (``runs/*.toml``). `run(method, setting, knobs, tools)` computes the diagram and returns a
`MethodResult`: arrays over the parameter (values, a1, a2, stable, which branch or sweep direction
each point belongs to), the special points found, the warm wall time, the cold build time and a
message. `Tools` holds what the methods share for one model (the derivation of eq. 21, the AME (24),
one compiled integrator of eq. (21), the continuation systems), so that builds are paid once and
timed separately.

Rungs (cheapest first):

* ``ame-1dof``: continuation (PyCont EP-C) of the A2 = 0 reduction of the AME (Sect. 5, the
  mono-modal branches I, II). Points are Newton-polished equilibria (exact to ~1e-12); between
  points the branch is read by linear interpolation: error O(h^2) in the step h. Against eq. (21)
  the AME itself errs by O(eta^2) relative at fixed sigma (docs/ame_vs_ode21.md).
* ``ame-2dof``: the same for the Cartesian AME (24) with both modes, with branch switching at every
  branch point (the bi-modal branches III-V and the island II of Fig. 6).
* ``ame-sweep``: brute-force up/down integration sweeps of the AME (`methods.sweeps`).
* ``ode21-sweep``: brute-force up/down integration sweeps of eq. (21) itself (compiled DOP853): the
  reference rung; its error in rtol follows DOP853's tolerance proportionality (order ~1).

Periodic-orbit continuation of (21) and the N-mode model join the ladder when their modules exist
(`available_methods`).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any, Mapping

import numpy as np

__all__ = ["Knob", "Method", "Setting", "MethodResult", "Tools", "METHODS", "available_methods",
           "method", "setting_from_scene", "run"]


@dataclass(frozen=True)
class Knob:
    """One accuracy or resolution control of a method."""

    name: str
    default: Any
    meaning: str


@dataclass(frozen=True)
class Method:
    """One rung of the ladder."""

    name: str
    solves: str
    accuracy: str                     # declared accuracy, in words
    order: float | None               # error ~ knob^order in ``order_knob`` (None: no such knob)
    order_knob: str | None
    cost_drivers: tuple[str, ...]
    knobs: tuple[Knob, ...]
    ladder: tuple[Mapping[str, Any], ...]   # knob settings the bench runs, coarse to fine
    model_error: str = ""             # what the knob cannot remove (the model's own error)

    def defaults(self) -> dict[str, Any]:
        return {k.name: k.default for k in self.knobs}


@dataclass(frozen=True)
class Setting:
    """A figure's fixed parameters and sigma range (from a scene file)."""

    scene: str                        # scene name, e.g. "fig06"
    title: str
    model: Path
    U: float
    eta: float
    sigma_range: tuple[float, float]
    source: str = ""                  # the scene file


@dataclass(frozen=True)
class MethodResult:
    """A method's diagram over sigma (arrays of equal length; ``branch`` names the branch of a
    continuation or the direction of a sweep for each point)."""

    method: str
    setting: str
    knobs: Mapping[str, Any]
    values: np.ndarray
    a1: np.ndarray
    a2: np.ndarray
    stable: np.ndarray
    branch: tuple[str, ...]
    special: tuple[Mapping[str, Any], ...]     # dicts type, sigma, a1, a2, branch
    seconds: float                    # wall time of the computation (builds excluded)
    build_seconds: float              # the one-off builds it needed (compiled libraries, PyCont setup)
    message: str
    ok: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))  # sweeps: steady period-1 points
    info: Mapping[str, Any] = field(default_factory=dict)


def _ladder(*rows) -> tuple:
    return tuple(MappingProxyType(dict(r)) for r in rows)


_STEP = Knob("max_step", 2e-2, "largest pseudo-arclength step (scaled units: the sigma range is 1)")
_CTOL = Knob("tol", 1e-10, "corrector tolerance (points are then polished by Newton to 1e-12)")
_ENGINE = Knob("engine", "pycont", "continuation engine: PyCont's EP-C or autocable's compiled C kernel")
_CONT_LADDER = ({"max_step": 0.05}, {"max_step": 0.02},
                {"max_step": 0.1, "engine": "compiled"}, {"max_step": 0.05, "engine": "compiled"},
                {"max_step": 0.02, "engine": "compiled"}, {"max_step": 0.01, "engine": "compiled"},
                {"max_step": 0.005, "engine": "compiled"})

METHODS: Mapping[str, Method] = MappingProxyType({
    "ame-1dof": Method(
        "ame-1dof", "equilibria of the A2 = 0 reduction of the AME (24) continued in sigma (PyCont EP-C)",
        "points exact to ~1e-12 (Newton); linear interpolation between points errs O(h^2)", 2.0,
        "max_step", ("points along the branch ~ 1/max_step", "PyCont step ~ ms per point"),
        (_STEP, _CTOL, _ENGINE), _ladder(*_CONT_LADDER),
        "the AME's own error against eq. (21): O(eta^2) relative; misses every bi-modal branch"),
    "ame-2dof": Method(
        "ame-2dof", "equilibria of the Cartesian AME (24), both modes, continued in sigma, with branch "
        "switching at every branch point (bi-modal branches, islands)",
        "points exact to ~1e-12 (Newton); linear interpolation between points errs O(h^2)", 2.0,
        "max_step", ("points along the branches ~ 1/max_step", "number of branch points switched"),
        (_STEP, _CTOL, _ENGINE), _ladder(*_CONT_LADDER),
        "the AME's own error against eq. (21): O(eta^2) relative"),
    "ame-sweep": Method(
        "ame-sweep", "steady states of the AME (24) by integration (LSODA), sigma swept up and down",
        "equilibria refined by Newton (~1e-12); only attractors reachable by the sweep", None, None,
        ("number of sigma points", "slow-flow transients ~ 1/(xi_s omega1)"),
        (Knob("rtol", 1e-8, "LSODA relative tolerance"), Knob("points", 21, "sigma values per sweep")),
        _ladder({"rtol": 1e-6, "points": 11}, {"rtol": 1e-8, "points": 21}),
        "the AME's own error against eq. (21): O(eta^2) relative"),
    "ode21-sweep": Method(
        "ode21-sweep", "steady responses of eq. (21) by compiled DOP853 integration, sigma swept up "
        "and down (each point starts from the previous steady state)",
        "trajectory error ~ rtol (DOP853 tolerance proportionality: 5.6 rtol over 50 forcing periods "
        "for rtol <= 1e-7); the amplitude read-out (parabolic peak through 64 samples per period) adds "
        "~5e-6 relative, so rtol below ~1e-6 does not improve a1; steady test at max(1e-8, 10 rtol)",
        1.0, "rtol", ("number of sigma points", "transients ~ 1/(xi_s omega1) per point",
                      "forcing periods x samples per period"),
        (Knob("rtol", 1e-8, "DOP853 relative tolerance (atol = 1e-3 rtol)"),
         Knob("points", 21, "sigma values per sweep")),
        _ladder({"rtol": 1e-5, "points": 11}, {"rtol": 1e-7, "points": 11}, {"rtol": 1e-8, "points": 21},
                {"rtol": 1e-9, "points": 41})),
})

#: The reference solution of the bench: tight integration sweeps of eq. (21).
REFERENCE_KNOBS = MappingProxyType({"rtol": 1e-11, "points": 41})


def _optional_methods() -> dict[str, Method]:
    """Rungs whose modules may be absent: periodic orbits of (21), the N-mode model. What they solve
    and their accuracy are quoted from the modules' own ``METHOD_INFO``."""
    import importlib
    out = {}
    try:
        info = importlib.import_module("autocable.methods.integration.periodic21").METHOD_INFO
    except (ImportError, AttributeError):
        info = None
    if info is not None:
        out["ode21-periodic"] = Method(
            "ode21-periodic", str(info.get("solves", "")), str(info.get("accuracy", "")), 5.0, "ntst",
            ("points along the branch ~ range / step", "AUTO Newton on 6 ntst ncol unknowns per point",
             "one variational integration of (21) per point (Floquet multipliers)"),
            (Knob("ntst", 40, "collocation mesh intervals"), Knob("ncol", 4, "collocation points per interval "
                                                                   "(error order ncol + 1 in ntst)"),
             Knob("step", None, "largest step in sigma (None: 1/100 of the range)"),
             Knob("max_points", 400, "points per direction")),
            _ladder({"ntst": 10}, {"ntst": 20}))
    try:
        info = importlib.import_module("autocable.methods.integration.nmode").METHOD_INFO
    except (ImportError, AttributeError):
        info = None
    if info is not None:
        out["ode21-nmode"] = Method(
            "ode21-nmode", str(info.get("solves", "")), str(info.get("accuracy", "")), None, None,
            (str(info.get("cost_drivers", "")),),
            (Knob("n_in", 2, "in-plane modes"), Knob("n_out", 2, "out-of-plane modes"),
             Knob("points", 11, "sigma values (each integrated from rest)")),
            _ladder({"n_in": 1, "n_out": 1, "points": 11}, {"n_in": 2, "n_out": 2, "points": 11}),
            "the truncation of eq. (21) to two modes is what it measures")
    return out


def available_methods() -> dict[str, Method]:
    """Every rung whose code is present, cheapest first."""
    return {**METHODS, **_optional_methods()}


def method(name: str) -> Method:
    known = available_methods()
    if name not in known:
        raise ValueError(f"unknown method {name!r}; known: {', '.join(known)}")
    return known[name]


def setting_from_scene(path: str | Path) -> Setting:
    """The fixed U, eta and the sigma range of a scene's first sigma run."""
    from autocable.scene.runner import load_scene
    from autocable.spec import SpecError
    scene = load_scene(path)
    runs = [r for r in scene.runs if r.parameter == "sigma" and r.kind != "curve"]
    if not runs:
        raise SpecError(str(path), "run", "the method ladder needs a run continuing sigma")
    r = runs[0]
    fixed = {**{"U": 0.0, "eta": 0.0}, **scene.fixed, **r.fixed}
    return Setting(scene.name, scene.title or scene.name, Path(scene.model), float(fixed["U"]),
                   float(fixed["eta"]), (float(r.range[0]), float(r.range[1])), str(path))


class Tools:
    """What the methods and studies share for one model, each built once: derivation, AME, one
    compiled eq. (21) integrator (and its variational system, for Floquet multipliers), AME
    integrators, continuation systems; records how long each one-off build took. The one bundle of
    the studies (the ladder, `advise`, the work-precision bench and the failure map use it)."""

    @classmethod
    def build(cls, model_path: str | Path, ordering: str = "paper") -> "Tools":
        """`Tools` with the compiled eq. (21) generator loaded now, so that no later timing
        includes it (the failure map's per-point wall times)."""
        tools = cls(model_path, ordering)
        from autocable.model.symbolic import parameter_values
        tools.ode_int.run((0.0, 0.0, 0.0, 0.0), 0.0, 1.0, 0.5, parameter_values(0.0, 0.0, tools.derivation.ode.omega1))
        return tools

    def __init__(self, model_path: str | Path, ordering: str = "paper"):
        from autocable.model.ame_cache import derive_ame
        from autocable.model.derive import derive
        t0 = time.perf_counter()
        self.derivation = derive(model_path)
        self.ordering = ordering            # the Multiple Scales ordering of the AME rungs
        self.ame = derive_ame(self.derivation, ordering=ordering).ame
        self.builds: dict[str, float] = {"derive": time.perf_counter() - t0}
        self._ode21 = None
        self._systems: dict = {}
        self._extra: dict = {}

    def ode21(self, rtol: float):
        from autocable.methods.integration.ode21 import Ode21Integrator
        if self._ode21 is None:
            integ = Ode21Integrator(self.derivation.ode)
            t0 = time.perf_counter()
            integ._compiled()          # build (or load) the compiled library now, timed apart
            self.builds["ode21"] = time.perf_counter() - t0
            self._ode21 = integ
        return self._ode21.with_tolerances(rtol, 1e-3 * rtol)

    def ame_integrator(self, rtol: float):
        from autocable.methods.integration.ame import AmeIntegrator
        key = ("ame", float(rtol))
        if key not in self._extra:
            t0 = time.perf_counter()
            self._extra[key] = AmeIntegrator(self.ame, rtol=rtol)
            self.builds.setdefault("ame-integrator", time.perf_counter() - t0)
        return self._extra[key]

    @property
    def ode_int(self):
        """Eq. (21)'s integrator at its default tolerances."""
        if "ode_int" not in self._extra:
            from autocable.methods.integration.ode21 import Ode21Integrator
            self._extra["ode_int"] = Ode21Integrator(self.derivation.ode)
        return self._extra["ode_int"]

    @property
    def ame_int(self):
        """The AME integrator at its default tolerances."""
        if "ame_int" not in self._extra:
            from autocable.methods.integration.ame import AmeIntegrator
            self._extra["ame_int"] = AmeIntegrator(self.ame)
        return self._extra["ame_int"]

    @property
    def variational(self):
        """Eq. (21) with its variational equations (`floquet21.Variational21`)."""
        if "variational" not in self._extra:
            from autocable.methods.integration.floquet21 import Variational21
            self._extra["variational"] = Variational21(self.derivation.ode)
        return self._extra["variational"]

    def system(self, dof: str, wind: bool):
        from autocable.methods.continuation import ame_system
        key = (dof, wind)
        if key not in self._systems:
            t0 = time.perf_counter()
            self._systems[key] = ame_system(self.ame, dof, wind=wind)
            self.builds[f"system-{dof}{'-wind' if wind else ''}"] = time.perf_counter() - t0
        return self._systems[key]

    def build_seconds(self, *keys) -> float:
        return float(sum(self.builds.get(k, 0.0) for k in keys))


# -- the rungs -----------------------------------------------------------------------------------
def _same_bp(a, b, span: float) -> bool:
    return abs(a.value - b.value) <= 1e-4 * span and abs(a.a1 - b.a1) <= 1e-3 * max(a.a1, b.a1, 1e-12) \
        and abs(a.a2 - b.a2) <= 1e-3 * max(a.a1, b.a1, 1e-12)


def _other_end(C, problem, system, settings, first, engine: str, hi: float):
    values = {**problem.values, "sigma": hi}
    x, ok, _ = C.equilibrium_near(system, np.zeros(system.dimension), system.parameter_vector(values),
                                  scale=problem.state_scale)
    if not ok:
        return None
    a = system.amplitude_values(x)
    b = first.branch
    at_hi = [i for i in range(len(b)) if abs(b.values[i] - hi) <= 1e-6 * problem.span]
    if any(abs(b["a1"][i] - a[0]) <= 1e-3 * max(a[0], 1e-12) for i in at_hi):
        return None
    other = problem.at(sigma=hi)
    try:
        return C.continue_equilibria(other, settings, x, name="I+", engine=engine)
    except C.StartError:
        return None


def _continuation(tools: Tools, dof: str, setting: Setting, knobs: Mapping, max_branches: int = 8):
    from autocable.methods import continuation as C
    lo, hi = setting.sigma_range
    wind = setting.U != 0.0
    system = tools.system(dof, wind)
    values = {"sigma": lo, "U": setting.U, "eta": setting.eta}
    h = float(knobs["max_step"])
    settings = C.ContinuationSettings(step=min(5e-3, h), max_step=h, tol=float(knobs.get("tol", 1e-10)),
                                      switch_step=min(1e-2, h))
    key = f"{knobs.get('engine', 'pycont')}-{dof}{'-wind' if wind else ''}"
    t0 = time.perf_counter()
    problem = C.EquilibriumProblem(system, "sigma", values, (lo, hi), C.auto_state_scale(system, values))
    engine = str(knobs.get("engine", "pycont"))
    first = C.continue_equilibria(problem, settings, None, name="I", engine=engine)
    # PyCont's first use of a system compiles and sets it up: a build, timed apart.
    setup = first.timings.get("setup_s", 0.0) if key not in tools.builds else 0.0
    if key not in tools.builds:
        tools.builds[key] = setup
    results, queue, seen, messages = [first], [first], [], []
    # The small response at the other end of the range may lie on a part of the diagram the first
    # branch does not reach inside the range (the lower branch of a hardening resonance whose fold
    # lies beyond it): start there too unless the first branch already passes through it.
    other = _other_end(C, problem, system, settings, first, engine, hi)
    if other is not None:
        results.append(other)
        queue.append(other)
    while queue and len(results) < max_branches:
        res = queue.pop(0)
        for bp in res.branch.of_type("BP"):
            if bp.origin != "autocable" or any(_same_bp(bp, s, hi - lo) for s in seen):
                continue
            seen.append(bp)
            if bp.label == "BP0" or len(results) >= max_branches:
                continue
            try:
                new = C.switch_branch(res, bp.label, settings, name=f"{res.branch.name}-{bp.label}",
                                      engine=engine)
            except Exception as exc:    # a failed switch is a finding of this rung, not a crash
                messages.append(f"switch at {res.branch.name}:{bp.label} failed: {exc}")
                continue
            results.append(new)
            queue.append(new)
    seconds = time.perf_counter() - t0 - setup
    vals, a1, a2, stable, branch, special = [], [], [], [], [], []
    for res in results:
        b = res.branch
        vals.append(b.values)
        a1.append(b["a1"])
        a2.append(b["a2"] if "a2" in b.table else np.zeros(len(b)))
        stable.append(b.stable)
        branch += [b.name] * len(b)
        for s in b.special_points:
            if s.type in ("LP", "BP", "H") and s.label != "BP0":
                special.append(MappingProxyType({"type": s.type, "sigma": float(s.value), "a1": float(s.a1),
                                                 "a2": float(s.a2), "branch": b.name}))
    ends = "; ".join(f"{r.branch.name}: " + ", ".join(f"{e.side} {e.reason}" for e in r.branch.ends)
                     for r in results)
    return dict(values=np.concatenate(vals), a1=np.concatenate(a1), a2=np.concatenate(a2),
                stable=np.concatenate(stable).astype(bool), branch=tuple(branch), special=tuple(special),
                seconds=seconds, build_seconds=tools.build_seconds(key), ok=np.ones(len(branch), bool),
                message="; ".join([f"{len(results)} branches ({ends})"] + messages),
                info={"points": len(branch), "branches": [r.branch.name for r in results]})


def _sweep(tools: Tools, kind: str, setting: Setting, knobs: Mapping):
    from autocable.methods.integration.sweeps import sweep
    lo, hi = setting.sigma_range
    n = int(knobs["points"])
    rtol = float(knobs["rtol"])
    grid = np.linspace(lo, hi, n)
    fixed = {"U": setting.U, "eta": setting.eta}
    if kind == "ode21":
        integ = tools.ode21(rtol)
        options = {"steady_tol": max(1e-8, 10 * rtol)}
        key = "ode21"
    else:
        integ = tools.ame_integrator(rtol)
        options = {}
        key = "ame-integrator"
    t0 = time.perf_counter()
    points = sweep(integ, "sigma", grid, fixed, **options)
    seconds = time.perf_counter() - t0
    ok = np.array([p.steady and p.periodic and math.isfinite(p.a1) for p in points])
    bad = [f"{p.direction} {p.value:+.4f}: {p.message}" for p in points if not (p.steady and p.periodic)]
    return dict(values=np.array([p.value for p in points]), a1=np.array([p.a1 for p in points]),
                a2=np.array([p.a2 for p in points]), stable=ok.copy(), branch=tuple(p.direction for p in points),
                special=_sweep_jumps(points), seconds=seconds, build_seconds=tools.build_seconds(key), ok=ok,
                message=f"{len(points)} points, {int(ok.sum())} steady period-1"
                        + (f"; not period-1: {len(bad)} ({bad[0]} ...)" if bad else ""),
                info={"points": len(points),
                      "envelope": [[p.a1_min, p.a1_max, p.a2_min, p.a2_max] for p in points]})


def _sweep_jumps(points) -> tuple:
    """Coexistence boundaries of a sweep: sigma intervals at whose ends the up and down sweeps
    start (or stop) disagreeing (folds or pitchforks of the attractors lie inside)."""
    up = {round(p.value, 12): p for p in points if p.direction == "up"}
    down = {round(p.value, 12): p for p in points if p.direction == "down"}
    grid = sorted(set(up) & set(down))
    differ = [_distance(up[s].a1, up[s].a2, down[s].a1, down[s].a2) > 0.05
              if (up[s].steady and down[s].steady) else False for s in grid]
    out = []
    for i in range(1, len(grid)):
        if differ[i] != differ[i - 1]:
            out.append(MappingProxyType({"type": "jump", "sigma": 0.5 * (grid[i - 1] + grid[i]),
                                         "lo": grid[i - 1], "hi": grid[i], "a1": math.nan, "a2": math.nan,
                                         "branch": "up/down"}))
    return tuple(out)


def _distance(a1, a2, b1, b2) -> float:
    """Relative distance of two responses: a1 relative to itself, a2 relative to itself where it
    is at least 1 % of a1 (below that, a2 ~ 0 and is measured against 1 % of a1)."""
    if not (math.isfinite(a1) and math.isfinite(b1)) or b1 <= 0:
        return math.inf
    e1 = abs(a1 - b1) / b1
    e2 = abs(a2 - b2) / max(abs(b2), 1e-2 * b1)
    return max(e1, e2)


def _optional_run(tools: Tools, name: str, setting: Setting, knobs: Mapping):
    if name == "ode21-periodic":
        from autocable.methods.integration.periodic21 import continue_periodic21
        lo, hi = setting.sigma_range
        integ = tools.ode21(1e-10)
        t0 = time.perf_counter()
        # Started inside the range (from a start on a range end AUTO may take the outward sense on
        # both sides, periodic21's docstring): mid-range, and again at 80 % of the range unless the
        # response reached there from rest lies on a branch already found (Fig. 6: mid-range
        # starts on the bi-modal loop, 80 % on the planar lower branch where the AME is valid).
        parts, ends, build = [], [], None
        for k, frac in enumerate((0.5, 0.8)):
            s0 = lo + frac * (hi - lo)
            if parts:
                r = integ.simulate(setting.U, setting.eta, s0)
                if not (r.steady and r.periodic) or any(
                        len(p.values) and np.min(np.abs(p.values - s0)) < 0.02 * (hi - lo)
                        and abs(p.a1[int(np.argmin(np.abs(p.values - s0)))] - r.a1) < 1e-3 * r.a1
                        for p in parts):
                    continue
            br = continue_periodic21(tools.derivation, U=setting.U, eta=setting.eta, sigma_range=(lo, hi),
                                     start_sigma=s0, integrator=integ, **dict(knobs))
            build = float(br.info.get("timings", {}).get("build_s", 0.0)) if build is None else build
            parts.append(br)
            ends.append(f"P{k + 1} from sigma = {s0:+.4f}: {len(br.values)} points, {br.end_reason}")
        key = "auto-periodic21"
        if key not in tools.builds:
            tools.builds[key] = build
        seconds = time.perf_counter() - t0 - (build if tools.builds[key] == build else 0.0)
        special = tuple(MappingProxyType({"type": sp_.get("type", "?"), "sigma": float(sp_.get("sigma", math.nan)),
                                          "a1": float(sp_.get("a1", math.nan)), "a2": float(sp_.get("a2", math.nan)),
                                          "branch": f"P{k + 1}"})
                        for k, br in enumerate(parts) for sp_ in br.special)
        cat = (lambda field, dtype=float: np.concatenate([np.asarray(getattr(br, field), dtype) for br in parts]))
        n = sum(len(br.values) for br in parts)
        return dict(values=cat("values"), a1=cat("a1"), a2=cat("a2"), stable=cat("stable", bool),
                    branch=tuple(f"P{k + 1}" for k, br in enumerate(parts) for _ in br.values),
                    special=special, seconds=seconds, build_seconds=tools.builds[key], ok=np.ones(n, bool),
                    message="; ".join(ends), info={"points": n, "branches": len(parts)})
    if name == "ode21-nmode":
        from autocable.methods.integration.nmode import NModeIntegrator
        knobs = dict(knobs)
        n = int(knobs.pop("points", 11))
        n_in, n_out = int(knobs.pop("n_in", 2)), int(knobs.pop("n_out", 2))
        key = f"nmode-{n_in}-{n_out}"
        if key not in tools._extra:
            t0 = time.perf_counter()
            integ = NModeIntegrator(tools.derivation, n_in, n_out)
            integ._compiled()         # the C build, timed apart
            tools._extra[key] = integ
            tools.builds[key] = time.perf_counter() - t0
        integ = tools._extra[key]
        lo, hi = setting.sigma_range
        t0 = time.perf_counter()
        rs = [integ.simulate(setting.U, setting.eta, float(s)) for s in np.linspace(lo, hi, n)]
        seconds = time.perf_counter() - t0
        ok = np.array([bool(getattr(r, "steady", True)) and math.isfinite(r.a1) for r in rs])
        return dict(values=np.linspace(lo, hi, n), a1=np.array([r.a1 for r in rs]),
                    a2=np.array([r.a2 for r in rs]), stable=ok.copy(), branch=("up",) * n, special=(),
                    seconds=seconds, build_seconds=tools.build_seconds(key), ok=ok,
                    message=f"{n} points (up sweep from rest at each point)", info={"points": n})
    raise ValueError(f"unknown method {name!r}")


def run(method_or_name, setting: Setting, knobs: Mapping | None = None, tools: Tools | None = None) -> MethodResult:
    """Compute ``setting``'s diagram by one rung; ``knobs`` override the method's defaults."""
    m = method(method_or_name) if isinstance(method_or_name, str) else method_or_name
    values = {**m.defaults(), **dict(knobs or {})}
    unknown = set(values) - {k.name for k in m.knobs}
    if unknown and m.knobs:
        raise ValueError(f"method {m.name}: unknown knobs {sorted(unknown)}; it has "
                         f"{[k.name for k in m.knobs]}")
    tools = tools or Tools(setting.model)
    if m.name == "ame-1dof":
        out = _continuation(tools, "1dof", setting, values)
    elif m.name == "ame-2dof":
        out = _continuation(tools, "2dof", setting, values)
    elif m.name == "ode21-sweep":
        out = _sweep(tools, "ode21", setting, values)
    elif m.name == "ame-sweep":
        out = _sweep(tools, "ame", setting, values)
    else:
        out = _optional_run(tools, m.name, setting, values)
    return MethodResult(method=m.name, setting=setting.scene, knobs=MappingProxyType(values), **out)
