"""Running a scene (`autocable run`): its continuation runs in order, later ones from labelled points
of earlier ones (like AUTO-07p's scripts), the overlays of eq. (21), and the files it writes
(`autocable.scene.schema` describes the scene file; `time_scene` runs ``[time]`` scenes, Fig. 11).

`run_scene(load_scene(path), out_dir)` writes ``branches.csv``, ``special_points.csv``, ``run.json``
(`autocable.results`) and ``<scene>.png``/``.pdf`` (`autocable.plotting.diagrams`), with curve runs
also ``<scene>_plane.png``/``.pdf``. ``ame = "auto"`` scenes need a chooser of the AME (the probes of
`autocable.studies.advise`), passed in as ``choose_ame``: the command line and `autocable.run_scene`
pass it, so the core never imports the studies built on it.
"""
from __future__ import annotations

import math
import platform
import sys
import time
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any, Callable, Mapping

from autocable.errors import ComputationError
from autocable.model.units import units_of
from autocable.spec import SpecError, load_model

from autocable.scene.provenance import ode21_engine, versions
from autocable.scene.time_scene import run_time_scene
from autocable.scene.schema import (ENGINES, PARAMETERS, RESOLUTIONS, Progress, RunSpec, Scene, load_scene,
                                    read_compare)

__all__ = ["run_scene", "coarse_settings", "write_compare", "load_scene", "summary_lines"]

# ================================================================================================
# running
# ================================================================================================

def _system_for(scene: Scene, ame, values: Mapping[str, float], parameter: str, rng, path, where,
                memo: dict | None = None):
    """The AME system for a run: aerodynamic rows only when the wind blows (1/U powers).

    ``memo`` (one per scene run) hands every run the same `System` object: building the wind AME
    as sympy data costs about a second, and its numeric functions and C kernel load once."""
    from autocable.methods.continuation import ame_system
    if scene.ame == "1dof-amplitude":
        from autocable.methods.amplitude_system import galloping_amplitude_system
        if parameter == "eta" or values.get("eta", 0.0) != 0.0:
            raise SpecError(path, f"{where}.fixed.eta", 'ame = "1dof-amplitude" (Fig. 3) holds at '
                                                       "eta = 0 only; fix eta = 0 and do not continue it")
        if parameter == "U" and rng[0] <= 0:
            raise SpecError(path, f"{where}.range", "continuing U needs U > 0 over the whole range "
                                                    "(the aerodynamic terms carry 1/U); start just above 0")
        return galloping_amplitude_system(ame)
    if parameter == "U":
        if rng[0] <= 0:
            raise SpecError(path, f"{where}.range", "continuing U needs U > 0 over the whole range "
                                                    "(the aerodynamic terms carry 1/U); start just above 0")
        wind = True
    else:
        wind = values.get("U", 0.0) != 0.0
    memo = {} if memo is None else memo
    if (scene.ame, wind) not in memo:
        memo[(scene.ame, wind)] = ame_system(ame, scene.ame, wind=wind)
    return memo[(scene.ame, wind)]



# ------------------------------------------------------------------------------------------------
# one function per run kind (RUN_KINDS): what a scene's [[run]] continues
# ------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class _Run:
    """What every run kind needs: the scene's run, its problem and settings, and where it starts."""

    run: RunSpec
    problem: Any                  # EquilibriumProblem
    settings: Any                 # ContinuationSettings
    system: Any                   # System
    values: Mapping[str, float]
    scale: float
    source: Any                   # the ContinuationResult of a "RUN:LABEL" start, or None
    start_state: Any              # the labelled point's state, or None
    engine: str
    say: Callable[[str], None]
    path: Path
    where: str
    known: tuple = ()             # the scene's branches computed before this run (search starts)

    def from_label(self):
        """The labelled point of an earlier run, in this run's problem (its parameter and range)."""
        from autocable.methods import continuation as C
        return C.ContinuationResult(self.source.branch, self.problem, self.settings), \
            self.run.start.label.split(":")[1]


def run_curve(r: _Run):
    """``kind = "curve"``: the curve of folds (LP-C), Hopf points (H-C2) or pitchforks through a
    labelled point, in (parameter, parameter2)."""
    from autocable.methods import continuation as C
    src, label = r.from_label()
    fn = C.continue_folds if label.startswith("LP") else \
        C.continue_branch_points if label.startswith("BP") else C.continue_hopf
    return fn(src, label, r.run.parameter2, r.run.range2, r.settings, name=r.run.name,
              directions=r.run.directions, progress=r.say)


def run_cycles_from_orbit(r: _Run):
    """``kind = "cycles"`` with ``start = { orbit = [...] }``: the stable periodic orbit the AME
    settle on from those amplitudes, and its branch (compiled collocation; Figs. 8 and 10's P)."""
    import numpy as np

    from autocable.methods import continuation as C
    amps = list(r.run.start.values)
    n_modes = r.system.dimension // 2
    amps += [0.0] * max(0, n_modes - len(amps))
    y0 = np.zeros(r.system.dimension)
    y0[0::2] = amps[:n_modes]
    r.say(f"  integrating the AME from a = {amps[:n_modes]} to a periodic orbit")
    t_orb, x_orb, period = C.periodic_orbit(r.system, r.values, y0, scale=r.scale,
                                            seconds=r.settings.orbit_seconds)
    return C.continue_cycles_from_orbit(r.problem, r.settings, t_orb, x_orb, period, name=r.run.name,
                                        directions=r.run.directions, progress=r.say)


def run_cycles(r: _Run):
    """``kind = "cycles"`` from a labelled Hopf point (PyCont's LC-C or the compiled collocation)."""
    from autocable.methods import continuation as C
    src, label = r.from_label()
    return C.continue_cycles(src, label, r.settings, name=r.run.name, progress=r.say, engine=r.engine)


