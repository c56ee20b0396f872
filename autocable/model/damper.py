"""A viscous damper on a stay near its lower anchorage: the modal damping it adds, mode by mode.

The rest state of eq. (21) stays stable up to a design wind when the modal damping ratio is large
enough (`autocable.studies.onset.design_damping`); on a real stay that damping comes from a viscous
damper fixed between the cable and the deck at a distance x_d from the anchorage. This module turns a
damper (x_d, constant c, optionally the stiffness k_s of its support) into added damping ratios and
back.

**The exact taut string** (Krenk 2000). A string of tension T, mass m per length and length L, with
a dashpot c at x = x_d; solutions ~ exp(s t) with s = i z sqrt(T/m) / L. Each segment is a sine
vanishing at its anchorage; continuity and the force balance at the damper,
T (w'(x_d+) - w'(x_d-)) = c s w(x_d), give the transcendental frequency equation

    sin z + i eta sin(r z) sin((1 - r) z) = 0,    r = x_d / L,   eta = c / sqrt(T m),

entire in z (no poles), solved for mode k by Newton's method started at the undamped root z = k pi,
continued in the damper (tan(theta) = eta, theta from 0) so that the root followed is the k-th one
for any c, an infinite c included (theta = pi/2: the string clamped at x_d, z = k pi / (1 - r)).
The damping ratio is zeta = -Re s / |s| = Im z / |z|, the damped frequency Re z sqrt(T/m) / (2 pi L).
A support of stiffness k_s in series with the dashpot makes the damper's force c s w / (1 + s c /
k_s) (a Maxwell element: Krenk & Hogsberg 2005, Fujino & Hoang 2008); the equation multiplied
through stays entire: (cos theta + i rho z sin theta) sin z + i sin theta sin(rz) sin((1-r)z) = 0
with rho = T / (k_s L).

**The asymptotic formula** (Krenk 2000, the universal curve of Pacheco, Fujino & Sulekh 1993 in
closed form): for a damper near the anchorage (r << 1),

    zeta_k / r = kappa / (1 + kappa^2),    kappa = eta k pi r,

so the optimal constant of mode k is c = sqrt(T m) / (k pi r) (kappa = 1) and the largest added
damping r / 2. With the support spring, nu = k_s x_d / T: zeta_k / r = R_k kappa' / (1 + kappa'^2),
kappa' = kappa (1 + 1/nu), R_k = nu / (1 + nu) (Krenk & Hogsberg 2005; the "R_k" of Fujino & Hoang
2008): the maximum drops by R_k, the optimal constant by R_k too.

**Corrections** (asymptotic, in the form of Main & Krenk 2005: the largest damping is half the
relative rise of the frequency when the damper is locked, the slope at small c is c phi(x_d)^2 /
(2 M omega); between them the universal curve, zeta / r = R kappa~ / (1 + kappa~^2) with
kappa~ = kappa E / R, R the factor on the maximum, E the factor on the small-c slope):

* bending stiffness (Hoang & Fujino 2007; Main & Jones 2007): a clamped stay bends in a boundary
  layer of length l_b = sqrt(EI/T) at the anchorage; with eps = x_d / l_b,
  E_f = ((eps - 1 + exp(-eps)) / eps)^2 and
  R_f = 2 (eps - 1 + exp(-eps))^2 / (eps (2 eps - 3 + 4 exp(-eps) - exp(-2 eps)))
  (R_f ~ 1 - 1/(2 eps) for a long boundary-layer distance), derived here from the quasi-static
  boundary layers of the free and the locked beam and checked against the exact tensioned beam
  (`beam_root`; tests/test_damper.py);
* sag (Krenk & Nielsen 2002; Irvine's lambda^2 of eq. 17): the symmetric modes (odd k) of the
  sagging cable, tan(x) = x - 4 x^3 / lambda^2 with x = omega-bar / 2, have
  R_s = tan^2 x / (tan^2 x + 3 (1 - tan(x)/x)) (locking x_d shortens the span and lambda^2 with it)
  and E_s from the mode's slope at the anchorage (`sag_factors`); R_s = 0 at the crossover
  lambda^2 = 4 pi^2 (the first symmetric mode has no slope at the anchorages there, Xu & Yu 1998);
  the antisymmetric modes (even k) do not stretch the cable and are not corrected. Checked against
  the exact sagging cable (`sag_root`).

The design value of mode k (`ModeDamping.added_damping_corrected`) is the exact taut-string root
times the ratio of the corrected to the plain asymptotic formula at the same c: the root carries the
finite x_d / L, the ratio the bending and sag that the string lacks.

Sources: S. Krenk (2000), Vibrations of a taut cable with an external damper, J. Appl. Mech. 67,
772-776. B. M. Pacheco, Y. Fujino, A. Sulekh (1993), Estimation curve for modal damping in stay cables
with viscous damper, J. Struct. Eng. 119(6), 1961-1979. S. Krenk, S. R. K. Nielsen (2002), Vibrations
of a shallow cable with a viscous damper, Proc. R. Soc. Lond. A 458, 339-357. S. Krenk,
J. Hogsberg (2005), Damping of cables by a transverse force, J. Eng. Mech. 131(4), 340-348.
J. A. Main, S. Krenk (2005), Efficiency and tuning of viscous dampers on discrete systems, J. Sound
Vib. 286, 97-122. J. A. Main, N. P. Jones (2007), Vibration of tensioned beams with intermediate
damper, I-II, J. Eng. Mech. 133(4), 369-388. N. Hoang, Y. Fujino (2007), Analytical study on bending
effects in a stay cable with a damper, J. Eng. Mech. 133(11), 1241-1246. Y. Fujino, N. Hoang (2008),
Design formulas for damping of a stay cable with a damper, J. Struct. Eng. 134(2), 269-278.
H. M. Irvine (1981), Cable Structures, MIT Press.
"""
from __future__ import annotations

