"""sympy -> C: an adaptive DOP853 integrator compiled for one first-order system y' = f(t, y; p).

What it holds. The direct integrations of autocable step a small polynomial vector field (eq. (21)
of Luongo & Zulli, 4 states; the Cartesian AME (24), 4 states) over tens of thousands of time
units. Profiled through PyDSTool's Dopri generator, Fig. 10's overlay spent 8 of its 9.7 s inside
the C integrator on responses that blow up: a finite-time blow-up is only noticed when the step
budget of a whole chunk is spent. Here the integrator stops on the first accepted step beyond a
bound, and a bounded forcing period of eq. (21) costs about 10 microseconds. This module writes
one C file per right-hand side with

* f(t, y; p) from ``sympy.cse`` and the C printer of `autocable.codegen.ckernel` (integer powers as
  products, 17-digit constants), the factors of each term that depend on the parameters alone
  summed into coefficients computed once per run (`_hoist`);
* for a right-hand side with atan2 and square roots of the state (the exact quasi-steady load of
  `autocable.model.exact_load`, one of each per quadrature node): an atan2 of its own (`_ATAN2_C`,
  four lanes with AVX2 where the processor has it) and an errno-free sqrt, each computed for all
  nodes in one loop once their arguments are known (`_batched_block`): the exact right-hand side
  runs 2.5 times faster than with glibc's atan2 and sqrt inline (`autocable bench exact-load`);
* Hairer & Wanner's DOP853 (explicit Runge-Kutta 8(5,3), "Solving ODEs I", Sect. II.10): the
  coefficients are scipy's table of it (`scipy.integrate._ivp.dop853_coefficients`, printed into
  the C source with 17 digits), the error estimate is Hairer's mixed 5th/3rd-order norm
  err = |h| E5^2 / sqrt(n (E5^2 + 0.01 E3^2)) with sk = atol + rtol max(|y_old|, |y_new|), the
  step control is his (safety 0.9, 0.333 <= h_new / h <= 6, exponent 1/8, no growth right after a
  rejection, h <= max_step), the first step his ``hinit``; PyDSTool's Dopri generator wraps the
  same code (Hairer's dop853.c), so both engines take the same steps up to details of the restart;
* its Jacobian d f / d y (``ac_jac``) for implicit integrators and Newton steps of callers;
* the 7th-order dense output of DOP853 (three extra stages on the accepted steps that hold a
  sample time) evaluated at the caller's sample times, so samples never shorten a step;
* stops that a caller needs to tell a blow-up from a response: a budget of accepted steps, a step
  size below 10 ulp of t, a non-finite state, and ``|y_i| > bound`` for the first ``n_bound``
  components (a modal amplitude beyond the model's validity), each reported with a status code.

Coefficients as run-time data, as in `autocable.codegen.ckernel`: every Float of the right-hand
side is a weight (`autocable.codegen.coefficients`) read from the parameter array after the
parameters (hoisted with them into the per-run coefficients), so one library serves every
right-hand side of one structure (the AME of every candidate model of the calibration, eq. (21)
of every model of one form). Build and cache as for `autocable.codegen.ckernel` (whose printer,
compiler call and build lock are reused): the library is keyed by a content hash of the
right-hand side's structure, names, DOP853 table and this emitter's version (not the caller's
name), and lives in ``cache_root()/cintegrate/<hash>/`` (checked by sha256 before every load, as
there).
"""
from __future__ import annotations

import ctypes
import functools
import math
import os
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Sequence

import numpy as np
import sympy as sp

from autocable import _store as cache
from autocable.codegen.coefficients import Template, coefficient_template
from autocable.codegen.ckernel import (CFLAGS, KernelBuildError, _block, _compile, _Printer, cached_library,
                                      load_private)
from autocable.model import derivatives
from autocable.model.symbolic import plain_symbols

__all__ = ["INTEGRATOR_VERSION", "STATUS", "CIntegrator", "CRun", "Repeated", "compiled_integrator",
           "integrator_source", "sample_grid"]

#: Bump when the emitted C changes meaning: it is part of the content hash.
INTEGRATOR_VERSION = "9"

#: How a run ended (the status code of the C loop).
STATUS = {0: "done", 1: "step_budget", 2: "step_too_small", 3: "bound", 4: "not_finite"}


def _coefficients():
    """Hairer's DOP853 table as scipy holds it: A (16 x 16, rows 13-15 the dense-output stages),
    B (12), C (16), E3, E5 (13; the 13th, f at the new point, has weight 0) and D (4 x 16)."""
    from scipy.integrate._ivp import dop853_coefficients as d
    if d.E3[12] != 0.0 or d.E5[12] != 0.0:     # the error estimate must not need the FSAL stage
        raise KernelBuildError("unexpected DOP853 table in scipy: the error weights use stage 13")
    return d.A, d.B, d.C, d.E3, d.E5, d.D


def _lin(weights, stages, skip_zero=True) -> str:
    """C text of sum_j w_j K_j[i] over the non-zero weights."""
    terms = [f"{float(w)!r} * K{j}[i]" for j, w in zip(stages, weights) if not (skip_zero and w == 0.0)]
    return " + ".join(terms) if terms else "0.0"


