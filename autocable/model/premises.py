"""The premises of the model, checked where inputs enter: an error where the model cannot apply,
a warning where it is stretched, each naming the quantity.

Eq. (21) rests on a nearly taut cable (small static strain, small sag parameter delta), a slender
section, a near 1:1 internal resonance omega2 ~ omega1, and small nondimensional support motion and
detuning (the Multiple Scales of Sect. 4 expand in them). Values outside these ranges are refused or
flagged here, not discovered later as nonsense amplitudes.
"""
from __future__ import annotations

import math
import numbers
import warnings
from typing import Mapping

from autocable.model.statics import cable_statics
from autocable.spec import MAX_MESSAGE, ModelSpec, SpecError, show

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
                                          f"got {show(value)}")
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
        "strain": ("static strain tau = T/EA", "cable.horizontal_tension_N, cable.axial_stiffness_N, "
                   "cable.chord_slope_deg (T = H/cos alpha)", "a nearly taut elastic cable"),
        "slenderness": ("slenderness D/l", "cable.diameter_m, cable.length_m", "a slender cable"),
        "delta": ("sag parameter delta = m g l cos^2(alpha)/H",
                  "cable.mass_per_length_kg_m, cable.gravity_m_s2, cable.length_m, cable.horizontal_tension_N, "
                  "cable.chord_slope_deg",
                  "a nearly taut cable"),
        "lambda2": ("Irvine's lambda^2", "cable.mass_per_length_kg_m, cable.gravity_m_s2, "
                    "cable.length_m, cable.horizontal_tension_N, cable.axial_stiffness_N, cable.chord_slope_deg",
                    "the 1:1 resonance (omega1 < 2 omega2; lambda^2 = delta^2/tau)"),
        "detuning": ("internal detuning |omega2 - omega1|", "the cable's sag and stiffness",
                     "a near 1:1 resonance"),
        "chi": ("torsion ratio chi = GJ/EI", "cable.torsional_stiffness_Nm2, cable.bending_stiffness_Nm2",
                "a real cable section"),
    }

    def error(key, value, lo, hi):
        what, fields, needs = names[key]
        # the keys of [cable] without their table's name each time: field and message fit in one
        # SpecError line (240 characters) with every field named, lambda^2's six included
        if fields.startswith("cable."):
            fields = "[cable] " + ", ".join(f.removeprefix("cable.") for f in fields.split(", "))
        # why eq. (21) needs the bound, when the line has room for it beside the file and every field
        full = f"{value:.3g} is outside [{lo:g}, {hi:.4g}], where eq. (21) describes {needs}; check {fields}"
        short = f"{value:.3g} not in [{lo:g}, {hi:.4g}]; check {fields}"
        raise SpecError(where, what, full if len(f"{what}: {full}") <= MAX_MESSAGE else short)

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


def _length(value) -> int | None:
    """len(value), or None for a value without one (a number; a 0-d numpy array, whose ``__len__``
    raises TypeError)."""
    try:
        return len(value)
    except TypeError:
        return None


def _number(function: str, name: str, value) -> float:
    # numbers.Real: int, float and numpy's float32/int64 (registered there); bool (and numpy's
    # bool_, not registered) is a flag, not a number
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
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
    if isinstance(value, (str, bytes)) or _length(value) != 4:
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
            _number(function, name, value)
            values[name] = value        # as given: a refusal quotes it as the caller wrote it
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


# -- the one argument checker of the command line and the Python API ---------------------------------
#
# Both raise `ArgumentError` (a `SpecError`): the command line names the option (``where`` =
# "arguments", ``name`` = "--wind"), the API the function and the keyword. Every message quotes the
# value as given (``show``: the typed text on the command line, ``np.float32(0.0014)`` from numpy).

