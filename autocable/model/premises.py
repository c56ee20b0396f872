"""The premises of the model, checked where inputs enter: an error where the model cannot apply,
a warning where it is stretched, each naming the quantity.

Eq. (21) rests on a nearly taut cable (small static strain, small sag parameter delta), a slender
section, a near 1:1 internal resonance omega2 ~ omega1, and small nondimensional support motion and
detuning (the Multiple Scales of Sect. 4 expand in them). Values outside these ranges are refused or
flagged here, not discovered later as nonsense amplitudes.
"""
from __future__ import annotations

import math
import warnings
from typing import Mapping

from autocable.model.statics import cable_statics
from autocable.spec import ModelSpec, SpecError, show

__all__ = ["PremiseWarning", "MAX_AMPLITUDE", "PARAMETER_RANGES", "CABLE_LIMITS", "check_parameters", "check_model"]


class PremiseWarning(UserWarning):
    """A value where the model is stretched but still computed; ``str`` is one line naming it."""


#: The largest |q_k| (or |q_k'|, a_k) a start may have: eq. (21)'s coordinates are fractions of the
#: cable length, and beyond 0.1 (12 m on the sample cable) its small-amplitude expansions cannot
#: apply (the paper's responses are below 1e-2); integration calls a response past it diverged
#: (`autocable.methods.integration.ode21.DIVERGED`).
MAX_AMPLITUDE = 0.1

#: The longest integration any input may ask for (t* units: ``simulate --max-time``, a sweep's
#: ``max_time``, a scene's ``chart.t_end``, ``overlay.max_time`` and ``time.t_end``). The default
#: 60000 reaches every steady state of the sample cable; a million is about half an hour of
#: eq. (21) per point, and bounds every single compiled call (a chart's AME run to 1e6 takes well
#: under a second), so that Ctrl-C is answered at once.
MAX_INTEGRATION_TIME = 1e6

#: name -> (error below, error above, warn above |value|, what it is). U* = U/U_c, eta* = eta/l,
#: sigma = Omega - omega1 (nondimensional time of eq. 21).
PARAMETER_RANGES: dict[str, tuple[float, float, float, str]] = {
    "U": (0.0, 5.0, 2.0, "the nondimensional wind speed U* = U/U_c"),
    "eta": (0.0, 0.05, 5e-3, "the nondimensional support amplitude eta* = eta/l"),
    "sigma": (-0.5, 0.5, 0.2, "the detuning sigma = Omega - omega1"),
}


def check_parameters(values: Mapping[str, float], where: str = "arguments",
                     fields: Mapping[str, str] | None = None) -> None:
    """Refuse non-finite or out-of-range U, eta, sigma (`SpecError` naming ``where`` and the field);
    warn (`PremiseWarning`) where the expansions of Sect. 4 are stretched. ``fields`` maps a
    parameter to the name the user wrote (e.g. ``{"eta": "--eta"}``)."""
    fields = fields or {}
    for name, value in values.items():
        if name not in PARAMETER_RANGES:
            continue
        lo, hi, warn, what = PARAMETER_RANGES[name]
        label = fields.get(name, name)
        try:
            x = float(value)
        except (TypeError, ValueError, OverflowError):
            raise SpecError(where, label, f"expected a number, {what}, got {show(value)}") from None
        if not math.isfinite(x):
            raise SpecError(where, label, f"expected a finite number, {what}, got {value!r}")
        if not lo <= x <= hi:
            raise SpecError(where, label, f"{what} must lie in [{lo:g}, {hi:g}] for eq. (21) to apply, "
                                          f"got {x!r}")
        if abs(x) > warn:
            warnings.warn(PremiseWarning(f"{where}: {label} = {x:g}: {what} beyond {warn:g}, where the "
                                         f"small-amplitude expansions of Sect. 4 are stretched"),
                          stacklevel=2)