import cmath
import math
from dataclasses import asdict, dataclass

import numpy as np
from scipy.optimize import brentq, minimize_scalar

from autocable.errors import ComputationError
from autocable.model.premises import ArgumentError

__all__ = ["DEFAULT_MAX_FREQUENCY_HZ", "StringCable", "ModeDamping", "cable_of", "string_root",
           "added_damping", "asymptotic_damping", "optimum", "least_constant", "mode_damping",
           "modes_up_to", "bending_factors", "sag_factors", "beam_root", "sag_root", "universal_curve",
           "eq21_mode", "onset_damping"]

#: Modes reported by default: those of the taut string up to this frequency [Hz] (the wind-excited
#: range of a stay; rain-wind vibration is seen in the lowest modes, below about 3 Hz).
DEFAULT_MAX_FREQUENCY_HZ = 3.0
#: Newton stops when a step is below this fraction of |z| (then one more step is taken).
_STEP_TOL = 1e-14
#: Steps of the continuation in theta (tan theta = eta) from the undamped root; halved on failure.
_CONTINUATION_STEPS = 24


@dataclass(frozen=True)
class StringCable:
    """The stay as the damper sees it: tension T [N], mass m [kg/m], length L [m]; EI [N m^2] and
    Irvine's lambda^2 for the corrections (0: none)."""

    tension_N: float
    mass_kg_m: float
    length_m: float
    bending_stiffness_Nm2: float = 0.0
    lambda2: float = 0.0

    @property
    def impedance(self) -> float:
        """sqrt(T m) [N s/m]: the dashpot constant of eta = 1."""
        return math.sqrt(self.tension_N * self.mass_kg_m)

    @property
    def wave_speed(self) -> float:
        return math.sqrt(self.tension_N / self.mass_kg_m)

    def frequency_hz(self, k: int) -> float:
        """The k-th undamped frequency of the taut string, k / (2 L) sqrt(T/m) [Hz]."""
        return k * self.wave_speed / (2 * self.length_m)


def cable_of(spec) -> StringCable:
    """The `StringCable` of a model spec: T = T-bar = H-bar / cos(alpha) (Sect. 2.1), m, l, EI and
    lambda^2 of eq. (17) (`autocable.model.statics.cable_statics`)."""
    from autocable.model.statics import cable_statics
    st = cable_statics(spec.cable)
    c = spec.cable
    return StringCable(st.T_bar, c.mass_per_length_kg_m, c.length_m, c.bending_stiffness_Nm2, st.lambda2)


def eq21_mode(spec) -> int:
    """The mode of the taut string whose damping is eq. (21)'s in-plane mode's: k of the mode pair
    (1, the paper's first symmetric in-plane mode, unless the spec chooses another pair)."""
    return int(getattr(spec.cable, "mode_pair", 1))


# -- checks ------------------------------------------------------------------------------------------
def _positive(function: str, name: str, value, allow_inf: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) and type(value).__module__ != "numpy":
        raise ArgumentError(function, name, f"expected a positive number, got {value!r}")
    x = float(value)
    if math.isnan(x) or not x > 0 or (math.isinf(x) and not allow_inf):
        raise ArgumentError(function, name, f"expected a positive{'' if allow_inf else ' finite'} number, "
                                            f"got {value!r}")
    return x


