"""autocable: nonlinear dynamics of stay cables under wind and support motion (Luongo & Zulli).

The public API, for scripted runs in the spirit of AUTO-07p's and BifurcationKit's scripting. Every
name loads lazily (``import autocable`` costs nothing), so a script pays only for what it uses:

    import autocable as ac

    model = ac.load_model("models/luongo_zulli_2012.toml")      # the spec (SI units)
    eq21 = ac.derive(model)                                      # eq. (21): coefficients, modes
    ame = ac.derive_ame(eq21).ame                                # the AME (22)-(24)
    system = ac.ame_system(ame, "2dof", wind=False)              # Cartesian AME (24) at U = 0
    problem = ac.EquilibriumProblem(system, "sigma", {"U": 0.0, "eta": 1.4e-3, "sigma": -0.05},
                                    (-0.05, 0.05))                # state scale: the AME's own (default)
    I = ac.continue_equilibria(problem, ac.ContinuationSettings(), start="trivial")
    III = ac.switch_branch(I, "BP1")                             # at a labelled point of I
    cycles = ac.continue_cycles(I, "H1")                         # from a Hopf point of I
    folds = ac.continue_folds(I, "LP1", "eta", (0.0, 3e-3))      # a two-parameter curve
    pitchforks = ac.continue_branch_points(I, "BP1", "eta", (0.0, 2.5e-3))   # where Fig. 6's bi-modal branches are born
    fig = ac.plot_branches([I.branch, III.branch], "fig06", x="sigma", y=("a1", "a2"))  # a Figure
    I.branch.to_dataframe()                                      # branches.csv's rows (pandas)

    res = ac.frequency_response(eq21, U=0.0, eta=1.4e-3, sigma=(-0.05, 0.05))   # all of it in one call

Angles: the spec and the reports are in degrees (``eq21.theta0_deg``, ``eq21.beta_deg``); the
radians (``eq21.theta0``) are what the equations use. ``eq21.summary()`` prints the essentials.

Scenes (``runs/*.toml``) run the same chain from a file: ``ac.run_scene(ac.load_scene(path), out)``;
``ac.read_results(out)`` reads what a run wrote. Eq. (21) itself is integrated by
``ac.Ode21Integrator(eq21.ode)`` and the AME by ``ac.AmeIntegrator``; its steady responses are shot
for by ``ac.ShootingSolver(eq21.ode).steady(U, eta, sigma)`` and mapped over grids by
``ac.run_sweep(ac.load_sweep(path), out)``. `examples/` holds whole
scripts (each run by the tests).
"""
from __future__ import annotations

import importlib

from autocable._version import __version__  # noqa: F401  (in __all__)

#: public name -> the module that holds it (imported on first use)
_API = {
    # the model: spec -> eq. (21) -> AME (22)-(24)
    "load_model": "autocable.spec",
    "ModelSpec": "autocable.spec",
    "SpecError": "autocable.spec",
    "derive": "autocable.model.derive",
    "Derivation": "autocable.model.derive",
    "derive_ame": "autocable.model.ame_cache",
    # continuation (PyCont or the compiled kernel behind one front)
    "System": "autocable.methods.continuation",
    "ame_system": "autocable.methods.continuation",
    "auto_state_scale": "autocable.methods.continuation",
    "EquilibriumProblem": "autocable.methods.continuation",
    "ContinuationSettings": "autocable.methods.continuation",
    "ContinuationResult": "autocable.methods.continuation",
    "StartError": "autocable.methods.continuation",
    "ENGINES": "autocable.methods.continuation",
    "continue_equilibria": "autocable.methods.continuation",
    "switch_branch": "autocable.methods.continuation",
    "continue_cycles": "autocable.methods.continuation",
    "continue_cycles_from_orbit": "autocable.methods.continuation",
    "periodic_orbit": "autocable.methods.continuation",
    "continue_folds": "autocable.methods.continuation",
    "continue_hopf": "autocable.methods.continuation",
    "continue_branch_points": "autocable.methods.continuation",
    "equilibrium_near": "autocable.methods.continuation",
    "settle": "autocable.methods.continuation",
    # one call: branches, special points and stability of a frequency response
    "frequency_response": "autocable.methods.frequency_response",
    # time integration
    "Ode21Integrator": "autocable.methods.integration.ode21",
    "AmeIntegrator": "autocable.methods.integration.ame",
    "sweep": "autocable.methods.integration.sweeps",
    "ShootingSolver": "autocable.methods.integration.shooting",
    # sweeps as data (grids of steady responses, on Dask)
    "load_sweep": "autocable.scene.sweep_schema",
    "run_sweep": "autocable.studies.sweep",
    # results
    "Branch": "autocable.results",
    "SpecialPoint": "autocable.results",
    "EndPoint": "autocable.results",
    "RunResults": "autocable.results",
    "read_results": "autocable.results",
    "write_results": "autocable.results",
    # scenes
    "load_scene": "autocable.scene.schema",
    "branches_dataframe": "autocable.results",
    # plots (matplotlib loads only here)
    "plot_scene": "autocable.plotting.diagrams",
    "plot_plane": "autocable.plotting.diagrams",
    "plot_time_series": "autocable.plotting.diagrams",
    "plot_simulation": "autocable.plotting.diagrams",
    "plot_chart": "autocable.plotting.chart",
    "save_figure": "autocable.plotting.style",
    "si_scales": "autocable.plotting.units",
}

