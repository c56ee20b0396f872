"""A sampled response measured on its own period: the cycles of an autonomous (self-excited) motion.

Why. Without support motion (eta* = 0) every forcing term of eq. (21) vanishes (each carries eta*
times f, f' or f'': `autocable.model.symbolic.first_order_rhs`), so eq. (21) is autonomous and a
galloping cycle has its own period T_c = 2 pi / omega_c, unrelated to the nominal forcing period
2 pi / Omega. Measured over windows of forcing periods the cycle's samples drift in phase, the
three-point parabolic peaks of `ode21.half_range` jitter by ~1e-6 relative, and no relative test of
1e-8 is ever met: a constant galloping amplitude reads "not steady" (issue: a1 constant to 1.5e-6 at
U* = 1.2). Here the period is found from the signal itself.

How. The samples carry both q_k and q_k' (the state of eq. 21), so between two samples q_k is known
to fourth order by the cubic Hermite interpolant through (q_k, q_k') at both ends. The upward zero
crossings of the dominant coordinate (the one with the larger range) give the cycle boundaries and
the periods; the extremes of each q_k inside a cycle (the roots of the Hermite derivative in an
interval where q_k' changes sign) give its amplitude per cycle, a_k = half the peak-to-peak over
one turn (the convention of docs/model.md, C1, over the response's own period instead of the
forcing's); the state at each crossing (q_k by Hermite, q_k' linearly refined from the two
neighbouring samples) gives the points of the Poincare section q_dominant = 0, increasing.

The error of one Hermite extreme is at most h^4 max|q''''| / 384 (h the sample step): 2.4e-7 of the
amplitude at 64 samples per period, 1.5e-8 at 128; the scatter of the per-cycle values over a
window (their phases against the sample grid differ from cycle to cycle) measures it, and is
reported as the amplitude's error.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


def hermite_crossings(t: np.ndarray, x: np.ndarray, xd: np.ndarray) -> np.ndarray:
    """Times where ``x`` crosses zero upwards, each the root in its sample interval of the cubic
    Hermite interpolant through (x, x') at both ends (bisection on the cubic: robust, 50 halvings)."""
    t, x, xd = (np.asarray(v, float) for v in (t, x, xd))
    idx = np.nonzero((x[:-1] < 0.0) & (x[1:] >= 0.0))[0]
    out = np.empty(len(idx))
    for n, i in enumerate(idx):
        h = t[i + 1] - t[i]
        p = _hermite(x[i], xd[i] * h, x[i + 1], xd[i + 1] * h)
        lo, hi = 0.0, 1.0
        for _ in range(50):
            mid = 0.5 * (lo + hi)
            if p(mid) < 0.0:
                lo = mid
            else:
                hi = mid
        out[n] = t[i] + 0.5 * (lo + hi) * h
    return out


def _hermite(p0, m0, p1, m1):
    """The cubic Hermite interpolant on s in [0, 1] (m0, m1: derivatives times the step)."""
    def p(s):
        s2, s3 = s * s, s * s * s
        return (2 * s3 - 3 * s2 + 1) * p0 + (s3 - 2 * s2 + s) * m0 + (-2 * s3 + 3 * s2) * p1 + (s3 - s2) * m1
    return p


def _hermite_slope(p0, m0, p1, m1, s: float) -> float:
    """d/ds of the cubic Hermite interpolant at s."""
    return (6 * s * s - 6 * s) * p0 + (3 * s * s - 4 * s + 1) * m0 + (-6 * s * s + 6 * s) * p1 + (3 * s * s - 2 * s) * m1


def hermite_extremes(t, x, xd, lo: float, hi: float) -> tuple[float, float]:
    """(max, min) of the signal over [lo, hi), from the samples inside it and the Hermite-refined
    extremes of the intervals where x' changes sign, those that straddle lo or hi included (an
    extreme of q2 may sit at a zero crossing of q1, where which side of the boundary its computed
    time falls on is rounding: over one period, taking it on both sides repeats the same value)."""
    hi_v, lo_v = cycle_extremes(t, x, xd, (lo, hi))
    return float(hi_v[0]), float(lo_v[0])


def cycle_extremes(t, x, xd, bounds) -> tuple[np.ndarray, np.ndarray]:
    """(max, min) of the signal over each cycle [bounds[i], bounds[i+1]) as `hermite_extremes`
    takes them, all cycles in one pass over the samples (a scan of every sample per cycle is
    quadratic in the length of a long integration). Raises ValueError for a cycle without a
    sample inside."""
    t, x, xd, c = (np.asarray(v, float) for v in (t, x, xd, bounds))
    n = len(c) - 1
    start = np.searchsorted(t, c[:-1], side="left")     # first sample with t >= lo
    stop = np.searchsorted(t, c[1:], side="left")       # first sample with t >= hi
    if n < 1 or np.any(stop <= start):
        raise ValueError("a cycle without a sample inside it: no extremes")
    # segment i of reduceat runs from start[i] to start[i+1], which is stop[i]; the last to the end
    # of what it is given, cut at stop[-1]
    hi_v = np.maximum.reduceat(x[:stop[-1]], start)
    lo_v = np.minimum.reduceat(x[:stop[-1]], start)
    idx = np.nonzero((t[1:] > c[0]) & (t[:-1] < c[-1]) & (np.sign(xd[:-1]) != np.sign(xd[1:])))[0]
    h = t[idx + 1] - t[idx]
    ok, value = _extremes_many(x[idx], xd[idx] * h, x[idx + 1], xd[idx + 1] * h)
    idx, value = idx[ok], value[ok]
    # the cycles j with t[i+1] > c[j] and t[i] < c[j+1] (an interval straddling a bound counts in
    # both): one or two, since every cycle holds a sample
    j0 = np.maximum(np.searchsorted(c, t[idx], side="right") - 1, 0)
    j1 = np.minimum(np.searchsorted(c, t[idx + 1], side="left") - 1, n - 1)
    for j, keep in ((j0, j0 <= j1), (j1, j1 > j0)):
        np.maximum.at(hi_v, j[keep], value[keep])
        np.minimum.at(lo_v, j[keep], value[keep])
    return hi_v, lo_v


def _extremes_many(p0, m0, p1, m1) -> tuple[np.ndarray, np.ndarray]:
    """The extremes of cubic Hermite interpolants on s in [0, 1] (m0, m1: derivatives times the
    step; `_hermite`): (whether the derivative, a s^2 + b s + c, has a root in [0, 1] -- the
    first of q/a and c/q that lies there, with the stable quadratic formula --, the value there)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        a = 6 * p0 + 3 * m0 - 6 * p1 + 3 * m1
        b = -6 * p0 - 4 * m0 + 6 * p1 - 2 * m1
        c = m0
        flat = np.abs(a) < 1e-300
        disc = b * b - 4 * a * c
        q = -0.5 * (b + np.copysign(np.sqrt(np.where(disc < 0, 0.0, disc)), b))
        first = np.where(flat, -c / b, q / a)
        second = c / q
        has_first = np.where(flat, b != 0, disc >= 0)
        has_second = ~flat & (disc >= 0) & (q != 0)
        in1 = has_first & (first >= 0.0) & (first <= 1.0)
        in2 = has_second & (second >= 0.0) & (second <= 1.0)
        s = np.where(in1, first, second)
        s2, s3 = s * s, s * s * s
        value = (2 * s3 - 3 * s2 + 1) * p0 + (s3 - 2 * s2 + s) * m0 + (-2 * s3 + 3 * s2) * p1 + (s3 - s2) * m1
    return in1 | in2, value


@dataclass(frozen=True)
class Cycles:
    """The whole cycles of a sampled response (module docstring)."""

    period: float                 # mean of the cycle periods
    period_spread: float          # max |T_i - period|
    amplitudes: tuple             # (a1, a2): means of the per-cycle half peak-to-peak
    errors: tuple                 # (e1, e2): max |a_k,i - a_k| over the cycles (the stated error)
    ranges: tuple                 # ((min, max) of a1,i, (min, max) of a2,i) over the cycles
    section: np.ndarray           # the states (q1, q2, q1', q2') at the cycle boundaries
    section_change: float         # max |section_{i+1} - section_i| / max |section|
    count: int                    # number of whole cycles
    coordinate: int               # 0 or 1: the coordinate whose crossings bound the cycles


#: The largest number of zero crossings of the section coordinate per period that `own_cycles`
#: considers: a q1 driven by q2^2 (an out-of-plane cycle) crosses zero twice per period.
MAX_CROSSINGS_PER_PERIOD = 3


def own_cycles(t: np.ndarray, ys: np.ndarray, *, min_cycles: int = 3, coordinate: int | None = None,
               crossings_per_period: int | None = None) -> Cycles | None:
    """The cycles of the samples ``ys`` (columns q1, q2, q1', q2') at times ``t``, bounded by the
    upward zero crossings of ``coordinate`` (default: the one with the larger range); None with
    fewer than ``min_cycles`` whole cycles (or a coordinate that does not cross zero).

    A period may hold several upward crossings (q1 at twice the frequency of an out-of-plane cycle
    that drives it quadratically): the period is taken as m crossings, m = 1 .. 3 the smallest
    whose section states repeat ten times better than those of one crossing, if any
    (``crossings_per_period`` fixes m)."""
    t, ys = np.asarray(t, float), np.asarray(ys, float)
    if len(t) < 8:
        return None
    k = int(np.argmax(np.ptp(ys[:, :2], axis=0))) if coordinate is None else int(coordinate)
    c = hermite_crossings(t, ys[:, k], ys[:, 2 + k])
    if len(c) < min_cycles + 1:
        return None
    # the section states: q_k and q_k' from the Hermite interpolant (q_k' to third order in h)
    sec = []
    for tc in c:
        i = min(int(np.searchsorted(t, tc)) - 1, len(t) - 2)
        h = t[i + 1] - t[i]
        s = (tc - t[i]) / h
        q = [_hermite(ys[i, j], ys[i, 2 + j] * h, ys[i + 1, j], ys[i + 1, 2 + j] * h)(s) for j in (0, 1)]
        v = [_hermite_slope(ys[i, j], ys[i, 2 + j] * h, ys[i + 1, j], ys[i + 1, 2 + j] * h, s) / h
             for j in (0, 1)]
        sec.append(q + v)
    sec = np.asarray(sec)
    scale = max(float(np.max(np.abs(sec))), 1e-300)

    def change(m):
        return float(np.max(np.abs(sec[m:] - sec[:-m]))) / scale

    m = crossings_per_period or 1
    for n in (range(2, MAX_CROSSINGS_PER_PERIOD + 1) if crossings_per_period is None else ()):
        if len(c) >= n * min_cycles + 1 and change(n) < 0.1 * change(1):
            m = n
            break
    c, sec = c[::m], sec[::m]
    if len(c) < min_cycles + 1:
        return None
    periods = np.diff(c)
    amps = []
    for j in (0, 1):
        mx, mn = cycle_extremes(t, ys[:, j], ys[:, 2 + j], c)
        amps.append(0.5 * (mx - mn))
    amps = np.asarray(amps)
    means = amps.mean(axis=1)
    errors = np.max(np.abs(amps - means[:, None]), axis=1)
    T = float(periods.mean())
    return Cycles(period=T, period_spread=float(np.max(np.abs(periods - T))),
                  amplitudes=(float(means[0]), float(means[1])), errors=(float(errors[0]), float(errors[1])),
                  ranges=tuple((float(a.min()), float(a.max())) for a in amps),
                  section=sec, section_change=float(np.max(np.abs(np.diff(sec, axis=0)))) / scale, count=len(periods),
                  coordinate=k)


def orbit_amplitudes(t: np.ndarray, ys: np.ndarray) -> tuple[tuple, tuple]:
    """((a1, a2), (e1, e2)) of one closed turn sampled at ``t`` (first and last sample the same
    state): half the peak-to-peak of q1, q2 with Hermite-refined extremes, and the error of each by
    Richardson (the same from every other sample differs by about 15 times it: fourth order)."""
    t, ys = np.asarray(t, float), np.asarray(ys, float)
    amps, errs = [], []
    for j in (0, 1):
        fine = hermite_extremes(t, ys[:, j], ys[:, 2 + j], t[0], t[-1] + 1.0)
        coarse = hermite_extremes(t[::2], ys[::2, j], ys[::2, 2 + j], t[0], t[-1] + 1.0)
        a, b = 0.5 * (fine[0] - fine[1]), 0.5 * (coarse[0] - coarse[1])
        amps.append(a)
        errs.append(abs(a - b) / 15.0)
    return tuple(amps), tuple(errs)