def check_number(function: str, name: str, value, lo: float = -math.inf, hi: float = math.inf, *,
                 integer: bool = False, lo_open: bool = False, what: str = "") -> float:
    """``value`` as a float: a real number (numpy scalars included, bool refused), finite, in
    [lo, hi] ((lo, hi] with ``lo_open``), an integer with ``integer``; else `ArgumentError` naming
    ``function`` and ``name``, ``what`` the value is, and the value as given."""
    kind = "an integer" if integer else "a number"
    span = ("" if lo == -math.inf and hi == math.inf else f" {'>' if lo_open else '>='} {lo:g}" if hi == math.inf
            else f" in {'(' if lo_open else '['}{lo:g}, {hi:g}]")
    expected = f"expected {kind}{span}{f' ({what})' if what else ''}"
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or integer and not isinstance(
            value, numbers.Integral) and not (isinstance(value, float) and value.is_integer()):
        raise ArgumentError(function, name, f"{expected}, got {show(value)}")
    try:
        x = float(value)
    except (TypeError, ValueError, OverflowError):
        raise ArgumentError(function, name, f"{expected}, got {show(value)}") from None
    if not math.isfinite(x) or not (lo < x if lo_open else lo <= x) or not x <= hi:
        raise ArgumentError(function, name, f"{expected}, got {show(value)}")
    return x


def check_interval(function: str, name: str, value, lo: float = -math.inf, hi: float = math.inf,
                   what: str = "") -> tuple[float, float]:
    """``value`` = (a, b): two numbers (`check_number`, in [lo, hi]) with a < b."""
    if isinstance(value, (str, bytes)) or _length(value) != 2:
        raise ArgumentError(function, name, f"expected a range (lo, hi) of two numbers{f' ({what})' if what else ''}, "
                                            f"got {show(value)}")
    a, b = (check_number(function, f"{name}[{k}]", v, lo, hi, what=what) for k, v in enumerate(value))
    if not a < b:
        raise ArgumentError(function, name, f"expected a range (lo, hi) with lo < hi, got {show(value)}")
    return a, b


def check_choice(function: str, name: str, value, choices):
    """``value`` if it is one of ``choices`` (compared by equality, strings only as strings)."""
    if not any(value is c or type(value) is type(c) and value == c for c in choices):
        raise ArgumentError(function, name, f"expected one of {', '.join(repr(c) for c in choices)}, got {show(value)}")
    return value


def check_type(function: str, name: str, value, types, expected: str):
    """``value`` if it is an instance of ``types``; else `ArgumentError` saying what is ``expected``
    (the fix, e.g. "a ContinuationSettings (ac.ContinuationSettings(...))")."""
    if not isinstance(value, types):
        raise ArgumentError(function, name, f"expected {expected}, got {show(value)}")
    return value


#: The SI twin of each parameter of eq. (21) (eq. 18: U* = U/U_c, eta* = eta/l; eq. 17: the forcing
#: Omega = omega1 + sigma in units of omega): parameter -> (API keyword, unit, what it is).
SI_PARAMETERS: dict[str, tuple[str, str, str]] = {
    "U": ("wind_m_s", "m/s", "the wind speed U [m/s]"),
    "eta": ("deck_amplitude_m", "m", "the support (deck) motion's amplitude eta [m]"),
    "sigma": ("deck_frequency_Hz", "Hz", "the support (deck) motion's frequency Omega/2pi [Hz]"),
}


#: The nondimensional symbols of eqs. (17)-(18) in messages.
STAR_NAMES = {"U": "U*", "eta": "eta*", "sigma": "sigma"}


def choose_parameter(function: str, name: str, star, si, star_label: str | None = None,
                     si_label: str | None = None):
    """Which of a parameter's two kinds was given: ("star", value), ("si", value) or None; both
    given (not `NOT_GIVEN`; None is a value to refuse) is refused naming both (``--U`` or
    ``--wind``, not both)."""
    star_label = star_label or name
    si_label = si_label or SI_PARAMETERS[name][0]
    has_star, has_si = star is not NOT_GIVEN, si is not NOT_GIVEN
    if has_star and has_si:
        raise ArgumentError(function, si_label, f"{name} given twice: as {star_label} = {show(star)} and as "
                                                f"{si_label} = {show(si)}; give one of them")
    return ("si", si) if has_si else ("star", star) if has_star else None