def _ratio(cable: StringCable, position_m, function: str) -> float:
    x = _positive(function, "position_m", position_m)
    if not x < cable.length_m / 2:
        raise ArgumentError(function, "position_m", f"expected a distance from the lower anchorage below half "
                                                    f"the length ({cable.length_m / 2:g} m), got {x:g}")
    return x / cable.length_m


def _mode(function: str, k) -> int:
    if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k < 1:
        raise ArgumentError(function, "k", f"expected a mode number 1, 2, ..., got {k!r}")
    return int(k)


def _rho(cable: StringCable, support_stiffness_N_m, function: str) -> float:
    if support_stiffness_N_m is None:
        return 0.0
    return cable.tension_N / (_positive(function, "support_stiffness_N_m", support_stiffness_N_m)
                              * cable.length_m)


# -- the exact taut string ---------------------------------------------------------------------------
def _trig(eta: float) -> tuple[float, float]:
    """(cos theta, sin theta) of tan theta = eta, from eta itself (exact digits for a large eta,
    where theta is within 1e-9 of pi/2)."""
    if math.isinf(eta):
        return 0.0, 1.0
    h = math.hypot(1.0, eta)
    return 1.0 / h, eta / h


def _string_equation(z: complex, r: float, trig: tuple[float, float], rho: float) -> tuple[complex, complex]:
    """F(z) = (cos th + i rho z sin th) sin z + i sin th sin(r z) sin((1-r) z) and dF/dz."""
    ct, st = trig
    sz, cz = cmath.sin(z), cmath.cos(z)
    s1, c1 = cmath.sin(r * z), cmath.cos(r * z)
    s2, c2 = cmath.sin((1 - r) * z), cmath.cos((1 - r) * z)
    lead = ct + 1j * rho * z * st
    F = lead * sz + 1j * st * s1 * s2
    dF = 1j * rho * st * sz + lead * cz + 1j * st * (r * c1 * s2 + (1 - r) * s1 * c2)
    return F, dF


def _newton(fun, z: complex, max_iter: int = 60) -> tuple[complex, int]:
    for it in range(1, max_iter + 1):
        F, dF = fun(z)
        if dF == 0:
            break
        step = F / dF
        z -= step
        if not cmath.isfinite(z) or abs(z.imag) > 700:     # off to infinity (sin z overflows)
            break
        if abs(step) <= _STEP_TOL * max(abs(z), 1.0):
            F, dF = fun(z)
            if dF != 0:
                z -= F / dF
            return z, it + 1
    raise ComputationError(f"damper: Newton's method did not converge from z = {z:.6g}")


def _continue(fun_at, k: int, eta: float, guard, what: str) -> tuple[complex, int]:
    """The root of fun_at(z, (cos theta, sin theta)) followed from z = k pi at theta = 0 to
    tan theta = ``eta``; a step is halved when Newton fails or lands where ``guard(z_old, z_new)``
    refuses (another root)."""
    theta_end = _theta(eta)
    z, theta, total = complex(k * math.pi), 0.0, 0
    step = theta_end / _CONTINUATION_STEPS
    while theta < theta_end:
        t = min(theta + step, theta_end)
        trig = _trig(eta) if t == theta_end else (math.cos(t), math.sin(t))
        try:
            z_new, n = _newton(lambda w: fun_at(w, trig), z)
            ok = guard(z, z_new)
        except (ComputationError, OverflowError, ZeroDivisionError):
            ok, n = False, 0
        total += n
        if ok:
            z, theta = z_new, t
            step = min(step * 1.5, theta_end / 4)
        else:
            step /= 2
            if step < 1e-9:
                raise ComputationError(
                    f"damper: mode {k} {what} could not be followed up to eta = c / sqrt(T m) = {eta:.6g} from "
                    f"the undamped string (it turns overdamped on the way: a damper this far from the "
                    f"anchorage for this mode; the damper formulas are for k x_d / L well below 1/2): move it "
                    f"nearer the anchorage (damper.position_m, or --position)")
    return z, total


def _theta(eta: float) -> float:
    return math.pi / 2 if math.isinf(eta) else math.atan(eta)