def run_switch(r: _Run):
    """``kind = "switch"``: the other branch through a labelled branch point, both sides."""
    from autocable.methods import continuation as C
    src, label = r.from_label()
    return C.switch_branch(src, label, r.settings, name=r.run.name, progress=r.say, engine=r.engine)


def run_equilibria(r: _Run):
    """``kind = "equilibria"``: a branch of equilibria from the trivial state, a given state, the
    steady state integration reaches from given amplitudes, or a labelled point."""
    import numpy as np

    from autocable.methods import continuation as C
    start, system = r.run.start, r.system
    if start.kind == "trivial":
        x0 = np.zeros(system.dimension)
    elif start.kind == "state":
        if len(start.values) != system.dimension:
            raise SpecError(r.path, f"{r.where}.start.state", f"expected {system.dimension} numbers "
                                                              f"{list(system.variables)}")
        x0 = np.array(start.values)
    elif start.kind == "integrate":
        amps = list(start.values)
        if system.dimension == 1:
            # the polar amplitude equation of Fig. 3 (ame = "1dof-amplitude"): its state is a1 itself
            n_modes, y0 = 1, np.array([float(amps[0]) if amps else 0.0])
        else:
            n_modes = system.dimension // 2
            amps += [0.0] * max(0, n_modes - len(amps))
            y0 = np.zeros(system.dimension)
            y0[0::2] = amps[:n_modes]
        r.say(f"  integrating the AME from a = {amps[:n_modes]} to a steady state")
        x0 = C.settle(system, r.values, y0, scale=r.scale, engine=r.engine,
                      seconds=r.settings.settle_seconds, evaluations=r.settings.settle_evaluations)
    elif start.kind == "search":
        return run_search(r)
    else:
        x0 = r.start_state
    try:
        return C.continue_equilibria(r.problem, r.settings, x0, name=r.run.name, directions=r.run.directions,
                                     progress=r.say, engine=r.engine)
    except C.StartError as exc:
        if start.kind != "trivial":
            raise
        moved = _trivial_start_elsewhere(r)
        if moved is None:
            raise
        r.say(f"  {exc}; Newton from rest converges at {r.problem.parameter} = {moved.values[moved.parameter]:g}: "
              f"the branch starts there")
        return C.continue_equilibria(moved, r.settings, np.zeros(system.dimension), name=r.run.name,
                                     directions=r.run.directions, progress=r.say, engine=r.engine)


#: Values of the continued parameter tried, across the range, when Newton from rest does not converge
#: at the range's start (``start = "trivial"``).
TRIVIAL_TRIES = 41


def _trivial_start_elsewhere(r: _Run):
    """The run's problem moved to the first value of the continued parameter, across its range from
    the start, where Newton from rest converges to an equilibrium; None if there is none. The small
    forced response that ``start = "trivial"`` means need not exist at the range's start for every
    model (a fold of it may lie there), and a start tuned to one model is what scenes avoid."""
    import numpy as np

    from autocable.methods.continuation.equilibrium_analysis import equilibrium_near
    prob, sysm = r.problem, r.system
    lo, hi = prob.bounds
    names = list(sysm.parameter_names)
    for v in np.linspace(lo, hi, TRIVIAL_TRIES)[1:]:
        values = {**prob.values, prob.parameter: float(v)}
        p = sysm.parameter_vector(values)
        x, ok, _ = equilibrium_near(sysm, np.zeros(sysm.dimension), p, tol=r.settings.newton_tol,
                                    scale=prob.state_scale)
        if ok and all(math.isfinite(float(y)) for y in x):
            return replace(prob, values=dict(zip(names, p)))
    return None


def on_known_branch(branches, parameter: str, value: float, state, rel_tol: float = 1e-2) -> str:
    """The name of the first equilibrium branch (continued in ``parameter``) that passes through
    ``state`` at ``parameter = value``: a chord between two of its points within ``rel_tol`` of
    |state| of it, or of its mirror image (r_k, s_k) -> -(r_k, s_k) for k >= 2 (the out-of-plane
    mode's sign, a symmetry of the AME without wind); else "". Two coexisting branches can lie a
    few per cent apart in (a1, a2) (Fig. 7 at sigma = -0.03: 4.49e-3 / 2.64e-3 and 4.43e-3 /
    2.58e-3, both stable), so states are compared, not amplitudes."""
    import numpy as np

    x = np.asarray(state, float)
    mirror = x.copy()
    mirror[2:] = -mirror[2:]
    tol = rel_tol * float(np.linalg.norm(x)) + 1e-12
    for b in branches:
        if b.kind != "equilibrium" or b.parameter != parameter or not len(b):
            continue
        P = np.asarray(b.table[parameter], float)
        X = np.column_stack([np.asarray(b.table[v], float) for v in b.variables])
        if X.shape[1] != x.size:
            continue
        for i in range(len(P) - 1):
            if (P[i] - value) * (P[i + 1] - value) > 0:
                continue
            span = P[i + 1] - P[i]
            t = 0.5 if span == 0 else (value - P[i]) / span
            y = X[i] + t * (X[i + 1] - X[i])
            if min(np.linalg.norm(y - x), np.linalg.norm(y - mirror)) <= tol:
                return b.name
    return ""


