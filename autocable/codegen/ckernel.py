"""sympy -> C: a compiled equilibrium-continuation kernel for one autonomous system.

What it holds. From the same sympy right-hand side that PyCont continues (the Cartesian AME (24) of
Luongo & Zulli, or any `autocable.methods.continuation.system.System`) it writes one C file with

* F(x; p), J_x = dF/dx and J_p = dF/dp, from ``sympy.cse`` and a C printer that writes integer
  powers as products (``pow`` with a constant exponent is not inlined without -ffast-math);
* the scaled chart of `autocable.methods.continuation.chart` (x~ = x / xscale,
  lam = (p_k - base_k) / pscale): F~ and DF~ = [J_x, J_p[:, k] pscale / xscale];
* a Keller pseudo-arclength continuation loop: Euler predictor along the unit tangent, Newton
  corrector on (F~ = 0, t . (Y - Y_pred) = 0), the new tangent from [DF~; t_old] t = e_{n+1}, and
  PyCont's step control (the step grows by 1.2 after a corrector that converged in fewer than 6
  iterations, shrinks by 0.8 after a failure, and the branch ends when it fails at the minimum
  step), every point polished by Newton at fixed parameter (as autocable does after PyCont), the
  range end put exactly on the boundary, a closed curve detected as the PyCont driver does;
* F~ and DF~ at many points in one call (``ac_chart_batch``: the collocation points of a periodic
  orbit, `autocable.methods.continuation.compiled_cycles`);
* per point, the test functions autocable uses (`autocable.methods.continuation.equilibria`): the tangent's
  parameter component (LP), det [DF~; t] (BP), det(2J (.) I) (Hopf and neutral saddles, the
  bialternate product of `autocable.methods.continuation.events`), and the number of
  eigenvalues of J with positive real part from the Routh array of the characteristic polynomial;
* inside a step where a test function changes sign, an extra point on its zero (Illinois regula
  falsi in the arclength of the step, each trial point by Keller's corrector), as AUTO puts its
  special points on the branch: the special point is then bracketed tightly for autocable's
  locator;
* per point the eigenvalues of J (balancing, Hessenberg reduction by stabilised elimination,
  Francis double-shift QR: EISPACK's balanc/elmhes/hqr sequence), sorted by decreasing real part;
* autocable's locator itself (``ac_locate``: `chart._locate`'s Brent search on the chord, each
  trial point corrected orthogonally to it, with the analysis's LP, BP and Hopf test functions),
  Newton at fixed parameters (``ac_newton``, `equilibria.equilibrium_near`) and the tangent at
  a point (``ac_tangent``), so that a branch costs a few Python calls besides the loop.

Degenerate Routh arrays. The characteristic polynomial (Faddeev-LeVerrier) is taken for J / ||J||_F
so that its coefficients are O(1); when an entry of the Routh array's first column is below 1e-9
in modulus (an eigenvalue, or a pair sum, within about that of the imaginary axis relative to
||J||: at or next to a bifurcation point) or J = 0, the count is reported as -1, "undecided", and
the caller decides from numpy's eigenvalues. Counts that are decided are exact sign counts of
quantities computed in a few dozen flops from J.

Coefficients as run-time data. The numbers of the right-hand side are not printed into the C:
every Float becomes a weight w[k] (`autocable.codegen.coefficients`) read from the NW numbers after
the parameters (after the chart's numbers in a chart array), so one library serves every system
of one structure (the calibration's candidate models, the scenes of models that differ only in
numbers); J_x and J_p are differentiated from the template, so they read the same w.

Build. The source is keyed by a content hash of the right-hand side's structure (its template:
the Floats replaced by weight symbols), the names and the emitter version, not by the system's
name; the library lives in ``cache_root()/ckernel/<hash>/`` (its sha256 in ``kernel.json``,
checked before every load) and is compiled with gcc (``$CC`` if set) under an advisory file lock,
so concurrent processes build it once. Any compiler
failure raises `KernelBuildError` with one line naming the system, the compiler's first error and
what to do.
"""
from __future__ import annotations

import ctypes
import functools
import os
import shutil
import subprocess
import tempfile
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Callable, Sequence

import numpy as np
import sympy as sp
from sympy.core.function import AppliedUndef
from sympy.printing.c import C99CodePrinter

from autocable import _store as cache
from autocable.codegen.coefficients import Template
from autocable.model import derivatives

__all__ = ["KERNEL_VERSION", "KernelBuildError", "CKernel", "kernel_source", "compiled_kernel",
           "build_timing", "REASONS"]

#: Bump when the emitted C changes meaning: it is part of the content hash.
KERNEL_VERSION = "10"
CFLAGS = ("-O2", "-fPIC", "-shared", "-std=c99", "-Werror=implicit-function-declaration")

#: How a side of the branch ended (the ``reason`` code returned by the C loop).
REASONS = {1: "range", 2: "closed", 3: "max_points", 4: "step_collapse", 5: "no_convergence"}


class KernelBuildError(RuntimeError):
    """The C kernel could not be emitted, compiled or loaded (the message is one line)."""


class _Printer(C99CodePrinter):
    """C99 with named array slots for the symbols, integer powers as products and 17-digit floats."""

    def __init__(self, names):
        super().__init__()
        self._names = names

    def _print_Symbol(self, expr):
        return self._names.get(expr.name, expr.name)

    def _print_Float(self, expr):
        return repr(float(expr))

    def _print_Rational(self, expr):
        return f"({float(expr.p)!r}/{float(expr.q)!r})"

    def _print_Integer(self, expr):
        return f"{float(expr)!r}"

    def _print_Pow(self, expr):
        b, e = expr.as_base_exp()
        if e.is_Integer and 1 <= abs(int(e)) <= 8:
            base = self.parenthesize(b, 1000)
            prod = "*".join([base] * abs(int(e)))
            return f"({prod})" if int(e) > 0 else f"(1.0/({prod}))"
        if e == sp.Rational(1, 2):
            return f"sqrt({self._print(b)})"
        return super()._print_Pow(expr)


def _block(printer: _Printer, exprs, targets: Sequence[str], prefix: str) -> list[str]:
    # No cse pre-optimisations: sympy's "basic" ones (factor_terms) cost three quarters of the
    # emission (4.5 s -> 1.3 s CPU for the 2-dof wind AME, paid once per model) and saved no
    # operation (5383 against 5372 '*' and '+' in that kernel's C).
    subs, red = sp.cse(list(exprs), symbols=sp.numbered_symbols(prefix), optimizations=None)
    lines = [f"    const double {s.name} = {printer.doprint(e)};" for s, e in subs]
    lines += [f"    {t} = {printer.doprint(e)};" for t, e in zip(targets, red)]
    return lines


def kernel_source(variables: Sequence[str], parameters: Sequence[str], rhs: Sequence,
                  weights: Sequence[str] = ()) -> str:
    """The C text of the kernel for x' = rhs(x; p, w), x in ``variables``, p in ``parameters`` order,
    w the numeric coefficients named ``weights`` (`autocable.codegen.coefficients`), read at run
    time: from the NW numbers after the NP parameters of a parameter array, after the chart's
    (base, k, xscale, pscale) of a chart array."""
    n, m = len(variables), len(parameters)
    if n < 1:
        raise KernelBuildError("the C kernel needs at least one state variable")
    xs = [sp.Symbol(v) for v in variables]
    ps = [sp.Symbol(p) for p in parameters]
    names = {v: f"x[{i}]" for i, v in enumerate(variables)}
    names.update({p: f"p[{j}]" for j, p in enumerate(parameters)})
    names.update({w: f"w[{k}]" for k, w in enumerate(weights)})
    pr = _Printer(names)
    F = sp.Matrix([sp.sympify(e) for e in rhs])
    memo: dict = {}
    J = derivatives.jacobian(list(F), xs, memo)
    Jp = derivatives.jacobian(list(F), ps, memo) if m else sp.zeros(n, 0)
    body_f = _block(pr, list(F), [f"out[{i}]" for i in range(n)], "ac_tf")
    body_j = _block(pr, [J[i, j] for i in range(n) for j in range(n)],
                    [f"out[{i * n + j}]" for i in range(n) for j in range(n)], "ac_tj")
    # J_p one column per parameter: the chart needs only the continued parameter's.
    cols = []
    for j in range(m):
        body = _block(pr, [Jp[i, j] for i in range(n)], [f"out[{i}]" for i in range(n)], f"ac_tp{j}_")
        cols.append(f"    case {j}: {{\n" + "\n".join("    " + ln for ln in body) + "\n        break;\n    }")
    head = f"""/* autocable C kernel (version {KERNEL_VERSION}): x = ({', '.join(variables)}),
   p = ({', '.join(parameters)}). Generated from sympy; do not edit. */
#include <math.h>
#include <string.h>
#define N {n}
#define M {m if m else 1}
#define NP {m}
#define NW {len(weights)}

static void f_eval(const double *x, const double *p, const double *w, double *out) {{
    (void)x; (void)p; (void)w;
{chr(10).join(body_f)}
}}

static void jac_eval(const double *x, const double *p, const double *w, double *out) {{
    (void)x; (void)p; (void)w;
{chr(10).join(body_j)}
}}

/* Column j of J_p (n entries). */
static void jacp_col_eval(const double *x, const double *p, const double *w, int j, double *out) {{
    (void)x; (void)p; (void)w; (void)out;
    switch (j) {{
{chr(10).join(cols)}
    default: break;
    }}
}}

static void jacp_eval(const double *x, const double *p, const double *w, double *out) {{
    double col[N];
    int i, j;
    for (j = 0; j < NP; j++) {{
        jacp_col_eval(x, p, w, j, col);
        for (i = 0; i < N; i++) out[i * M + j] = col[i];
    }}
}}
"""
    return head + _GENERIC


