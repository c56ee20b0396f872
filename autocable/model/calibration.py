"""Calibration of the unknown wind angles so that galloping starts at U_c (eq. 18, Sect. 5).

The paper states U_c = 36 m/s as a result but gives neither the yaw beta nor the rivulet angle
Theta0 (docs/model.md, U1). Given one of them, the other is found so that
the trivial solution of eq. (21) at eta = 0 loses stability at U* = 1 (U = U_c) through the in-plane
mode (Fig. 3 is in-plane galloping), while the out-of-plane mode stays stable up to U* = 1.3, the
largest wind of Sect. 5. Stability is judged on the eigenvalues of the linear part of eq. (21),
both modes and all their aerodynamic couplings included.

With curves other than eq. (13)'s cubics (a table, a fit bounded by the dry cylinder:
`autocable.model.curves`) every candidate angle moves the static angle phi0, and the linear load is
that of the curves' own cubic at that phi0 (`equivalent_cubic`), the cubic eq. (21) is then derived
with: the calibrated angle is the one the derived model has its onset at. A root whose static angle
lies outside the curves' stated valid range (``aero.valid_phi_deg``, a table's range, a blend's fit
range) is rejected: there the curves are not the measured section's (a blend's zone would otherwise
offer roots of its own).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq

from autocable.model.aero import expand_load_jet, linear_load
from autocable.model.curves import curves_from_spec, eq21_fits, static_angle
from autocable.model.galerkin import linear_aero_matrix


class CalibrationError(ValueError):
    """No angle satisfies the calibration conditions; ``field`` is the spec field to change."""

    def __init__(self, field: str, message: str):
        self.field, self.message = field, message
        super().__init__(f"{field}: {message}")


@dataclass(frozen=True)
class Calibration:
    beta: float            # yaw [rad]
    theta0: float          # rivulet angle [rad]
    solved_for: str        # "yaw_deg" or "rivulet_angle_deg"
    roots_deg: tuple       # every root found in the scanned range [deg]
    rejected: tuple        # (root_deg, reason) for the roots that failed a condition


def _linear_matrix(omega1, omega2, xi_s, aero_lin: dict, U: float) -> np.ndarray:
    """First-order form of eq. (21) at eta = 0; aero_lin from `linear_aero_matrix` (at U = 1)."""
    A = np.zeros((4, 4))
    A[0, 2] = A[1, 3] = 1.0
    A[2, 0] = -omega1**2
    A[3, 1] = -omega2**2
    A[2, 2] = -2 * xi_s * omega1
    A[3, 3] = -2 * xi_s * omega2
    for (k, j), c in aero_lin.items():
        scale = U**2 if j == 1 else U     # the twist term carries U^2, the velocity terms U
        A[1 + k, j] -= c * scale
    return A


def _growth(A):
    lam, vec = np.linalg.eig(A)
    i = int(np.argmax(lam.real))
    return lam[i].real, vec[:, i]


def calibrate(aero_spec, st, modes, integrator, K: float, nu: float, xi_s: float,
              scan_step_deg: float = 0.25) -> Calibration:
    """Find the missing angle (yaw or rivulet) of ``aero_spec``; see the module docstring."""
    solve_yaw = aero_spec.yaw_deg is None
    lift, drag = aero_spec.lift, aero_spec.drag
    lo, hi = (-90.0, 90.0)
    curves = curves_from_spec(aero_spec)
    local: dict = {}
    conv, axes = aero_spec.angle_convention, aero_spec.load_axes

    def linear(beta, th0):
        if curves.kind == "cubic":
            return linear_load(lift, drag, st.alpha, beta, th0, conv, axes)
        if (beta, th0) not in local:
            l4, d4 = curves.equivalent_cubic(static_angle(st.alpha, beta, th0, conv))
            if lift is not None and (l4, d4) == (tuple(lift), tuple(drag)):    # a blend inside its range
                local[beta, th0] = linear_load(l4, d4, st.alpha, beta, th0, conv, axes)
            else:
                # a new cubic at every angle: the jet's millisecond, not a sympy lambdify per angle
                exp = expand_load_jet(l4, d4, st.alpha, beta, th0, conv, axes)
                local[beta, th0] = {(c, m): (exp.b2 if c == 2 else exp.b3)[m] for c in (2, 3)
                                    for m in ((1, 0, 0), (0, 1, 0), (0, 0, 1))}
        return local[beta, th0]

    def _outside_curves(angle_deg) -> str:
        # A static state where the curves do not hold (a blend's zone, beyond a table) is no onset
        # of the measured section; the paper's fits state no range (theirs is about phi0 itself).
        if curves.valid_phi is None:
            return ""
        beta = math.radians(angle_deg) if solve_yaw else math.radians(aero_spec.yaw_deg)
        th0 = math.radians(aero_spec.rivulet_angle_deg) if solve_yaw else math.radians(angle_deg)
        phi0 = static_angle(st.alpha, beta, th0, conv)
        lo, hi = curves.valid_phi
        if lo <= phi0 <= hi:
            return ""
        return (f"its static angle phi0 = {math.degrees(phi0):.2f} deg is outside the curves' valid range "
                f"[{math.degrees(lo):.2f}, {math.degrees(hi):.2f}] deg")

    aero_at: dict = {}

    def matrix(angle_deg, U):
        # the aerodynamic matrix depends on the angle only: kept per angle, since a diagnosis of a
        # failed calibration (`_no_root_reason`) scans every angle at many winds
        if angle_deg not in aero_at:
            beta = math.radians(angle_deg) if solve_yaw else math.radians(aero_spec.yaw_deg)
            th0 = math.radians(aero_spec.rivulet_angle_deg) if solve_yaw else math.radians(angle_deg)
            aero_at[angle_deg] = linear_aero_matrix(integrator, K, nu, st.m_star, linear(beta, th0))
        return _linear_matrix(modes.omega1, modes.omega2, xi_s, aero_at[angle_deg], U)

    def g(angle_deg):
        return _growth(matrix(angle_deg, 1.0))[0]

    grid = np.arange(lo, hi + 1e-9, scan_step_deg)
    values = [g(a) for a in grid]
    roots = []
    for a0, a1, g0, g1 in zip(grid[:-1], grid[1:], values[:-1], values[1:]):
        if g0 == 0.0:
            roots.append(float(a0))
        elif g0 * g1 < 0:
            roots.append(brentq(g, a0, a1, xtol=1e-13, rtol=1e-15))
    accepted, rejected = [], []
    for r in roots:
        reason = _outside_curves(r) or _reject_reason(lambda U: matrix(r, U))
        (rejected.append((r, reason)) if reason else accepted.append(r))
    field = "yaw_deg" if solve_yaw else "rivulet_angle_deg"
    if not accepted:
        # The fix first, then the evidence: a message that must be cut keeps the fix. Most often
        # the yaw's sign is the wrong one for the chord slope's (only their relative sign matters).
        if solve_yaw:
            fix = f"try aero.rivulet_angle_deg = {-aero_spec.rivulet_angle_deg:g} or the other angle_convention"
        else:
            fix = (f"try aero.yaw_deg = {-aero_spec.yaw_deg:g} (its sign against the chord slope's) or the other "
                   "angle_convention")
        # What the user typed that no angle can meet, named with its value as given (a tiny damping
        # ratio or onset speed fails here, and the angle is not what to change then); kept within
        # a SpecError's MAX_MESSAGE, the fix included
        short_fix = fix.split(" (its sign")[0].replace(" or the other angle_convention", "")
        blamed = _diagnosis(roots, rejected, [float(a) for a in grid], values, matrix, xi_s,
                            aero_spec.critical_wind_speed_m_s, short_fix)
        if blamed:
            raise CalibrationError(*blamed)
        raise CalibrationError(
            f"aero.{field}", f"no angle gives an in-plane onset at U_c (out-of-plane stable to 1.3 U_c): {fix} "
            f"(roots {[round(r, 2) for r in roots[:3]]}{f' and {len(roots) - 3} more' if len(roots) > 3 else ''})")
    best = min(accepted, key=abs)
    beta = math.radians(best) if solve_yaw else math.radians(aero_spec.yaw_deg)
    th0 = math.radians(aero_spec.rivulet_angle_deg) if solve_yaw else math.radians(best)
    return Calibration(beta=beta, theta0=th0, solved_for=field, roots_deg=tuple(roots),
                       rejected=tuple(rejected))


def _diagnosis(roots, rejected, grid, values, matrix, xi_s: float, uc: float, fix: str):
    """(field, message) of a failed calibration that a typed value explains, or None. With no root
    at all every angle's in-plane growth at U_c has one sign: the onset speeds the angles do reach
    (the lowest, or the highest) say how far U_c (``aero.critical_wind_speed_m_s``) is from what
    the curves give with this damping. With every root unstable already far below U_c, the
    structural damping (``cable.damping_ratio``) is too small to hold another mode below U_c
    (the sample cable fits with 0.1 % and fails from 0.01 % down). ``fix``: the angle's fix."""
    from autocable.spec import number_text
    uc, xi_s = float(uc), float(xi_s)
    if not roots and values and all(np.isfinite(values)):
        stable = max(values) < 0          # every angle still stable at U_c: the onsets lie above it
        U_end = _reachable_onset(grid, matrix, above=stable)
        end = number_text(float(f"{U_end * uc:.4g}")) if U_end is not None else None
        if stable:
            return ("aero.critical_wind_speed_m_s",
                    f"{number_text(uc)} m/s is below every angle's onset with cable.damping_ratio = "
                    f"{number_text(xi_s)} ({f'the lowest: {end} m/s' if end else 'none up to 1000 U_c'}): give a "
                    f"larger U_c or a smaller damping_ratio, or {fix}")
        return ("aero.critical_wind_speed_m_s",
                f"{number_text(uc)} m/s is above every angle's onset with cable.damping_ratio = {number_text(xi_s)} "
                f"({f'the highest: {end} m/s' if end else 'unstable without wind'}): give a smaller U_c or a larger "
                f"damping_ratio, or {fix}")
    below = [float(r.split("U* = ")[1]) for _, r in rejected if r.startswith("unstable already at U* = ")]
    if roots and len(below) == len(rejected) == len(roots) and max(below) < 0.5:
        return ("cable.damping_ratio",
                f"{number_text(xi_s)} is too little: every angle with the onset at U_c is unstable already at "
                f"U* = {', '.join(f'{u:.2g}' for u in below[:3])} (another mode gallops first): give a larger "
                f"damping_ratio, or {fix}")
    return None