def string_root(k: int, r: float, eta: float, rho: float = 0.0) -> dict:
    """The k-th root z of the taut string's frequency equation (module docstring) for x_d = r L,
    eta = c / sqrt(T m) (``math.inf``: the damper locked) and rho = T / (k_s L) (0: rigid support):
    ``{"z", "residual", "iterations"}``, the residual |F(z)| of the equation scaled to O(1)
    coefficients (cos theta, sin theta)."""
    if eta == 0.0:
        return {"z": complex(k * math.pi), "residual": 0.0, "iterations": 0}

    def fun_at(z, trig):
        return _string_equation(z, r, trig, rho)

    def guard(z_old, z_new):
        # the k-th root moves from k pi towards k pi / (1 - r) with the damper, by less than a
        # half-spacing of the roots per step: a larger jump is another root
        return abs(z_new - z_old) < 0.5 * math.pi and z_new.imag >= -1e-12

    z, n = _continue(fun_at, k, eta, guard, f"(x_d/L = {r:.4g})")
    return {"z": z, "residual": abs(fun_at(z, _trig(eta))[0]), "iterations": n}


def _zeta(z: complex) -> float:
    return z.imag / abs(z)


def added_damping(cable: StringCable, k: int, position_m: float, constant_N_s_m: float,
                  support_stiffness_N_m: float | None = None) -> dict:
    """The exact damping ratio and frequencies of the taut string's mode ``k`` with the damper:
    ``{"added_damping", "frequency_Hz" (undamped), "damped_frequency_Hz", "natural_frequency_Hz"
    (|s| / 2 pi), "residual", "iterations"}``."""
    fn = "added_damping"
    k = _mode(fn, k)
    r = _ratio(cable, position_m, fn)
    c = _positive(fn, "constant_N_s_m", constant_N_s_m, allow_inf=support_stiffness_N_m is None)
    root = string_root(k, r, c / cable.impedance, _rho(cable, support_stiffness_N_m, fn))
    z = root["z"]
    scale = cable.wave_speed / (2 * math.pi * cable.length_m)
    return {"added_damping": _zeta(z), "frequency_Hz": cable.frequency_hz(k),
            "damped_frequency_Hz": z.real * scale, "natural_frequency_Hz": abs(z) * scale,
            "residual": root["residual"], "iterations": root["iterations"]}


# -- asymptotics and corrections ---------------------------------------------------------------------
def bending_factors(cable: StringCable, position_m: float) -> tuple[float, float]:
    """(R_f, E_f): the factors of bending stiffness on the largest added damping and on its slope at
    small c, eps = x_d / sqrt(EI/T) (module docstring; Hoang & Fujino 2007, Main & Jones 2007).
    (1, 1) without bending stiffness."""
    if cable.bending_stiffness_Nm2 <= 0:
        return 1.0, 1.0
    eps = position_m / math.sqrt(cable.bending_stiffness_Nm2 / cable.tension_N)
    q = math.exp(-eps)
    # eps - 1 + exp(-eps) ~ eps^2 / 2 near the anchorage: expm1 keeps the digits there
    g = eps + math.expm1(-eps)
    den = eps * (2 * eps - 3 + 4 * q - q * q)
    if den <= 0 or g <= 0:
        return 0.0, 0.0
    # the clamped stay vibrates as a string of length L - 2 l_b: the relative frequency rise and
    # the slope scale with 1 / (L - 2 l_b)
    stretch = 1 / (1 - 2 * position_m / eps / cable.length_m)
    return 2 * g * g / den * stretch, (g / eps) ** 2 * stretch ** 2


def _sag_root(k: int, lambda2: float) -> float:
    """x = omega-bar / 2 of the symmetric in-plane mode continuing the taut string's odd mode k:
    the root of tan x = x - 4 x^3 / lambda^2 in (k pi / 2, k pi / 2 + pi) (Irvine 1981)."""
    def g(x):   # (tan x - x + 4 x^3 / lambda^2) cos x: continuous across the pole of tan
        return math.sin(x) - (x - 4 * x ** 3 / lambda2) * math.cos(x)
    lo, hi = k * math.pi / 2 + 1e-12, k * math.pi / 2 + math.pi - 1e-12
    return brentq(g, lo, hi, xtol=1e-15, rtol=4 * np.finfo(float).eps)


def sag_factors(cable: StringCable, k: int) -> tuple[float, float]:
    """(R_s, E_s): the factors of sag on the largest added damping and on its slope at small c of
    the taut string's mode k (Krenk & Nielsen 2002; module docstring): 1 for an antisymmetric mode
    (even k) or a cable without sag. For the symmetric mode with x = omega-bar / 2,
    R_s = tan^2 x / (tan^2 x + 3 (1 - tan x / x)): locking the damper shortens the span by x_d and
    lambda^2 ~ (span)^3 with it, d ln omega = (x_d / L) R_s; E_s = (2x/(k pi)) tan^2 x (L/2) /
    int phi^2, phi = 1 - cos(2x (s - 1/2)) / cos x, the mode's slope at the anchorage against the
    taut string's."""
    if k % 2 == 0 or cable.lambda2 <= 0:
        return 1.0, 1.0
    x = _sag_root(k, cable.lambda2)
    t = math.tan(x)
    R = t * t / (t * t + 3 * (1 - t / x))
    c = math.cos(x)
    # int_0^1 phi^2 ds with phi = 1 - cos(2x (s - 1/2)) / cos x
    integral = 1 - 2 * t / x + (0.5 + math.sin(2 * x) / (4 * x)) / (c * c)
    E = (2 * x / (k * math.pi)) * t * t * 0.5 / integral
    return R, E


