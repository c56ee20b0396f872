"""Scaled coordinates and defining system of the two-parameter curves (LP-C of folds, H-C2 of Hopf
points): `_CurveChart` (x~ = x / xscale, lam, lam2, time scaled by tscale; f = 0 plus a bordered test
function) and the codimension-2 test functions on it (CP, BT, ZH, GH, DH), with their classification
by the eigenvalues."""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from types import MappingProxyType
from typing import Any

import numpy as np

from autocable.methods.continuation.events import (_critical_pair, _hopf_check, _oriented_null,
                                                     _pair_sum_product, bialternate, first_lyapunov)
from autocable.methods.continuation.system import System


#: kind -> (the special-point type it starts from, PyCont's curve type, PyCont's labels on it)
_CURVES = MappingProxyType({"fold": ("LP", "LP-C", ("CP", "BT", "ZH")),
                            "hopf": ("H", "H-C2", ("BT", "ZH", "GH"))})


@dataclass(frozen=True, eq=False)
class _CurveChart:
    """Y = (x / xscale, lam, lam2): p[k1] = base[k1] + s1 lam, p[k2] = base[k2] + s2 lam2, time scaled
    by ``tscale`` (so the Jacobian PyCont sees is O(1) even for a slow flow like the AME).

    The defining system of the curve, autocable's own: F~ = tscale f / xscale = 0 and g = 0, g the
    bordered test function (Govaerts, Numerical Methods for Bifurcations, Sect. 3.4; Kuznetsov,
    Sect. 10.2) of M = tscale J (folds) or of its bialternate product 2M (.) I (Hopf points and
    neutral saddles), with borders fixed at `at`. ``F`` and ``DF`` have the shapes `_correct` and
    `_locate` expect: (n+1) equations in n+2 unknowns."""

    system: System
    kind: str
    k1: int
    k2: int
    base: np.ndarray
    xscale: float
    s1: float
    s2: float
    tscale: float
    border: tuple | None = None

    def p(self, Y) -> np.ndarray:
        p = self.base.copy()
        p[self.k1] += self.s1 * Y[-2]
        p[self.k2] += self.s2 * Y[-1]
        return p

    def to_phys(self, Y) -> tuple[np.ndarray, np.ndarray]:
        Y = np.asarray(Y, float)
        return Y[:-2] * self.xscale, self.p(Y)

    def to_chart(self, x, p) -> np.ndarray:
        return np.concatenate([np.asarray(x, float) / self.xscale,
                               [(p[self.k1] - self.base[self.k1]) / self.s1,
                                (p[self.k2] - self.base[self.k2]) / self.s2]])

    def values(self, Y) -> tuple[float, float]:
        p = self.p(np.asarray(Y, float))
        return float(p[self.k1]), float(p[self.k2])

    def lam(self, which: int, value: float) -> float:
        k, s = (self.k1, self.s1) if which == 1 else (self.k2, self.s2)
        return (float(value) - self.base[k]) / s

    def jac(self, Y) -> np.ndarray:
        return self.system.jac(*self.to_phys(Y))

    def matrix(self, Y) -> np.ndarray:
        A = self.tscale * self.jac(Y)
        return A if self.kind == "fold" else bialternate(A)

    def at(self, Y) -> "_CurveChart":
        """This chart with the borders of the test function taken at Y (singular vectors of the
        smallest singular value of M: the bordered matrix is then regular near Y)."""
        U, _, Vt = np.linalg.svd(self.matrix(Y))
        return replace(self, border=(U[:, -1].copy(), Vt[-1].copy()))

    def g(self, Y) -> float:
        M = self.matrix(Y)
        b, c = self.border
        m = M.shape[0]
        A = np.zeros((m + 1, m + 1))
        A[:m, :m], A[:m, m], A[m, :m] = M, b, c
        rhs = np.zeros(m + 1)
        rhs[m] = 1.0
        return float(np.linalg.solve(A, rhs)[m])

    def F(self, Y) -> np.ndarray:
        if self.border is None:
            return self.at(Y).F(Y)
        x, p = self.to_phys(Y)
        return np.append(self.tscale * self.system.f(x, p) / self.xscale, self.g(Y))

    def DF(self, Y) -> np.ndarray:
        Y = np.asarray(Y, float)
        if self.border is None:
            return self.at(Y).DF(Y)
        x, p = self.to_phys(Y)
        J, Jp = self.system.jac(x, p), self.system.jac_p(x, p)
        top = np.column_stack([self.tscale * J, self.tscale * Jp[:, self.k1] * self.s1 / self.xscale,
                               self.tscale * Jp[:, self.k2] * self.s2 / self.xscale])
        h = 1e-6
        grad = np.zeros(Y.size)
        for j in range(Y.size):
            e = np.zeros(Y.size)
            e[j] = h
            grad[j] = (self.g(Y + e) - self.g(Y - e)) / (2 * h)
        return np.vstack([top, grad])

    def pycont_pars(self) -> dict[str, float]:
        pars = self.system.parameter_dict(self.base)
        pars.update(xscale=self.xscale, tscale=self.tscale, lam=0.0, lam2=0.0)
        for i, name in enumerate(self.system.parameter_names):
            pars[f"d_{name}"] = self.s1 if i == self.k1 else 0.0
            pars[f"d2_{name}"] = self.s2 if i == self.k2 else 0.0
        return pars

    def point_dict(self, Y) -> dict[str, float]:
        d = {v: float(y) for v, y in zip(self.system.variables, Y[:-2])}
        d["lam"], d["lam2"] = float(Y[-2]), float(Y[-1])
        return d