#: atan2 for the exact quasi-steady load's angle of attack (eq. 12): one per quadrature node and
#: stage, the costliest operation of the exact right-hand side. glibc's atan2 is correctly rounded
#: and spends 10-25 ns; the divider is the bottleneck of the node's arithmetic (its one sqrt, and here
#: one division). The octant is reduced to |t| <= tan(pi/8) (t = (num - den) / (num + den) beyond,
#: plus pi/4), and atan(t) = t + t z g(z), z = t^2, with g the degree-9 polynomial interpolating
#: (atan(t)/t - 1)/z at ten Chebyshev points of [0, tan(pi/8)^2] (computed in 50-digit arithmetic):
#: 2.2e-16 relative on the reduced range, within 1e-15 of glibc over all octants
#: (tests/test_exact_load.py). C99's signs of zero; for finite arguments only (a non-finite state
#: stops the integrator anyway).
_ATAN2_C = """
static inline double ac_atan2(double y, double x) {
    const double ax = fabs(x), ay = fabs(y);
    const int swap = ay > ax;
    const double num = swap ? ax : ay, den = swap ? ay : ax;
    const int big = num > 0.41421356237309504880 * den;
    const double tn = big ? num - den : num, td = big ? num + den : den;
    const double t = tn / (td > 0.0 ? td : 1.0), z = t * t, z2 = z * z, z4 = z2 * z2;
    /* Estrin's scheme: the node's latency, not its operation count, sets the cost */
    const double g = ((-0.3333333333333325 + z * 0.19999999999898407) + z2 * (-0.1428571426609662
                      + z * 0.11111109636534361)) + z4 * ((-0.09090852557176049 + z * 0.0769105515839315)
                      + z2 * (-0.06649613695291669 + z * 0.05736332165907643)
                      + z4 * (-0.04483334622272886 + z * 0.02275052699336167));
    double r = t + t * z * g;
    r += big ? 0.78539816339744830962 : 0.0;
    r = swap ? 1.57079632679489661923 - r : r;
    r = signbit(x) ? 3.14159265358979323846 - r : r;
    return copysign(r, y);
}
"""


#: The exact load's |V| (eq. 11), one per node and stage. C's sqrt may set errno, so the compiler
#: guards every one with a call of libm's for negative arguments; SSE2's instruction has no such path
#: (|V|^2 >= 0 here anyway) and comes two at a time (`_PAIRED`). On other machines C's sqrt.
_SQRT_C = """
#if defined(__SSE2__)
#include <emmintrin.h>
static inline double ac_sqrt(double v) { return _mm_cvtsd_f64(_mm_sqrt_sd(_mm_set_sd(v), _mm_set_sd(v))); }
#else
static inline double ac_sqrt(double v) { return sqrt(v); }
#endif
"""


class _IntegratorPrinter(_Printer):
    """The printer of `autocable.codegen.ckernel` with atan2 as ``ac_atan2`` (`_ATAN2_C`) and square
    roots as ``ac_sqrt`` (`_SQRT_C`)."""

    def _print_atan2(self, expr):
        y, x = expr.args
        return f"ac_atan2({self._print(y)}, {self._print(x)})"

    def _print_Pow(self, expr):
        if expr.exp == sp.Rational(1, 2):
            return f"ac_sqrt({self._print(expr.base)})"
        return super()._print_Pow(expr)


#: `ac_atan2` four at a time where the processor has AVX2 and FMA (x86-64, GCC or clang: chosen at
#: run time, so the library still runs on any x86-64): the same octant reduction and polynomial on
#: vectors of four angles, the octant tests as lane masks. Measured: 1.75 ns an angle against 4.5 ns
#: for the scalar loop (the division and the polynomial's latency are shared by four lanes).
_ATAN2_AVX2_C = """
#if defined(__x86_64__) && defined(__GNUC__)
#define AC_ATAN2_AVX2 1
typedef double ac_v4 __attribute__((vector_size(32)));
typedef long long ac_m4 __attribute__((vector_size(32)));
#define AC_SEL(m, a, b) ((ac_v4)(((m) & (ac_m4)(a)) | (~(m) & (ac_m4)(b))))
__attribute__((target("avx2,fma")))
static void ac_atan2_avx2(const double *ys, const double *xs, double *out, int n) {
    const long long s = (long long)0x8000000000000000ULL;
    const ac_m4 sign = {s, s, s, s};
    const ac_v4 one = {1.0, 1.0, 1.0, 1.0}, zero = {0.0, 0.0, 0.0, 0.0};
    int k;
    for (k = 0; k + 3 < n; k += 4) {
        ac_v4 y, x, r;
        memcpy(&y, ys + k, sizeof(y));
        memcpy(&x, xs + k, sizeof(x));
        const ac_v4 ax = (ac_v4)((ac_m4)x & ~sign), ay = (ac_v4)((ac_m4)y & ~sign);
        const ac_m4 swap = ay > ax;
        const ac_v4 num = AC_SEL(swap, ax, ay), den = AC_SEL(swap, ay, ax);
        const ac_m4 big = num > 0.41421356237309504880 * den;
        const ac_v4 tn = AC_SEL(big, num - den, num), td = AC_SEL(big, num + den, den);
        const ac_v4 t = tn / AC_SEL(td > zero, td, one), z = t * t, z2 = z * z, z4 = z2 * z2;
        const ac_v4 g = ((-0.3333333333333325 + z * 0.19999999999898407) + z2 * (-0.1428571426609662
                          + z * 0.11111109636534361)) + z4 * ((-0.09090852557176049 + z * 0.0769105515839315)
                          + z2 * (-0.06649613695291669 + z * 0.05736332165907643)
                          + z4 * (-0.04483334622272886 + z * 0.02275052699336167));
        r = t + t * z * g;
        r = r + (ac_v4)(big & (ac_m4)(one * 0.78539816339744830962));
        r = AC_SEL(swap, 1.57079632679489661923 - r, r);
        r = AC_SEL((ac_m4)x < 0, 3.14159265358979323846 - r, r);
        r = (ac_v4)((ac_m4)r | ((ac_m4)y & sign));
        memcpy(out + k, &r, sizeof(r));
    }
    for (; k < n; k++) out[k] = ac_atan2(ys[k], xs[k]);
}
#endif
"""