def asymptotic_damping(cable: StringCable, k: int, position_m: float, constant_N_s_m: float,
                       support_stiffness_N_m: float | None = None, corrected: bool = False) -> dict:
    """Krenk's universal curve (module docstring) for mode ``k``: ``{"kappa", "added_damping",
    "max_added_damping", "optimal_constant_N_s_m", "factor_max", "factor_slope"}``; with
    ``corrected`` the bending and sag factors (R_f R_s on the maximum, E_f E_s on the small-c
    slope), always the support factor R_k."""
    fn = "asymptotic_damping"
    k = _mode(fn, k)
    r = _ratio(cable, position_m, fn)
    c = _positive(fn, "constant_N_s_m", constant_N_s_m)
    kappa = c / cable.impedance * k * math.pi * r
    if support_stiffness_N_m is None:
        Rk = 1.0
    else:
        nu = _positive(fn, "support_stiffness_N_m", support_stiffness_N_m) * position_m / cable.tension_N
        Rk = nu / (1 + nu)
    R, E = 1.0, 1.0
    if corrected:
        Rf, Ef = bending_factors(cable, position_m)
        Rs, Es = sag_factors(cable, k)
        R, E = Rf * Rs, Ef * Es
    if R * Rk <= 0:
        zeta, c_opt = 0.0, math.inf
    else:
        kt = kappa * E / (R * Rk)
        zeta = r * R * Rk * kt / (1 + kt * kt)
        c_opt = cable.impedance / (k * math.pi * r) * R * Rk / E
    return {"kappa": kappa, "added_damping": zeta, "max_added_damping": 0.5 * r * R * Rk,
            "optimal_constant_N_s_m": c_opt, "factor_max": R * Rk, "factor_slope": E}


# -- optimum and design ------------------------------------------------------------------------------
def _zeta_of_c(cable: StringCable, k: int, position_m: float, support_stiffness_N_m, corrected: bool):
    """zeta(c) of mode k: the exact taut string, times the ratio of the corrected to the plain
    asymptotic formula with ``corrected`` (the design value)."""
    r = position_m / cable.length_m
    rho = 0.0 if support_stiffness_N_m is None else cable.tension_N / (support_stiffness_N_m * cable.length_m)

    def zeta(c: float) -> float:
        z = _zeta(string_root(k, r, c / cable.impedance, rho)["z"])
        if corrected:
            plain = asymptotic_damping(cable, k, position_m, c, support_stiffness_N_m)["added_damping"]
            corr = asymptotic_damping(cable, k, position_m, c, support_stiffness_N_m, corrected=True)
            z = z * corr["added_damping"] / plain if plain > 0 else z
        return z
    return zeta


def optimum(cable: StringCable, k: int, position_m: float, support_stiffness_N_m: float | None = None,
            corrected: bool = False) -> dict:
    """The damper constant giving mode ``k`` its largest damping ratio at ``position_m`` (exact taut
    string, with ``corrected`` times the bending and sag ratio; maximised over ln c by Brent's bounded
    search around the asymptotic optimum): ``{"optimal_constant_N_s_m", "max_added_damping"}``."""
    fn = "optimum"
    k = _mode(fn, k)
    _ratio(cable, position_m, fn)
    _rho(cable, support_stiffness_N_m, fn)
    asym = asymptotic_damping(cable, k, position_m, cable.impedance, support_stiffness_N_m, corrected=corrected)
    if not math.isfinite(asym["optimal_constant_N_s_m"]):
        return {"optimal_constant_N_s_m": math.inf, "max_added_damping": 0.0}
    u0 = math.log(asym["optimal_constant_N_s_m"])
    # the exact optimum lies within a few per cent of the asymptotic one for x_d < L/10, within a
    # factor of a few up to x_d = L/2
    lo, hi = u0 - math.log(20.0), u0 + math.log(20.0)
    zeta = _zeta_of_c(cable, k, position_m, support_stiffness_N_m, corrected)
    res = minimize_scalar(lambda u: -zeta(math.exp(u)), bounds=(lo, hi), method="bounded", options={"xatol": 1e-9})
    u = float(res.x)
    if min(u - lo, hi - u) < 1e-6:
        raise ComputationError(f"damper: the optimum of mode {k} lies at the edge of the search "
                               f"(c = {math.exp(u):.6g} N s/m, 20 times from the asymptotic one)")
    return {"optimal_constant_N_s_m": math.exp(u), "max_added_damping": -float(res.fun)}