# The system-independent part: chart, linear algebra, test functions, the continuation loop.
_GENERIC = r"""
/* A parameter array p holds the NP parameters, then the NW coefficients w. */
int ac_dims(int *out) { out[0] = N; out[1] = NP; out[2] = NW; return 0; }
void ac_f(const double *x, const double *p, double *out) { f_eval(x, p, p + NP, out); }
void ac_jac(const double *x, const double *p, double *out) { jac_eval(x, p, p + NP, out); }
void ac_jacp(const double *x, const double *p, double *out) { jacp_eval(x, p, p + NP, out); }

/* cfg = (base[0..NP-1], k, xscale, pscale, w[0..NW-1]); the chart keeps a pointer to w, so cfg
   outlives the chart (every chart lives inside one call that receives cfg). */
typedef struct { double base[M]; int k; double xs, ps; const double *w; } chart_t;

static void chart_of(const double *cfg, chart_t *c) {
    int j;
    for (j = 0; j < NP; j++) c->base[j] = cfg[j];
    c->k = (int)cfg[NP]; c->xs = cfg[NP + 1]; c->ps = cfg[NP + 2]; c->w = cfg + NP + 3;
}

/* F~(Y) (n), DF~(Y) (n x (n+1), row major, may be NULL), J_x physical (n x n, may be NULL). */
static void chart_eval(const chart_t *c, const double *Y, double *Fo, double *DF, double *Jx) {
    double x[N], p[M], f[N], J[N * N], Jp[N];
    int i, j;
    for (i = 0; i < N; i++) x[i] = Y[i] * c->xs;
    for (j = 0; j < NP; j++) p[j] = c->base[j];
    if (NP) p[c->k] += c->ps * Y[N];
    if (Fo) { f_eval(x, p, c->w, f); for (i = 0; i < N; i++) Fo[i] = f[i] / c->xs; }
    if (DF || Jx) {
        jac_eval(x, p, c->w, J);
        if (Jx) memcpy(Jx, J, sizeof(J));
        if (DF) {
            if (NP) jacp_col_eval(x, p, c->w, c->k, Jp);
            for (i = 0; i < N; i++) {
                for (j = 0; j < N; j++) DF[i * (N + 1) + j] = J[i * N + j];
                DF[i * (N + 1) + N] = NP ? Jp[i] * c->ps / c->xs : 0.0;
            }
        }
    }
}

void ac_chart(const double *cfg, const double *Y, double *Fo, double *DF) {
    chart_t c; chart_of(cfg, &c); chart_eval(&c, Y, Fo, DF, NULL);
}

/* F~ and DF~ at K points at once (the rows of Y, n+1 numbers each; Fo K x n, DF K x n x (n+1)):
   one call per collocation Jacobian instead of one per collocation point. */
void ac_chart_batch(const double *cfg, int K, const double *Y, double *Fo, double *DF) {
    chart_t c; int q; chart_of(cfg, &c);
    for (q = 0; q < K; q++) chart_eval(&c, Y + q * (N + 1), Fo + q * N, DF + q * N * (N + 1), NULL);
}

/* Gaussian elimination with partial pivoting of the n x n row-major A (destroyed); solves A z = b
   in place when b is not NULL; returns det A (0 on an exactly singular pivot). (Forcing it
   inline at its constant-size call sites saves ~8% of the loop's instructions but adds ~0.2 s of
   gcc time to every kernel build: not worth it.) */
static double lu_solve(int n, double *A, double *b) {
    int i, j, r, piv;
    double det = 1.0;
    for (j = 0; j < n; j++) {
        piv = j;
        for (r = j + 1; r < n; r++) if (fabs(A[r * n + j]) > fabs(A[piv * n + j])) piv = r;
        if (A[piv * n + j] == 0.0) return 0.0;
        if (piv != j) {
            /* Columns before j are no longer read. */
            for (i = j; i < n; i++) { double t = A[j * n + i]; A[j * n + i] = A[piv * n + i]; A[piv * n + i] = t; }
            if (b) { double t = b[j]; b[j] = b[piv]; b[piv] = t; }
            det = -det;
        }
        det *= A[j * n + j];
        for (r = j + 1; r < n; r++) {
            double l = A[r * n + j] / A[j * n + j];
            if (l == 0.0) continue;
            for (i = j + 1; i < n; i++) A[r * n + i] -= l * A[j * n + i];
            if (b) b[r] -= l * b[j];
        }
    }
    if (b) for (j = n - 1; j >= 0; j--) {
        double s = b[j];
        for (i = j + 1; i < n; i++) s -= A[j * n + i] * b[i];
        b[j] = s / A[j * n + j];
    }
    return det;
}

static double norm(int n, const double *v) { double s = 0; int i; for (i = 0; i < n; i++) s += v[i] * v[i]; return sqrt(s); }
static int all_finite(int n, const double *v) { int i; for (i = 0; i < n; i++) if (!isfinite(v[i])) return 0; return 1; }

/* det(2A (.) I), the bialternate product in the pair order of bifurcation_functions.bialternate. */
static double hopf_test(const double *A) {
#if N < 2
    (void)A; return 1.0;
#else
    enum { Q = N * (N - 1) / 2 };
    double B[Q * Q];
    int P[Q][2], a, b, n = 0, p, q, r, s;
    for (p = 1; p < N; p++) for (q = 0; q < p; q++) { P[n][0] = p; P[n][1] = q; n++; }
    for (a = 0; a < Q; a++) for (b = 0; b < Q; b++) {
        double v = 0.0;
        p = P[a][0]; q = P[a][1]; r = P[b][0]; s = P[b][1];
        if (r == q) v = -A[p * N + s];
        else if (r != p && s == q) v = A[p * N + r];
        else if (r == p && s == q) v = A[p * N + p] + A[q * N + q];
        else if (r == p && s != q) v = A[q * N + s];
        else if (s == p) v = -A[q * N + r];
        B[a * Q + b] = v;
    }
    return lu_solve(Q, B, NULL);
#endif
}

/* Eigenvalues of J with positive real part, from the Routh array of det(s I - J / ||J||_F);
   -1 when undecided (a first-column entry below 1e-9, or J = 0). */
static int unstable_count(const double *J) {
    double A[N * N], Mk[N * N], T[N * N], c[N + 1], R[N + 1][N + 2];
    double fro = 0.0, tr;
    int i, j, l, k, cols = N / 2 + 2, changes = 0;
    for (i = 0; i < N * N; i++) fro += J[i] * J[i];
    fro = sqrt(fro);
    if (!(fro > 0.0) || !isfinite(fro)) return -1;
    for (i = 0; i < N * N; i++) A[i] = J[i] / fro;
    /* Faddeev-LeVerrier: M_1 = I, c_k = -tr(A M_k) / k, M_{k+1} = A M_k + c_k I. */
    c[0] = 1.0;
    memset(Mk, 0, sizeof(Mk));
    for (i = 0; i < N; i++) Mk[i * N + i] = 1.0;
    for (k = 1; k <= N; k++) {
        for (i = 0; i < N; i++) for (j = 0; j < N; j++) {
            double s = 0; for (l = 0; l < N; l++) s += A[i * N + l] * Mk[l * N + j]; T[i * N + j] = s;
        }
        tr = 0; for (i = 0; i < N; i++) tr += T[i * N + i];
        c[k] = -tr / k;
        for (i = 0; i < N * N; i++) Mk[i] = T[i];
        for (i = 0; i < N; i++) Mk[i * N + i] += c[k];
    }
    for (i = 0; i <= N; i++) for (j = 0; j < N + 2; j++) R[i][j] = 0.0;
    for (j = 0; 2 * j <= N; j++) R[0][j] = c[2 * j];
    for (j = 0; 2 * j + 1 <= N; j++) R[1][j] = c[2 * j + 1];
    for (i = 2; i <= N; i++) {
        if (fabs(R[i - 1][0]) <= 1e-9) return -1;
        for (j = 0; j + 1 < cols; j++)
            R[i][j] = (R[i - 1][0] * R[i - 2][j + 1] - R[i - 2][0] * R[i - 1][j + 1]) / R[i - 1][0];
    }
    for (i = 0; i <= N; i++) if (fabs(R[i][0]) <= 1e-9) return -1;
    for (i = 1; i <= N; i++) if ((R[i][0] > 0) != (R[i - 1][0] > 0)) changes++;
    return changes;
}

/* Eigenvalues of the n x n row-major J (EISPACK's sequence: balancing by powers of 2, reduction
   to upper Hessenberg form by stabilised elimination, the Francis double-shift QR iteration).
   out = (re[0..n-1], im[0..n-1]) by decreasing real part, then decreasing imaginary part (the
   order autocable sorts numpy's eigenvalues in); NaN when the QR iteration does not converge. */
#define EH(i, j) a[(i) - 1][(j) - 1]
#define ESIGN(x, y) ((y) >= 0.0 ? fabs(x) : -fabs(x))
static void eigenvalues(const double *J, double *out) {
    double a[N][N], wr[N], wi[N];
    double anorm, p = 0, q = 0, r = 0, s, t, u, v, w, x, y, z;
    int i, j, k, l, m, nn, its, done;
    for (i = 0; i < N; i++) for (j = 0; j < N; j++) a[i][j] = J[i * N + j];
    do {                                    /* balance: rows and columns of equal norms */
        done = 1;
        for (i = 0; i < N; i++) {
            double cn = 0.0, rn = 0.0, f = 1.0, g, sum;
            for (j = 0; j < N; j++) if (j != i) { cn += fabs(a[j][i]); rn += fabs(a[i][j]); }
            if (cn == 0.0 || rn == 0.0 || !isfinite(cn + rn)) continue;
            g = rn / 2.0; sum = cn + rn;
            while (cn < g) { f *= 2.0; cn *= 4.0; }
            g = rn * 2.0;
            while (cn > g) { f /= 2.0; cn /= 4.0; }
            if ((cn + rn) / f < 0.95 * sum) {
                done = 0;
                for (j = 0; j < N; j++) a[i][j] /= f;
                for (j = 0; j < N; j++) a[j][i] *= f;
            }
        }
    } while (!done);
    for (m = 1; m < N - 1; m++) {           /* Hessenberg form, pivoting on the largest entry */
        x = 0.0; i = m;
        for (j = m; j < N; j++) if (fabs(a[j][m - 1]) > fabs(x)) { x = a[j][m - 1]; i = j; }
        if (i != m) {
            for (j = m - 1; j < N; j++) { y = a[i][j]; a[i][j] = a[m][j]; a[m][j] = y; }
            for (j = 0; j < N; j++) { y = a[j][i]; a[j][i] = a[j][m]; a[j][m] = y; }
        }
        if (x != 0.0) for (i = m + 1; i < N; i++) {
            y = a[i][m - 1];
            if (y == 0.0) continue;
            y /= x;
            a[i][m - 1] = 0.0;
            for (j = m; j < N; j++) a[i][j] -= y * a[m][j];
            for (j = 0; j < N; j++) a[j][m] += y * a[j][i];
        }
    }
    anorm = 0.0;                            /* QR iteration on the Hessenberg matrix (1-based EH) */
    for (i = 1; i <= N; i++) for (j = (i > 1 ? i - 1 : 1); j <= N; j++) anorm += fabs(EH(i, j));
    nn = N; t = 0.0;
    while (nn >= 1) {
        its = 0;
        do {
            for (l = nn; l >= 2; l--) {
                s = fabs(EH(l - 1, l - 1)) + fabs(EH(l, l));
                if (s == 0.0) s = anorm;
                if (fabs(EH(l, l - 1)) + s == s) { EH(l, l - 1) = 0.0; break; }
            }
            x = EH(nn, nn);
            if (l == nn) {                  /* one root */
                wr[nn - 1] = x + t; wi[nn - 1] = 0.0; nn--;
            } else {
                y = EH(nn - 1, nn - 1);
                w = EH(nn, nn - 1) * EH(nn - 1, nn);
                if (l == nn - 1) {          /* two roots */
                    p = 0.5 * (y - x);
                    q = p * p + w;
                    z = sqrt(fabs(q));
                    x += t;
                    if (q >= 0.0) {
                        z = p + ESIGN(z, p);
                        wr[nn - 2] = wr[nn - 1] = x + z;
                        if (z != 0.0) wr[nn - 1] = x - w / z;
                        wi[nn - 2] = wi[nn - 1] = 0.0;
                    } else {
                        wr[nn - 2] = wr[nn - 1] = x + p;
                        wi[nn - 2] = z; wi[nn - 1] = -z;
                    }
                    nn -= 2;
                } else {
                    if (its == 60 || !isfinite(x + y + w)) {
                        for (i = 0; i < 2 * N; i++) out[i] = NAN;
                        return;
                    }
                    if (its == 10 || its == 20) {   /* exceptional shift */
                        t += x;
                        for (i = 1; i <= nn; i++) EH(i, i) -= x;
                        s = fabs(EH(nn, nn - 1)) + fabs(EH(nn - 1, nn - 2));
                        y = x = 0.75 * s;
                        w = -0.4375 * s * s;
                    }
                    ++its;
                    for (m = nn - 2; m >= l; m--) { /* two small consecutive subdiagonal entries */
                        z = EH(m, m);
                        r = x - z;
                        s = y - z;
                        p = (r * s - w) / EH(m + 1, m) + EH(m, m + 1);
                        q = EH(m + 1, m + 1) - z - r - s;
                        r = EH(m + 2, m + 1);
                        s = fabs(p) + fabs(q) + fabs(r);
                        p /= s; q /= s; r /= s;
                        if (m == l) break;
                        u = fabs(EH(m, m - 1)) * (fabs(q) + fabs(r));
                        v = fabs(p) * (fabs(EH(m - 1, m - 1)) + fabs(z) + fabs(EH(m + 1, m + 1)));
                        if (u + v == v) break;
                    }
                    for (i = m + 2; i <= nn; i++) {
                        EH(i, i - 2) = 0.0;
                        if (i != m + 2) EH(i, i - 3) = 0.0;
                    }
                    for (k = m; k <= nn - 1; k++) {  /* the double QR step on rows l..nn */
                        if (k != m) {
                            p = EH(k, k - 1);
                            q = EH(k + 1, k - 1);
                            r = k != nn - 1 ? EH(k + 2, k - 1) : 0.0;
                            if ((x = fabs(p) + fabs(q) + fabs(r)) != 0.0) { p /= x; q /= x; r /= x; }
                        }
                        s = ESIGN(sqrt(p * p + q * q + r * r), p);
                        if (s == 0.0) continue;
                        if (k == m) { if (l != m) EH(k, k - 1) = -EH(k, k - 1); }
                        else EH(k, k - 1) = -s * x;
                        p += s;
                        x = p / s; y = q / s; z = r / s;
                        q /= p; r /= p;
                        for (j = k; j <= nn; j++) {
                            p = EH(k, j) + q * EH(k + 1, j);
                            if (k != nn - 1) { p += r * EH(k + 2, j); EH(k + 2, j) -= p * z; }
                            EH(k + 1, j) -= p * y;
                            EH(k, j) -= p * x;
                        }
                        for (i = l; i <= (nn < k + 3 ? nn : k + 3); i++) {
                            p = x * EH(i, k) + y * EH(i, k + 1);
                            if (k != nn - 1) { p += z * EH(i, k + 2); EH(i, k + 2) -= p * r; }
                            EH(i, k + 1) -= p * q;
                            EH(i, k) -= p;
                        }
                    }
                }
            }
        } while (l < nn - 1);
    }
    for (i = 1; i < N; i++) {               /* by decreasing real, then imaginary part */
        double ar = wr[i], ai = wi[i];
        for (j = i; j > 0 && (wr[j - 1] < ar || (wr[j - 1] == ar && wi[j - 1] < ai)); j--) {
            wr[j] = wr[j - 1]; wi[j] = wi[j - 1];
        }
        wr[j] = ar; wi[j] = ai;
    }
    for (i = 0; i < N; i++) { out[i] = wr[i]; out[N + i] = wi[i]; }
}
#undef EH
#undef ESIGN

/* For tests: the Hopf test function and the unstable count of an n x n row-major J. */
double ac_hopf(const double *J) { return hopf_test(J); }
void ac_eig(const double *J, double *out) { eigenvalues(J, out); }
int ac_count(const double *J) { return unstable_count(J); }

/* Unit tangent t with [DF; tref] t = e_{n+1} (so t . tref > 0); returns 0 on a singular system. */
static int tangent(const double *DF, const double *tref, double *t) {
    double A[(N + 1) * (N + 1)];
    int i;
    memcpy(A, DF, sizeof(double) * N * (N + 1));
    for (i = 0; i <= N; i++) { A[N * (N + 1) + i] = tref[i]; t[i] = 0.0; }
    t[N] = 1.0;
    if (lu_solve(N + 1, A, t) == 0.0 || !all_finite(N + 1, t)) return 0;
    double s = norm(N + 1, t);
    for (i = 0; i <= N; i++) t[i] /= s;
    return 1;
}

/* Newton on F~(Y) = 0, normal . (Y - target) = 0 from target (continuation_chart._correct). */
static int correct(const chart_t *c, double *Y, const double *target, const double *normal, double tol, int maxit) {
    double F[N], A[(N + 1) * (N + 1)], g[N + 1];
    int it, i;
    memcpy(Y, target, sizeof(double) * (N + 1));
    for (it = 0; it < maxit; it++) {
        chart_eval(c, Y, F, A, NULL);
        for (i = 0; i < N; i++) g[i] = F[i];
        g[N] = 0; for (i = 0; i <= N; i++) { g[N] += normal[i] * (Y[i] - target[i]); A[N * (N + 1) + i] = normal[i]; }
        if (lu_solve(N + 1, A, g) == 0.0) return 0;
        for (i = 0; i <= N; i++) Y[i] -= g[i];
        if (!all_finite(N + 1, Y)) { memcpy(Y, target, sizeof(double) * (N + 1)); return 0; }
        if (norm(N + 1, g) <= tol * (1.0 + norm(N + 1, Y))) return 1;
    }
    return 0;
}

/* Newton at fixed lam (equilibria.equilibrium_near in chart units, 8 iterations); the polished
   point is kept when it converged and moved by at most 1e-6 (|x~| + 1), as autocable does.
   F0 is F~(Y), already known to the caller (the corrector's last residual). */
static int polish(const chart_t *c, double *Y, double tol, const double *F0) {
    double Z[N + 1], F[N], J[N * N];
    int it, i, ok = 0;
    memcpy(Z, Y, sizeof(Z));
    for (it = 0; it < 8; it++) {
        if (it == 0) { memcpy(F, F0, sizeof(F)); chart_eval(c, Z, NULL, NULL, J); }
        else chart_eval(c, Z, F, NULL, J);
        if (lu_solve(N, J, F) == 0.0) break;
        for (i = 0; i < N; i++) Z[i] -= F[i];
        if (!all_finite(N + 1, Z)) return 0;
        if (norm(N, F) <= tol * (norm(N, Z) + 1.0)) { ok = 1; break; }
    }
    if (!ok) return 0;
    double d = 0; for (i = 0; i < N; i++) d += (Z[i] - Y[i]) * (Z[i] - Y[i]);
    if (sqrt(d) > 1e-6 * (norm(N, Y) + 1.0)) return 0;
    memcpy(Y, Z, sizeof(double) * N);
    return 1;
}

/* (vp, det [DF; t], det 2J(.)I) from DF~ and J_x at a point with tangent t. */
static void point_tests(const double *DF, const double *J, const double *t, double *v) {
    double A[(N + 1) * (N + 1)];
    memcpy(A, DF, sizeof(double) * N * (N + 1));
    memcpy(A + N * (N + 1), t, sizeof(double) * (N + 1));
    v[0] = t[N];
    v[1] = lu_solve(N + 1, A, NULL);
    v[2] = hopf_test(J);
}

/* Store point i: Y, its tangent, the tests v (from point_tests), the unstable count, J and its
   eigenvalues. */
static void store_at(int i, const double *Y, const double *t, const double *J, const double *v,
                     double *Ys, double *Ts, double *tests, int *npos, double *Js, double *Es) {
    memcpy(Ys + i * (N + 1), Y, sizeof(double) * (N + 1));
    memcpy(Ts + i * (N + 1), t, sizeof(double) * (N + 1));
    memcpy(tests + 3 * i, v, sizeof(double) * 3);
    npos[i] = unstable_count(J);
    memcpy(Js + i * N * N, J, sizeof(double) * N * N);
    eigenvalues(J, Es + 2 * N * i);
}

static void store(const chart_t *c, int i, const double *Y, const double *t, double *Ys, double *Ts,
                  double *tests, int *npos, double *Js, double *Es) {
    double DF[N * (N + 1)], J[N * N], v[3];
    chart_eval(c, Y, NULL, DF, J);
    point_tests(DF, J, t, v);
    store_at(i, Y, t, J, v, Ys, Ts, tests, npos, Js, Es);
}

/* The point where the hyperplane t . (Z - Y) = s meets the branch (Keller's corrector, to tol). */
static int keller(const chart_t *c, const double *Y, const double *t, double s, double tol, double *Z) {
    double P[N + 1], F[N], A[(N + 1) * (N + 1)], g[N + 1];
    int it, i;
    for (i = 0; i <= N; i++) Z[i] = P[i] = Y[i] + s * t[i];
    for (it = 0; it < 25; it++) {
        chart_eval(c, Z, F, A, NULL);
        for (i = 0; i < N; i++) g[i] = F[i];
        g[N] = 0; for (i = 0; i <= N; i++) { g[N] += t[i] * (Z[i] - P[i]); A[N * (N + 1) + i] = t[i]; }
        if (lu_solve(N + 1, A, g) == 0.0) return 0;
        for (i = 0; i <= N; i++) Z[i] -= g[i];
        if (!all_finite(N + 1, Z)) return 0;
        if (norm(N + 1, g) <= tol * (1.0 + norm(N + 1, Z))) return 1;
    }
    return 0;
}

/* (vp, det [DF; t], det 2J(.)I) at Y with tangent t. */
static void tests_at(const chart_t *c, const double *Y, const double *t, double *v) {
    double DF[N * (N + 1)], J[N * N];
    chart_eval(c, Y, NULL, DF, J);
    point_tests(DF, J, t, v);
}

/* A zero of test k inside the step from (Y, t) (value f0) to the point at s = ds (value f1, end
   tangent t1), the way AUTO puts its special points on the branch: Illinois regula falsi in s,
   each trial point by `keller`. The tangent of a trial point is solved for LP and H; for BP it
   is interpolated between t and t1 (next to a BP the kernel of DF is nearly 2-D and the solved
   tangent is not defined; det [DF; t] vanishes there for any t). Returns s of the zero found
   (|test| <= 1e-10 max(|f0|, |f1|)), or -1. */
static double locate_zero(const chart_t *c, const double *Y, const double *t, const double *t1, double ds,
                          int k, double f0, double f1, double ntol, double *Z, double *tz) {
    double a = 0.0, b = ds, fa = f0, fb = f1, big = fmax(fabs(f0), fabs(f1)), v[3], DF[N * (N + 1)];
    int it, side = 0, i;
    for (it = 0; it < 60; it++) {
        double s = (a * fb - b * fa) / (fb - fa);
        if (!(s > a && s < b)) s = 0.5 * (a + b);
        if (!keller(c, Y, t, s, ntol, Z)) return -1.0;
        if (k == 1) {
            double w = s / ds;
            for (i = 0; i <= N; i++) tz[i] = (1.0 - w) * t[i] + w * t1[i];
            double nz = norm(N + 1, tz);
            for (i = 0; i <= N; i++) tz[i] /= nz;
        } else {
            chart_eval(c, Z, NULL, DF, NULL);
            if (!tangent(DF, t, tz)) return -1.0;
        }
        tests_at(c, Z, tz, v);
        if (fabs(v[k]) <= 1e-12 * big || b - a <= 1e-15 * ds) return fabs(v[k]) <= 1e-10 * big ? s : -1.0;
        if ((v[k] > 0) == (fb > 0)) { b = s; fb = v[k]; if (side == -1) fa *= 0.5; side = -1; }
        else { a = s; fa = v[k]; if (side == 1) fb *= 0.5; side = 1; }
    }
    return -1.0;
}

/* ---- chart._locate in C: a test function's zero on the branch between two of its points ---- */
typedef struct { const chart_t *c; const double *Ya; double d[N + 1], dn[N + 1]; int kind; double tol; } seg_t;

/* The branch point of chord parameter s: Newton orthogonally to the chord from Ya + s d
   (chart._correct); the uncorrected point when Newton fails. */
static void seg_point(const seg_t *g, double s, double *Y) {
    double T[N + 1];
    int i;
    for (i = 0; i <= N; i++) T[i] = g->Ya[i] + s * g->d[i];
    if (!correct(g->c, Y, T, g->d, g->tol, 25)) memcpy(Y, T, sizeof(T));
}

/* The test functions of equilibrium_analysis at Y: kind 0 (LP) the unit tangent's parameter
   component, the tangent oriented along the chord; 1 (BP) det [DF~; chord / |chord|];
   2 (H) det 2J(.)I. */
static double seg_test(const seg_t *g, const double *Y) {
    double DF[N * (N + 1)], J[N * N], A[(N + 1) * (N + 1)], t[N + 1];
    if (g->kind == 2) { chart_eval(g->c, Y, NULL, NULL, J); return hopf_test(J); }
    chart_eval(g->c, Y, NULL, DF, NULL);
    if (g->kind == 0) return tangent(DF, g->d, t) ? t[N] : NAN;
    memcpy(A, DF, sizeof(DF));
    memcpy(A + N * (N + 1), g->dn, sizeof(double) * (N + 1));
    return lu_solve(N + 1, A, NULL);
}

static double seg_value(const seg_t *g, double s) { double Y[N + 1]; seg_point(g, s, Y); return seg_test(g, Y); }

static int sgn(double v) { return (v == 0.0 || !isfinite(v)) ? 0 : (v > 0.0 ? 1 : -1); }

/* Brent's root finder on [xa, xb] (fa, fb: the values there, of opposite signs) with the step
   rules and stopping test of scipy.optimize.brentq (tolerance xtol + rtol |x|), so that it visits
   the trial points the Python locator visits. *conv = 1 when converged within maxiter. */
static double brent(const seg_t *g, double xa, double xb, double fa, double fb, double xtol, double rtol,
                    int maxiter, int *conv) {
    double xp = xa, fp = fa, xc = xb, fc = fb, xk = 0.0, fk = 0.0, sp = 0.0, sc = 0.0;
    int it;
    *conv = 1;
    if (fp == 0.0) return xp;
    if (fc == 0.0) return xc;
    *conv = 0;
    for (it = 0; it < maxiter; it++) {
        double del, half, trial, lim;
        if (fp * fc < 0.0) { xk = xp; fk = fp; sp = sc = xc - xp; }  /* xk: the other end of the bracket */
        if (fabs(fk) < fabs(fc)) {                                       /* xc: the best estimate */
            xp = xc; xc = xk; xk = xp;
            fp = fc; fc = fk; fk = fp;
        }
        del = (xtol + rtol * fabs(xc)) / 2.0;
        half = (xk - xc) / 2.0;
        if (fc == 0.0 || fabs(half) < del) { *conv = 1; return xc; }
        if (fabs(sp) > del && fabs(fc) < fabs(fp)) {
            if (xp == xk) trial = -fc * (xc - xp) / (fc - fp);       /* secant */
            else {                                                     /* inverse quadratic */
                double dp = (fp - fc) / (xp - xc), dk = (fk - fc) / (xk - xc);
                trial = -fc * (fk * dk - fp * dp) / (dk * dp * (fk - fp));
            }
            lim = 3.0 * fabs(half) - del;
            if (fabs(sp) < lim) lim = fabs(sp);
            if (2.0 * fabs(trial) < lim) { sp = sc; sc = trial; }
            else { sp = half; sc = half; }
        } else { sp = half; sc = half; }
        xp = xc; fp = fc;
        xc += fabs(sc) > del ? sc : (half > 0.0 ? del : -del);
        fc = seg_value(g, xc);
    }
    return xc;
}

/* chart._locate (with equilibrium_analysis's test functions) for test `kind` between the branch
   points Ya and Yb: Y gets the point; returns 1 when the zero was bracketed and Brent converged. */
int ac_locate(const double *cfg, const double *Ya, const double *Yb, int kind, double tol, double *Y) {
    chart_t c;
    seg_t g;
    double ga, gb, s, nd = 0.0;
    int i, conv;
    chart_of(cfg, &c);
    g.c = &c; g.Ya = Ya; g.kind = kind; g.tol = tol;
    for (i = 0; i <= N; i++) { g.d[i] = Yb[i] - Ya[i]; nd += g.d[i] * g.d[i]; }
    nd = sqrt(nd);
    for (i = 0; i <= N; i++) g.dn[i] = g.d[i] / nd;
    ga = seg_value(&g, 0.0);
    gb = seg_value(&g, 1.0);
    if (isfinite(ga) && isfinite(gb) && sgn(ga) * sgn(gb) > 0) {
        /* A point already on the zero (the kernel's located point): an end whose test value is
           negligible against the other's. */
        int a_small = fabs(ga) <= fabs(gb);
        if ((a_small ? fabs(ga) : fabs(gb)) <= 1e-9 * (a_small ? fabs(gb) : fabs(ga))) {
            seg_point(&g, a_small ? 0.0 : 1.0, Y);
            return 1;
        }
    }
    if (!(isfinite(ga) && isfinite(gb)) || sgn(ga) * sgn(gb) > 0) {
        s = ga == gb ? 0.5 : ga / (ga - gb);
        s = s > 0.0 ? (s < 1.0 ? s : 1.0) : 0.0;
        seg_point(&g, s, Y);
        return 0;
    }
    if (ga == 0.0) { seg_point(&g, 0.0, Y); return 1; }
    if (gb == 0.0) { seg_point(&g, 1.0, Y); return 1; }
    s = brent(&g, 0.0, 1.0, ga, gb, 1e-14, 1e-15, 100, &conv);
    seg_point(&g, s, Y);
    return conv;
}

/* equilibria.equilibrium_near on the kernel's f and J_x: Newton at fixed p from x0 (the step
   criterion relative to |x| + scale); res = max |f(x)| (infinite when an iterate is not finite,
   x then x0). Returns 1 when converged. */
int ac_newton(const double *x0, const double *p, double tol, double scale, int maxiter, double *x, double *res) {
    double f[N], J[N * N];
    const double *w = p + NP;
    int it, i, conv = 0;
    memcpy(x, x0, sizeof(double) * N);
    for (it = 0; it < maxiter; it++) {
        f_eval(x, p, w, f);
        jac_eval(x, p, w, J);
        if (lu_solve(N, J, f) == 0.0) break;
        for (i = 0; i < N; i++) x[i] -= f[i];
        if (!all_finite(N, x)) { memcpy(x, x0, sizeof(double) * N); *res = INFINITY; return 0; }
        if (norm(N, f) <= tol * (norm(N, x) + scale)) { conv = 1; break; }
    }
    f_eval(x, p, w, f);
    *res = 0.0;
    for (i = 0; i < N; i++) if (!(fabs(f[i]) <= *res)) *res = fabs(f[i]);
    return conv;
}

/* The unit tangent at Y with [DF~; tref] t = e_{n+1} (t . tref > 0); 0 when singular. */
int ac_tangent(const double *cfg, const double *Y, const double *tref, double *t) {
    chart_t c;
    double DF[N * (N + 1)];
    chart_of(cfg, &c);
    chart_eval(&c, Y, NULL, DF, NULL);
    return tangent(DF, tref, t);
}

/* One side of a branch from Y0 along the unit direction d0.
   opts = (step, min_step, max_step, tol, max_corrector_iters, lam_lo, lam_hi, newton_tol,
           locate): locate = 1 puts a point on every zero of a test function inside a step.
   Outputs, max_points rows each: Ys, Ts (n+1), tests (3), npos, Js (n*n), polished (1/0).
   Returns the number of points (the first is Y0); *reason gets a REASONS code. */
int ac_continue(const double *cfg, const double *Y0, const double *d0, const double *opts, int max_points,
                double *Ys, double *Ts, double *tests, int *npos, double *Js, double *Es, int *polished,
                int *reason) {
    chart_t c;
    double Y[N + 1], Yp[N + 1], Yc[N + 1], t[N + 1], tn[N + 1], F[N], DF[N * (N + 1)], A[(N + 1) * (N + 1)], g[N + 1];
    double J[N * N], v1[3];
    double ds = opts[0], dsmin = opts[1], dsmax = opts[2], tol = opts[3], lo = opts[5], hi = opts[6], ntol = opts[7];
    double span = 0.0, used = ds;
    int maxit = (int)opts[4], np_ = 0, i, k, conv, locate = opts[8] != 0.0;
    chart_of(cfg, &c);
    memcpy(Y, Y0, sizeof(Y));
    chart_eval(&c, Y, NULL, DF, J);
    if (!tangent(DF, d0, t)) memcpy(t, d0, sizeof(t));
    point_tests(DF, J, t, v1);
    store_at(0, Y, t, J, v1, Ys, Ts, tests, npos, Js, Es);
    polished[0] = 0;
    np_ = 1;
    *reason = 3;
    while (np_ < max_points) {
        for (i = 0; i <= N; i++) Yp[i] = Y[i] + ds * t[i];
        memcpy(Yc, Yp, sizeof(Yc));
        conv = 0;
        for (k = 1; k <= maxit; k++) {
            /* After the first iteration F~(Yc) is the residual just checked below. */
            chart_eval(&c, Yc, k == 1 ? F : NULL, DF, NULL);
            memcpy(A, DF, sizeof(DF));
            for (i = 0; i < N; i++) g[i] = F[i];
            g[N] = 0; for (i = 0; i <= N; i++) { g[N] += t[i] * (Yc[i] - Yp[i]); A[N * (N + 1) + i] = t[i]; }
            if (lu_solve(N + 1, A, g) == 0.0) break;
            for (i = 0; i <= N; i++) Yc[i] -= g[i];
            if (!all_finite(N + 1, Yc)) break;
            chart_eval(&c, Yc, F, NULL, NULL);
            if (!all_finite(N, F)) break;
            if (norm(N, F) < tol && norm(N + 1, g) < tol) { conv = 1; break; }
        }
        if (!conv) {
            if (ds > dsmin) { ds = fmax(dsmin, ds * 0.8); continue; }
            *reason = 4;
            return np_;
        }
        used = ds;
        if (ds < dsmax && k < 6) ds = fmin(dsmax, ds * 1.2);
        polished[np_] = polish(&c, Yc, ntol, F);
        chart_eval(&c, Yc, NULL, DF, J);
        if (!tangent(DF, t, tn)) memcpy(tn, t, sizeof(tn));
        if (!(lo - 1e-12 <= Yc[N] && Yc[N] <= hi + 1e-12)) {
            double bound = Yc[N] > hi ? hi : lo;
            if (fabs(Y[N] - bound) <= 1e-12) { *reason = 1; return np_; }
            double s = (bound - Y[N]) / (Yc[N] - Y[N]), guess[N + 1], e[N + 1], Yb[N + 1];
            for (i = 0; i <= N; i++) { guess[i] = Y[i] + s * (Yc[i] - Y[i]); e[i] = 0.0; }
            e[N] = 1.0;
            if (!correct(&c, Yb, guess, e, ntol, 25)) memcpy(Yb, guess, sizeof(Yb));
            chart_eval(&c, Yb, NULL, DF, NULL);
            if (!tangent(DF, t, tn)) memcpy(tn, t, sizeof(tn));
            store(&c, np_, Yb, tn, Ys, Ts, tests, npos, Js, Es);
            polished[np_] = 0;
            *reason = 1;
            return np_ + 1;
        }
        point_tests(DF, J, tn, v1);
        if (locate) {
            /* Zeros of the test functions inside this step, in order of s, become points. */
            double sz[3], Zs[3][N + 1], Tz[3][N + 1];
            int kk, m = 0, order[3];
            for (kk = 0; kk < (N >= 2 ? 3 : 2); kk++) {
                double f0 = tests[3 * (np_ - 1) + kk];
                if (!(f0 * v1[kk] < 0.0)) continue;
                sz[m] = locate_zero(&c, Y, t, tn, used, kk, f0, v1[kk], ntol, Zs[m], Tz[m]);
                if (sz[m] > 0.0) { order[m] = m; m++; }
            }
            for (i = 1; i < m; i++) for (k = i; k > 0 && sz[order[k]] < sz[order[k - 1]]; k--) {
                int tmp = order[k]; order[k] = order[k - 1]; order[k - 1] = tmp;
            }
            for (i = 0; i < m && np_ + 1 < max_points; i++) {
                store(&c, np_, Zs[order[i]], Tz[order[i]], Ys, Ts, tests, npos, Js, Es);
                polished[np_] = 1;
                np_++;
            }
        }
        store_at(np_, Yc, tn, J, v1, Ys, Ts, tests, npos, Js, Es);
        np_++;
        memcpy(Y, Yc, sizeof(Y));
        memcpy(t, tn, sizeof(t));
        double d = 0; for (i = 0; i <= N; i++) d += (Y[i] - Y0[i]) * (Y[i] - Y0[i]);
        d = sqrt(d);
        if (d > span) span = d;
        /* A closed curve: back at the start after having gone away (the PyCont driver's test). */
        if (np_ > 8 && span > 4 * dsmax && d < 1.5 * dsmax && np_ < max_points) {
            double DF0[N * (N + 1)], t0[N + 1];
            chart_eval(&c, Y0, NULL, DF0, NULL);
            if (!tangent(DF0, t, t0)) memcpy(t0, t, sizeof(t0));
            store(&c, np_, Y0, t0, Ys, Ts, tests, npos, Js, Es);
            polished[np_] = 0;
            *reason = 2;
            return np_ + 1;
        }
    }
    return np_;
}
"""