#: The exact right-hand side's f compiled twice, for AVX2 and FMA and for any x86-64, the processor's
#: chosen when the library is loaded (GCC's target_clones, an ifunc: glibc): the nodes' arithmetic in
#: three-operand instructions. Measured on the sample's forced exact right-hand side: 142 -> 135 ns
#: (the cubic one, not cloned, would gain 46 -> 45 ns).
_F_CLONES = """#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && defined(__GLIBC__)
__attribute__((target_clones("avx2,fma", "default")))
#endif
"""


#: A loop of square roots, two at a time where SSE2 has them: the divider (one division and one root
#: per node) bounds the exact load, and it takes a pair of roots in about the time of one (measured
#: on the sample's forced right-hand side: 230 -> 205 ns per evaluation; pairing the atan2's
#: divisions the same way gained nothing measurable and is not done).
_PAIRED = """#if defined(__SSE2__)
    for (k = 0; k + 1 < {n}; k += 2) _mm_storeu_pd({dst} + k, {op});
    for (; k < {n}; k++) {dst}[k] = {one};
#else
    for (k = 0; k < {n}; k++) {dst}[k] = {one};
#endif"""


def _batch_c(n_atan2: int, n_sqrt: int) -> str:
    """C of ``ac_atan2_n`` and ``ac_sqrt_n``: the angles and speeds of one right-hand side, each in
    one loop (`_batched_block`)."""
    out = ""
    if n_atan2:
        out += _ATAN2_AVX2_C + f"""
static void ac_atan2_n(const double *ys, const double *xs, double *out) {{
    int k;
#ifdef AC_ATAN2_AVX2
    if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma")) {{
        ac_atan2_avx2(ys, xs, out, {n_atan2});
        return;
    }}
#endif
    for (k = 0; k < {n_atan2}; k++) out[k] = ac_atan2(ys[k], xs[k]);
}}
"""
    if n_sqrt:
        out += f"""
#ifdef AC_ATAN2_AVX2
#include <immintrin.h>
__attribute__((target("avx")))
static void ac_sqrt_avx(const double *xs, double *out, int n) {{
    int k;
    for (k = 0; k + 3 < n; k += 4) _mm256_storeu_pd(out + k, _mm256_sqrt_pd(_mm256_loadu_pd(xs + k)));
    for (; k < n; k++) out[k] = ac_sqrt(xs[k]);
}}
#endif

static void ac_sqrt_n(const double *xs, double *out) {{
    int k;
#ifdef AC_ATAN2_AVX2
    if (__builtin_cpu_supports("avx")) {{
        ac_sqrt_avx(xs, out, {n_sqrt});
        return;
    }}
#endif
{_PAIRED.format(n=n_sqrt, op="_mm_sqrt_pd(_mm_loadu_pd(xs + k))", dst="out", one="ac_sqrt(xs[k])")}
}}
"""
    return out


def _batched_block(pr, exprs, targets, names: dict) -> tuple[list, int, int]:
    """`autocable.codegen.ckernel._block` of the right-hand side, with its atan2 and square roots of
    the state (the exact load's angle and speed at every quadrature node) taken out of the
    straight-line code: their arguments are computed first, then every angle in one loop
    (``ac_atan2_n``) and every speed in another (``ac_sqrt_n``), then the rest. Measured on the
    exact rung of the sample (`autocable bench exact-load`): an angle costs about 8 ns inline, where
    the other nodes' work competes for the processor's window, and 4 ns in the loop, whose
    iterations overlap. Returns the lines and the numbers of angles and roots (0, 0: the plain
    block)."""
    dynamic = set().union(*(e.free_symbols for e in exprs)) - {sp.Symbol(n) for n in names
                                                                if names[n].startswith(("p[", "c["))}
    atans = sorted(set().union(*(e.atoms(sp.atan2) for e in exprs)), key=sp.default_sort_key)
    roots = sorted({p for e in exprs for p in e.atoms(sp.Pow)
                    if p.exp == sp.Rational(1, 2) and p.base.free_symbols & dynamic}, key=sp.default_sort_key)
    if not atans and not roots:
        return _block(pr, exprs, targets, "ac_ti"), 0, 0
    angles = [sp.Symbol(f"ac_at{k}") for k in range(len(atans))]
    speeds = [sp.Symbol(f"ac_sq{k}") for k in range(len(roots))]
    names.update({a.name: f"ac_at[{k}]" for k, a in enumerate(angles)})
    names.update({a.name: f"ac_sq[{k}]" for k, a in enumerate(speeds)})
    swap = dict(zip(atans, angles)) | dict(zip(roots, speeds))
    args = [a for atom in atans for a in atom.args] + [r.base for r in roots]
    subs, red = sp.cse(args + [e.xreplace(swap) for e in exprs], symbols=sp.numbered_symbols("ac_ti"),
                       optimizations=None)
    late = set(angles) | set(speeds)
    early_lines, late_lines = [], []
    for sym, e in subs:
        line = f"    const double {sym.name} = {pr.doprint(e)};"
        if e.free_symbols & late:
            late.add(sym)
            late_lines.append(line)
        else:
            early_lines.append(line)
    na, ns = len(atans), len(roots)
    lines = [f"    double ac_ay[{max(na, 1)}], ac_ax[{max(na, 1)}], ac_at[{max(na, 1)}], "
             f"ac_sb[{max(ns, 1)}], ac_sq[{max(ns, 1)}];"] + early_lines
    lines += [f"    ac_ay[{k}] = {pr.doprint(red[2 * k])}; ac_ax[{k}] = {pr.doprint(red[2 * k + 1])};"
              for k in range(na)]
    lines += [f"    ac_sb[{k}] = {pr.doprint(red[2 * na + k])};" for k in range(ns)]
    if na:
        lines.append("    ac_atan2_n(ac_ay, ac_ax, ac_at);")
    if ns:
        lines.append("    ac_sqrt_n(ac_sb, ac_sq);")
    lines += late_lines
    lines += [f"    {t} = {pr.doprint(e)};" for t, e in zip(targets, red[2 * na + ns:])]
    return lines, na, ns