def least_constant(cable: StringCable, position_m: float, target: float, k: int = 1,
                   support_stiffness_N_m: float | None = None, corrected: bool = False) -> tuple[float | None, str]:
    """The least damper constant [N s/m] at ``position_m`` that adds the damping ratio ``target`` to
    mode ``k`` (the exact taut string, with ``corrected`` its design value; on the rising side of the
    curve, below the optimum, by Brent's method on ln c) and ""; or (None, why) when ``target`` is
    above the largest damping attainable there."""
    fn = "least_constant"
    k = _mode(fn, k)
    r = _ratio(cable, position_m, fn)
    target = _positive(fn, "target", target)
    opt = optimum(cable, k, position_m, support_stiffness_N_m, corrected=corrected)
    if target > opt["max_added_damping"]:
        return None, (f"a damper at {position_m:g} m (x_d/L = {r:.4g}) adds at most "
                      f"{100 * opt['max_added_damping']:.4g} % to mode {k} (at c = "
                      f"{opt['optimal_constant_N_s_m']:.4g} N s/m), below the {100 * target:.4g} % needed; "
                      f"move it to about x_d/L = {2 * target:.3g} or more (the maximum is about x_d / (2 L))")
    zeta = _zeta_of_c(cable, k, position_m, support_stiffness_N_m, corrected)
    hi = math.log(opt["optimal_constant_N_s_m"])
    lo = hi - 40.0          # zeta ~ c at small c: e^-40 of the optimum is below any target asked
    if zeta(math.exp(lo)) >= target:
        return math.exp(lo), ""
    u = brentq(lambda u: zeta(math.exp(u)) - target, lo, hi, xtol=1e-13, rtol=1e-14)
    return math.exp(u), ""


@dataclass(frozen=True)
class ModeDamping:
    """Mode k of the stay with the damper (`mode_damping`)."""

    k: int
    frequency_Hz: float                  # undamped taut string, k/(2L) sqrt(T/m)
    damped_frequency_Hz: float           # Re s / 2 pi with the damper (exact)
    added_damping: float                 # exact taut string
    added_damping_asymptotic: float      # Krenk's universal curve
    added_damping_corrected: float       # exact x (corrected / plain asymptotic): bending, sag
    kappa: float                         # eta k pi x_d / L
    optimal_constant_N_s_m: float        # exact
    max_added_damping: float             # exact, at the optimal constant
    optimal_constant_asymptotic_N_s_m: float
    max_added_damping_asymptotic: float
    optimal_constant_corrected_N_s_m: float   # the optimum of the design value
    max_added_damping_corrected: float   # the design value's maximum
    bending_factor: float                # R_f
    sag_factor: float                    # R_s
    support_factor: float                # R_k
    residual: float                      # |F(z)| of the root at the given constant
    iterations: int

    def as_dict(self) -> dict:
        return asdict(self)


def mode_damping(cable: StringCable, k: int, position_m: float, constant_N_s_m: float,
                 support_stiffness_N_m: float | None = None) -> ModeDamping:
    """Everything about mode ``k`` with the damper: exact, asymptotic, corrected, the optimum."""
    ex = added_damping(cable, k, position_m, constant_N_s_m, support_stiffness_N_m)
    plain = asymptotic_damping(cable, k, position_m, constant_N_s_m, support_stiffness_N_m)
    corr = asymptotic_damping(cable, k, position_m, constant_N_s_m, support_stiffness_N_m, corrected=True)
    opt = optimum(cable, k, position_m, support_stiffness_N_m)
    opt_c = optimum(cable, k, position_m, support_stiffness_N_m, corrected=True)
    ratio = corr["added_damping"] / plain["added_damping"] if plain["added_damping"] > 0 else 1.0
    Rf, _ = bending_factors(cable, position_m)
    Rs, _ = sag_factors(cable, k)
    Rk = plain["factor_max"]
    return ModeDamping(
        k=k, frequency_Hz=ex["frequency_Hz"], damped_frequency_Hz=ex["damped_frequency_Hz"],
        added_damping=ex["added_damping"], added_damping_asymptotic=plain["added_damping"],
        added_damping_corrected=ex["added_damping"] * ratio, kappa=plain["kappa"],
        optimal_constant_N_s_m=opt["optimal_constant_N_s_m"], max_added_damping=opt["max_added_damping"],
        optimal_constant_asymptotic_N_s_m=plain["optimal_constant_N_s_m"],
        max_added_damping_asymptotic=plain["max_added_damping"],
        optimal_constant_corrected_N_s_m=opt_c["optimal_constant_N_s_m"],
        max_added_damping_corrected=opt_c["max_added_damping"],
        bending_factor=Rf, sag_factor=Rs, support_factor=Rk,
        residual=ex["residual"], iterations=ex["iterations"])


