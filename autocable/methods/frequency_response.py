"""A frequency response in one call: the amplitude of the AME's equilibria (period-1 motions of
eq. 21) against the detuning sigma at fixed wind U* and support motion eta*, with every special point
(LP: the jumps; H: where quasi-periodic motion is born; BP: where the bi-modal branches of Figs. 6-10
leave the mono-modal one) and the stability of every point, as the scenes of Figs. 5-10 compute it.

    import autocable as ac
    res = ac.frequency_response("models/luongo_zulli_2012.toml", U=0.0, eta=1.4e-3, sigma=(-0.05, 0.05))
    res.to_dataframe()                       # branches.csv as a DataFrame
    ac.plot_branches(res.branches, x="sigma", y=("a1", "a2"))

The same in SI (eqs. 17-18: U* = U/U_c, eta* = eta/l, sigma = 2 pi f/omega - omega1):

    res = ac.frequency_response(eq21, wind_m_s=8, deck_amplitude_m=0.02, deck_frequency_Hz=(0.75, 0.80))
"""
from __future__ import annotations

import os
import warnings
from dataclasses import replace

from autocable.model.premises import (NOT_GIVEN, SI_PARAMETERS, ArgumentError, check_call, check_choice,
                                      check_interval, check_type, choose_parameter, parameter_from_si)
from autocable.results import RunResults, TruncatedBranchWarning, truncation_notes
from autocable.spec import show

__all__ = ["frequency_response", "ROMAN", "COVER_TRIES", "COVER_FACTOR"]

#: Branch names in the paper's manner (Figs. 5-10 number their branches I, II, III, ...).
ROMAN = ("I", "II", "III", "IV", "V", "VI", "VII", "VIII", "IX", "X", "XI", "XII")
#: A branch that stops at its point budget before the end of the range is continued again with
#: ``max_points`` times `COVER_FACTOR`, at most `COVER_TRIES` times (2000 -> 8000 -> 32000 points
#: per direction by default: the compiled kernel spends microseconds a point).
COVER_TRIES, COVER_FACTOR = 2, 4


def _name(k: int) -> str:
    return ROMAN[k] if k < len(ROMAN) else f"B{k + 1}"


def _covering(run, settings):
    """``run(settings)`` (a `ContinuationResult`), again with a larger point budget while its branch
    stops at ``max_points`` (`COVER_TRIES` times, x `COVER_FACTOR`); the warnings of a superseded
    try are dropped, a branch still cut short after the last says so with the budget it had."""
    for attempt in range(COVER_TRIES + 1):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            result = run(settings)
        if not result.branch.truncated or attempt == COVER_TRIES:
            break
        settings = replace(settings, max_points=settings.max_points * COVER_FACTOR)
    for w in caught:
        if issubclass(w.category, TruncatedBranchWarning):
            continue
        warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    for note in truncation_notes([result.branch]):
        warnings.warn(f"{note} (frequency_response already raised max_points {COVER_TRIES} times, to "
                      f"{settings.max_points}; give settings=ContinuationSettings(max_points=...) or a "
                      f"larger max_step)" if attempt else note, TruncatedBranchWarning, stacklevel=3)
    return result