def _transcendental(e, dynamic: set) -> bool:
    """Whether ``e`` has an atan2 or a non-integer power of the state (the exact load's angle and
    speed of the relative wind), as opposed to a polynomial in the state and sin/cos of t."""
    return any(a.free_symbols & dynamic for a in e.atoms(sp.atan2)) or any(
        not p.exp.is_Integer and p.base.free_symbols & dynamic for p in e.atoms(sp.Pow))


def _hoist(rhs, dynamic: set) -> tuple[list, list]:
    """Split every term of the expanded right-hand sides into a factor of the parameters alone and
    a factor of the state and t; the parameter factors (summed per distinct state factor) become
    coefficients ``ac_c<k>`` computed once per run. Eq. (21)'s terms carry products of U, eta,
    Omega and the wind switches that would otherwise be multiplied again at every stage."""
    coefs: list = []
    index: dict = {}
    out = []
    for e in rhs:
        groups: dict = {}
        # A right-hand side with transcendental functions of the state (the exact quasi-steady
        # load's sqrt and atan2) is split as it stands: expanding it multiplies its size.
        for term in sp.Add.make_args(e if _transcendental(e, dynamic) else sp.expand(e)):
            const, dyn = [], []
            for f in sp.Mul.make_args(term):
                (dyn if f.free_symbols & dynamic else const).append(f)
            key = sp.Mul(*dyn)
            groups[key] = groups.get(key, sp.Integer(0)) + sp.Mul(*const)
        total = sp.Integer(0)
        for key, coef in groups.items():
            if coef.is_Number:
                total += coef * key
                continue
            if coef not in index:
                index[coef] = len(coefs)
                coefs.append(coef)
            total += sp.Symbol(f"ac_c{index[coef]}") * key
        out.append(total)
    return coefs, out