def _reachable_onset(grid, matrix, above: bool) -> float | None:
    """The least U* (``above``: every angle stable at U* = 1) at which some angle of ``grid`` loses
    stability, or the largest U* (every angle unstable at 1) at which the last one does, by
    bisection on U* of the largest (smallest) growth rate over the angles; None where none lies in
    (0, 1000]."""
    pick = max if above else min       # the first angle to lose stability, or the last

    def h(U):
        return pick(_growth(matrix(a, U))[0] for a in grid)
    if above:
        lo, hi = 1.0, 2.0
        while h(hi) < 0:
            if hi >= 1000:
                return None
            lo, hi = hi, min(2 * hi, 1000.0)
    else:
        lo, hi = 0.0, 1.0
        if h(0.0) >= 0:
            return None
    for _ in range(30):        # 1e-9 of the bracket: the 4 digits quoted
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if h(mid) < 0 else (lo, mid)
    return hi if above else lo


def _reject_reason(matrix_at) -> str:
    """Why a root fails the conditions of the module docstring ('' if it does not)."""
    for U in np.linspace(0.0, 0.999, 41):
        if _growth(matrix_at(U))[0] >= 0:
            return f"unstable already at U* = {U:.3f}"
    grow, vec = _growth(matrix_at(1.001))
    if grow <= 0:
        return "the trivial solution does not lose stability when U* crosses 1"
    if abs(vec[0]) < abs(vec[1]):
        return "the critical mode at U* = 1 is out-of-plane"
    for U in np.linspace(0.0, 1.3, 53):
        lam, vec = np.linalg.eig(matrix_at(U))
        for l, v in zip(lam, vec.T):
            if abs(v[1]) > abs(v[0]) and l.real >= 0:
                return f"the out-of-plane mode is unstable at U* = {U:.3f}"
    return ""