#: The derived cable's premises: quantity -> (warn beyond, error beyond). Why these values:
#:
#: * static strain tau = T-bar/EA: eqs. (1-4) linearise the constitutive law about a taut, elastic
#:   cable; steel stays work at 1e-3..5e-3 (the sample 1.8e-3). Above 1e-2 the strain is outside any
#:   elastic stay; above 0.5 the cable has stretched by half its length and "nearly taut" has no
#:   meaning (EA = 1 N gives 3.8e6, which the frequencies alone would hide: omega1 = 1 + 2e-12).
#: * slenderness D/l: the cable is a 1-d continuum loaded by a 2-d section (eqs. 9-14); at 1e-2 the
#:   section is a hundredth of the span, at 0.1 a beam rather than a cable (sample: 9.8e-4).
#: * sag delta = kappa-bar l: the nearly-taut statics take the chord as the reference line; delta is
#:   the angle (rad) the profile turns over the span: above 1 (57 deg) the cable is a hanging chain.
#:   (delta > 0.1 is flagged by `autocable.model.statics.regime_warnings`.)
#: * Irvine's lambda^2 = delta^2/tau: above 4 pi^2 the first symmetric in-plane frequency crosses the
#:   antisymmetric one (omega1 > 2) and the 1:1 resonance of Sect. 4 is gone. Below 1e-12
#:   omega1 - 1 = 4 lambda^2/pi^4 is lost to rounding (the in-plane root cannot be resolved) and,
#:   with natural twist ends, the slaved twist ~ 2 pi/delta grows without bound.
#: * internal detuning |omega2 - omega1|: the Multiple Scales treat it as small (rho = O(eps));
#:   beyond 0.1 the near 1:1 resonance is stretched (sample: 0.004). It cannot exceed 1 once
#:   lambda^2 <= 4 pi^2, so it only warns.
#: * torsion ratio chi = GJ/EI: 1/(1 + nu), below 1, for a solid isotropic section, less for a strand
#:   (sample: 0.076); above 10 no section has it, and below 1e-6 the slaved twist of eq. (20), with
#:   wavenumber delta/sqrt(chi), overflows.
CABLE_LIMITS: dict[str, tuple[float, float]] = {
    "strain": (1e-2, 0.5),
    "slenderness": (1e-2, 0.1),
    "delta": (math.inf, 1.0),
    "lambda2": (math.inf, 4 * math.pi ** 2),
    "detuning": (0.1, math.inf),
    "chi": (math.inf, 10.0),
}
LAMBDA2_MIN = 1e-12
CHI_MIN = 1e-6
#: Below this D/l no stay exists (a 1 mm wire over 1 km); the Scruton number m xi/(rho D^2) and the
#: load's D^2 underflow to 0 far below it (D = 1e-200 m divided by zero).
SLENDERNESS_MIN = 1e-6


