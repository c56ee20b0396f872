"""A frequency response in one call: the amplitude of the AME's equilibria (period-1 motions of
eq. 21) against the detuning sigma at fixed wind U* and support motion eta*, with every special point
(LP: the jumps; H: where quasi-periodic motion is born; BP: where the bi-modal branches of Figs. 6-10
leave the mono-modal one) and the stability of every point, as the scenes of Figs. 5-10 compute it.

    import autocable as ac
    res = ac.frequency_response("models/luongo_zulli_2012.toml", U=0.0, eta=1.4e-3, sigma=(-0.05, 0.05))
    res.to_dataframe()                       # branches.csv as a DataFrame
    ac.plot_branches(res.branches, x="sigma", y=("a1", "a2"))
"""
from __future__ import annotations

import math
import os

from autocable.results import RunResults

__all__ = ["frequency_response"]


def frequency_response(source, *, U: float = 0.0, eta: float, sigma: tuple[float, float] = (-0.05, 0.05),
                       ame: str = "2dof", ordering: str = "paper", switch: bool = True, engine: str = "compiled",
                       settings=None, progress=None) -> RunResults:
    """The frequency response of the AME (24) of ``source`` at wind ``U`` (``U*``) and support
    amplitude ``eta`` (``eta*``), over ``sigma = (lo, hi)``: branch ``I`` from the small forced
    response at sigma = lo (the zero state refined by Newton), and with ``switch`` every branch
    through one of its branch points (``I-BP1``, ...). Each `Branch` has its special points and a
    ``stable`` column (autocable's own eigenvalues).

    ``source``: a `Derivation` (`derive`), its ``ode`` (eq. 21 as a `TwoModeODE`), a `ModelSpec` or
    the path of a model file. ``ame``:
    "2dof" or "1dof" (the A2 = 0 reduction of Sect. 5); ``ordering``: the Multiple Scales ordering
    ("paper" or "natural"); ``engine``: "compiled" (the C kernel, default) or "pycont";
    ``settings``: `ContinuationSettings` (default: steps of at most 1/5 of the sigma range).
    Returns a `RunResults` (``to_dataframe()``, `plot_branches`)."""
    from autocable.methods.continuation import (ContinuationSettings, EquilibriumProblem, ame_system,
                                                continue_equilibria, switch_branch)
    from autocable.model.ame_cache import derive_ame
    from autocable.model.derive import Derivation, derive

    lo, hi = (float(v) for v in sigma)
    if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
        raise ValueError(f"sigma: expected a range (lo, hi) with lo < hi, got {sigma!r}")
    for name, v in (("U", U), ("eta", eta)):
        if not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0):
            raise ValueError(f"{name}: expected a finite number >= 0, got {v!r}")
    from autocable.model.equations import TwoModeODE
    if isinstance(source, TwoModeODE):           # eq. (21) itself (``eq21.ode``)
        eq21, name, key = source, str(source.provenance.get("name", "eq. (21)")), source.content_hash()
    else:
        eq21 = source if isinstance(source, Derivation) else derive(
            os.fspath(source) if isinstance(source, (str, os.PathLike)) else source)
        name, key = eq21.spec.name, eq21.spec.content_hash()
    cached = derive_ame(eq21, ordering=ordering)
    system = ame_system(cached.ame, ame, wind=U != 0.0)
    values = {"U": float(U), "eta": float(eta), "sigma": lo}
    problem = EquilibriumProblem(system, "sigma", values, (lo, hi))
    settings = settings or ContinuationSettings(max_step=(hi - lo) / 5)
    main = continue_equilibria(problem, settings, name="I", engine=engine, progress=progress)
    results = [main]
    if switch:
        results += [switch_branch(main, p, settings, name=f"I-{p.label}", engine=engine, progress=progress)
                    for p in main.branch.special_points if p.type == "BP" and p.label != "BP0"]
    provenance = {"model": name, "model_hash": key, "ame": ame, "ordering": ordering,
                  "engine": engine, "fixed": {"U": float(U), "eta": float(eta)}, "range": [lo, hi],
                  "state_scale": problem.state_scale}
    return RunResults("frequency_response", tuple(r.branch for r in results), provenance)
