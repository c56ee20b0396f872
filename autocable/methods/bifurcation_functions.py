"""Test functions of bifurcations, from the exact Jacobian and derivatives of a `System`.

The bialternate product 2A (.) I and its determinant (Hopf points and neutral saddles), the first
Lyapunov coefficient l1 (Kuznetsov, eq. 3.20), and the eigenvalue checks of the two-parameter
curves (the critical pair of a Hopf point, sigma_min/sigma_max at a fold)."""
from __future__ import annotations

import math

import numpy as np

from autocable.methods.system import System


def bialternate(A: np.ndarray) -> np.ndarray:
    """The bialternate product 2A (.) I, of order n(n-1)/2, whose eigenvalues are lambda_i + lambda_j
    (i < j) (Kuznetsov, Sect. 10.2.2; Govaerts, Numerical Methods for Bifurcations, Sect. 4.4.4). Its
    determinant vanishes at Hopf points and neutral saddles."""
    n = A.shape[0]
    pairs = [(p, q) for p in range(1, n) for q in range(p)]
    m = len(pairs)
    B = np.zeros((m, m))
    for a, (p, q) in enumerate(pairs):
        for b, (r, s) in enumerate(pairs):
            if r == q:
                B[a, b] = -A[p, s]
            elif r != p and s == q:
                B[a, b] = A[p, r]
            elif r == p and s == q:
                B[a, b] = A[p, p] + A[q, q]
            elif r == p and s != q:
                B[a, b] = A[q, s]
            elif s == p:
                B[a, b] = -A[q, r]
    return B


def _hopf_test(J: np.ndarray) -> float:
    return float(np.linalg.det(bialternate(J))) if J.shape[0] >= 2 else 1.0


def first_lyapunov(system: System, x, p) -> tuple[float, float]:
    """(l1, omega) at a Hopf point: Kuznetsov's l1 (eq. 3.20, <p, q> = 1, <q, q> = 1), from exact
    derivatives. l1 < 0: supercritical (stable cycles born), l1 > 0: subcritical."""
    x, p = np.asarray(x, float), np.asarray(p, float)
    A = system.jac(x, p)
    n = A.shape[0]
    ev, right = np.linalg.eig(A)
    upper = [j for j in range(n) if ev[j].imag > 0]
    if not upper:
        raise ValueError("no complex eigenvalue pair: not a Hopf point")
    i = min(upper, key=lambda j: abs(ev[j].real))
    w = float(ev[i].imag)
    q = right[:, i] / np.linalg.norm(right[:, i])
    evt, left = np.linalg.eig(A.T)
    pv = left[:, int(np.argmin(np.abs(evt + 1j * w)))]
    pv = pv / np.conj(np.vdot(pv, q))
    H = system.hessian(x, p)
    T = system.third(x, p)

    def B(u, v):
        return np.einsum("ijk,j,k->i", H, u, v)

    def C(u, v, z):
        return np.einsum("ijkl,j,k,l->i", T, u, v, z)

    g = (C(q, q, q.conj()) - 2 * B(q, np.linalg.solve(A, B(q, q.conj())))
         + B(q.conj(), np.linalg.solve(2j * w * np.eye(n) - A, B(q, q))))
    return float(np.real(np.vdot(pv, g)) / (2 * w)), w


def _critical_pair(ev: np.ndarray) -> tuple[int, int]:
    """The pair of eigenvalues whose sum is nearest to zero (the Hopf pair, or a neutral saddle's)."""
    n = len(ev)
    best, pair = math.inf, (0, min(1, n - 1))
    for a in range(n):
        for b in range(a + 1, n):
            s_ = abs(ev[a] + ev[b])
            if s_ < best:
                best, pair = s_, (a, b)
    return pair


def _pair_sum_product(ev: np.ndarray) -> float:
    """Real part of the product of lambda_i + lambda_j over the pairs of ``ev`` (real for a real
    matrix's spectrum): it changes sign when a pair's sum crosses zero."""
    out = 1.0 + 0j
    for a in range(len(ev)):
        for b in range(a + 1, len(ev)):
            out *= ev[a] + ev[b]
    return float(out.real)


def _hopf_check(ev: np.ndarray, scale: float | None = None) -> tuple[float, float, float]:
    """(kappa, omega, residual) of the critical pair: kappa = lambda_a lambda_b (omega^2 > 0 for a
    Hopf pair, < 0 for a neutral saddle), omega its imaginary part, residual = |Re| / scale (inf
    when the pair is real: not on the imaginary axis). ``scale``: the Jacobian's norm (default
    max |lambda|; near a Bogdanov-Takens point every eigenvalue is small, the norm is not)."""
    a, b = _critical_pair(ev)
    scale = max(float(np.max(np.abs(ev))) if scale is None else float(scale), 1e-300)
    kappa = float((ev[a] * ev[b]).real)
    if abs(ev[a].imag) <= 1e-8 * scale:
        return kappa, 0.0, math.inf
    return kappa, abs(float(ev[a].imag)), abs(float(ev[a].real)) / scale


def _fold_check(J: np.ndarray) -> float:
    """sigma_min / sigma_max of J: 0 exactly where det J = 0 (scale-free)."""
    sv = np.linalg.svd(J, compute_uv=False)
    return float(sv[-1] / sv[0]) if sv[0] > 0 else 0.0


def _oriented_null(J: np.ndarray, ref=None) -> tuple[np.ndarray, np.ndarray]:
    """Right (v) and left (w) singular vectors of J's smallest singular value, signs following ``ref``."""
    U, _, Vt = np.linalg.svd(J)
    v, w = Vt[-1].copy(), U[:, -1].copy()
    if ref is not None:
        if v @ ref[0] < 0:
            v = -v
        if w @ ref[1] < 0:
            w = -w
    return v, w