def check_model(spec: ModelSpec) -> dict[str, float]:
    """Refuse (`SpecError` naming the file and the quantity, its value and the accepted range) a
    cable eq. (21) cannot describe, and warn (`PremiseWarning`) where it is stretched; see
    `CABLE_LIMITS`. Cheap (statics and one root), and runs before any root finding that an
    impossible cable would make fail. Returns the quantities checked."""
    c, where = spec.cable, spec.path or spec.name
    # The groups of eq. (17) by products and quotients only (no powers, which raise OverflowError
    # on numbers that are finite but absurd), so every one is checked before statics and modes.
    cos_a = math.cos(math.radians(c.chord_slope_deg))
    tau = c.horizontal_tension_N / cos_a / c.axial_stiffness_N
    delta = c.mass_per_length_kg_m * c.gravity_m_s2 * cos_a * cos_a / c.horizontal_tension_N * c.length_m
    q = {"strain": tau, "slenderness": c.diameter_m / c.length_m, "delta": delta,
         "lambda2": delta * (delta / tau) if tau > 0 else math.inf,
         "chi": c.torsional_stiffness_Nm2 / c.bending_stiffness_Nm2}
    names = {
        "strain": ("static strain tau = T/EA", "cable.horizontal_tension_N, cable.axial_stiffness_N",
                   "a nearly taut elastic cable"),
        "slenderness": ("slenderness D/l", "cable.diameter_m, cable.length_m", "a slender cable"),
        "delta": ("sag parameter delta = m g l cos^2(alpha)/H",
                  "cable.mass_per_length_kg_m, cable.gravity_m_s2, cable.length_m, cable.horizontal_tension_N, "
                  "cable.chord_slope_deg",
                  "a nearly taut cable"),
        "lambda2": ("Irvine's lambda^2 = delta^2/tau", "cable.mass_per_length_kg_m, cable.gravity_m_s2, "
                    "cable.length_m, cable.horizontal_tension_N, cable.axial_stiffness_N",
                    "the 1:1 resonance (omega1 < 2 omega2)"),
        "detuning": ("internal detuning |omega2 - omega1|", "the cable's sag and stiffness",
                     "a near 1:1 resonance"),
        "chi": ("torsion ratio chi = GJ/EI", "cable.torsional_stiffness_Nm2, cable.bending_stiffness_Nm2",
                "a real cable section"),
    }

    def error(key, value, lo, hi):
        what, fields, needs = names[key]
        raise SpecError(where, what, f"{value:.3g} is outside [{lo:g}, {hi:.4g}], where eq. (21) "
                                     f"describes {needs}; check {fields}")

    def warn(key, value, limit):
        what, fields, needs = names[key]
        warnings.warn(PremiseWarning(f"{where}: {what} = {value:.3g} exceeds {limit:g}: eq. (21) assumes "
                                     f"{needs}, and is stretched here ({fields})"), stacklevel=3)

    lows = {"lambda2": LAMBDA2_MIN, "chi": CHI_MIN, "slenderness": SLENDERNESS_MIN}
    for key in ("strain", "slenderness", "delta", "lambda2", "chi"):
        lo, hi = lows.get(key, 0.0), CABLE_LIMITS[key][1]
        if not lo <= q[key] <= hi:      # also catches NaN
            error(key, q[key], lo, hi)
    from autocable.model.modes import irvine_root    # scipy: only here, so scene parsing stays light
    st = cable_statics(c)
    q["detuning"] = abs(1.0 - irvine_root(st.lambda2) / math.pi)    # omega2 = 1 (modes.py)
    for key in ("strain", "slenderness", "detuning"):
        w, e = CABLE_LIMITS[key]
        if q[key] > w:
            warn(key, q[key], w)
    if spec.aero.angle_convention == "reversed":
        # Kept readable for older results only: it flips the wind angle and not the twist, so the
        # load depends on how the section is oriented in space (autocable.model.aero.frame_residual).
        warnings.warn(PremiseWarning(
            f'{where}: aero.angle_convention = "reversed" is a legacy reading that is not frame '
            f'indifferent (turning wind and section together changes the load); use "mirrored" '
            f'(the same in-plane terms, frame indifferent) or "eq12"'), stacklevel=2)
    _check_missing_modes(spec, st, q, where)
    return q


#: Warning band of `_check_missing_modes`: a left-out mode closer than this many internal detunings.
MISSING_MODE_WARN = 2.0


def _check_missing_modes(spec: ModelSpec, st, q: dict, where: str) -> None:
    """Refuse a cable whose two retained modes (omega1, omega2 = 1, eq. 17 units) do not stand apart
    from the rest: a left-out mode (the in-plane antisymmetric and the second out-of-plane modes at
    omega = 2 exactly, the second symmetric in-plane mode at the second root of Irvine's equation,
    `autocable.model.modes_n`) lying closer to a retained mode or to the forcing (Omega = omega1 +
    sigma, sigma small) than the retained modes' own detuning |omega2 - omega1| takes part in the
    1:1 resonance that Sect. 4 assumes is between those two alone. This happens as Irvine's lambda^2
    nears the 4 pi^2 crossover, where omega1 climbs to the antisymmetric omega = 2. Within
    `MISSING_MODE_WARN` detunings: a warning."""
    from autocable.model.modes_n import irvine_roots
    from autocable.model.units import units_of
    omega1 = irvine_roots(st.lambda2, 1)[0] / math.pi
    rho = abs(omega1 - 1.0)
    others = (("in-plane antisymmetric", 2.0), ("2nd out-of-plane", 2.0),
              ("2nd symmetric in-plane", irvine_roots(st.lambda2, 2)[1] / math.pi))
    gaps = [(min(abs(w - omega1), abs(w - 1.0)), name, w) for name, w in others]
    gap = min(g for g, _, _ in gaps)
    q["missing_mode_gap"] = gap
    if gap >= MISSING_MODE_WARN * rho:
        return
    names = [name for g, name, _ in gaps if g == gap]
    w = next(w for g, _, w in gaps if g == gap)
    f = units_of(spec, st).frequency_hz(1.0)
    text = (f"the {' and '.join(names)} mode{'s' if len(names) > 1 else ''} at {w * f:.4g} Hz (omega = {w:.4g}) "
            f"lie{'' if len(names) > 1 else 's'} {gap:.3g} from omega1 = {omega1:.4g} ({omega1 * f:.4g} Hz), "
            f"against the retained pair's detuning {rho:.3g} (lambda^2 = {st.lambda2:.4g}, crossover at 4 pi^2)")
    if gap < rho:
        raise SpecError(where, "two-mode model", f"two modes cannot describe this cable: {text}")
    warnings.warn(PremiseWarning(f"{where}: two-mode model: {text}: within {MISSING_MODE_WARN:g} "
                                 "detunings: the two-mode model is stretched"), stacklevel=3)


