"""Scaled coordinates of one-parameter continuation (`_Chart`: x~ = x / xscale, lam = (p - p0) /
pscale, the coordinates PyCont sees) and the numerics on them: tangents, the Newton corrector,
sign changes of test functions and their location on the branch (Brent), and the assembly of a
`Branch` back in physical units.

The curve chart of two-parameter continuation (`autocable.methods.continuation.curve_chart`) has the same
``F``/``DF`` shapes, so `_correct` and `_locate` serve both."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from autocable.methods.continuation.problem import EquilibriumProblem
from autocable.methods.continuation.system import System
from autocable.results import Branch


@dataclass(frozen=True, eq=False)
class _Chart:
    """Y = (x / xscale, (p_k - base_k) / pscale): the coordinates PyCont sees."""

    system: System
    k: int                   # index of the continued parameter
    base: np.ndarray         # physical parameter vector at lam = 0
    xscale: float
    pscale: float

    @classmethod
    def of(cls, problem: EquilibriumProblem, base_value: float | None = None) -> "_Chart":
        sysm = problem.system
        k = sysm.parameter_names.index(problem.parameter)
        base = sysm.parameter_vector(problem.values)
        if base_value is not None:
            base[k] = base_value
        return cls(sysm, k, base, float(problem.state_scale), float(problem.span))

    def p(self, lam: float) -> np.ndarray:
        p = self.base.copy()
        p[self.k] += self.pscale * lam
        return p

    def value(self, lam: float) -> float:
        return float(self.base[self.k] + self.pscale * lam)

    def lam(self, value: float) -> float:
        return (float(value) - self.base[self.k]) / self.pscale

    def to_phys(self, Y) -> tuple[np.ndarray, np.ndarray]:
        Y = np.asarray(Y, float)
        return Y[:-1] * self.xscale, self.p(Y[-1])

    def to_chart(self, x, value) -> np.ndarray:
        return np.append(np.asarray(x, float) / self.xscale, self.lam(value))

    def F(self, Y) -> np.ndarray:
        x, p = self.to_phys(Y)
        return self.system.f(x, p) / self.xscale

    def jac(self, x, p) -> np.ndarray:
        """J_x at the physical (x, p)."""
        return self.system.jac(x, p)

    def DF(self, Y) -> np.ndarray:
        """n x (n+1): [J_x, dF/dlam] in chart units."""
        x, p = self.to_phys(Y)
        J = self.system.jac(x, p)
        Jl = self.system.jac_p(x, p)[:, self.k] * self.pscale / self.xscale
        return np.column_stack([J, Jl])

    def pycont_pars(self, lam0: float = 0.0) -> dict[str, float]:
        pars = self.system.parameter_dict(self.base)
        pars["xscale"] = self.xscale
        for i, name in enumerate(self.system.parameter_names):
            pars[f"d_{name}"] = self.pscale if i == self.k else 0.0
        pars["lam"] = float(lam0)
        return pars

    def point_dict(self, Y) -> dict[str, float]:
        d = {v: float(y) for v, y in zip(self.system.variables, Y[:-1])}
        d["lam"] = float(Y[-1])
        return d


def _tangent(DF: np.ndarray) -> np.ndarray:
    """Unit null vector of the n x (n+1) matrix DF (the branch tangent)."""
    _, _, vt = np.linalg.svd(DF)
    return vt[-1]


def _correct(chart: _Chart, target: np.ndarray, normal: np.ndarray, tol: float, maxiter: int = 25):
    """Newton on F(Y) = 0, normal . (Y - target) = 0, from ``target``. Returns (Y, converged)."""
    Y = np.array(target, dtype=float)
    normal = np.asarray(normal, float)
    for _ in range(maxiter):
        G = np.append(chart.F(Y), normal @ (Y - target))
        A = np.vstack([chart.DF(Y), normal])
        try:
            step = np.linalg.solve(A, G)
        except np.linalg.LinAlgError:
            return Y, False
        Y = Y - step
        if not np.all(np.isfinite(Y)):
            return target, False
        if np.linalg.norm(step) <= tol * (1.0 + np.linalg.norm(Y)):
            return Y, True
    return Y, False


def _sign(v: float) -> int:
    return 0 if v == 0 or not math.isfinite(v) else (1 if v > 0 else -1)


def _sign_changes(values: Sequence[float]) -> list[int]:
    """Indices i such that the sign changes between point i and the next point with a nonzero value
    (exact zeros are skipped, so a zero at a point does not count twice)."""
    v = np.asarray(values, float).ravel()
    s = np.sign(v)
    s[~np.isfinite(v)] = 0.0
    idx = np.flatnonzero(s)
    return idx[:-1][s[idx[1:]] != s[idx[:-1]]].tolist()


def _oriented_tangents(chart: _Chart, Ys: Sequence[np.ndarray]) -> np.ndarray:
    """Branch tangents at every point, oriented along the direction of travel."""
    n = len(Ys)
    T = np.zeros((n, Ys[0].size))
    for i, Y in enumerate(Ys):
        _, sv, vt = np.linalg.svd(chart.DF(Y))
        a, b = max(i - 1, 0), min(i + 1, n - 1)
        chord = Ys[b] - Ys[a]
        v = vt[-1]
        if sv[-1] <= 1e-8 * sv[0] and np.linalg.norm(chord) > 0:
            v = chord / np.linalg.norm(chord)  # on a BP the kernel is 2-D: follow the branch itself
        if i > 0 and abs(v @ chord) <= 1e-3 * np.linalg.norm(chord):
            chord = T[i - 1]  # a chord across a sharp turn or of zero length: follow the last tangent
        T[i] = v if v @ chord >= 0 else -v
    return T


def _locate(chart: _Chart, Ya, Yb, tau: Callable[[np.ndarray], float], tol: float):
    """Zero of ``tau`` on the branch between Ya and Yb: Brent in the chord parameter, each trial point
    corrected onto the branch orthogonally to the chord. Returns (Y, converged)."""
    from scipy.optimize import brentq

    d = Yb - Ya
    cache: dict[float, np.ndarray] = {}

    def point(s: float) -> np.ndarray:
        if s not in cache:
            Y, ok = _correct(chart, Ya + s * d, d, tol)
            cache[s] = Y if ok else Ya + s * d
        return cache[s]

    def g(s: float) -> float:
        return tau(point(s))

    ga, gb = g(0.0), g(1.0)
    if np.isfinite(ga) and np.isfinite(gb) and _sign(ga) * _sign(gb) > 0:
        # PyCont may have put a point on the zero already (its own located point): accept an end
        # whose test value is negligible against the other's.
        small, big, s0 = (abs(ga), abs(gb), 0.0) if abs(ga) <= abs(gb) else (abs(gb), abs(ga), 1.0)
        if small <= 1e-9 * big:
            return point(s0), True
    if not (np.isfinite(ga) and np.isfinite(gb)) or _sign(ga) * _sign(gb) > 0:
        s = 0.5 if ga == gb else min(max(ga / (ga - gb), 0.0), 1.0)
        return point(s), False
    if ga == 0:
        return point(0.0), True
    if gb == 0:
        return point(1.0), True
    # A test function that is not smooth along the chord (a neutral saddle's bialternate product
    # next to a fold, noisy corrections) can keep Brent from converging: keep its best bracket point
    # and say it did not converge, rather than fail the whole branch.
    s, info = brentq(g, 0.0, 1.0, xtol=1e-14, rtol=1e-15, maxiter=100, full_output=True, disp=False)
    return point(s), bool(info.converged)


def _build_branch(name: str, kind: str, chart: _Chart, X, P, stable, eig, specials, ends, info,
                  extra_columns: Mapping[str, Sequence[float]] | None = None) -> Branch:
    sysm = chart.system
    table: dict[str, Any] = {}
    P = np.asarray(P, float).reshape(len(X), -1)
    for j, pname in enumerate(sysm.parameter_names):
        table[pname] = P[:, j]
    amps = sysm.amplitude_values(np.asarray(X, float).reshape(len(X), -1)) if len(X) else \
        tuple(np.zeros(0) for _ in sysm.amplitudes)
    for a, v in zip(sysm.amplitude_names, amps):
        table[a] = np.asarray(v, float) * np.ones(len(X))
    X = np.asarray(X, float).reshape(len(X), sysm.dimension)
    for j, v in enumerate(sysm.variables):
        table[v] = X[:, j]
    if extra_columns:
        table.update({k: np.asarray(v, float) for k, v in extra_columns.items()})
    return Branch(name=name, kind=kind, parameter=sysm.parameter_names[chart.k],
                  parameter_names=sysm.parameter_names, variables=sysm.variables,
                  amplitude_names=sysm.amplitude_names, table=table, stable=stable,
                  eigenvalues=eig, special_points=specials, ends=ends, info=info)
