"""The first Lyapunov coefficient of a Hopf point (Kuznetsov, Elements of Applied Bifurcation Theory,
3rd ed., Sect. 3.5, eq. 3.20), for any vector field x' = A x + B(x, x)/2 + C(x, x, x)/6 + O(|x|^4).

With A q = i omega q, A^T p = -i omega p, <p, q> = p-bar^T q = 1 and |q| = 1,

    c1 = g21 / 2,  g21 = <p, C(q, q, q-bar)> - 2 <p, B(q, A^-1 B(q, q-bar))>
                         + <p, B(q-bar, (2 i omega I - A)^-1 B(q, q))>,
    l1 = Re(c1) / omega.

On the centre manifold x = z q + z-bar q-bar + O(|z|^2) the normal form is z' = lambda(mu) z + c1 z |z|^2,
so the radius obeys r' = Re(lambda) r + Re(c1) r^3: l1 < 0 is a super-critical Hopf point (a stable
cycle born on the unstable side), l1 > 0 a sub-critical one (an unstable cycle on the stable side,
hysteresis). The cycle's radius is r^2 = -Re(lambda)/Re(c1), and component k of x oscillates with
amplitude 2 |q_k| r, so the post-critical amplitudes obey
    a_k^2 = 4 |q_k|^2 (d Re lambda / d mu) (mu - mu_c) / (-Re c1)         (`amplitude_slopes`).
The value of l1 depends on the normalisation |q| = 1 (stated with it); its sign and the amplitude
slopes do not.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np


@dataclass(frozen=True)
class HopfPoint:
    omega: float                # the critical frequency (Im lambda > 0)
    q: np.ndarray               # right eigenvector, |q| = 1, A q = i omega q
    p: np.ndarray               # left eigenvector, A^T p = -i omega p, <p, q> = 1
    c1: complex                 # the normal form's cubic coefficient
    l1: float                   # first Lyapunov coefficient Re(c1)/omega (|q| = 1)

    def amplitude_slopes(self, growth_slope: float) -> np.ndarray:
        """d(a_k^2)/d mu of every component, given d Re lambda / d mu at the Hopf point."""
        return 4.0 * np.abs(self.q) ** 2 * growth_slope / (-self.c1.real)

    def growth_slope(self, dA: np.ndarray) -> float:
        """d Re lambda / d mu from dA/dmu: Re <p, dA q> (first-order perturbation, <p, q> = 1)."""
        return float(np.vdot(self.p, dA @ self.q).real)


def critical_pair(A: np.ndarray) -> tuple[complex, np.ndarray]:
    """The eigenvalue with Im > 0 nearest the imaginary axis, and its eigenvector (|q| = 1)."""
    lam, V = np.linalg.eig(A)
    upper = [i for i in range(len(lam)) if lam[i].imag > 0]
    if not upper:
        raise ValueError("no complex pair: not a Hopf point")
    i = min(upper, key=lambda j: abs(lam[j].real))
    q = V[:, i] / np.linalg.norm(V[:, i])
    return complex(lam[i]), q


def first_lyapunov(A: np.ndarray, B: Callable, C: Callable) -> HopfPoint:
    """The first Lyapunov coefficient at the Hopf point of x' = A x + B(x,x)/2 + C(x,x,x)/6 (module
    docstring); A must have its critical pair on (or within round-off of) the imaginary axis. B and C
    are the symmetric multilinear forms (second and third derivatives at 0), taking complex vectors."""
    A = np.asarray(A, dtype=float)
    lam, q = critical_pair(A)
    omega = lam.imag
    mu, W = np.linalg.eig(A.T)
    j = int(np.argmin(np.abs(mu - np.conj(lam))))
    p = W[:, j].astype(complex)
    p = p / np.conj(np.vdot(p, q))          # <p, q> = p-bar^T q = 1
    n = len(q)
    qb = np.conj(q)
    h11 = np.linalg.solve(A, B(q, qb))
    h20 = np.linalg.solve(2j * omega * np.eye(n) - A, B(q, q))
    g21 = np.vdot(p, C(q, q, qb)) - 2 * np.vdot(p, B(q, h11)) + np.vdot(p, B(qb, h20))
    c1 = complex(g21 / 2)
    return HopfPoint(omega=float(omega), q=q, p=p, c1=c1, l1=c1.real / omega)