class ArgumentError(SpecError):
    """A bad argument of a Python call of autocable's API: ``str(err)`` is one line
    ``function: argument: what is accepted, got ...``. A `SpecError` (so also a `ValueError`):
    the command line reports it as bad input (exit 2)."""


def _number(function: str, name: str, value) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) and type(value).__module__ != "numpy":
        raise ArgumentError(function, name, f"expected a number, got {show(value)}")
    try:
        x = float(value)
    except (TypeError, ValueError, OverflowError):
        raise ArgumentError(function, name, f"expected a number, got {show(value)}") from None
    if not math.isfinite(x):
        raise ArgumentError(function, name, f"expected a finite number, got {value!r}")
    return x


def check_state(function: str, name: str, value, order: str = "(q1, q1', q2, q2')", limit: bool = True) -> tuple:
    """Four finite numbers, within `MAX_AMPLITUDE` with ``limit`` (a start of eq. (21)), as floats."""
    if isinstance(value, (str, bytes)) or not hasattr(value, "__len__") or len(value) != 4:
        raise ArgumentError(function, name, f"expected four numbers {order}, got {show(value)}")
    out = tuple(_number(function, f"{name}[{k}]", v) for k, v in enumerate(value))
    for k, v in enumerate(out if limit else ()):
        if abs(v) > MAX_AMPLITUDE:
            raise ArgumentError(function, f"{name}[{k}]", f"expected |value| <= {MAX_AMPLITUDE:g} (eq. 21's "
                                                          f"coordinates are fractions of the cable length), got {v!r}")
    return out


#: An argument `check_call` is not asked to check (None is a value to refuse).
NOT_GIVEN = object()


def check_call(function: str, *, U=NOT_GIVEN, eta=NOT_GIVEN, sigma=NOT_GIVEN, q0=NOT_GIVEN, max_time=NOT_GIVEN,
               omega1=None, time_name: str = "max_time") -> None:
    """The premises the command line applies, for a Python call (`ArgumentError` naming the
    argument): U, eta, sigma numbers in `PARAMETER_RANGES` (no warning where stretched: the
    command line and the input files warn);
    ``q0`` four finite numbers within `MAX_AMPLITUDE`; ``max_time`` (or the argument named
    ``time_name``) a time of at least one forcing period 2 pi/(omega1 + sigma) and at most
    `MAX_INTEGRATION_TIME`. Arguments not given (`NOT_GIVEN`) are not checked."""
    values = {}
    for name, value in (("U", U), ("eta", eta), ("sigma", sigma)):
        if value is not NOT_GIVEN:
            values[name] = _number(function, name, value)
    try:
        # errors only: a stretched value is the command line's and the input files' to warn about
        # once (a sweep would otherwise warn at every point)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", PremiseWarning)
            check_parameters(values, function, {k: k for k in values})
    except ArgumentError:
        raise
    except SpecError as exc:
        raise ArgumentError(function, exc.field, str(exc).split(f"{exc.field}: ", 1)[-1]) from None
    if q0 is not NOT_GIVEN:
        check_state(function, "q0", q0)
    if max_time is not NOT_GIVEN:
        t = _number(function, time_name, max_time)
        if not 0 < t <= MAX_INTEGRATION_TIME:
            raise ArgumentError(function, time_name, f"expected a time in (0, {MAX_INTEGRATION_TIME:g}] (t* units), "
                                                     f"got {max_time!r}")
        if omega1 is not None and "sigma" in values:
            period = 2 * math.pi / (omega1 + values["sigma"])
            if t < period:
                raise ArgumentError(function, time_name, f"expected at least one forcing period, 2 pi/Omega = "
                                                         f"{period:.6g} at sigma = {values['sigma']:g}, got {max_time!r}")