# ------------------------------------------------------------------------------------------------
# build and load
# ------------------------------------------------------------------------------------------------
def _lock(folder: Path):
    """Serialise builds of one kernel across processes (`autocable._store.cache_lock`: recovers
    from a damaged lock file, runs unlocked in a read-only cache)."""
    return cache.cache_lock(folder / "build.lock")


#: The manifest beside ``kernel.so``: the library's sha256, checked before every load.
MANIFEST = "kernel.json"


def _library_ok(folder: Path) -> bool:
    lib = folder / "kernel.so"
    manifest = cache.load_checked_json(folder / MANIFEST, None)
    return (isinstance(manifest, dict) and lib.is_file()
            and manifest.get("library_sha256") == cache.file_sha256(lib))


def cached_library(folder: Path, build: Callable[[], None], what: str, code: str | None = None) -> tuple[Path, bool]:
    """``folder/kernel.so``, built by ``build()`` unless a library that matches its manifest's
    sha256 is there; returns (path, built). A library that fails the check (edited, truncated,
    from a killed build) is rebuilt with one stderr line. A warm folder is only read. ``code``: the
    fingerprint of the code generator the folder's key holds (`autocable._store.code_fingerprint`);
    a library built while that code changed gets no manifest (used now, rebuilt by the next
    process) and one line says so."""
    lib = folder / "kernel.so"
    if _library_ok(folder):
        return lib, False
    with _lock(folder):
        if _library_ok(folder):          # another process built it while we waited
            return lib, False
        if lib.exists() or (folder / MANIFEST).exists():
            cache.report_rebuilt(f"{what} {folder.name}")
        build()
        why = cache.code_refusal("kernel", code) if code else ""
        if why:
            cache.report_not_stored(f"{what} {folder.name}", why)
            (folder / MANIFEST).unlink(missing_ok=True)
        else:
            cache.store_checked_json(folder / MANIFEST, {"library_sha256": cache.file_sha256(lib)})
    return lib, True


