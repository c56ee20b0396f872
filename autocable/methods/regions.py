"""Regions of a stability chart: what the AME (24) settles on over a grid of a parameter plane
(`classify_grid`), and the connected regions of equal response with a label at each one's centre
(`label_regions`).

Classification (`classify_point`). At each grid point the Cartesian AME is integrated (autocable's
compiled DOP853, `autocable.codegen.cintegrate`) from a few starts (rest with a small out-of-plane
seed, and larger amplitudes) over ``t_end`` time units (t*, as eq. (21)); the second half of each
run decides what it reached:

* ``diverged``: the integration stopped on the amplitude bound (or a non-finite state, a step
  collapse): no bounded response (the AME's blow-up above the island of Fig. 4);
* an equilibrium (the state moves by less than ``steady_tol`` of its size over the last window):
  ``bi-modal`` if a2 > ``bimodal_ratio`` a1 (both modes, Figs. 6, 9), otherwise ``small`` if a1 is
  within ``small_factor`` of the linear forced response a_lin = |J(0)^-1 f(0)| (the small forced
  response of branch I, and rest when eta = 0; amplitudes below ``floor`` are rest) and
  ``mono-modal`` beyond it (the resonant,
  hardened branch: Figs. 5-6 above their folds);
* a bounded motion that does not settle (a stable cycle of the AME: the cable's motion
  quasi-periodic): ``galloping`` when a1 stays within ``steady_ratio`` of its mean (a
  self-excited oscillation at its own frequency, unlocked from the support: the Cartesian
  amplitudes rotate, the amplitude does not), ``modulated`` when it oscillates (Figs. 4, 8, 11).

A point's class is the set of the attractors its starts reach, e.g. ``small`` or
``mono-modal + small`` (coexistence, between folds). Everything is computed; nothing is placed by
hand. ``label_regions`` finds the 4-connected components of equal class on the grid and puts each
label at the component's centroid (or, when that cell is not in the component, at its cell
nearest the centroid)."""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, Mapping, Sequence

import numpy as np

__all__ = ["ATTRACTORS", "ClassifySettings", "classify_point", "classify_grid", "label_regions", "Region"]

#: The kinds of attractor a start can reach, in drawing order.
ATTRACTORS = ("small", "mono-modal", "bi-modal", "galloping", "modulated", "diverged")


@dataclass(frozen=True)
class ClassifySettings:
    """How each grid point is classified (module docstring)."""

    t_end: float = 30000.0                 # t* units per start
    samples: int = 600                     # samples over [0, t_end]
    starts: tuple = ((0.0, 1e-6), (5e-3, 1e-6))   # (a1, a2): r_k = a_k, s_k = 0
    bound: float = 0.05                    # |r_k|, |s_k| beyond it: diverged
    steady_tol: float = 1e-4               # equilibrium: max |x - x_end| / max(|x_end|, 1e-9) over the window
    bimodal_ratio: float = 1e-2            # a2 / a1 above it: bi-modal
    small_factor: float = 1.5              # a1 <= small_factor a_lin: the small forced response
    steady_ratio: float = 0.05             # cycles: (max - min) / (max + min) of a1 below it: galloping
    rtol: float = 1e-8
    floor: float = 1e-7                    # amplitudes below it count as rest (the AME's are 1e-4..1e-2)
    extensions: int = 2                    # a run not settled at t_end is continued up to this many times


def _linear_response(system, p) -> float:
    """a1 of the linear forced response: one Newton step from rest, x = -J(0)^-1 f(0)."""
    n = system.dimension
    x0 = np.zeros(n)
    f0 = system.f(x0, p)
    if not np.any(f0):
        return 0.0
    try:
        x = -np.linalg.solve(system.jac(x0, p), f0)
    except np.linalg.LinAlgError:
        return math.inf
    return float(system.amplitude_values(x)[0])