def run_search(r: _Run) -> list:
    """``start = { search = [v1, ...] }``: at each value in turn, every equilibrium Newton finds from
    the fixed grid (`autocable.methods.continuation.search`); every stable one on no branch of the
    scene so far (the earlier runs' and those this search has continued) starts a branch: the first
    is named after the run, the next ``NAME_2``, ``NAME_3``, ... Nothing found: an empty list (the
    scene goes on; run.json says what was searched). A branch whose continuation fails is skipped
    with a message, and the search goes on: the branches already continued are kept."""
    from autocable.methods import continuation as C
    from autocable.methods.continuation.search import find_equilibria
    from autocable.model.premises import MAX_AMPLITUDE

    if r.system.dimension % 2:
        raise SpecError(r.path, f"{r.where}.start", '{ search = [...] } needs the Cartesian AME (ame = "2dof" '
                                                    'or "1dof")')
    p_name = r.run.parameter
    out: list = []
    for v in r.run.start.values:
        eqs = find_equilibria(r.system, {**r.values, p_name: v}, scale=r.scale, max_amplitude=MAX_AMPLITUDE)
        stable = [e for e in eqs if e.stable]
        r.say(f"  search at {p_name} = {v:g}: {len(eqs)} equilibria, {len(stable)} stable")
        for e in stable:
            known = tuple(r.known) + tuple(res.branch for res in out)
            if on_known_branch(known, p_name, v, e.state):
                continue
            name = r.run.name if not out else f"{r.run.name}_{len(out) + 1}"
            amps = ", ".join(f"{a:.4g}" for a in e.amplitudes)
            r.say(f"  {name} from a = {amps} at {p_name} = {v:g}")
            try:
                out.append(C.continue_equilibria(r.problem.at(**{p_name: v}), r.settings, list(e.state),
                                                 name=name, directions=r.run.directions, progress=r.say,
                                                 engine=r.engine))
            except (C.StartError, ComputationError) as exc:
                r.say(f"  the branch from a = {amps} at {p_name} = {v:g} failed, skipped: {exc}")
    return out


#: The run kinds of a scene ("orbit": a cycles run started from an integrated orbit).
RUN_KINDS = {"equilibria": run_equilibria, "cycles": run_cycles, "orbit": run_cycles_from_orbit,
             "switch": run_switch, "curve": run_curve}


def coarse_settings(steps: Mapping[str, Any]) -> dict[str, Any]:
    """The ``resolution = "coarse"`` step controls for a run's ``steps`` (what the tests run):
    longer largest steps (x2, at most 0.1 of the range; x3 made Fig. 6's II step over a branch point),
    at most 20 points per cycle branch and 150 per curve direction. Special points are still
    located and refined by autocable's test functions, so their locations do not depend on the
    step; only the density of the drawn branches does."""
    from autocable.methods.continuation import ContinuationSettings
    base = ContinuationSettings(**steps)
    out = dict(steps)
    out["max_step"] = max(base.max_step, min(2 * base.max_step, 0.1))
    out["cycle_max_step"] = max(base.cycle_max_step, min(2 * base.cycle_max_step, 0.1))
    out["curve_max_step"] = max(base.curve_max_step, min(2 * base.curve_max_step, 0.1))
    out["cycle_max_points"] = min(base.cycle_max_points, 20)
    out["curve_max_points"] = min(base.curve_max_points, 150)
    return out


def _settings(run: RunSpec, resolution: str = "full"):
    from autocable.methods.continuation import ContinuationSettings
    return ContinuationSettings(**(coarse_settings(run.steps) if resolution == "coarse" else run.steps))


def run_scene(scene: Scene, out_dir: str | Path, *, progress: Progress | None = None,
              plot: bool = True, resolution: str = "full", engine: str | None = None,
              choose_ame: Callable | None = None, response_map: str | Path | None = None):
    """Run every run of ``scene`` in order, write the results into ``out_dir`` and plot them.

    ``engine`` ("pycont" or "compiled") overrides the scene's ``engine`` for equilibria, branch
    switching and cycles from Hopf points (cycles from an integrated orbit always use the compiled
    collocation: PyCont's LC-C starts only at Hopf points). ``choose_ame(scene, tol=...)`` picks the
    AME of an ``ame = "auto"`` scene (`autocable.studies.advise.choose_ame`, which the command line
    and `autocable.run_scene` pass); such a scene without it is refused.

    ``resolution = "coarse"`` (the tests) runs the same scene with longer steps and capped cycle
    and curve runs (`coarse_settings`) and every third overlay value; a ``[time]`` scene is the
    same at both resolutions.

    A scene with a ``[chart]`` table also classifies the AME's response on the chart's grid
    (``regions.csv``, ``regions.json``) and draws ``<scene>_chart.png``/``.pdf`` with the curves, the
    labelled regions and, from ``response_map`` (or the table's ``map``), the classes of a
    brute-force map of eq. (21) (`_run_chart`).

    Returns the `RunResults`. A branch that fails part-way is kept with its points and an end
    reason; a start that does not converge, or a start value outside the range, stops the scene
    with a `SpecError` naming the run.

    The files are written into a staging folder inside ``out_dir`` and published when the scene
    ends, run.json last (`autocable.run_folder.output_folder`): ``out_dir`` reads as complete only
    after a run that finished; a run that raises leaves ``status = "failed"`` with the reason, a
    killed one ``"running"``.
    """
    from autocable.run_folder import output_folder

    def say(msg: str) -> None:
        if progress:
            progress(f"[{scene.name}] {msg}")

    if resolution not in RESOLUTIONS:
        raise ValueError(f"resolution must be one of {RESOLUTIONS}, got {resolution!r}")
    if engine is not None:
        if engine not in ENGINES:
            raise ValueError(f"engine must be one of {ENGINES}, got {engine!r}")
        scene = replace(scene, engine=engine)
    # a bad map is refused before the folder is touched
    rmap = read_chart_map(scene, response_map) if scene.chart is not None and scene.time is None else None
    # files the run reads may sit in its output folder (e.g. `--map DIR/sweep.nc`): never refused
    inputs = (scene.path, scene.model, scene.compare.csv if scene.compare else None,
              rmap["path"] if rmap else None)
    with output_folder(out_dir, scene.name, inputs) as stage:
        if scene.time is not None:
            return run_time_scene(scene, stage, say, plot, resolution)
        return _run_branches(scene, stage, Path(out_dir), say, plot, resolution, choose_ame, rmap)