def _key(variables, parameters, template, cc: str, code: str | None = None) -> str:
    # The system-independent C text too: an edit to it that forgets KERNEL_VERSION still rebuilds;
    # and the generator's own files (``code``, `autocable._store.code_fingerprint`), for an edit
    # anywhere in the code that prints the C.
    # The structure only (the template's key): neither the coefficients nor the system's name,
    # so every model of one structure shares the library.
    return cache.content_hash({"version": KERNEL_VERSION, "generic": _GENERIC, "variables": list(variables),
                               "code": code or cache.code_fingerprint("kernel"),
                               "parameters": list(parameters), "rhs": template.key,
                               "weights": list(template.weight_names), "cc": cc, "cflags": list(CFLAGS)})


def _first_error(text: str) -> str:
    lines = [ln.strip() for ln in text.splitlines() if ln.strip()]
    for ln in lines:
        if "error" in ln.lower():
            return ln
    return lines[0] if lines else "no message"


def _compile(source: str, folder: Path, cc: str, label: str | None) -> Path:
    """gcc on ``source`` into ``folder/kernel.so``; errors start "C kernel of <label>: " (nothing
    when ``label`` is None: the caller names the system)."""
    lib = folder / "kernel.so"
    src = folder / "kernel.c"
    exe = shutil.which(cc)
    who = f"C kernel of {label}: " if label else ""
    if exe is None:
        raise KernelBuildError(f"{who}compiler {cc!r} not found; install gcc or set "
                               f"CC to a C compiler")
    try:
        cache.atomic_write_text(src, source)
        fd, tmp = tempfile.mkstemp(prefix=".kernel.", suffix=".so", dir=folder)
    except OSError as exc:
        raise cache.cache_error(folder, exc) from None
    os.close(fd)
    try:
        done = subprocess.run([exe, *CFLAGS, "-o", tmp, str(src), "-lm"], capture_output=True, text=True)
        if done.returncode != 0:
            raise KernelBuildError(f"{who}{cc} failed: {_first_error(done.stderr)} "
                                   f"(source kept in {src}); use engine='pycont' for this system")
        os.chmod(tmp, cache.file_mode())   # not mkstemp's 0600: other users of a shared cache load it
        os.replace(tmp, lib)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    return lib