def classify_point(system, values: Mapping[str, float], settings: ClassifySettings = ClassifySettings(),
                   integrator=None) -> tuple[str, list[dict]]:
    """The class of the AME ``system`` at ``values`` (module docstring): ("kind1 + kind2", one dict
    per start with kind, a1, a2, and the a1 range over the window)."""
    from autocable.codegen.cintegrate import compiled_integrator, sample_grid

    ci = integrator or compiled_integrator(f"{system.name}_flow", system.variables, system.parameter_names,
                                           system.rhs, None)
    p = system.parameter_vector(values)
    a_lin = _linear_response(system, p)
    grid = sample_grid(0.0, settings.t_end, settings.t_end / settings.samples)
    half = len(grid) // 2
    n_modes = len(system.amplitudes)
    rows = []
    for start in settings.starts:
        y0 = np.zeros(system.dimension)
        for k, a in enumerate(start[:n_modes]):
            pair = system.amplitudes[k][1]
            if pair:
                y0[system.variables.index(pair[0])] = a
        # A run that has not settled by t_end is continued (up to ``extensions`` times) before it
        # is called a cycle: near a bifurcation the transients are slow.
        for _ in range(settings.extensions + 1):
            r = ci.run(y0, grid, p, rtol=settings.rtol, atol=settings.rtol * settings.floor,
                       bound=settings.bound, n_bound=system.dimension)
            if not r.ok:
                break
            Y = r.y[half:]
            size = max(float(np.max(np.abs(Y[-1]))), settings.floor)
            moving = float(np.max(np.abs(Y - Y[-1]))) / size
            if moving <= settings.steady_tol:
                break
            y0 = r.y[-1]
        if not r.ok:
            rows.append({"start": list(start), "kind": "diverged", "a1": math.nan, "a2": math.nan,
                         "a1_min": math.nan, "a1_max": math.nan, "status": r.status})
            continue
        amps = system.amplitude_values(Y)
        a1 = np.asarray(amps[0], float) * np.ones(len(Y))
        a2 = np.asarray(amps[1], float) * np.ones(len(Y)) if len(amps) > 1 else np.zeros(len(Y))
        if moving <= settings.steady_tol:
            if max(a1[-1], a2[-1]) <= settings.floor:
                kind = "small"                 # rest (eta = 0), or as good as rest
            elif a2[-1] > settings.bimodal_ratio * a1[-1]:
                kind = "bi-modal"
            elif a1[-1] <= settings.small_factor * a_lin + 1e-12:
                kind = "small"
            else:
                kind = "mono-modal"
        else:
            depth = (a1.max() - a1.min()) / max(a1.max() + a1.min(), 1e-300)
            kind = "galloping" if depth <= settings.steady_ratio else "modulated"
        rows.append({"start": list(start), "kind": kind, "a1": float(a1[-1]), "a2": float(a2[-1]),
                     "a1_min": float(a1.min()), "a1_max": float(a1.max()), "status": r.status})
    kinds = sorted({row["kind"] for row in rows}, key=ATTRACTORS.index)
    return " + ".join(kinds), rows


def classify_grid(system, fixed: Mapping[str, float], x: str, xs: Sequence[float], y: str, ys: Sequence[float],
                  settings: ClassifySettings = ClassifySettings(),
                  progress: Callable[[str], None] | None = None) -> list[dict]:
    """`classify_point` at every (x, y) of the grid xs x ys (the other parameters at ``fixed``):
    one row per point with x, y, the class, and a1/a2 of each start (``a1_<k>``, ``a2_<k>``,
    ``kind_<k>``)."""
    from autocable.codegen.cintegrate import compiled_integrator

    ci = compiled_integrator(f"{system.name}_flow", system.variables, system.parameter_names, system.rhs, None)
    out = []
    total = len(xs) * len(ys)
    for j, yv in enumerate(ys):
        for i, xv in enumerate(xs):
            values = {**fixed, x: float(xv), y: float(yv)}
            cls, rows = classify_point(system, values, settings, ci)
            row = {x: float(xv), y: float(yv), "class": cls, "i": i, "j": j}
            for k, r in enumerate(rows):
                row[f"kind_{k}"], row[f"a1_{k}"], row[f"a2_{k}"] = r["kind"], r["a1"], r["a2"]
            out.append(row)
        if progress:
            progress(f"  regions: {len(out)} of {total} grid points classified")
    return out


@dataclass(frozen=True)
class Region:
    """One connected region of equal class: its label position (x, y) and size in grid cells."""

    label: str
    x: float
    y: float
    cells: int
    members: tuple = field(default=(), repr=False)     # (i, j) of its cells


def label_regions(classes: np.ndarray, xs: Sequence[float], ys: Sequence[float]) -> list[Region]:
    """The 4-connected regions of equal value of ``classes`` (shape (len(ys), len(xs)), strings),
    each labelled at its centroid in (x, y) (at its own cell nearest the centroid when the centroid
    falls outside it, e.g. for an L-shaped region). Sorted by size, largest first."""
    from scipy import ndimage

    classes = np.asarray(classes, dtype=object)
    xs, ys = np.asarray(xs, float), np.asarray(ys, float)
    if classes.shape != (len(ys), len(xs)):
        raise ValueError(f"classes has shape {classes.shape}, expected (len(ys), len(xs)) = {(len(ys), len(xs))}")
    # Centroids in grid units, mapped to the axes by interpolation (the grid may be uneven).
    out = []
    for value in sorted(set(classes.ravel().tolist())):
        lab, n = ndimage.label(classes == value)
        for k in range(1, n + 1):
            jj, ii = np.nonzero(lab == k)
            cj, ci = float(jj.mean()), float(ii.mean())
            rj, ri = int(round(cj)), int(round(ci))
            if lab[rj, ri] != k:
                m = int(np.argmin((jj - cj) ** 2 + (ii - ci) ** 2))
                cj, ci = float(jj[m]), float(ii[m])
            out.append(Region(str(value), float(np.interp(ci, np.arange(len(xs)), xs)),
                              float(np.interp(cj, np.arange(len(ys)), ys)), int(len(ii)),
                              tuple(zip(ii.tolist(), jj.tolist()))))
    return sorted(out, key=lambda r: (-r.cells, r.label, r.x, r.y))