def integrator_source(variables: Sequence[str], parameters: Sequence[str], rhs: Sequence,
                      time_symbol: str | None = "t", weights: Sequence[str] = ()) -> str:
    """The C text of the DOP853 integrator of y' = rhs(t, y; p, w), y in ``variables``, p in
    ``parameters`` order; ``time_symbol`` names t in ``rhs`` (None for an autonomous field);
    ``weights`` name the numeric coefficients (`autocable.codegen.coefficients`), read at run time
    from the parameter array after the NP parameters."""
    n, m = len(variables), len(parameters)
    if n < 1:
        raise KernelBuildError("the C integrator needs at least one state variable")
    names = {v: f"y[{i}]" for i, v in enumerate(variables)}
    names.update({q: f"p[{j}]" for j, q in enumerate(parameters)})
    names.update({w: f"p[{m + k}]" for k, w in enumerate(weights)})
    if time_symbol:
        names[time_symbol] = "t"
    dynamic = {sp.Symbol(v) for v in variables} | ({sp.Symbol(time_symbol)} if time_symbol else set())
    coefs, split = _hoist([sp.sympify(e) for e in rhs], dynamic)
    names.update({f"ac_c{k}": f"c[{k}]" for k in range(len(coefs))})
    pr = _IntegratorPrinter(names)
    body_c = _block(pr, coefs, [f"c[{k}]" for k in range(len(coefs))], "ac_tc") if coefs else []
    body, n_atan2, n_sqrt = _batched_block(pr, split, [f"out[{i}]" for i in range(n)], names)
    ys = [sp.Symbol(v) for v in variables]
    memo: dict = {}
    jac = _block(pr, [derivatives.diff(e, v, memo) for e in split for v in ys],
                 [f"out[{k}]" for k in range(n * n)], "ac_tj")
    A, B, C, E3, E5, D = _coefficients()
    stages = []
    # Stages 2..12 (K1..K11): y + h sum_j a_sj K_j, evaluated at t + c_s h.
    for s in range(1, 12):
        stages.append(f"    for (i = 0; i < N; i++) yy[i] = y[i] + h * ({_lin(A[s, :s], range(s))});\n"
                      f"    f_eval(t + {float(C[s])!r} * h, yy, p, c, K{s});")
    extra = []
    for s in range(13, 16):
        extra.append(f"        for (i = 0; i < N; i++) yy[i] = y[i] + h * ({_lin(A[s, :s], range(s))});\n"
                     f"        f_eval(t + {float(C[s])!r} * h, yy, p, c, K{s});")
    dense = "\n".join(f"            F[{3 + r}][i] = h * ({_lin(D[r], range(16))});" for r in range(4))
    decl = "    double " + ", ".join(f"K{j}[N]" for j in range(16)) + ";"
    head = f"""/* autocable C integrator (version {INTEGRATOR_VERSION}): DOP853 for y = ({', '.join(variables)}),
   p = ({', '.join(parameters)}), t = {time_symbol or '(autonomous)'}. Generated from sympy; do not edit. */
#include <math.h>
#include <string.h>
#define N {n}
#define NP {m}
#define NW {len(weights)}
#define NC {max(len(coefs), 1)}
{_SQRT_C + _ATAN2_C if any(sp.sympify(e).has(sp.atan2) for e in split) else ""}{_batch_c(n_atan2, n_sqrt)}
static void coef_eval(const double *p, double *c) {{
    (void)p; (void)c;
{chr(10).join(body_c)}
}}

{_F_CLONES if n_atan2 else ""}static void f_eval(double t, const double *y, const double *p, const double *c, double *out) {{
    (void)t; (void)y; (void)p; (void)c;
{chr(10).join(body)}
}}

void ac_rhs(double t, const double *y, const double *p, double *out) {{
    double c[NC];
    coef_eval(p, c);
    f_eval(t, y, p, c, out);
}}

/* d rhs_i / d y_j, row major (for implicit integrators and Newton steps outside this file). */
void ac_jac(double t, const double *y, const double *p, double *out) {{
    double c[NC];
    (void)t;
    coef_eval(p, c);
{chr(10).join(jac)}
}}
int ac_dims(int *out) {{ out[0] = N; out[1] = NP; out[2] = NW; return 0; }}

/* Hairer's hinit: a first step from the size of f and of its change over an Euler step. */
static double hinit(double t, const double *y, const double *p, const double *c, const double *f0, double hmax,
                    double rtol, double atol) {{
    double dnf = 0.0, dny = 0.0, der2 = 0.0, h, h1, der12, sk, yy[N], f1[N];
    int i;
    for (i = 0; i < N; i++) {{
        sk = atol + rtol * fabs(y[i]);
        dnf += (f0[i] / sk) * (f0[i] / sk);
        dny += (y[i] / sk) * (y[i] / sk);
    }}
    h = (dnf <= 1e-10 || dny <= 1e-10) ? 1e-6 : sqrt(dny / dnf) * 0.01;
    h = fmin(h, hmax);
    for (i = 0; i < N; i++) yy[i] = y[i] + h * f0[i];
    f_eval(t + h, yy, p, c, f1);
    for (i = 0; i < N; i++) {{
        sk = atol + rtol * fabs(y[i]);
        der2 += ((f1[i] - f0[i]) / sk) * ((f1[i] - f0[i]) / sk);
    }}
    der2 = sqrt(der2) / h;
    der12 = fmax(fabs(der2), sqrt(dnf));
    h1 = der12 <= 1e-15 ? fmax(1e-6, h * 1e-3) : pow(0.01 / der12, 1.0 / 8.0);
    return fmin(100.0 * h, fmin(h1, hmax));
}}

/* Integrate from t0 with y0 towards t1 = grid[ng - 1] (the grid is increasing, grid[0] = t0),
   writing the state at every grid time into ys (ng x N, row major).
   p = (the NP parameters, the NW coefficients).
   opt = (rtol, atol, hmax, max_steps, bound, n_bound, h0): h0 = 0 takes hinit's first step.
   info (out) = (status, t reached, accepted, rejected, f evaluations, last step, y reached[N]).
   Returns the number of grid rows written (all of them when status is 0). */
int ac_integrate(const double *y0, const double *grid, int ng, const double *p, const double *opt,
                 double *ys, double *info) {{
{decl}
    double y[N], yy[N], ynew[N], F[7][N], c[NC];
    double t = grid[0], t1 = grid[ng - 1], rtol = opt[0], atol = opt[1], hmax = fabs(opt[2]);
    double bound = opt[4], h, hnew, err, err3, sk, e5, e3, fac11, fac;
    long max_steps = (long)opt[3], nacc = 0, nrej = 0, nfev = 0;
    int i, k = 0, nb = (int)opt[5], status = 0, last = 0, reject = 0;
    const double safe = 0.9, facc1 = 1.0 / 0.333, facc2 = 1.0 / 6.0, uround = 2.3e-16;
    memcpy(y, y0, sizeof(y));
    for (i = 0; i < N; i++) if (!isfinite(y[i])) status = 4;
    coef_eval(p, c);
    f_eval(t, y, p, c, K0); nfev++;
    h = opt[6] > 0.0 ? fmin(opt[6], hmax) : hinit(t, y, p, c, K0, hmax, rtol, atol);
    nfev++;
    while (k < ng && grid[k] <= t) {{ memcpy(ys + (long)k * N, y, sizeof(y)); k++; }}
    while (status == 0 && t < t1) {{
        if (nacc >= max_steps) {{ status = 1; break; }}
        if (0.1 * fabs(h) <= fabs(t) * uround) {{ status = 2; break; }}
        if (t + 1.01 * h >= t1) {{ h = t1 - t; last = 1; }}
{chr(10).join(stages)}
        for (i = 0; i < N; i++) ynew[i] = y[i] + h * ({_lin(B, range(12))});
        nfev += 11;
        err = 0.0; err3 = 0.0;
        for (i = 0; i < N; i++) {{
            sk = atol + rtol * fmax(fabs(y[i]), fabs(ynew[i]));
            e5 = ({_lin(E5[:12], range(12))}) / sk;
            e3 = ({_lin(E3[:12], range(12))}) / sk;
            err += e5 * e5; err3 += e3 * e3;
        }}
        {{
            double deno = err + 0.01 * err3;
            if (deno <= 0.0) deno = 1.0;
            err = fabs(h) * err * sqrt(1.0 / (deno * (double)N));
        }}
        if (!isfinite(err)) {{ status = 4; break; }}
        fac11 = pow(err, 1.0 / 8.0);
        fac = fmax(facc2, fmin(facc1, fac11 / safe));
        hnew = h / fac;
        if (err > 1.0) {{
            hnew = h / fmin(facc1, fac11 / safe);
            reject = 1; last = 0;
            if (nacc >= 1) nrej++;
            h = hnew;
            continue;
        }}
        nacc++;
        {{
            double tnew = last ? t1 : t + h;
            f_eval(tnew, ynew, p, c, K12); nfev++;
            if (k < ng && grid[k] <= tnew) {{
                /* dense output of this step: three more stages, then the 7th-degree polynomial */
{chr(10).join(extra)}
                nfev += 3;
                for (i = 0; i < N; i++) {{
                    double dy = ynew[i] - y[i];
                    F[0][i] = dy;
                    F[1][i] = h * K0[i] - dy;
                    F[2][i] = 2.0 * dy - h * (K12[i] + K0[i]);
{dense}
                }}
                while (k < ng && grid[k] <= tnew) {{
                    double *out = ys + (long)k * N;
                    if (grid[k] == tnew) memcpy(out, ynew, sizeof(ynew));
                    else {{
                        double x = (grid[k] - t) / h, x1 = 1.0 - x;
                        for (i = 0; i < N; i++) {{
                            double v = F[6][i] * x;
                            v = (v + F[5][i]) * x1;
                            v = (v + F[4][i]) * x;
                            v = (v + F[3][i]) * x1;
                            v = (v + F[2][i]) * x;
                            v = (v + F[1][i]) * x1;
                            v = (v + F[0][i]) * x;
                            out[i] = y[i] + v;
                        }}
                    }}
                    k++;
                }}
            }}
            memcpy(K0, K12, sizeof(K0));
            memcpy(y, ynew, sizeof(y));
            t = tnew;
        }}
        for (i = 0; i < N; i++) if (!isfinite(y[i])) status = 4;
        for (i = 0; i < nb && i < N; i++) if (fabs(y[i]) > bound) status = 3;
        if (last) break;
        if (fabs(hnew) > hmax) hnew = hmax;
        if (reject) hnew = fmin(fabs(hnew), fabs(h));
        reject = 0;
        h = hnew;
    }}
    info[0] = status; info[1] = t; info[2] = (double)nacc; info[3] = (double)nrej;
    info[4] = (double)nfev; info[5] = h;
    for (i = 0; i < N; i++) info[6 + i] = y[i];
    return k;
}}
"""
    return head