def _run_branches(scene: Scene, out: Path, shown: Path, say, plot: bool, resolution: str,
                  choose_ame: Callable | None, rmap: dict | None):
    """`run_scene` of a continuation scene, its files into ``out`` (the staging folder; ``shown``
    is the output folder the messages name)."""
    import numpy as np

    from autocable.methods import continuation as C
    from autocable.model.ame_cache import derive_ame
    from autocable.model.derive import derive
    from autocable.results import RunResults, write_results

    t_all = time.perf_counter()
    stages: dict[str, Any] = {}
    advice = None
    if scene.ame == "auto":
        # The lightest AME that reproduces this scene within ame_tol (`autocable advise`):
        # cheap probes first, then the whole scene with the chosen rung.
        if choose_ame is None:
            raise SpecError(scene.path, "ame", 'ame = "auto" needs the chooser of the AME: run the scene with '
                                              '`autocable run` or `autocable.run_scene`, or pass '
                                              'choose_ame=autocable.studies.advise.choose_ame')
        t0 = time.perf_counter()
        say(f'ame = "auto": probing which amplitude equations this scene needs (tol {scene.ame_tol:g})')
        advice = choose_ame(scene, tol=scene.ame_tol)
        for line in advice.report().splitlines():
            say(f"  {line}")
        scene = replace(scene, ame=advice.ame)
        stages["advise_s"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    say(f"model {scene.model.name}: eq. (21)")
    spec = load_model(scene.model)
    deriv = derive(spec)
    stages["derive_s"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    say(f"amplitude equations (24), {scene.ordering} ordering")
    cached = derive_ame(deriv, ordering=scene.ordering)
    ame = cached.ame
    stages["ame_s"] = time.perf_counter() - t0
    omega1 = float(ame.omegas[0])
    results: dict[str, C.ContinuationResult] = {}
    systems: dict = {}
    branches = []
    run_times: dict[str, Any] = {}
    failed: dict[str, str] = {}      # run -> why it has no branch (a budget spent, a numerical failure)
    not_found: set[str] = set()      # search runs that found no new branch (a finding, not a failure)
    path = scene.path

    def check_values(values, where):
        if values["sigma"] <= -omega1:
            raise SpecError(path, where, f"sigma = {values['sigma']:g} gives a non-positive forcing "
                                         f"frequency Omega = omega1 + sigma")

    def add(result: C.ContinuationResult):
        results[result.branch.name] = result
        branches.append(result.branch)
        b = result.branch
        ends = "; ".join(f"{e.side}: {e.reason}" for e in b.ends)
        say(f"  {b.name}: {len(b)} points" + (f" ({b.kind} curve in {b.parameter}, {b.parameter2})"
                                              if b.parameter2 else "") + ", special points "
            f"{', '.join(s.label for s in b.special_points) or 'none'} ({ends})")

    def follow_up(compute, name: str, where: str) -> None:
        """A branch launched from a run's special point (cycles from H, switching at BP): a
        numerical failure there loses that branch only, as a run's own start does."""
        try:
            add(compute())
        except ComputationError as exc:
            failed[name] = f"{where} (follow-up {name}): {exc}"
            say(f"  {name} failed: {exc}")

    for run in scene.runs:
        where = f"run[{run.index}]"
        t_run = time.perf_counter()
        lo, hi = run.range
        values = {p: 0.0 for p in PARAMETERS}
        values.update(scene.fixed)
        values.update(run.fixed)
        start_state = None
        source = None
        if run.start.kind == "label":
            src_name, label = run.start.label.split(":")
            if src_name in not_found:
                say(f"run {run.name} skipped: its start {run.start.label} is on run {src_name}, whose search "
                    f"found no branch")
                continue
            if src_name in failed:
                failed[run.name] = f"its start {run.start.label} is on run {src_name}, which failed"
                say(f"run {run.name} skipped: {failed[run.name]}")
                continue
            if src_name not in results:
                raise SpecError(path, f"{where}.start", f"no branch {src_name!r} has been computed")
            try:
                sp_ = results[src_name].special(label)
            except KeyError as exc:
                raise SpecError(path, f"{where}.start", str(exc).strip("'\"")) from None
            source = results[src_name]
            values.update(sp_.parameters)
            values.update(run.fixed)
            start_state = np.array(sp_.state)
        at = run.at if run.at is not None else (values[run.parameter] if run.start.kind == "label" else lo)
        if not lo <= at <= hi:
            raise SpecError(path, f"{where}.range", f"the start value {run.parameter} = {at:g} is outside "
                                                    f"the range [{lo:g}, {hi:g}]")
        values[run.parameter] = at
        check_values(values, where)
        check_values({**values, "sigma": lo if run.parameter == "sigma" else values["sigma"]}, f"{where}.range")
        if run.kind == "curve":
            lo2, hi2 = run.range2
            v2 = values[run.parameter2]
            if not lo2 <= v2 <= hi2:
                raise SpecError(path, f"{where}.range2", f"the start point {run.start.label} has {run.parameter2} = "
                                                         f"{v2:g}, outside the range [{lo2:g}, {hi2:g}]")
            if run.parameter2 == "U" and lo2 <= 0:
                raise SpecError(path, f"{where}.range2", "continuing U needs U > 0 over the whole range "
                                                         "(the aerodynamic terms carry 1/U); start just above 0")
            if run.parameter2 == "sigma":
                check_values({**values, "sigma": lo2}, f"{where}.range2")
        if run.kind == "curve" and run.parameter2 == "U":
            system = _system_for(scene, ame, values, "U", run.range2, path, where, systems)
        else:
            system = _system_for(scene, ame, values, run.parameter, run.range, path, where, systems)
        scale = scene.state_scale or C.auto_state_scale(system, values)
        problem = C.EquilibriumProblem(system, run.parameter, values, run.range, state_scale=scale)
        settings = _settings(run, resolution)
        if run.kind == "curve":
            what = {"LP": "folds", "H": "Hopf points", "BP": "pitchforks"}[run.start.label.split(":")[1].rstrip("0123456789")]
            say(f"run {run.name}: curve of {what} in "
                f"({run.parameter}, {run.parameter2}) over [{lo:g}, {hi:g}] x [{run.range2[0]:g}, "
                f"{run.range2[1]:g}] from {run.start.label}")
        else:
            say(f"run {run.name}: {run.kind} in {run.parameter} over [{lo:g}, {hi:g}] from "
                f"{run.start.label or run.start.kind} at {run.parameter} = {at:g}")
        kind = "orbit" if run.kind == "cycles" and run.start.kind == "orbit" else run.kind
        try:
            result = RUN_KINDS[kind](_Run(run, problem, settings, system, values, scale, source, start_state,
                                          scene.engine, say, path, where, tuple(branches)))
        except (C.StartError, C.SymmetryError) as exc:
            raise SpecError(path, f"{where}.start", str(exc)) from None
        except ComputationError as exc:
            # A spent budget or a numerical failure: this run has no branch; the others are still
            # computed and written, and the scene ends with the failure (exit status 3).
            failed[run.name] = f"{where}.start: {exc}"
            say(f"run {run.name} failed: {exc}")
            continue
        extras = []
        if isinstance(result, list):
            # a search: every new branch it continued (none: a finding about the model, not a failure)
            result, extras = (result[0], result[1:]) if result else (None, [])
        if result is None:
            searched = ", ".join(f"{v:g}" for v in run.start.values)
            say(f"run {run.name}: no stable equilibrium off the earlier branches at {run.parameter} = {searched}")
            run_times[run.name] = {"wall_s": time.perf_counter() - t_run,
                                   "search": f"no stable equilibrium off the earlier branches at "
                                             f"{run.parameter} = {searched}"}
            not_found.add(run.name)
            continue
        add(result)
        for extra in extras:
            add(extra)
        follow = {"cycles": 0, "switch": 0}
        if run.kind != "cycles" and run.cycles:
            for h in results[run.name].branch.of_type("H"):
                if h.origin != "autocable":
                    continue
                say(f"  cycles from {h.name}")
                follow_up(lambda h=h: C.continue_cycles(results[run.name], h.label, settings,
                                                        name=f"{run.name}-{h.label}", progress=say,
                                                        engine=scene.engine), f"{run.name}-{h.label}", where)
                follow["cycles"] += 1
        if run.kind != "cycles" and run.switch:
            for bp in results[run.name].branch.of_type("BP"):
                if bp.origin != "autocable" or bp.label == "BP0":
                    continue
                say(f"  switching branches at {bp.name}")
                follow_up(lambda bp=bp: C.switch_branch(results[run.name], bp.label, settings,
                                                        name=f"{run.name}-{bp.label}", progress=say,
                                                        engine=scene.engine), f"{run.name}-{bp.label}", where)
                follow["switch"] += 1
        run_times[run.name] = {"wall_s": time.perf_counter() - t_run,
                               **{k: v for k, v in results[run.name].timings.items()},
                               "follow_ups": follow, "state_scale": scale}
    stages["runs"] = run_times
    branches, validity = _with_twist(branches, spec, deriv)
    provenance = {
        "scene": str(scene.path), "scene_name": scene.name, "title": scene.title,
        "scene_text": scene.text, "model": str(scene.model), "model_name": spec.name,
        "model_hash": spec.content_hash(), "ode_hash": deriv.ode.content_hash(), "ame_key": cached.key,
        "ame": scene.ame, "ordering": scene.ordering, "engine": scene.engine, "ode21_engine": ode21_engine(),
        "ame_advice": None if advice is None else {"requested": "auto", "tol": advice.tol, "chosen": advice.ame,
                                                   "lightest_rung": advice.rung, "reasons": list(advice.reasons)},
        "omega1": omega1, "omega2": float(ame.omegas[1]) if len(ame.omegas) > 1 else None,
        "si_scales": asdict(units_of(spec, deriv.statics)),
        "amplitude_convention": "a_k = sqrt(r_k^2 + s_k^2): peak modal amplitude (peak displacement / l, "
                                "modes normalised to a unit maximum); Omega = omega1 + sigma",
        "stability": "autocable's eigenvalues (equilibria) and Floquet multipliers (cycles), not PyCont's flags",
        "cycle_engine": scene.engine,
        "versions": versions(), "platform": platform.platform(), "argv": list(sys.argv),
        "resolution": resolution,
        "model_validity": validity,
        "failed_runs": dict(failed),
    }
    res = RunResults(scene.name, tuple(branches), {**provenance, "stages": stages})
    overlay_rows = None
    if scene.overlay is not None:
        t0 = time.perf_counter()
        overlay_rows = _run_overlay(scene, deriv, ame, say, resolution)
        _write_overlay(overlay_rows, out / "overlay.csv")
        # The AME side of the comparison, solved at the overlay's values rather than read off a chord.
        from autocable.methods.continuation.equilibria_at import COLUMNS, equilibria_at
        exact = equilibria_at(results, scene.overlay.parameter, [r["value"] for r in overlay_rows])
        _write_overlay(exact, out / "overlay_ame.csv", COLUMNS)
        stages["overlay_s"] = time.perf_counter() - t0
    chart_out = None
    if scene.chart is not None:
        t0 = time.perf_counter()
        chart_out = _run_chart(scene, ame, systems, say, out, resolution)
        chart_out["map"] = _score_map(scene, chart_out, out, rmap, say)
        stages["chart_s"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    write_results(res, out, status="running")    # "complete" once published
    stages["write_s"] = time.perf_counter() - t0
    compare = read_compare(scene.compare) if scene.compare else None
    compare_stats = None
    if compare and branches:
        compare_stats = write_compare(scene, compare, branches, out)
    if plot and branches:
        t0 = time.perf_counter()
        from autocable.plotting.diagrams import plot_scene, save_figure
        from autocable.scene.figure_units import figure_units
        units = figure_units(scene.plot.units, deriv)
        files = save_figure(plot_scene(res, x=scene.plot.x, y=scene.plot.y, title=scene.plot.title,
                                       labels=scene.plot.labels, compare=compare,
                                       compare_panel=scene.compare.panel if scene.compare else None,
                                       compare_label=scene.compare.label if scene.compare else "",
                                       compare_stats=compare_stats, overlay=overlay_rows, units=units),
                            out / scene.name)
        stages["plot_s"] = time.perf_counter() - t0
        if scene.plot.plane and any(b.kind in ("fold", "hopf", "branch_point") for b in branches):
            from autocable.plotting.diagrams import plot_plane
            files += save_figure(plot_plane(res, x=scene.plot.plane[0], y=scene.plot.plane[1],
                                            title=scene.plot.title, labels=scene.plot.labels, units=units),
                                 out / f"{scene.name}_plane")
            stages["plot_s"] = time.perf_counter() - t0
        if chart_out is not None:
            t1 = time.perf_counter()
            files += _plot_chart(scene, res, chart_out, out, units)
            stages["chart_plot_s"] = time.perf_counter() - t1
        say(f"plot: {', '.join(str(shown / Path(f).name) for f in files)}")
    stages["total_s"] = time.perf_counter() - t_all
    res = RunResults(scene.name, tuple(branches), {**provenance, "stages": stages})
    # again, now with the complete timings: the same branches, so run.json only
    write_results(res, out, status="running", tables=False)
    if failed:
        # published as "failed" by output_folder: what was computed stays, visibly incomplete
        name, why = next(iter(failed.items()))
        more = f" (and {len(failed) - 1} more)" if len(failed) > 1 else ""
        raise ComputationError(f"{path}: run {name} failed{more}: {why}; the other runs are written "
                               f"to {shown} (run.json lists the failed runs)")
    return res


def _run_chart(scene: Scene, ame, systems: dict, say, out: Path, resolution: str) -> dict:
    """Classify the AME's response on the chart's grid (`autocable.methods.regions`), label the
    connected regions, write ``regions.csv`` (one row per grid point) and ``regions.json``."""
    import csv
    import json

    import numpy as np

    from autocable.methods.regions import ClassifySettings, classify_grid, label_regions

    ch = scene.chart
    values = {p: 0.0 for p in PARAMETERS}
    values.update(scene.fixed)
    nx, ny = ch.grid
    if resolution == "coarse":
        nx, ny = max(4, nx // 2), max(4, ny // 2)
    xs = np.linspace(*ch.x_range, nx)
    ys = np.linspace(*ch.y_range, ny)
    # The wind AME whenever the wind blows anywhere on the chart (its rows carry 1/U).
    rng = ch.x_range if ch.x == "U" else ch.y_range if ch.y == "U" else (values["U"], values["U"])
    wind_axis = "U" if "U" in (ch.x, ch.y) else ch.x
    system = _system_for(scene, ame, values, wind_axis, rng, scene.path, "chart", systems)
    settings = ClassifySettings(t_end=ch.t_end, starts=ch.starts)
    say(f"chart: classifying the AME's response on a {nx} x {ny} grid of ({ch.x}, {ch.y})")
    rows = classify_grid(system, values, ch.x, xs, ch.y, ys, settings,
                         progress=say if nx * ny >= 100 else None)
    classes = np.array([r["class"] for r in rows], dtype=object).reshape(ny, nx)
    regions = label_regions(classes, xs, ys)
    keys = list(rows[0])
    for r in rows:
        keys += [k for k in r if k not in keys]
    out.mkdir(parents=True, exist_ok=True)
    with open(out / "regions.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=keys)
        w.writeheader()
        w.writerows(rows)
    data = {"plane": [ch.x, ch.y], "fixed": {k: v for k, v in values.items() if k not in (ch.x, ch.y)},
            "grid": [nx, ny], "settings": {k: (list(v) if isinstance(v, tuple) else v)
                                           for k, v in settings.__dict__.items()},
            "regions": [{"label": g.label, ch.x: g.x, ch.y: g.y, "cells": g.cells} for g in regions]}
    (out / "regions.json").write_text(json.dumps(data, indent=1))
    say(f"  regions: {', '.join(f'{g.label} ({g.cells})' for g in regions[:8])}"
        + (" ..." if len(regions) > 8 else ""))
    return {"rows": rows, "regions": regions, "fixed": data["fixed"]}


def read_chart_map(scene: Scene, response_map) -> dict | None:
    """The brute-force map (``response_map`` or the table's ``map``) in the chart's plane, read
    before anything is computed (a bad map is refused at once, not after the runs)."""
    from autocable.plotting.chart import read_response_map
    from autocable.scene.map_checks import check_map

    ch = scene.chart
    path = Path(response_map) if response_map is not None else ch.map
    if path is None:
        return None
    values = {p: 0.0 for p in PARAMETERS}
    values.update(scene.fixed)
    # checked against this chart (model, third parameter, ranges, class codes), naming where it came from
    where = "--map" if response_map is not None else f"{scene.path}: chart.map"
    rmap = check_map(path, where, load_model(scene.model).content_hash(), ch.x, ch.y, ch.x_range, ch.y_range,
                     {k: v for k, v in values.items() if k not in (ch.x, ch.y)}, read_response_map)
    return dict(rmap, path=str(path))


def _score_map(scene: Scene, chart_out: dict, out: Path, rmap, say) -> dict | None:
    """How often the AME's class predicts the map's (added to ``regions.json``)."""
    import json

    from autocable.plotting.chart import agreement

    if rmap is None:
        return None
    ch = scene.chart
    score = agreement(chart_out["rows"], ch.x, ch.y, rmap)
    say(f"  map {rmap['path']}: {score['points']} points, the AME's class predicts eq. (21)'s at {score['agree']}")
    data = json.loads((out / "regions.json").read_text())
    data["map"] = {"path": rmap["path"], "fixed": rmap["fixed"], **score,
                   "outside_chart": rmap.get("outside", 0)}
    (out / "regions.json").write_text(json.dumps(data, indent=1))
    return rmap


def _plot_chart(scene: Scene, res, chart_out: dict, out: Path, units=None) -> list:
    """Draw ``<scene>_chart.png``/``.pdf`` (with the map's classes when there is one)."""
    from autocable.plotting.chart import plot_chart
    from autocable.plotting.style import save_figure

    ch = scene.chart
    rmap = chart_out.get("map")
    title = scene.plot.title + "".join(f", {k} = {v:g}" for k, v in chart_out["fixed"].items()
                                       if f"{k} =" not in scene.plot.title)
    return save_figure(plot_chart(res, chart_out["rows"], chart_out["regions"], x=ch.x, y=ch.y,
                                  x_range=ch.x_range, y_range=ch.y_range, title=title, response_map=rmap,
                                  units=units), out / f"{scene.name}_chart")


def _with_twist(branches, spec, deriv):
    """Where the model stops applying. Each branch with a2 gets two columns: ``twist``,
    the peak slaved twist max_s |theta2(s)| a2 [rad] (Sect. 3: theta = theta2(s) q2), and
    ``cubic_error``, the error of the cubic load of eq. (14) against the exact quasi-steady load at
    the motion of that point (`aero.CubicLoadError`: twist, and the mid-span velocities
    nu Omega a1, nu Omega a2, at the point's U); the provenance gets the bound `aero.CUBIC_RTOL`,
    the largest twist and error, how many points exceed the bound, and the range of the angle phi
    of eq. (12) the twist sweeps (the lift and drag fits of eq. 13 were measured over a few tens of
    degrees at most)."""
    import numpy as np

    from autocable.model.aero import CUBIC_RTOL, CubicLoadError
    from autocable.model.curves import eq21_fits
    from autocable.model.modes import twist_peak
    per_q2 = twist_peak(*deriv.twist)
    a = spec.aero
    lift, drag = eq21_fits(a, deriv.statics.alpha, deriv.beta, deriv.theta0)
    err = CubicLoadError(lift, drag, deriv.statics.alpha, deriv.beta, deriv.theta0, a.angle_convention,
                         a.load_axes)
    nu, om = deriv.velocity_ratio, deriv.ode.omega1
    out, largest, worst, beyond, total = [], 0.0, 0.0, 0, 0
    for b in branches:
        if "a2" in b.table and "a1" in b.table:
            a1 = np.abs(np.asarray(b.table["a1"], dtype=float))
            a2 = np.abs(np.asarray(b.table["a2"], dtype=float))
            U = np.asarray(b.table["U"], dtype=float) if "U" in b.table else np.zeros_like(a2)
            tw = per_q2 * a2
            ce = err.many(tw, nu * om * a1, nu * om * a2, U)
            ok = np.isfinite(tw)
            largest = max(largest, float(tw[ok].max()) if ok.any() else 0.0)
            fin = ce[np.isfinite(ce)]
            worst = max(worst, float(fin.max()) if fin.size else 0.0)
            beyond += int(np.sum(fin > CUBIC_RTOL))
            total += len(b)
            b = b.replace(table={**b.table, "twist": tw, "cubic_error": ce})
        out.append(b)
    # the cubic fits c_l, c_d of eq. (13) are in phi = phi0 - theta (velocities aside): a twist of
    # radians takes them far outside any measured range of [36], whatever the expansion's error
    phi0 = math.degrees(deriv.static_angle)
    validity = {"twist_per_q2_rad": per_q2, "cubic_rtol": CUBIC_RTOL, "largest_twist_rad": largest,
                "largest_cubic_error": worst, "points_beyond_bound": beyond, "points": total,
                "phi_range_deg": [phi0 - math.degrees(largest), phi0 + math.degrees(largest)]}
    return out, validity


def write_compare(scene: Scene, rows: list[dict], branches, out: Path) -> dict:
    """``compare.json``: per curve label of the digitised points, their distance to the computed
    branches in the compared panel (`autocable.scene.compare`); returns what it wrote."""
    from autocable._store import atomic_write_json
    from autocable.scene.compare import compare_summary
    try:
        summary = compare_summary(rows, branches, scene.plot.x, scene.compare.panel)
    except ValueError as exc:
        raise SpecError(scene.path, "compare.panel", str(exc)) from None
    atomic_write_json(out / "compare.json", {"csv": str(scene.compare.csv), "label": scene.compare.label,
                                             **summary})
    return summary



def _run_overlay(scene: Scene, deriv, ame, say, resolution: str = "full") -> list[dict]:
    """Sweep the overlay's method up and down over its parameter values (methods/sweeps.py).
    An eq. (21) integration that is seen converging to a stable period-1 orbit ends there
    (`sweeps.PeriodOneShortcut`: the same class and amplitudes as integrating on, to 1e-6), and
    one seen to be a recurrent modulated motion ends as not steady before max_time
    (`sweeps.RecurrenceStop`: the same class as integrating on)."""
    import numpy as np

    from autocable.methods.integration.sweeps import PeriodOneShortcut, RecurrenceStop, sweep, to_rows
    ov = scene.overlay
    values = np.linspace(ov.range[0], ov.range[1], ov.points)
    if resolution == "coarse":
        values = values[::3]        # a subset of the same values, from the first
    fixed = {k: v for k, v in scene.fixed.items() if k != ov.parameter}
    if ov.method == "ode21":
        from autocable.methods.integration.ode21 import SCENE_ENGINE, Ode21Integrator
        integrator = Ode21Integrator(deriv.ode, engine=SCENE_ENGINE)
        shortcut = PeriodOneShortcut(integrator)
        recurrence = RecurrenceStop(integrator, shortcut)
    else:
        from autocable.methods.integration.ame import AmeIntegrator
        integrator = AmeIntegrator(ame)
        shortcut = recurrence = None
    say(f"overlay: {ov.method} swept in {ov.parameter} over [{ov.range[0]:g}, {ov.range[1]:g}], "
        f"{ov.points} points, {'/'.join(ov.directions)}")

    def tell(p):
        state = "periodic" if p.periodic else ("steady" if p.steady else p.message.split(":")[0])
        say(f"  {p.direction:>4} {ov.parameter} = {p.value:+.5f}: a1 = {p.a1:.4e}, a2 = {p.a2:.4e} ({state})")

    return to_rows(sweep(integrator, ov.parameter, values, fixed, directions=ov.directions,
                         progress=tell, max_time=ov.max_time, shortcut=shortcut,
                         recurrence=recurrence))


def _write_overlay(rows: list[dict], path: Path, columns=("parameter",)) -> None:
    import csv
    import io

    from autocable._store import atomic_write_text
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=list(rows[0]) if rows else list(columns))
    writer.writeheader()
    writer.writerows(rows)
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(path, buf.getvalue())


# ================================================================================================
# time evolutions (Fig. 11)
# ================================================================================================
#: Columns of ``time_series.csv`` (one row per sample; source "ame" or "ode21").





# ================================================================================================
# the summary `autocable run` prints
# ================================================================================================
#: The SI form of each parameter in a summary: (name, unit, conversion of the nondimensional value).
_SI_PARAMETER = {"sigma": ("Omega", "Hz"), "U": ("U", "m/s"), "eta": ("eta", "m")}


def _si_value(units, omega1: float, parameter: str, value: float) -> float:
    """``value`` of ``parameter`` in SI (eqs. 17-18): sigma as the deck frequency (omega1 + sigma)
    omega / 2 pi [Hz], U* U_c [m/s], eta* l [m]."""
    if parameter == "sigma":
        return units.frequency_hz(omega1 + value)
    return units.wind_m_s(value) if parameter == "U" else units.support_m(value)


def summary_lines(res, units: str = "paper") -> list[str]:
    """The branch table `autocable run` prints: per branch its kind, points and ends (an end at
    the point budget says ``max_points`` and where: the branch is cut short there), and per special
    point its parameter value(s), amplitudes, a Hopf point's criticality with its first Lyapunov
    coefficient l1, and whether PyCont agrees. ``units = "si"`` (a scene's ``[plot] units`` or
    ``--units si``) gives the values in SI when the run carries its cable's scales: the deck
    frequency in Hz for sigma, U in m/s, eta in m, the peak displacements a_k l in m."""
    from autocable.model.units import units_from_dict

    prov = res.provenance
    si = None
    if units == "si" and prov.get("si_scales") and prov.get("omega1") is not None:
        si = units_from_dict(dict(prov["si_scales"])), float(prov["omega1"])

    def value(parameter: str, v: float) -> str:
        if si and parameter in _SI_PARAMETER:
            name, unit = _SI_PARAMETER[parameter]
            return f"{name} = {_si_value(si[0], si[1], parameter, v):.8g} {unit}"
        return f"{parameter} = {v: .8g}"

    def amplitudes(a1: float, a2: float) -> str:
        if si:
            return f"a1 l = {si[0].peak_m(a1):.4e} m  a2 l = {si[0].peak_m(a2):.4e} m"
        return f"a1 = {a1:.6e}  a2 = {a2:.6e}"

    lines = []
    for b in res.branches:
        ends = "; ".join(f"{e.side}: {e.reason}"
                         + (f" at {value(b.parameter, e.value).strip()}" if e.truncated else "")
                         + (f" ({e.message})" if e.reason not in ("range",) and e.message else "")
                         for e in b.ends)
        lines.append(f"  {b.name:<12} {b.kind:<11} {len(b):>5} points   {ends}")
        for s in b.special_points:
            conf = {True: "PyCont agrees", False: "PyCont missed it", None: ""}[s.confirmed_by_pycont] \
                if s.origin == "autocable" else "PyCont only, not confirmed"
            hopf = f"  {s.hopf_text}" if s.hopf_text else (f"  l1 = {s.extra['l1']:.4g}" if "l1" in s.extra else "")
            second = f", {value(s.extra['parameter2'], s.extra['value2'])}" if "value2" in s.extra else ""
            lines.append(f"    {s.label:<5} {value(s.parameter, s.value)}{second}  {amplitudes(s.a1, s.a2)}"
                         f"{hopf}  {conf}".rstrip())
    if units == "si" and si is None and res.branches:
        lines.append("  (values nondimensional: this run carries no SI scales)")
    return lines