def modes_up_to(cable: StringCable, max_frequency_hz: float = DEFAULT_MAX_FREQUENCY_HZ) -> list[int]:
    """The modes k of the taut string with k/(2L) sqrt(T/m) <= ``max_frequency_hz`` (1, 2, ...)."""
    f = _positive("modes_up_to", "max_frequency_hz", max_frequency_hz)
    return list(range(1, int(math.floor(f / cable.frequency_hz(1) * (1 + 1e-12))) + 1))


def universal_curve(cable: StringCable, k: int, position_m: float, support_stiffness_N_m: float | None = None,
                    kappas=None) -> list[dict]:
    """The exact zeta_k / (x_d / L) against the damper parameter kappa = eta k pi x_d / L (the
    abscissa of the universal curve) for the plot: rows {"kappa", "constant_N_s_m",
    "zeta_over_r", "asymptotic_over_r"}."""
    r = _ratio(cable, position_m, "universal_curve")
    ks = np.geomspace(0.02, 50.0, 61) if kappas is None else kappas
    rows = []
    for kap in ks:
        c = float(kap) * cable.impedance / (k * math.pi * r)
        try:
            ex = added_damping(cable, k, position_m, c, support_stiffness_N_m)
        except ComputationError:        # the mode turns overdamped beyond here: the curve ends
            break
        asym = asymptotic_damping(cable, k, position_m, c, support_stiffness_N_m)
        rows.append({"kappa": float(kap), "constant_N_s_m": c, "zeta_over_r": ex["added_damping"] / r,
                     "asymptotic_over_r": asym["added_damping"] / r})
    return rows


def onset_damping(spec) -> dict | None:
    """What the model's ``[damper]`` adds to the modal damping of eq. (21) (`eq21_mode`): the
    corrected exact value (`ModeDamping.added_damping_corrected`); None without a damper."""
    damper = getattr(spec, "damper", None)
    if damper is None:
        return None
    cable = cable_of(spec)
    k = eq21_mode(spec)
    md = mode_damping(cable, k, damper.position_m, damper.constant_N_s_m, damper.support_stiffness_N_m)
    return {"mode": k, "position_m": damper.position_m, "constant_N_s_m": damper.constant_N_s_m,
            "support_stiffness_N_m": damper.support_stiffness_N_m,
            "added_damping": md.added_damping_corrected, "added_damping_taut_string": md.added_damping,
            "structural_damping": spec.cable.damping_ratio,
            "total_damping": spec.cable.damping_ratio + md.added_damping_corrected}


# -- exact routes for the corrections (checks of the asymptotic factors) -----------------------------
def _det_root(det, z0: complex, h: float = 1e-7, max_iter: int = 80) -> complex:
    """A root of the analytic function det near z0 by Newton's method with a central difference."""
    z = complex(z0)
    for _ in range(max_iter):
        d = det(z)
        dd = (det(z + h) - det(z - h)) / (2 * h)
        if dd == 0:
            break
        step = d / dd
        z -= step
        # a determinant of unit-scaled rows is exact to ~1e-15: steps stall near 1e-13 |z|
        if abs(step) < 1e-10 * abs(z):
            return z
    raise ComputationError(f"damper: the determinant's root near {z0:.6g} was not found")


