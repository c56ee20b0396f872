"""The amplitude modulation equations (22)-(24) of a `Derivation`, cached as JSON.

`derive_ame(derivation)` runs the Multiple Scales engine (`autocable.model.multiscale`, Sect. 4) on
eq. (21) of the derivation and stores the result (`AmplitudeEquations.to_dict`, plain JSON) in the
autocable cache folder under a key made of the ODE's `content_hash()`, the engine options,
`AME_VERSION` and the sha256 of the files of ``autocable/model`` (`autocable._store.code_fingerprint`:
a change of the engine is seen without a version bump; an AME derived while that code changed is
not stored). The file carries the sha256 of its content, checked on load. So a changed eq. (21), a
changed ordering rule or a changed engine never reuses a stale
table. A cached AME loads without sympy work.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

from autocable._store import (cache_dir, code_fingerprint, content_hash, load_checked_json,
                              store_checked_json_for_code)
from autocable.model.ame import AmplitudeEquations
from autocable.model.equations import TwoModeODE
from autocable.spec import SpecError

#: Bump when the Multiple Scales engine or its default ordering changes the AME of a given eq. (21).
AME_VERSION = "ame-v1"


@dataclass(frozen=True)
class CachedAME:
    """An AME (eqs. 22-24) and where it came from."""

    ame: AmplitudeEquations
    from_cache: bool
    seconds: float                       # derivation (cold) or cache read (cached), wall clock
    key: str
    timings: dict = field(default_factory=dict, compare=False)


def ame_key(ode: TwoModeODE, omega: str = "exact", ordering: str = "paper", code: str | None = None) -> str:
    """The cache key of the AME of ``ode``: its content hash, the Omega treatment, the named
    ordering, `AME_VERSION` and the fingerprint of the code that derives it (``code``, default
    the files now: `autocable._store.code_fingerprint`)."""
    return content_hash({"ode": ode.content_hash(), "omega": omega, "ordering": ordering,
                         "version": AME_VERSION, "code": code or code_fingerprint("ame")})


def derive_ame(source, *, omega: str = "exact", ordering: str = "paper", use_cache: bool = True) -> CachedAME:
    """The AME of eq. (21) for ``source`` (a `Derivation` or a `TwoModeODE`) with the named Multiple
    Scales ordering (`multiscale.ORDERINGS`: "paper", rules R1-R3 of Sect. 4, or "natural").

    Cached in ``cache_dir("ame")``; ``use_cache=False`` derives afresh (and refreshes the cache)."""
    from autocable.model.multiscale import ORDERINGS
    if ordering not in ORDERINGS:
        raise ValueError(f"ordering must be one of {ORDERINGS}, got {ordering!r}")
    ode = source if isinstance(source, TwoModeODE) else source.ode
    pair = ode.provenance.get("mode_pair", 1)
    if pair != 1:
        # Sect. 4's scenes, premises and figures are those of the first pair (docs/mode-pairs.md)
        where = getattr(getattr(source, "spec", None), "path", "") or ode.provenance.get("model", "<model>")
        raise SpecError(where, "cable.mode_pair", f"the amplitude equations (22)-(24) are derived for the first "
                                                  f"mode pair only, got pair {pair}; integrate eq. (21) instead "
                                                  "(simulate --method ode21 or shooting, onset) or set mode_pair = 1")
    if ode.exact_load is not None:
        # the Multiple Scales reduction expands the cubic load of eq. (21); it would silently drop
        # the exact load the model file asks for
        where = getattr(getattr(source, "spec", None), "path", "") or ode.provenance.get("model", "<model>")
        raise SpecError(where, "aero.load", 'the amplitude equations (22)-(24) carry eq. (21)\'s cubic load, not the '
                                            'exact one; set load = "cubic" for AME scenes, or integrate eq. (21) '
                                            '(simulate --method ode21 or shooting, gallop)')
    code = code_fingerprint("ame")
    key = ame_key(ode, omega, ordering, code)
    path = cache_dir("ame") / f"ame-{key}.json"
    t0 = time.perf_counter()
    data = load_checked_json(path, f"amplitude equations {path.name}") if use_cache else None
    if data is not None:
        try:
            ame = AmplitudeEquations.from_dict(data)
        except (KeyError, TypeError, ValueError):
            # A corrupt or foreign file under our key: derive again rather than fail.
            data = None
        else:
            return CachedAME(ame, True, time.perf_counter() - t0, key,
                             {"cache_read_s": time.perf_counter() - t0})
    from autocable.model import multiscale
    ame = multiscale.derive(ode, ordering, omega=omega)
    seconds = time.perf_counter() - t0
    store_checked_json_for_code("ame", code, path, ame.to_dict(), f"amplitude equations {path.name}")
    return CachedAME(ame, False, seconds, key, {"multiscale_s": seconds})