def _curve_tests(chart: _CurveChart, Y, ref=None) -> tuple[dict[str, float], tuple]:
    """autocable's test functions of codimension-2 points at Y (physical Jacobian and derivatives).

    Folds: CP = w . B(v, v) (the fold's quadratic normal-form coefficient), BT = w . v (zero when the
    zero eigenvalue becomes double), ZH = the pair-sum product of the other eigenvalues (n >= 3).
    Hopf: BT = kappa = lambda_a lambda_b of the critical pair (omega^2; negative beyond BT), GH = the
    first Lyapunov coefficient, ZH = det J, DH = the pair-sum product of the other eigenvalues
    (n >= 4). Returns the values and the oriented null vectors (for the next point's signs)."""
    sysm = chart.system
    x, p = chart.to_phys(Y)
    J = sysm.jac(x, p)
    ev = np.linalg.eigvals(J)
    n = len(ev)
    out: dict[str, float] = {}
    vw = None
    if chart.kind == "fold":
        v, w = _oriented_null(J, ref)
        vw = (v, w)
        B = np.einsum("ijk,j,k->i", sysm.hessian(x, p), v, v)
        out["CP"] = float(w @ B)
        out["BT"] = float(w @ v)
        if n >= 3:
            rest = np.delete(ev, int(np.argmin(np.abs(ev))))
            out["ZH"] = _pair_sum_product(rest)
    else:
        kappa, omega, _ = _hopf_check(ev, np.linalg.norm(J))
        out["BT"] = kappa
        out["ZH"] = float(np.linalg.det(J))
        if omega > 0:
            try:
                out["GH"] = first_lyapunov(sysm, x, p)[0]
            except (np.linalg.LinAlgError, ValueError):
                out["GH"] = math.nan
        else:
            out["GH"] = math.nan
        if n >= 4:
            a, b = _critical_pair(ev)
            out["DH"] = _pair_sum_product(np.delete(ev, [a, b]))
    return out, vw


def _classify_curve_point(chart: _CurveChart, kind: str, Y) -> tuple[bool, str, dict]:
    """Is the zero of test function ``kind`` at Y really that point? The eigenvalues decide.
    Returns (accepted, why-not, extra data)."""
    x, p = chart.to_phys(Y)
    J = chart.system.jac(x, p)
    ev = np.linalg.eigvals(J)
    scale = max(float(np.linalg.norm(J)), 1e-300)
    small = np.sort(np.abs(ev))
    extra: dict[str, Any] = {"eigenvalues": [complex(e) for e in ev]}
    if kind == "BT":
        ok = len(ev) >= 2 and small[1] <= 1e-4 * scale
        return ok, "" if ok else f"no double zero eigenvalue (second smallest |lambda| = {small[1]:.3g})", extra
    if kind == "CP":
        return True, "", extra
    if chart.kind == "fold" and kind == "ZH":
        rest = np.delete(ev, int(np.argmin(np.abs(ev))))
        a, b = _critical_pair(rest)
        if abs(rest[a].imag) <= 1e-8 * scale:
            return False, "the other eigenvalues have a real pair (lambda, -lambda): a neutral saddle, not zero-Hopf", extra
        extra["omega"] = abs(float(rest[a].imag))
        return True, "", extra
    if kind == "GH":
        kappa, omega, _ = _hopf_check(ev, scale)
        extra["omega"] = omega
        return omega > 0, "" if omega > 0 else "the critical pair is real here", extra
    if kind == "ZH":   # on a Hopf curve: a real eigenvalue through zero
        a, b = _critical_pair(ev)
        rest = np.delete(ev, [a, b])
        kappa, omega, _ = _hopf_check(ev, scale)
        ok = omega > 0 and rest.size > 0 and np.min(np.abs(rest)) <= 1e-6 * scale
        extra["omega"] = omega
        return ok, "" if ok else "no simple zero eigenvalue beside the Hopf pair", extra
    if kind == "DH":
        a, b = _critical_pair(ev)
        rest = np.delete(ev, [a, b])
        c, d = _critical_pair(rest)
        ok = abs(rest[c].imag) > 1e-8 * scale
        extra["omega2"] = abs(float(rest[c].imag))
        return ok, "" if ok else "the second pair is real: a Hopf-neutral saddle, not a double Hopf point", extra
    return False, f"unknown point type {kind}", extra


def _kappa_direction(chart: _CurveChart, Y: np.ndarray, t: np.ndarray) -> float:
    """d(omega^2)/ds along the unit tangent t at Y, omega^2 as PyCont's H-C2 sees it (scaled time)."""
    def kap(Z):
        return _hopf_check(np.linalg.eigvals(chart.tscale * chart.jac(Z)))[0]
    h = 1e-6
    return (kap(Y + h * t) - kap(Y - h * t)) / (2 * h)