def frequency_response(source, *, U=NOT_GIVEN, eta=NOT_GIVEN, sigma=NOT_GIVEN, wind_m_s=NOT_GIVEN,
                       deck_amplitude_m=NOT_GIVEN, deck_frequency_Hz=NOT_GIVEN, ame: str = "2dof",
                       ordering: str = "paper", switch: bool = True, engine: str = "compiled",
                       settings=None, progress=None) -> RunResults:
    """The frequency response of the AME (24) of ``source`` at wind ``U`` (``U*``, default 0) and
    support amplitude ``eta`` (``eta*``), over ``sigma = (lo, hi)`` (default (-0.05, 0.05)): branch
    ``I`` from the small forced
    response at sigma = lo (the zero state refined by Newton), and with ``switch`` every branch
    through one of its branch points, named ``II``, ``III``, ... in the order of I's branch points
    (as the paper's figures number theirs; ``info["origin"]`` says where each was born, e.g.
    ``"I:BP1"``). Each `Branch` has its special points and a ``stable`` column (autocable's own
    eigenvalues).

    Nothing is cut silently: a branch that stops at its point budget (``max_points``) before the
    end of the range is continued again with 4 times the budget, twice at most; one still cut short
    warns (`TruncatedBranchWarning`), names the end in its ``ends`` and in
    ``to_dataframe().attrs["truncated"]``, and is marked on the plot.

    ``source``: a `Derivation` (`derive`), its ``ode`` (eq. 21 as a `TwoModeODE`), a `ModelSpec` or
    the path of a model file. ``ame``:
    "2dof" or "1dof" (the A2 = 0 reduction of Sect. 5); ``ordering``: the Multiple Scales ordering
    ("paper" or "natural"); ``engine``: "compiled" (the C kernel, default) or "pycont";
    ``settings``: `ContinuationSettings` (default: steps of at most 1/5 of the sigma range).

    In SI instead (eqs. 17-18, `autocable.model.units`; one kind per quantity, both refused by
    name): ``wind_m_s`` (U [m/s], U* = U/U_c), ``deck_amplitude_m`` (the support motion's amplitude
    [m], eta* = eta/l) and ``deck_frequency_Hz`` = (lo, hi) (the support motion's frequency [Hz],
    sigma = 2 pi f/omega - omega1: its detuning from the first in-plane frequency, the external
    resonance of eq. 21). They need the cable: ``source`` a `Derivation`, a `ModelSpec` or a model
    file, not eq. (21)'s ``ode`` alone. Every argument is checked before any work
    (`autocable.model.premises.ArgumentError` naming it, with the value as given; the ranges of
    `autocable.model.premises.PARAMETER_RANGES`).
    Returns a `RunResults` (``to_dataframe()``, `plot_branches`)."""
    from autocable.methods.continuation import (ContinuationSettings, EquilibriumProblem, ame_system,
                                                continue_equilibria, switch_branch)
    from autocable.model.ame_cache import derive_ame
    from autocable.model.derive import Derivation, derive

    from autocable.model.equations import TwoModeODE
    kinds = _check_arguments(source, U=U, eta=eta, sigma=sigma, wind_m_s=wind_m_s,
                             deck_amplitude_m=deck_amplitude_m, deck_frequency_Hz=deck_frequency_Hz, ame=ame,
                             ordering=ordering, switch=switch, engine=engine, settings=settings, progress=progress)
    if isinstance(source, TwoModeODE):           # eq. (21) itself (``eq21.ode``)
        eq21, name, key = source, str(source.provenance.get("name", "eq. (21)")), source.content_hash()
    else:
        eq21 = source if isinstance(source, Derivation) else derive(
            os.fspath(source) if isinstance(source, (str, os.PathLike)) else source)
        name, key = eq21.spec.name, eq21.spec.content_hash()
    U, eta, (lo, hi) = _parameters(kinds, eq21)
    cached = derive_ame(eq21, ordering=ordering)
    system = ame_system(cached.ame, ame, wind=U != 0.0)
    values = {"U": float(U), "eta": float(eta), "sigma": lo}
    problem = EquilibriumProblem(system, "sigma", values, (lo, hi))
    # steps of at most a fifth of the range (a narrow range, e.g. 0.770-0.775 Hz, too: the first step
    # no longer than the largest)
    settings = settings or ContinuationSettings(max_step=(hi - lo) / 5,
                                                step=min(ContinuationSettings.step, (hi - lo) / 5))
    main = _covering(lambda s: continue_equilibria(problem, s, name="I", engine=engine, progress=progress),
                     settings)
    branches = [main.branch]
    if switch:
        for p in (p for p in main.branch.special_points if p.type == "BP" and p.label != "BP0"):
            res = _covering(lambda s, p=p: switch_branch(main, p, s, name=_name(len(branches)), engine=engine,
                                                         progress=progress), settings)
            branches.append(res.branch.replace(info={**res.branch.info, "origin": f"I:{p.label}"}))
    si = _si_info(eq21)
    if si:      # SI columns in to_dataframe() and plot_branches(..., units="si") from the branches alone
        branches = [b.replace(info={**b.info, **si}) for b in branches]
    provenance = {"model": name, "model_hash": key, "ame": ame, "ordering": ordering,
                  "engine": engine, "fixed": {"U": float(U), "eta": float(eta)}, "range": [lo, hi],
                  "state_scale": problem.state_scale, **si}
    return RunResults("frequency_response", tuple(branches), provenance)