@dataclass(frozen=True, eq=False)
class CKernel:
    """A loaded kernel: F, J_x, J_p, the chart and the continuation loop of one system.

    The library is built for the system's structure; ``weights`` are this system's numeric
    coefficients (`autocable.codegen.coefficients`), appended to every parameter array and chart
    passed to C. A chart ``cfg`` is (base, k, xscale, pscale), or that followed by the weights
    (`config`), which spares the copy on every call."""

    n: int
    m: int
    path: Path
    lib: ctypes.CDLL
    timings: tuple  # (("emit_s", s), ("compile_s", s), ("load_s", s)); zeros when cached
    weights: np.ndarray = field(default_factory=lambda: np.empty(0))

    def config(self, base, k: int, xscale: float, pscale: float) -> np.ndarray:
        """The chart array (base, k, xscale, pscale, weights) of the methods that take ``cfg``."""
        return np.concatenate([np.asarray(base, float), [k, xscale, pscale], self.weights]).astype(float)

    def _p(self, p) -> np.ndarray:
        p = np.asarray(p, float)
        if p.shape != (self.m,):
            raise ValueError(f"the C kernel takes {self.m} parameters, got {np.shape(p)}")
        return np.concatenate([p, self.weights]) if self.weights.size else np.ascontiguousarray(p)

    def _cfg(self, cfg) -> np.ndarray:
        cfg = np.ascontiguousarray(cfg, float)
        if cfg.shape[0] == self.m + 3 + self.weights.size:
            return cfg
        if cfg.shape[0] == self.m + 3:
            return np.concatenate([cfg, self.weights])
        raise ValueError(f"a chart of the C kernel has {self.m + 3} numbers (base, k, xscale, pscale), "
                         f"got {cfg.shape[0]}")

    def f(self, x, p) -> np.ndarray:
        out = np.empty(self.n)
        x, p = _c(x), self._p(p)   # named: a temporary copy would be freed before the call
        self.lib.ac_f(_ptr(x), _ptr(p), _ptr(out))
        return out

    def jac(self, x, p) -> np.ndarray:
        out = np.empty((self.n, self.n))
        x, p = _c(x), self._p(p)   # named: a temporary copy would be freed before the call
        self.lib.ac_jac(_ptr(x), _ptr(p), _ptr(out))
        return out

    def jac_p(self, x, p) -> np.ndarray:
        out = np.empty((self.n, max(self.m, 1)))
        x, p = _c(x), self._p(p)   # named: a temporary copy would be freed before the call
        self.lib.ac_jacp(_ptr(x), _ptr(p), _ptr(out))
        return out[:, :self.m]

    def chart(self, cfg: np.ndarray, Y, derivative: bool) -> np.ndarray:
        """F~(Y) (``derivative`` False) or DF~(Y) (True) in the chart ``cfg`` = (base, k, xscale, pscale)."""
        cfg = self._cfg(cfg)
        Y = np.ascontiguousarray(Y, float)
        if derivative:
            out = np.empty((self.n, self.n + 1))
            self.lib.ac_chart(_ptr(cfg), _ptr(Y), None, _ptr(out))
        else:
            out = np.empty(self.n)
            self.lib.ac_chart(_ptr(cfg), _ptr(Y), _ptr(out), None)
        return out

    def hopf_test(self, J) -> float:
        """det(2J (.) I) as the loop computes it (1 for n = 1)."""
        J = _c(J)
        return float(self.lib.ac_hopf(_ptr(J)))

    def unstable_count(self, J) -> int:
        """Eigenvalues of J with positive real part by the loop's Routh count (-1: undecided)."""
        J = _c(J)
        return int(self.lib.ac_count(_ptr(J)))

    def both(self, cfg: np.ndarray, Y) -> tuple[np.ndarray, np.ndarray]:
        """(F~(Y), DF~(Y)) in one call."""
        cfg = self._cfg(cfg)
        Y = np.ascontiguousarray(Y, float)
        f, df = np.empty(self.n), np.empty((self.n, self.n + 1))
        self.lib.ac_chart(_ptr(cfg), _ptr(Y), _ptr(f), _ptr(df))
        return f, df

    def chart_batch(self, cfg: np.ndarray, Y) -> tuple[np.ndarray, np.ndarray]:
        """(F~, DF~) at every row of ``Y`` (K x (n+1)): arrays K x n and K x n x (n+1)."""
        cfg = self._cfg(cfg)
        Y = np.ascontiguousarray(Y, float)
        K = Y.shape[0]
        f, df = np.empty((K, self.n)), np.empty((K, self.n, self.n + 1))
        self.lib.ac_chart_batch(_ptr(cfg), K, _ptr(Y), _ptr(f), _ptr(df))
        return f, df

    def eigenvalues(self, J) -> np.ndarray:
        """Eigenvalues of J as the loop computes them (balancing, Hessenberg, double-shift QR), by
        decreasing real part, then decreasing imaginary part; NaN when QR did not converge."""
        J = _c(J)
        out = np.empty(2 * self.n)
        self.lib.ac_eig(_ptr(J), _ptr(out))
        return out[:self.n] + 1j * out[self.n:]

    def locate(self, cfg: np.ndarray, Ya, Yb, kind: int, tol: float) -> tuple[np.ndarray, bool]:
        """`chart._locate` of test ``kind`` (0 LP, 1 BP, 2 H: the test functions of
        `equilibrium_analysis`) between the branch points Ya and Yb, in C: (Y, converged)."""
        cfg = self._cfg(cfg)
        Ya, Yb = _c(Ya), _c(Yb)
        Y = np.empty(self.n + 1)
        ok = self.lib.ac_locate(_ptr(cfg), _ptr(Ya), _ptr(Yb), int(kind), float(tol),
                                _ptr(Y))
        return Y, bool(ok)

    def newton(self, x0, p, tol: float, scale: float, maxiter: int = 50) -> tuple[np.ndarray, bool, float]:
        """`equilibria.equilibrium_near` on the kernel's f and J_x: (x, converged, max|f|)."""
        x0, p = _c(x0), self._p(p)
        x, res = np.empty(self.n), np.empty(1)
        ok = self.lib.ac_newton(_ptr(x0), _ptr(p), float(tol), float(scale), int(maxiter),
                                _ptr(x), _ptr(res))
        return x, bool(ok), float(res[0])

    def tangent(self, cfg: np.ndarray, Y, tref) -> np.ndarray | None:
        """The unit tangent at Y with t . tref > 0 ([DF~; tref] t = e_{n+1}), or None when singular."""
        cfg = self._cfg(cfg)
        Y, tref = _c(Y), _c(tref)
        t = np.empty(self.n + 1)
        ok = self.lib.ac_tangent(_ptr(cfg), _ptr(Y), _ptr(tref), _ptr(t))
        return t if ok else None

    def continue_side(self, cfg: np.ndarray, Y0, d0, opts: Sequence[float], max_points: int) -> dict:
        """One side of a branch (see the C ``ac_continue``): arrays of the points, their tests and
        the eigenvalues of J at each (``E``, sorted as `eigenvalues` sorts them)."""
        n1, mp = self.n + 1, max(int(max_points), 1)
        Ys, Ts = np.empty((mp, n1)), np.empty((mp, n1))
        tests, Js, Es = np.empty((mp, 3)), np.empty((mp, self.n, self.n)), np.empty((mp, 2, self.n))
        npos, pol, reason = np.empty(mp, np.intc), np.empty(mp, np.intc), np.zeros(1, np.intc)
        o = np.ascontiguousarray(opts, float)
        cfg = self._cfg(cfg)
        Y0, d0 = _c(Y0), _c(d0)
        k = self.lib.ac_continue(_ptr(cfg), _ptr(Y0), _ptr(d0), _ptr(o), mp,
                                 _ptr(Ys), _ptr(Ts), _ptr(tests), _ptr(npos),
                                 _ptr(Js), _ptr(Es), _ptr(pol), _ptr(reason))
        return {"Y": Ys[:k], "T": Ts[:k], "tests": tests[:k], "npos": npos[:k].astype(int), "J": Js[:k],
                "E": Es[:k, 0] + 1j * Es[:k, 1], "polished": pol[:k].astype(bool),
                "reason": REASONS.get(int(reason[0]), "error")}


