"""Test functions of bifurcations, from the exact Jacobian and derivatives of a `System`.

The bialternate product 2A (.) I and its determinant (Hopf points and neutral saddles), the first
Lyapunov coefficient l1 (Kuznetsov, eq. 3.20), and the eigenvalue checks of the two-parameter
curves (the critical pair of a Hopf point, sigma_min/sigma_max at a fold)."""
from __future__ import annotations

import math

import numpy as np

from autocable.methods.continuation.system import System


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


# ------------------------------------------------------------------------------------------------
# cycles: Floquet multipliers and their crossings of the unit circle (LPC, PD, NS)
# ------------------------------------------------------------------------------------------------
def _monodromy(system: System, x0, p, T: float, rtol: float, samples: int = 400):
    """Integrate x' = f, Phi' = J Phi over one period: (Phi(T), x(T), dense samples of x)."""
    from scipy.integrate import solve_ivp

    n = system.dimension

    def rhs(_t, z):
        x = z[:n]
        Phi = z[n:].reshape(n, n)
        return np.concatenate([system.f(x, p), (system.jac(x, p) @ Phi).ravel()])

    if T <= 0 or not np.any(np.asarray(x0) != 0) and not np.any(system.f(x0, p)):
        # A degenerate cycle (the Hopf point itself): the monodromy of an equilibrium is exp(J T).
        from scipy.linalg import expm
        x0 = np.asarray(x0, float)
        return expm(system.jac(x0, p) * T), x0.copy(), np.tile(x0, (samples + 1, 1))
    z0 = np.concatenate([np.asarray(x0, float), np.eye(n).ravel()])
    ts = np.linspace(0.0, T, samples + 1)
    sol = solve_ivp(rhs, (0.0, T), z0, method="DOP853", t_eval=ts, rtol=rtol,
                    atol=rtol * (np.max(np.abs(x0)) + 1e-300) * 1e-2)
    if sol.status < 0 or sol.y.shape[1] != len(ts):
        raise RuntimeError(sol.message)
    return sol.y[n:, -1].reshape(n, n), sol.y[:n, -1], sol.y[:n].T


def _crossing_distance(mults: np.ndarray, kind: str) -> float:
    """Signed distance to the unit circle of the non-trivial multiplier that crosses it at an
    LPC (real, through +1), PD (real, through -1) or NS (complex pair)."""
    rest = np.delete(mults, int(np.argmin(np.abs(mults - 1.0))))
    real = np.abs(rest.imag) < 1e-7
    if kind == "LPC":
        d = rest[real].real - 1.0
    elif kind == "PD":
        d = -rest[real].real - 1.0
    else:
        d = np.abs(rest[~real]) - 1.0
    return float(d[np.argmin(np.abs(d))]) if d.size else 1.0


def _genuine_crossing(kind: str, m0: np.ndarray, m1: np.ndarray) -> bool:
    """Whether a change of `_cycle_counts` between two cycles is a multiplier crossing the unit
    circle as ``kind`` says, rather than two multipliers meeting on the real axis and leaving it as
    a complex pair (or back). A PD changes the number of real multipliers below -1 by an odd number
    (a collision of two changes it by two). An NS moves a complex pair from inside the circle to
    outside (or back), with an argument above 1e-3 rad: at a fold of cycles the double multiplier
    +1 splits into 1 +- 1e-6 i, a 1:1 resonance, not a torus bifurcation. An LPC is taken as counted."""
    def parts(m):
        m = np.asarray(m, complex)
        r = np.delete(m, int(np.argmin(np.abs(m - 1.0))))
        real = np.abs(r.imag) <= 1e-7 * np.maximum(np.abs(r), 1.0)
        cplx = r[~real]
        return (int(np.sum(real & (r.real < -1))), int(np.sum(np.abs(cplx) > 1)), int(np.sum(np.abs(cplx) < 1)),
                cplx)

    n0, out0, in0, c0 = parts(m0)
    n1, out1, in1, c1 = parts(m1)
    if kind == "PD":
        return (n1 - n0) % 2 == 1
    if kind == "NS":
        moved = out1 - out0
        return (moved != 0 and moved % 2 == 0 and in1 - in0 == -moved and c0.size and c1.size
                and min(np.min(np.abs(np.angle(c0))), np.min(np.abs(np.angle(c1)))) > 1e-3)
    return True


def _cycle_counts(mults: np.ndarray) -> tuple[int, int, int]:
    """(real > 1, real < -1, complex outside) counts of the non-trivial multipliers."""
    if mults.size == 0 or not np.all(np.isfinite(mults)):
        return (-1, -1, -1)
    rest = np.delete(mults, int(np.argmin(np.abs(mults - 1.0))))
    tol = 1e-7
    real = np.abs(rest.imag) <= tol * np.maximum(np.abs(rest), 1.0)
    return (int(np.sum(real & (rest.real > 1))), int(np.sum(real & (rest.real < -1))),
            int(np.sum(~real & (np.abs(rest) > 1))))


#: The cycle engines: PyCont's LC-C (AUTO) or autocable's own collocation on the C kernel.