def sample_grid(t0: float, t1: float, dt: float) -> np.ndarray:
    """t0, t0 + dt, ... up to t1 (t1 itself when it falls on the grid), as
    `autocable.codegen.pydstool.integrate` samples, so both engines report the same times."""
    t0, t1, dt = float(t0), float(t1), float(dt)
    if not (t1 > t0 and dt > 0):
        raise ValueError(f"need t1 > t0 and dt > 0, got t0={t0}, t1={t1}, dt={dt}")
    n = int(math.floor((t1 - t0) / dt * (1 + 1e-12))) + 1
    grid = t0 + dt * np.arange(n)
    if abs(grid[-1] - t1) <= 1e-9 * dt:
        grid[-1] = t1
    return np.minimum(grid, t1)


@dataclass(frozen=True)
class CRun:
    """One call of the compiled integrator: the samples it reached and how it ended."""

    t: np.ndarray            # the grid times written (all of the grid when status == "done")
    y: np.ndarray            # (len(t), n) states at those times
    status: str              # a value of STATUS
    t_reached: float         # where the integration stopped (the last accepted step)
    y_reached: np.ndarray    # the state there
    accepted: int
    rejected: int
    evaluations: int         # right-hand side evaluations
    last_step: float

    @property
    def ok(self) -> bool:
        return self.status == "done"


