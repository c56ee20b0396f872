"""Distance of digitised published points to computed branches.

A scene's ``[compare]`` table names a CSV of points read off a published figure (columns x, y,
curve, stable; see runs/README.md for how to digitise one). Each point is compared with the
computed bifurcation diagram drawn in the same panel (amplitude ``panel`` against the plot's x
parameter) as follows.

* Both axes are normalised by the plot's ranges: x by the span (max - min) of the computed points'
  x, y by the largest computed amplitude (the panels start at y = 0). A distance of 0.01 is then 1 %
  of the figure's width or height, whatever the units.
* The computed diagram is the set of polylines through consecutive points of every branch: the
  equilibrium branches (amplitude ``panel``) and, for the periodic orbits, both of their min and
  max lines (``<panel>_min``, ``<panel>_max``), as the figure draws them. Two-parameter curves are
  not in these panels and are ignored.
* The distance of a point is the smallest Euclidean distance, in the normalised plane, to any
  segment of any polyline (an isolated computed point counts as a segment of length 0).

Per curve label: the number of points, the largest and the root-mean-square distance.
"""
from __future__ import annotations

import math
from typing import Iterable, Mapping, Sequence

import numpy as np

__all__ = ["polylines", "point_distances", "compare_summary"]


def polylines(branches: Iterable, x: str, amp: str) -> list[np.ndarray]:
    """The (n, 2) arrays of (x, amplitude) that the figure draws for amplitude ``amp``."""
    out = []
    for b in branches:
        if b.kind in ("fold", "hopf", "branch_point") or x not in b.table or len(b) == 0:
            continue
        cols = [amp] if b.kind == "equilibrium" else [f"{amp}_min", f"{amp}_max"]
        for c in cols:
            if c not in b.table:
                continue
            xy = np.column_stack([np.asarray(b.table[x], float), np.asarray(b.table[c], float)])
            xy = xy[np.all(np.isfinite(xy), axis=1)]
            if len(xy):
                out.append(xy)
    return out


def _segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distance of point p to each segment [a_i, b_i] (rows of a and b)."""
    d = b - a
    dd = np.einsum("ij,ij->i", d, d)
    t = np.where(dd > 0, np.einsum("ij,ij->i", p - a, d) / np.where(dd > 0, dd, 1.0), 0.0)
    t = np.clip(t, 0.0, 1.0)
    q = a + t[:, None] * d
    return np.hypot(p[0] - q[:, 0], p[1] - q[:, 1])


def point_distances(points: Sequence[tuple[float, float]], lines: Sequence[np.ndarray],
                    x_range: float, y_range: float) -> np.ndarray:
    """Normalised distance of every point (x, y) to the nearest segment of ``lines``."""
    if not lines:
        raise ValueError("no computed branch to compare with in this panel")
    if not (x_range > 0 and y_range > 0):
        raise ValueError(f"the plot's ranges must be positive, got x {x_range}, y {y_range}")
    scale = np.array([x_range, y_range])
    a = np.concatenate([ln[:-1] if len(ln) > 1 else ln for ln in lines]) / scale
    b = np.concatenate([ln[1:] if len(ln) > 1 else ln for ln in lines]) / scale
    return np.array([float(np.min(_segment_distance(np.asarray(p, float) / scale, a, b))) for p in points])


def compare_summary(rows: Sequence[Mapping], branches: Sequence, x: str, amp: str) -> dict:
    """compare.json's content: the normalisation, then per curve label n, max and RMS distance."""
    lines = polylines(branches, x, amp)
    if not lines:
        raise ValueError(f"no computed branch has {amp} against {x}")
    allxy = np.concatenate(lines)
    x_range = float(np.max(allxy[:, 0]) - np.min(allxy[:, 0]))
    y_range = float(np.max(allxy[:, 1]))
    curves: dict[str, dict] = {}
    for label in sorted({str(r["curve"]) for r in rows}):
        pts = [(float(r["x"]), float(r["y"])) for r in rows if str(r["curve"]) == label]
        d = point_distances(pts, lines, x_range, y_range)
        curves[label] = {"n_points": int(len(d)), "max_distance": float(np.max(d)),
                         "rms_distance": float(math.sqrt(np.mean(d ** 2))),
                         "n_stable_flag": int(sum(1 for r in rows if str(r["curve"]) == label and r["stable"]))}
    return {"panel": amp, "x": x, "x_range": x_range, "y_range": y_range,
            "distance": "smallest Euclidean distance to the computed polylines (equilibria; cycle min/max) "
                        "with x divided by x_range (span of the computed x) and y by y_range (largest "
                        "computed amplitude): 0.01 = 1 % of the plot",
            "curves": curves}
