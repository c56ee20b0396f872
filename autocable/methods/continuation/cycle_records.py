"""The record of a branch of cycles (Branch columns, stability, LPC/PD/NS from the multipliers of
`events`), shared by PyCont's LC-C front (`cycles`) and the compiled collocation (`compiled_cycles`)."""
from __future__ import annotations

import math
import time

import numpy as np

from autocable.methods.continuation.chart import _build_branch, _Chart
from autocable.methods.continuation.problem import ContinuationResult, ContinuationSettings
from autocable.methods.continuation.system import System
from autocable.methods.continuation.events import _crossing_distance, _cycle_counts, _genuine_crossing
from autocable.results import EndPoint, SpecialPoint, stability_measure


def _sampled_extremes(sysm: System, samples) -> tuple[tuple[float, float], tuple[float, float]]:
    """((a1_min, a2_min), (a1_max, a2_max)) over the sampled states of a cycle (NaN for a missing a2)."""
    amps = sysm.amplitude_values(samples)
    lo, hi = [math.nan, math.nan], [math.nan, math.nan]
    for k, a in enumerate(amps[:2]):
        a = np.asarray(a) * np.ones(len(samples))
        lo[k], hi[k] = float(np.min(a)), float(np.max(a))
    return (lo[0], lo[1]), (hi[0], hi[1])


def cycle_result(name: str, problem, settings: ContinuationSettings, chart: _Chart, X, P, periods, mults,
                 amin, amax, auto_labels, side: EndPoint | tuple[EndPoint, ...], info: dict, timings: dict,
                 t_analysis: float | None = None, first_is_hopf: bool = True) -> ContinuationResult:
    """The cycle branch record from per-cycle data (both engines): x(0), the parameter vector, the
    period, the Floquet multipliers and the amplitude extremes of every cycle (the first one is the
    Hopf point, a degenerate cycle); stability (every non-trivial multiplier inside the unit circle)
    and LPC/PD/NS from multiplier crossings, located by linear interpolation between two cycles.

    ``auto_labels``: AUTO's (type, index) list to compare with (PyCont engine), or None (compiled
    engine: ``confirmed_by_pycont`` stays None). ``timings["analysis_s"]`` is measured from
    ``t_analysis`` when given. ``side``: the branch's end, or its ends (a branch continued both ways
    from a given orbit, ``first_is_hopf=False``)."""
    sysm = chart.system
    n = sysm.dimension
    cols = {c: [] for c in ("period", "a1_min", "a1_max", "a2_min", "a2_max")}
    stable = []
    mults = [np.asarray(m_, complex) for m_ in mults]
    for T, lo_, hi_, mu in zip(periods, amin, amax, mults):
        for k in (0, 1):
            cols[f"a{k + 1}_min"].append(float(lo_[k]))
            cols[f"a{k + 1}_max"].append(float(hi_[k]))
        cols["period"].append(float(T))
        m = stability_measure("cycle", mu)
        stable.append(bool(math.isfinite(m) and m < 1.0))
    auto_list = list(auto_labels or ())
    # Bifurcations of cycles from multiplier crossings, compared with AUTO's labels.
    specials = []
    counts = [_cycle_counts(m) for m in mults]
    counters: dict[str, int] = {}
    used = set()
    for i in range(len(X) - 1):
        c0, c1 = counts[i], counts[i + 1]
        if -1 in c0 or -1 in c1 or (i == 0 and first_is_hopf):
            continue  # the first point is the Hopf point itself (a degenerate cycle)
        for slot, kind in enumerate(("LPC", "PD", "NS")):
            if c0[slot] == c1[slot] or not _genuine_crossing(kind, mults[i], mults[i + 1]):
                continue
            match = next((m for m, (t, j) in enumerate(auto_list)
                          if m not in used and t == kind and abs(j - (i + 0.5)) <= 2), None)
            if match is not None:
                used.add(match)
            counters[kind] = counters.get(kind, 0) + 1
            # Linear interpolation in the distance of the crossing multiplier to the unit circle.
            d0, d1 = _crossing_distance(mults[i], kind), _crossing_distance(mults[i + 1], kind)
            s = d0 / (d0 - d1) if d0 != d1 else 0.5
            s = min(max(s, 0.0), 1.0)
            x = (1 - s) * X[i] + s * X[i + 1]
            p = (1 - s) * P[i] + s * P[i + 1]
            amps = [(1 - s) * cols[f"a{k}_max"][i] + s * cols[f"a{k}_max"][i + 1] for k in (1, 2)]
            if auto_labels is None:
                confirmed, note = None, ""
            else:
                confirmed = match is not None
                note = "" if match is not None else "; not in AUTO's list (AUTO missed it)"
            specials.append(SpecialPoint(
                branch=name, type=kind, label=f"{kind}{counters[kind]}", parameter=problem.parameter,
                value=float(p[chart.k]), a1=amps[0], a2=amps[1], state=tuple(x),
                parameters=sysm.parameter_dict(p), index=i, converged=False,
                confirmed_by_pycont=confirmed, origin="autocable",
                message="located by linear interpolation of the crossing multiplier between two cycles" + note,
                extra={"period": (1 - s) * cols["period"][i] + s * cols["period"][i + 1],
                       "multipliers": [complex(z) for z in mults[i + 1]]}))
    for m, (t, j) in enumerate(auto_list):
        if m in used or j >= len(X):
            continue
        counters[t] = counters.get(t, 0) + 1
        specials.append(SpecialPoint(
            branch=name, type=t, label=f"{t}{counters[t]}", parameter=problem.parameter,
            value=float(P[j][chart.k]), a1=cols["a1_max"][j], a2=cols["a2_max"][j], state=tuple(X[j]),
            parameters=sysm.parameter_dict(P[j]), index=j, converged=False, confirmed_by_pycont=True,
            origin="pycont", message=f"AUTO reports {t} here; autocable's multipliers show no crossing"))
    specials.sort(key=lambda s_: s_.index)
    X = np.array(X, float).reshape(len(X), n)
    P = np.array(P, float).reshape(len(X), len(sysm.parameters))
    ev = np.array(mults, dtype=complex).reshape(len(X), n) if mults else np.zeros((0, n), complex)
    branch = _build_branch(name, "cycle", chart, X, P, np.array(stable, bool), ev, tuple(specials),
                           side if isinstance(side, tuple) else (side,),
                           info, extra_columns=cols)
    # For cycles the a1, a2 columns hold the maxima over the cycle (the plotted upper envelope).
    table = dict(branch.table)
    for k in (1, 2):
        if f"a{k}" in table:
            table[f"a{k}"] = np.asarray(cols[f"a{k}_max"], float)
    branch = branch.replace(table=table)
    timings = dict(timings)
    if t_analysis is not None:
        timings["analysis_s"] = time.perf_counter() - t_analysis
    return ContinuationResult(branch, problem, settings, timings)