@dataclass(frozen=True, eq=False)
class CIntegrator:
    """A loaded DOP853 library of one right-hand side (see the module docstring)."""

    n: int
    m: int
    path: Path
    lib: ctypes.CDLL
    timings: tuple   # (("emit_s", s), ("compile_s", s), ("load_s", s)); zeros when cached
    #: this right-hand side's numeric coefficients (the library is built for its structure)
    weights: np.ndarray = field(default_factory=lambda: np.empty(0))

    def with_weights(self, p) -> np.ndarray:
        """The C parameter array: ``p`` (the m parameters) followed by the coefficients."""
        p = np.asarray(p, float)
        if p.shape != (self.m,):
            raise ValueError(f"the compiled integrator takes {self.m} parameters, got {np.shape(p)}")
        return np.concatenate([p, self.weights]) if self.weights.size else np.ascontiguousarray(p)

    def rhs(self, t: float, y, p) -> np.ndarray:
        out = np.empty(self.n)
        y, p = np.ascontiguousarray(y, float), self.with_weights(p)   # alive in the call
        self.lib.ac_rhs(float(t), y.ctypes.data, p.ctypes.data, out.ctypes.data)
        return out

    def jac(self, t: float, y, p) -> np.ndarray:
        """The Jacobian d rhs / d y at (t, y) (n x n)."""
        out = np.empty((self.n, self.n))
        y, p = np.ascontiguousarray(y, float), self.with_weights(p)   # alive in the call
        self.lib.ac_jac(float(t), y.ctypes.data, p.ctypes.data, out.ctypes.data)
        return out

    def run(self, y0, grid, p, *, rtol: float, atol: float, max_step: float = math.inf,
            max_steps: int = 10**9, bound: float = math.inf, n_bound: int = 0,
            first_step: float = 0.0) -> CRun:
        """Integrate from (grid[0], y0) to grid[-1], sampling at every grid time (increasing).

        Stops early (status) after ``max_steps`` accepted steps, on a step below 10 ulp of t, on
        a non-finite state, or when one of the first ``n_bound`` components exceeds ``bound`` in
        modulus (checked after every accepted step)."""
        y0 = np.ascontiguousarray(y0, float)
        grid = np.ascontiguousarray(grid, float)
        p = np.ascontiguousarray(p, float)
        if y0.shape != (self.n,) or p.shape != (self.m,):
            raise ValueError(f"the compiled integrator takes {self.n} states and {self.m} parameters, "
                             f"got {y0.shape[0]} and {p.shape[0]}")
        p = self.with_weights(p)
        if grid.ndim != 1 or len(grid) < 2 or np.any(np.diff(grid) <= 0):
            raise ValueError("the sample grid must be increasing with at least two times")
        if not (rtol > 0 and atol > 0):
            raise ValueError(f"tolerances must be positive, got rtol={rtol}, atol={atol}")
        ys = np.empty((len(grid), self.n))
        info = np.empty(6 + self.n)
        hmax = min(float(max_step), float(grid[-1] - grid[0]))
        opt = np.array([rtol, atol, hmax, float(min(max_steps, 2**52)), float(bound),
                        float(n_bound), float(first_step)])
        k = self.lib.ac_integrate(y0.ctypes.data, grid.ctypes.data, len(grid), p.ctypes.data,
                                  opt.ctypes.data, ys.ctypes.data, info.ctypes.data)
        return CRun(t=grid[:k], y=ys[:k], status=STATUS[int(info[0])], t_reached=float(info[1]),
                    y_reached=info[6:].copy(), accepted=int(info[2]), rejected=int(info[3]),
                    evaluations=int(info[4]), last_step=float(info[5]))


class Repeated:
    """One `CIntegrator`, one parameter vector and one sample grid, run many times from different
    starts (Newton on a period map calls it a few times per point, thousands of times per sweep).

    `CIntegrator.run` checks and allocates on every call, which costs about as much as a short
    run of the four equations of eq. (21); here the checks and the buffers are done once and a call
    only copies the start and the two tolerances in. The same C function with the same inputs:
    the results are bit for bit those of `run`. Every call writes the same buffers, so one
    `Repeated` serves one thread at a time (`ShootingSolver` keeps one set per thread)."""

    def __init__(self, integrator: CIntegrator, grid, p, *, max_step: float = math.inf,
                 max_steps: int = 10**9, bound: float = math.inf, n_bound: int = 0):
        grid = np.ascontiguousarray(grid, float)
        p = integrator.with_weights(p)
        if grid.ndim != 1 or len(grid) < 2 or np.any(np.diff(grid) <= 0):
            raise ValueError("the sample grid must be increasing with at least two times")
        n = integrator.n
        self.n = n
        self.grid, self.p = grid, p
        self.y0 = np.empty(n)
        self.ys = np.empty((len(grid), n))
        self.info = np.empty(6 + n)
        hmax = min(float(max_step), float(grid[-1] - grid[0]))
        self.opt = np.array([1.0, 1.0, hmax, float(min(max_steps, 2**52)), float(bound), float(n_bound), 0.0])
        self._call = integrator.lib.ac_integrate
        self._args = (self.y0.ctypes.data, grid.ctypes.data, len(grid), p.ctypes.data,
                      self.opt.ctypes.data, self.ys.ctypes.data, self.info.ctypes.data)

    def __call__(self, y0, rtol: float, atol: float):
        """The samples (a view of a buffer the next call overwrites: copy what you keep), or None
        when the run stopped early (any status but "done")."""
        if not (rtol > 0 and atol > 0):
            raise ValueError(f"tolerances must be positive, got rtol={rtol}, atol={atol}")
        try:
            self.y0[:] = y0
        except ValueError:
            raise ValueError(f"the compiled integrator takes {self.n} states, got {np.shape(y0)}") from None
        self.opt[0] = rtol
        self.opt[1] = atol
        self._call(*self._args)
        return self.ys if self.info[0] == 0.0 else None