__all__ = sorted([*_API, "run_scene", "plot_branches", "__version__"])


def __getattr__(name: str):
    if name not in _API:
        raise AttributeError(f"module 'autocable' has no attribute {name!r}")
    from autocable.api_checks import guarded     # the arguments checked before each call
    value = guarded(name, getattr(importlib.import_module(_API[name]), name))
    globals()[name] = value     # later look-ups skip this hook
    return value


def __dir__():
    return sorted(set(globals()) | set(_API))


def run_scene(scene, out_dir, *, progress=None, plot: bool = True, resolution: str = "full",
              engine: str | None = None):
    """Run a scene (`autocable.scene.runner.run_scene`) as ``autocable run`` does: an ``ame =
    "auto"`` scene gets its AME from the probes of `autocable.studies.advise`; ``engine``
    ("pycont" | "compiled") overrides the scene's continuation engine. Returns the `RunResults`."""
    import os

    from autocable.model.premises import ArgumentError
    from autocable.scene.runner import run_scene as run
    from autocable.scene.schema import Scene, load_scene
    from autocable.studies.advise import choose_ame
    if isinstance(scene, (str, os.PathLike)):       # the path of a scene file: loaded as `load_scene` does
        scene = load_scene(scene)
    if not isinstance(scene, Scene):
        raise ArgumentError("run_scene", "scene", f"expected a scene (ac.load_scene(path)) or the path of a "
                                                  f"scene file, got {type(scene).__name__}")
    if not isinstance(out_dir, (str, os.PathLike)) or not str(out_dir).strip():
        raise ArgumentError("run_scene", "out_dir", f"expected the path of an output folder, got {out_dir!r}")
    return run(scene, out_dir, progress=progress, plot=plot, resolution=resolution, engine=engine,
               choose_ame=choose_ame)


def plot_branches(branches, stem=None, *, x: str, y=("a1",), title: str = "", labels: bool = True, units=None,
                  ax=None):
    """Draw ``branches`` (`Branch` objects, or `ContinuationResult` objects) paper-style, stable
    continuous and unstable dashed, special points (LP, H, BP, ...) marked, labelled and named in the
    legend; return the matplotlib Figure, and write ``stem.png`` and ``stem.pdf`` when ``stem`` is
    given (`autocable.plotting.diagrams.plot_scene`). ``branches`` may be a `RunResults` (e.g.
    `frequency_response`'s). ``y``: one column ("a1") or several; ``units``: "si" (the scales the
    branches carry), `si_scales` or "paper"; ``ax``: an Axes (one per amplitude of ``y``) to draw
    into. A bad argument is an `ArgumentError` naming it."""
    from autocable.model.premises import ArgumentError
    from autocable.plotting.diagrams import check_plot_arguments, plot_scene
    from autocable.results import RunResults
    from autocable.results import Branch
    provenance = getattr(branches, "provenance", {})     # a RunResults: its branches and SI scales
    branches = getattr(branches, "branches", branches)
    if isinstance(branches, (str, bytes)) or not hasattr(branches, "__iter__"):
        raise ArgumentError("plot_branches", "branches", f"expected a sequence of Branch (or ContinuationResult) "
                                                         f"objects, got {type(branches).__name__}")
    plain = tuple(getattr(b, "branch", b) for b in branches)
    for k, b in enumerate(plain):
        if not isinstance(b, Branch):
            raise ArgumentError("plot_branches", f"branches[{k}]", f"expected a Branch (or ContinuationResult), "
                                                                   f"got {type(b).__name__}")
    results = RunResults("plot", plain, dict(provenance))
    y, units = check_plot_arguments("plot_branches", results, x, y, units, ax)
    return plot_scene(results, stem, x=x, y=y, title=title, labels=labels, units=units, ax=ax)