_CHAR = ctypes.c_char


def _ptr(a: np.ndarray) -> int:
    """The address of ``a``'s data. ``a.ctypes.data`` builds a Python object and imports a module
    on every access (about 1 us, several per kernel call); a ctypes view of a writable buffer is a
    few times cheaper. The caller keeps ``a`` alive until the C call returns (as with .ctypes)."""
    try:
        return ctypes.addressof(_CHAR.from_buffer(a))
    except (TypeError, ValueError, BufferError):   # read-only or empty arrays
        return a.ctypes.data


def _c(a) -> np.ndarray:
    """``a`` as a C-contiguous float array. Callers keep it in a variable until the C call returns:
    ``_c(a).ctypes.data`` of a copy (e.g. of a list) points into memory freed at once."""
    return np.ascontiguousarray(a, float)


def load_private(path: Path) -> ctypes.CDLL:
    """The library at ``path`` loaded from a private copy beside it, unlinked once loaded.

    autocable replaces cache files by rename only (`_compile`, `autocable._store.atomic_write_bytes`:
    a new inode, so a process that mapped the old library keeps it whole). A library rewritten in
    place by anything else (``cp`` over it) would otherwise crash every process that mapped it with
    SIGBUS at its next call; the copy's mapping never changes. In a read-only cache the library is
    loaded where it is."""
    try:
        fd, tmp = tempfile.mkstemp(prefix=".load.", suffix=".so", dir=path.parent)
    except OSError:
        return ctypes.CDLL(str(path))
    try:
        with os.fdopen(fd, "wb") as dst, open(path, "rb") as src:
            shutil.copyfileobj(src, dst)
        return ctypes.CDLL(tmp)
    finally:
        os.unlink(tmp)