def parameter_from_si(function: str, name: str, value, units, omega1: float, label: str | None = None) -> float:
    """The nondimensional ``name`` (U*, eta* or sigma) of an SI ``value`` (m/s, m, Hz) on the cable
    of ``units`` (`autocable.model.units.Units`) with first in-plane frequency ``omega1`` (eq. 21
    units), checked against `PARAMETER_RANGES`: `ArgumentError` naming ``label`` (default the API
    keyword of `SI_PARAMETERS`) with the value as given and the converted one."""
    keyword, unit, what = SI_PARAMETERS[name]
    label = label or keyword
    x = check_number(function, label, value, 0.0 if name != "sigma" else -math.inf, lo_open=name == "sigma",
                     what=what)
    if name == "sigma" and not x > 0:
        raise ArgumentError(function, label, f"expected a frequency > 0 Hz, got {show(value)}")
    star = {"U": units.wind_star, "eta": units.support_star}[name](x) if name != "sigma" \
        else units.detuning(x, omega1)
    lo, hi, _, what_star = PARAMETER_RANGES[name]
    if not lo <= star <= hi:
        si_lo, si_hi = ((units.wind_m_s(lo), units.wind_m_s(hi)) if name == "U" else
                        (units.support_m(lo), units.support_m(hi)) if name == "eta" else
                        (units.frequency_hz(omega1 + lo), units.frequency_hz(omega1 + hi)))
        raise ArgumentError(function, label, f"{what_star} must lie in [{lo:g}, {hi:g}] for eq. (21) to apply, "
                                             f"that is {label} in [{si_lo:.4g}, {si_hi:.4g}] {unit} on this "
                                             f"cable; got {show(value)} ({STAR_NAMES[name]} = {star:.4g})")
    return star


# -- wind speeds of a result (`autocable onset`) against the premises -------------------------------
#: The speed of sound in air at 20 deg C [m/s]: the Mach number of a wind speed.
SPEED_OF_SOUND_M_S = 343.0
#: The Mach number above which air is not incompressible: the quasi-steady load of eqs. (9-14) and
#: its fitted coefficients (eq. 13) are those of incompressible flow.
MACH_LIMIT = 0.3
#: The model files' own bound on a wind speed (aero.critical_wind_speed_m_s): about Mach 0.3.
WIND_LIMIT_M_S = 100.0


def wind_premises(U_m_s: float, U_star: float) -> list[str]:
    """Why a wind speed U [m/s] (U* = U/U_c) of a result lies past the model's premises: U* beyond
    the bound where `simulate` warns (`PARAMETER_RANGES`, the expansions of Sect. 4 stretched), U
    above the model files' `WIND_LIMIT_M_S` or a Mach number above `MACH_LIMIT`. Empty if none."""
    out = []
    warn = PARAMETER_RANGES["U"][2]
    if math.isfinite(U_star) and U_star > warn:
        out.append(f"U* = U/U_c = {U_star:.3g} > {warn:g} (where `simulate` warns: the expansions of Sect. 4 "
                   "are stretched)")
    if math.isfinite(U_m_s) and U_m_s > WIND_LIMIT_M_S:
        out.append(f"above {WIND_LIMIT_M_S:g} m/s, the model files' bound on a wind speed")
    if math.isfinite(U_m_s) and U_m_s / SPEED_OF_SOUND_M_S > MACH_LIMIT:
        out.append(f"Mach {U_m_s / SPEED_OF_SOUND_M_S:.3g} > {MACH_LIMIT:g} (the quasi-steady load is that of "
                   "incompressible air)")
    return out


def wind_warning(what: str, U_m_s: float, U_star: float) -> str | None:
    """One line: ``what`` at U m/s lies past the model's premises, and why (`wind_premises`); None
    if it does not."""
    why = wind_premises(U_m_s, U_star)
    return f"{what} U = {U_m_s:.4g} m/s lies past the model's premises: {'; '.join(why)}" if why else None
