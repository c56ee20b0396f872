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
  ``bi-modal`` if its a2 is not slaved to a1 (`a2_slaved`: the out-of-plane motion is a solution of
  its own, as on the branches born at the pitchforks of a mono-modal branch, Figs. 6, 9, not the
  response of the a2 equation forced by a1 through the wind's cross terms), otherwise ``small`` if
  a1 is within ``small_factor`` of the linear forced response a_lin = |J(0)^-1 f(0)| (the small
  forced response of branch I, and rest when eta = 0; amplitudes below ``floor`` are rest) and
  ``mono-modal`` beyond it (the resonant, hardened branch: Figs. 5-6 above their folds);
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

__all__ = ["ATTRACTORS", "ClassifySettings", "a2_slaved", "classify_point", "classify_grid", "label_regions",
           "Region"]

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
    small_factor: float = 1.5              # a1 <= small_factor a_lin: the small forced response
    steady_ratio: float = 0.05             # cycles: (max - min) / (max + min) of a1 below it: galloping
    rtol: float = 1e-8
    floor: float = 1e-7                    # amplitudes below it count as rest (the AME's are 1e-4..1e-2)
    extensions: int = 2                    # a run not settled at t_end is continued up to this many times


#: Homotopy steps of `a2_slaved` (the forcing of the a2 equation switched on in this many equal
#: steps, each solved by Newton from the previous one).
SLAVED_STEPS = 16
#: `a2_slaved`: the homotopy's end and the equilibrium's a2 are the same solution when they differ
#: by less than this, relative to the equilibrium's amplitude (a Newton solution is good to ~1e-12;
#: distinct solutions of the a2 equation differ by a fraction of the amplitude).
SLAVED_TOL = 1e-6


def a2_slaved(system, x, p, *, steps: int = SLAVED_STEPS, tol: float = SLAVED_TOL) -> bool | None:
    """Whether the out-of-plane part of the AME equilibrium ``x`` is slaved to its in-plane part.

    With the in-plane amplitudes w = (r1, s1) held at the equilibrium's, the a2 equations
    G(z) = F_(r2, s2)(w, z) = 0 in z = (r2, s2) are solved by homotopy in their forcing by a1,
    g = G(0): from z = 0, the solution of G(z) - g = 0 (the a2 equations without that forcing),
    g is switched on in ``steps`` steps, each solved by Newton from the previous z. The a2 of a
    mono-modal response is where this path ends: zero when nothing forces the a2 equations (no wind:
    the symmetry q2 -> -q2 of eq. 21), and the forced response a2 ~ |g| / |dG/dz| where the wind's
    cross terms couple the modes. A bi-modal solution (born at a branch point from a mono-modal
    branch, the out-of-plane mode in its own resonance: Figs. 6, 9) is another solution of G: the path
    does not reach it. No threshold on a2 / a1 enters: only whether two solutions of the same
    equations are the same (`SLAVED_TOL`). A path that cannot be followed (a singular dG/dz on the
    way: the forced response folds) reaches no solution, so that equilibrium is not slaved.
    None when the system has no a2 equations (the 1-dof reduction)."""
    pair = system.amplitudes[1][1] if len(system.amplitudes) > 1 else ()
    if len(pair) != 2:
        return None
    iz = [system.variables.index(v) for v in pair]
    x = np.asarray(x, float)
    z_star = x[iz].copy()

    def G(z):
        y = x.copy()
        y[iz] = z
        return np.asarray(system.f(y, p), float)[iz]

    def dG(z):
        y = x.copy()
        y[iz] = z
        return np.asarray(system.jac(y, p), float)[np.ix_(iz, iz)]

    g = G(np.zeros(2))
    size = max(float(np.max(np.abs(x))), 1e-300)
    z = np.zeros(2)
    for k in range(1, steps + 1):
        shift = (1.0 - k / steps) * g
        for _ in range(30):
            r = G(z) - shift
            try:
                dz = np.linalg.solve(dG(z), r)
            except np.linalg.LinAlgError:
                return False
            z = z - dz
            if float(np.max(np.abs(dz))) <= 1e-10 * size:
                break
        else:
            return False
    return bool(float(np.max(np.abs(z - z_star))) <= tol * size)


def refine_equilibrium(system, x, p, iterations: int = 20):
    """Newton on the whole AME from ``x`` (an integration's end state, steady to ``steady_tol``):
    (the equilibrium to ~1e-12 of its size, True), or (``x`` itself, False) when Newton does not
    converge."""
    x0 = np.asarray(x, float)
    y = x0.copy()
    size = max(float(np.max(np.abs(y))), 1e-300)
    for _ in range(iterations):
        try:
            dy = np.linalg.solve(np.asarray(system.jac(y, p), float), np.asarray(system.f(y, p), float))
        except np.linalg.LinAlgError:
            return x0, False
        y = y - dy
        if float(np.max(np.abs(dy))) <= 1e-12 * size:
            return y, True
    return x0, False


def _bimodal(system, x, p, settings) -> bool:
    """An equilibrium reached by integration is bi-modal when its a2 is not slaved to a1: judged at
    the equilibrium refined by Newton, or, when Newton fails, at the integration's end state to
    ten times its own steadiness."""
    y, ok = refine_equilibrium(system, x, p)
    return a2_slaved(system, y, p, tol=SLAVED_TOL if ok else 10 * settings.steady_tol) is False


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
            elif _bimodal(system, Y[-1], p, settings):
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