def _key(variables, parameters, time_symbol, template: Template, cc, code: str | None = None) -> str:
    # The structure only (the template's key): neither the coefficients nor the caller's name;
    # and the generator's files (``code``): an edit there without a version bump still rebuilds.
    A, B, C, E3, E5, D = _coefficients()
    return cache.content_hash({"version": INTEGRATOR_VERSION, "helpers": _SQRT_C + _ATAN2_C + _ATAN2_AVX2_C + _F_CLONES,
                               "variables": list(variables),
                               "code": code or cache.code_fingerprint("kernel"),
                               "parameters": list(parameters), "time": time_symbol,
                               "rhs": template.key, "weights": list(template.weight_names),
                               "cc": cc, "cflags": list(CFLAGS),
                               "table": [np.asarray(a).tolist() for a in (A, B, C, E3, E5, D)]})


def _load(path: Path, n: int, m: int, nw: int, timings) -> CIntegrator:
    try:
        lib = load_private(path)
    except OSError as exc:
        raise KernelBuildError(f"C integrator {path.name}: could not be loaded ({exc}); delete "
                               f"{path.parent} to rebuild it") from None
    vp = ctypes.c_void_p
    lib.ac_rhs.argtypes = [ctypes.c_double, vp, vp, vp]
    lib.ac_rhs.restype = None
    lib.ac_jac.argtypes = [ctypes.c_double, vp, vp, vp]
    lib.ac_jac.restype = None
    lib.ac_integrate.argtypes = [vp, vp, ctypes.c_int, vp, vp, vp, vp]
    lib.ac_integrate.restype = ctypes.c_int
    lib.ac_dims.argtypes = [vp]
    dims = np.zeros(3, np.intc)
    lib.ac_dims(dims.ctypes.data)
    if (int(dims[0]), int(dims[1]), int(dims[2])) != (n, m, nw):
        raise KernelBuildError(f"C integrator {path}: built for n = {dims[0]}, m = {dims[1]}, {dims[2]} "
                               f"coefficients, expected {n}, {m}, {nw}; delete {path.parent} to rebuild it")
    return CIntegrator(n, m, path, lib, timings)


# Keyed by the structure (a `Template` is equal to every template of its structure), so every
# right-hand side of one structure shares one loaded library; errors name no caller (one library
# serves many): `compiled_integrator` puts the caller's name in front.
@functools.lru_cache(maxsize=32)
def _integrator_for(variables: tuple, parameters: tuple, time_symbol, template: Template,
                    cc: str) -> CIntegrator:
    # The folder is named by the content hash only: the caller's name is free text.
    code = cache.code_fingerprint("kernel")
    folder = cache.cache_dir("cintegrate", _key(variables, parameters, time_symbol, template, cc, code))
    times = {"emit_s": 0.0, "compile_s": 0.0}

    def build() -> None:
        t0 = time.perf_counter()
        try:
            source = integrator_source(variables, parameters, template.rhs, time_symbol,
                                       template.weight_names)
        except KernelBuildError:
            raise
        except Exception as exc:  # noqa: BLE001 - sympy's printer raises many kinds
            text = " ".join(str(exc).split())
            raise KernelBuildError(f"the right-hand side cannot be written as C ({type(exc).__name__}: "
                                   f"{text}); use engine='dopri'") from None
        t1 = time.perf_counter()
        try:
            _compile(source, folder, cc, None)
        except KernelBuildError as exc:
            raise KernelBuildError(str(exc).replace("engine='pycont'", "engine='dopri'")) from None
        times.update(emit_s=t1 - t0, compile_s=time.perf_counter() - t1)

    lib, _ = cached_library(folder, build, "C integrator", code)
    emit_s, compile_s = times["emit_s"], times["compile_s"]
    t2 = time.perf_counter()
    k = _load(lib, len(variables), len(parameters), len(template.weight_names), ())
    return CIntegrator(k.n, k.m, k.path, k.lib, (("emit_s", emit_s), ("compile_s", compile_s),
                                                 ("load_s", time.perf_counter() - t2)))


def compiled_integrator(name: str, variables: Sequence[str], parameters: Sequence[str], rhs: Sequence,
                        time_symbol: str | None = "t", cc: str | None = None) -> CIntegrator:
    """The loaded DOP853 library of y' = rhs(t, y; p), built if needed (cached across processes).

    ``rhs``: sympy expressions in the symbols named by ``variables``, ``parameters`` and
    ``time_symbol``; ``cc``: the C compiler (default ``$CC`` or ``gcc``). Raises
    `autocable.codegen.ckernel.KernelBuildError` (one line)."""
    cc = cc or os.environ.get("CC", "").strip() or "gcc"
    plain = tuple(plain_symbols(e) for e in rhs)
    known = set(variables) | set(parameters) | ({time_symbol} if time_symbol else set())
    for e in plain:
        extra = {s.name for s in e.free_symbols} - known
        if extra:
            raise KernelBuildError(f"C integrator of {name!r}: undeclared symbols {sorted(extra)} in "
                                   f"the right-hand side")
    try:
        template = coefficient_template(plain)
        ci = _integrator_for(tuple(variables), tuple(parameters), time_symbol, template, cc)
    except (KernelBuildError, ValueError) as exc:
        text = str(exc)
        named = text if text.startswith("C integrator") else f"C integrator of {name!r}: {text}"
        raise KernelBuildError(named) from None
    return replace(ci, weights=template.weights)
