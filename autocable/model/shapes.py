"""Shape functions on s in [0, 1] and their integrals, computed two independent ways.

Every shape function of the model (the modes of eqs. 19-20, their derivatives, the twist, the
quasi-static shape of eq. 15) is a finite sum of c s^n e^{lambda s} with complex lambda: an
`ExpPoly`. Products stay in that class and integrals over [0, 1] have a closed form, which gives the
Galerkin coefficients exactly. The same integrals are also computed by Gauss-Legendre quadrature of
the functions written directly as numpy expressions (`Shape.evaluate`), a second, independent path;
the two must agree (tests assert 1e-8 relative).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np


def _integral_s_n_exp(n: int, lam: complex) -> complex:
    """int_0^1 s^n e^{lam s} ds in closed form (series for small |lam|, where the closed form cancels)."""
    if abs(lam) < 0.5:
        total, term, j = 0.0 + 0.0j, 1.0 + 0.0j, 0
        while True:
            add = term / (n + j + 1)
            total += add
            if abs(add) < 1e-18 * max(1.0, abs(total)) and j > 2:
                return total
            j += 1
            term *= lam / j
    e = np.exp(lam)
    total = 0.0 + 0.0j
    falling = 1.0
    for j in range(n + 1):
        total += (-1) ** j * falling * e / lam ** (j + 1)
        falling *= n - j
    return total - (-1) ** n * math.factorial(n) / lam ** (n + 1)


@dataclass(frozen=True)
class ExpPoly:
    """sum_k c_k s^{n_k} e^{lam_k s}; terms is a tuple of (n, lam, c)."""

    terms: tuple[tuple[int, complex, complex], ...]

    @staticmethod
    def _collect(items) -> "ExpPoly":
        acc: dict[tuple[int, complex], complex] = {}
        for n, lam, c in items:
            # Rounding the exponent only merges terms equal up to round-off; it changes no value.
            key = (n, complex(round(lam.real, 13), round(lam.imag, 13)))
            acc[key] = acc.get(key, 0.0) + c
        return ExpPoly(tuple((n, lam, c) for (n, lam), c in acc.items() if c != 0))

    def __mul__(self, other: "ExpPoly") -> "ExpPoly":
        return ExpPoly._collect((n1 + n2, l1 + l2, c1 * c2)
                                for n1, l1, c1 in self.terms for n2, l2, c2 in other.terms)

    def derivative(self) -> "ExpPoly":
        items = []
        for n, lam, c in self.terms:
            if n:
                items.append((n - 1, lam, c * n))
            if lam != 0:
                items.append((n, lam, c * lam))
        return ExpPoly._collect(items)

    def integral(self) -> float:
        """int_0^1 in closed form; the imaginary part cancels for real functions."""
        return float(sum(c * _integral_s_n_exp(n, lam) for n, lam, c in self.terms).real)

    def __call__(self, s):
        s = np.asarray(s, dtype=float)
        return sum(c * s**n * np.exp(lam * s) for n, lam, c in self.terms).real


def cos_term(k: float, shift: float) -> ExpPoly:
    """cos(k (s - shift))."""
    return ExpPoly._collect([(0, 1j * k, 0.5 * np.exp(-1j * k * shift)),
                             (0, -1j * k, 0.5 * np.exp(1j * k * shift))])


def sin_term(k: float) -> ExpPoly:
    """sin(k s)."""
    return ExpPoly._collect([(0, 1j * k, -0.5j), (0, -1j * k, 0.5j)])


def cosh_term(k: float, shift: float) -> ExpPoly:
    """cosh(k (s - shift))."""
    return ExpPoly._collect([(0, complex(k), 0.5 * math.exp(-k * shift)),
                             (0, complex(-k), 0.5 * math.exp(k * shift))])


def poly(*coeffs: float) -> ExpPoly:
    """c0 + c1 s + c2 s^2 + ..."""
    return ExpPoly._collect((n, 0j, complex(c)) for n, c in enumerate(coeffs))


def scaled(p: ExpPoly, a: float, b: ExpPoly | None = None) -> ExpPoly:
    """a * p (+ b)."""
    items = [(n, lam, a * c) for n, lam, c in p.terms]
    if b is not None:
        items += list(b.terms)
    return ExpPoly._collect(items)


@dataclass(frozen=True)
class Shape:
    """A named shape function: closed form (`exp`) and a direct numpy evaluation (`evaluate`)."""

    name: str
    exp: ExpPoly
    evaluate: Callable[[np.ndarray], np.ndarray]


class ClosedFormIntegrator:
    """Integrates products of shapes exactly through their `ExpPoly` forms."""

    name = "closed-form"

    def __init__(self, shapes: dict[str, Shape]):
        self._shapes = shapes
        self._memo: dict[tuple[str, ...], float] = {}

    def __call__(self, key: tuple[str, ...]) -> float:
        if key not in self._memo:
            prod = poly(1.0)
            for name in key:
                prod = prod * self._shapes[name].exp
            self._memo[key] = prod.integral()
        return self._memo[key]


class QuadratureIntegrator:
    """Integrates products of shapes by Gauss-Legendre quadrature of their direct evaluations."""

    name = "quadrature"

    def __init__(self, shapes: dict[str, Shape], nodes: int = 96):
        x, w = np.polynomial.legendre.leggauss(nodes)
        self._s, self._w = 0.5 * (x + 1.0), 0.5 * w
        self._values = {k: sh.evaluate(self._s) for k, sh in shapes.items()}
        self._memo: dict[tuple[str, ...], float] = {}

    def __call__(self, key: tuple[str, ...]) -> float:
        if key not in self._memo:
            prod = np.ones_like(self._s)
            for name in key:
                prod = prod * self._values[name]
            self._memo[key] = float(np.dot(self._w, prod))
        return self._memo[key]