def _load(path: Path, n: int, m: int, nw: int, timings) -> CKernel:
    try:
        lib = load_private(path)
    except OSError as exc:
        raise KernelBuildError(f"C kernel {path.name}: could not be loaded ({exc}); delete "
                               f"{path.parent} to rebuild it") from None
    vp, ip = ctypes.c_void_p, ctypes.c_int
    for fn in ("ac_f", "ac_jac", "ac_jacp"):
        getattr(lib, fn).argtypes = [vp, vp, vp]
        getattr(lib, fn).restype = None
    lib.ac_chart.argtypes = [vp, vp, vp, vp]
    lib.ac_chart.restype = None
    lib.ac_chart_batch.argtypes = [vp, ip, vp, vp, vp]
    lib.ac_chart_batch.restype = None
    lib.ac_continue.argtypes = [vp, vp, vp, vp, ip, vp, vp, vp, vp, vp, vp, vp, vp]
    lib.ac_continue.restype = ip
    lib.ac_locate.argtypes = [vp, vp, vp, ip, ctypes.c_double, vp]
    lib.ac_locate.restype = ip
    lib.ac_newton.argtypes = [vp, vp, ctypes.c_double, ctypes.c_double, ip, vp, vp]
    lib.ac_newton.restype = ip
    lib.ac_tangent.argtypes = [vp, vp, vp, vp]
    lib.ac_tangent.restype = ip
    lib.ac_eig.argtypes = [vp, vp]
    lib.ac_eig.restype = None
    lib.ac_dims.argtypes = [vp]
    lib.ac_hopf.argtypes = [vp]
    lib.ac_hopf.restype = ctypes.c_double
    lib.ac_count.argtypes = [vp]
    lib.ac_count.restype = ip
    dims = np.zeros(3, np.intc)
    lib.ac_dims(_ptr(dims))
    if (int(dims[0]), int(dims[1]), int(dims[2])) != (n, m, nw):
        raise KernelBuildError(f"C kernel {path}: built for n = {dims[0]}, m = {dims[1]}, {dims[2]} "
                               f"coefficients, expected {n}, {m}, {nw}; delete {path.parent} to rebuild it")
    return CKernel(n, m, path, lib, timings)