def decoupled_angles(aero_spec, st, modes, integrator, K: float, nu: float, xi_s: float,
                     guess_deg=(-26.0, 25.0)) -> tuple[float, float]:
    """(beta, Theta0) in degrees at which the in-plane galloping onset is exactly mono-modal.

    Two conditions: the in-plane aerodynamic damping cancels the structural one at U_c
    (zeta11 = -2 xi_s omega1: docs/model.md, M5 and U1), and the linear
    load of the in-plane velocity on the out-of-plane equation vanishes (xi12 = 0), so that the
    linearised eq. (21) at eta = 0 is block-triangular and its in-plane pair crosses the imaginary
    axis at U* = 1 with no out-of-plane component (Fig. 3: mono-modal galloping). This is how the
    sample model's yaw was chosen; `calibrate` then finds Theta0 from it.
    """
    from scipy.optimize import fsolve

    target = -2 * xi_s * modes.omega1

    def residual(x):
        beta, th0 = math.radians(x[0]), math.radians(x[1])
        lift, drag = eq21_fits(aero_spec, st.alpha, beta, th0)    # a table or a blend: its cubic at phi0
        lin = linear_load(lift, drag, st.alpha, beta, th0, aero_spec.angle_convention, aero_spec.load_axes)
        al = linear_aero_matrix(integrator, K, nu, st.m_star, lin)
        return [(al[(1, 2)] - target) / abs(target), al[(2, 2)] / abs(target)]

    x, info, ok, msg = fsolve(residual, list(guess_deg), xtol=1e-13, full_output=True)
    if ok != 1 or max(abs(r) for r in residual(x)) > 1e-9:
        raise CalibrationError("aero", f"no decoupled (yaw, rivulet) pair near {guess_deg} deg: {msg}")
    return float(x[0]), float(x[1])