def beam_root(k: int, r: float, eta: float, xi: float) -> complex:
    """The k-th root z (s = i z sqrt(T/m) / L) of the tensioned beam clamped at both ends with the
    dashpot at x_d = r L, xi = L sqrt(T/EI) (Main & Jones 2007): EI w'''' - T w'' + m w_tt = 0 on
    each side, w, w', w'' continuous at x_d, EI [w'''] = -c s w(x_d); followed in theta from the
    undamped root. An 8 x 8 determinant in a basis scaled to each segment (exp(-p (x - x0)),
    exp(-p (x1 - x))), so that xi in the thousands does not overflow."""
    def det(z, t):
        zz = z * z
        disc = cmath.sqrt(1 + 4 * zz / xi ** 2)
        p = xi * cmath.sqrt((1 + disc) / 2)             # ~ xi: the boundary layers
        b = xi * cmath.sqrt((disc - 1) / 2)             # ~ z: the string-like wave
        segs = ((0.0, r), (r, 1.0))

        def basis(seg, x, d):
            x0, x1 = segs[seg]
            # d-th derivatives of sin(b(x-x0)), cos(b(x-x0)), exp(-p(x-x0)), exp(-p(x1-x))
            u = x - x0
            sb = [cmath.sin(b * u), b * cmath.cos(b * u), -b * b * cmath.sin(b * u), -b ** 3 * cmath.cos(b * u)][d]
            cb = [cmath.cos(b * u), -b * cmath.sin(b * u), -b * b * cmath.cos(b * u), b ** 3 * cmath.sin(b * u)][d]
            e1 = (-p) ** d * cmath.exp(-p * u)
            e2 = p ** d * cmath.exp(-p * (x1 - x))
            return [sb, cb, e1, e2]

        M = np.zeros((8, 8), dtype=complex)
        M[0, :4] = basis(0, 0.0, 0)
        M[1, :4] = basis(0, 0.0, 1)
        M[2, 4:] = basis(1, 1.0, 0)
        M[3, 4:] = basis(1, 1.0, 1)
        for row, d in ((4, 0), (5, 1), (6, 2)):
            M[row, :4] = basis(0, r, d)
            M[row, 4:] = [-v for v in basis(1, r, d)]
        # cos t (1/xi^2) (w'''(r+) - w'''(r-)) + sin t i z w(r) = 0  (tan t = eta)
        ct, st = math.cos(t), math.sin(t)
        left3, right3, left0 = basis(0, r, 3), basis(1, r, 3), basis(0, r, 0)
        M[7, :4] = [-ct * v / xi ** 2 + st * 1j * z * w for v, w in zip(left3, left0)]
        M[7, 4:] = [ct * v / xi ** 2 for v in right3]
        # rows of derivatives carry powers of p ~ xi: scale each row to a unit maximum (same roots)
        M /= np.abs(M).max(axis=1, keepdims=True)
        return np.linalg.det(M)

    theta_end = _theta(eta)
    # the undamped root: the clamped tensioned beam's k-th (near k pi / (1 - 2/xi))
    z = _det_root(lambda w: det(w, 0.0), k * math.pi / (1 - 2 / xi))
    n = _CONTINUATION_STEPS
    for j in range(1, n + 1):
        z = _det_root(lambda w, t=theta_end * j / n: det(w, t), z)
    return z


def sag_root(k: int, r: float, eta: float, lambda2: float) -> complex:
    """The k-th root z of the sagging cable (Irvine's linear theory, lambda^2 of eq. 17) with the
    dashpot at x_d = r L: w'' + z^2 w = lambda^2 int_0^1 w on each side, w = A sin + P (1 - cos)
    with P z^2 = lambda^2 int w; continuity and the jump at x_d; a 3 x 3 determinant (Krenk &
    Nielsen 2002), followed in theta from the undamped symmetric (odd k) or antisymmetric root."""
    def det(z, t):
        a, b = r * z, (1 - r) * z
        sa, ca, sb, cb = cmath.sin(a), cmath.cos(a), cmath.sin(b), cmath.cos(b)
        ct, st = math.cos(t), math.sin(t)
        M = np.array([
            # continuity: A1 sin a + P (1 - cos a) - A2 sin b - P (1 - cos b) = 0
            [sa, -sb, cb - ca],
            # cos t (w2' - w1') / z - i sin t w(x_d) = 0
            [-ct * ca - 1j * st * sa, -ct * cb, -ct * (sa + sb) - 1j * st * (1 - ca)],
            # P z^2 = lambda^2 (A1 (1 - cos a)/z + A2 (1 - cos b)/z + P (1 - (sin a + sin b)/z))
            [lambda2 * (1 - ca) / z, lambda2 * (1 - cb) / z, lambda2 * (1 - (sa + sb) / z) - z * z],
        ], dtype=complex)
        return np.linalg.det(M)

    theta_end = _theta(eta)
    z0 = 2 * _sag_root(k, lambda2) if k % 2 and lambda2 > 0 else k * math.pi
    z = _det_root(lambda w: det(w, 0.0), z0)
    n = _CONTINUATION_STEPS
    for j in range(1, n + 1):
        z = _det_root(lambda w, t=theta_end * j / n: det(w, t), z)
    return z