# A process keeps the kernels it loaded (a shared library stays mapped anyway); keyed by the
# structure, so every system of one structure shares one (the name only labels messages).
@functools.lru_cache(maxsize=32)
def _kernel_for(variables: tuple, parameters: tuple, template: Template, cc: str) -> CKernel:
    # Errors name no system (one library serves many): `compiled_kernel` puts the caller's in front.
    # The folder is named by the content hash only: a system's name is free text.
    code = cache.code_fingerprint("kernel")
    folder = cache.cache_dir("ckernel", _key(variables, parameters, template, cc, code))
    times = {"emit_s": 0.0, "compile_s": 0.0}
    rhs = template.rhs

    def build() -> None:
        t0 = time.perf_counter()
        undefined = sorted({str(f.func) for e in rhs for f in sp.sympify(e).atoms(AppliedUndef)})
        if undefined:
            raise KernelBuildError(f"the right-hand side calls {undefined}, which C does not know; "
                                   f"define them or use engine='pycont'")
        try:
            source = kernel_source(variables, parameters, rhs, template.weight_names)
        except KernelBuildError:
            raise
        except Exception as exc:  # noqa: BLE001 - sympy's printer raises many kinds
            text = " ".join(str(exc).split())
            raise KernelBuildError(f"the right-hand side cannot be written as C "
                                   f"({type(exc).__name__}: {text}); use engine='pycont'") from None
        t1 = time.perf_counter()
        _compile(source, folder, cc, None)
        times.update(emit_s=t1 - t0, compile_s=time.perf_counter() - t1)

    lib, _ = cached_library(folder, build, "C kernel", code)
    emit_s, compile_s = times["emit_s"], times["compile_s"]
    t2 = time.perf_counter()
    k = _load(lib, len(variables), len(parameters), len(template.weight_names), ())
    return CKernel(k.n, k.m, k.path, k.lib, (("emit_s", emit_s), ("compile_s", compile_s),
                                             ("load_s", time.perf_counter() - t2)))


def build_timing(system, cc: str | None = None) -> dict[str, float]:
    """The one-time costs of a kernel, measured from scratch in a temporary folder (the cache is
    not touched): ``emit_s`` (sympy derivatives, CSE and C printing) and ``compile_s`` (gcc)."""
    cc = cc or os.environ.get("CC", "").strip() or "gcc"
    t0 = time.perf_counter()
    template = system.template
    source = kernel_source(system.variables, system.parameter_names, template.rhs, template.weight_names)
    t1 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="autocable-ckernel-") as tmp:
        _compile(source, Path(tmp), cc, repr(system.name))
        t2 = time.perf_counter()
    return {"emit_s": t1 - t0, "compile_s": t2 - t1, "source_lines": source.count("\n")}


def compiled_kernel(system, cc: str | None = None) -> CKernel:
    """The loaded C kernel of ``system`` (a `autocable.methods.continuation.system.System`), built if needed.

    ``cc``: the C compiler (default ``$CC`` or ``gcc``). Raises `KernelBuildError` (one line)."""
    cc = cc or os.environ.get("CC", "").strip() or "gcc"
    try:
        template = system.template
    except ValueError as exc:
        raise KernelBuildError(f"C kernel of {system.name!r}: {exc}") from None
    try:
        k = _kernel_for(tuple(system.variables), tuple(system.parameter_names), template, cc)
    except KernelBuildError as exc:
        text = str(exc)
        named = text if text.startswith("C kernel") else f"C kernel of {system.name!r}: {text}"
        raise KernelBuildError(named) from None
    return replace(k, weights=template.weights)