def _si_info(eq21) -> dict:
    """The cable's SI scales and omega1 (`autocable.model.units`) of a `Derivation`; {} for eq. (21)
    given alone (a `TwoModeODE` carries no cable)."""
    from dataclasses import asdict

    from autocable.model.units import units_of
    spec, statics, ode = (getattr(eq21, k, None) for k in ("spec", "statics", "ode"))
    if spec is None or statics is None or ode is None:
        return {}
    return {"si_scales": asdict(units_of(spec, statics)), "omega1": float(ode.omega1)}


def _check_arguments(source, *, U, eta, sigma, wind_m_s, deck_amplitude_m, deck_frequency_Hz, ame, ordering,
                     switch, engine, settings, progress) -> dict:
    """Every argument of `frequency_response` before any work (`ArgumentError` naming it): parameter
    -> ("star" | "si", value) or None (not given; U = 0, sigma = (-0.05, 0.05))."""
    import os

    from autocable.methods.continuation.settings import ENGINES, ContinuationSettings
    from autocable.model.derive import Derivation
    from autocable.model.equations import TwoModeODE
    from autocable.model.orderings import ORDERINGS
    from autocable.spec import ModelSpec
    f = "frequency_response"
    check_type(f, "source", source, (Derivation, TwoModeODE, ModelSpec, str, os.PathLike),
               "a Derivation (ac.derive(...)), its .ode, a ModelSpec or the path of a model file")
    check_choice(f, "ame", ame, ("2dof", "1dof"))
    check_choice(f, "ordering", ordering, ORDERINGS)
    check_choice(f, "engine", engine, ENGINES)
    check_type(f, "switch", switch, bool, "True or False")
    if settings is not None:
        check_type(f, "settings", settings, ContinuationSettings,
                   "a ContinuationSettings (ac.ContinuationSettings(...)) or None")
    if progress is not None and not callable(progress):
        raise ArgumentError(f, "progress", f"expected a callable (or None), got {show(progress)}")
    kinds = {name: choose_parameter(f, name, star, si) for name, star, si in
             (("U", U, wind_m_s), ("eta", eta, deck_amplitude_m), ("sigma", sigma, deck_frequency_Hz))}
    if kinds["eta"] is None:
        raise ArgumentError(f, "eta", "missing: give eta (eta* = eta/l) or deck_amplitude_m (in m)")
    for name, kind in kinds.items():
        if kind is None:
            continue
        if kind[0] == "si":
            if isinstance(source, TwoModeODE):
                raise ArgumentError(f, SI_PARAMETERS[name][0], "SI values need the cable (its length, U_c and "
                                    "omega): pass the Derivation (ac.derive(...)) rather than its .ode")
            keyword, _, what = SI_PARAMETERS[name]
            if name == "sigma":
                check_interval(f, keyword, kind[1], 0.0, what=what)
        elif name != "sigma":
            check_call(f, **{name: kind[1]})
        else:
            for k, v in enumerate(check_interval(f, "sigma", kind[1], what="the detuning sigma = Omega - omega1")):
                try:
                    check_call(f, sigma=v)
                except ArgumentError as exc:
                    raise ArgumentError(f, f"sigma[{k}]", str(exc).split(": sigma: ", 1)[-1]) from None
    return kinds


def _parameters(kinds: dict, eq21) -> tuple:
    """(U*, eta*, (sigma_lo, sigma_hi)) of `_check_arguments`' ``kinds``: the SI ones converted on
    the cable of the `Derivation` ``eq21`` (`autocable.model.units`, eqs. 17-18) and refused by
    their keyword outside `autocable.model.premises.PARAMETER_RANGES`."""
    f, values = "frequency_response", {"U": 0.0, "sigma": (-0.05, 0.05)}
    units = None
    for name, kind in kinds.items():
        if kind is None:
            continue
        if kind[0] == "star":
            values[name] = tuple(float(v) for v in kind[1]) if name == "sigma" else float(kind[1])
            continue
        if units is None:
            from autocable.model.units import units_of
            units = units_of(eq21.spec, eq21.statics)
        keyword = SI_PARAMETERS[name][0]
        if name == "sigma":
            values[name] = tuple(parameter_from_si(f, "sigma", v, units, eq21.ode.omega1, f"{keyword}[{k}]")
                                 for k, v in enumerate(kind[1]))
        else:
            values[name] = parameter_from_si(f, name, kind[1], units, eq21.ode.omega1)
    return values["U"], values["eta"], values["sigma"]
