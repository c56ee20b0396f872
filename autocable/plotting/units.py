"""Axis labels and the quantities of a plot in the paper's symbols or in SI units.

By default every axis reads in the nondimensional quantities of Luongo & Zulli's eqs. (17)-(18),
with the paper's symbols: a_1, a_2 (peak modal amplitudes, displacement / l), sigma (the detuning of
the excitation frequency Omega = omega_1 + sigma), U* = U / U_c, eta* = eta / l, t* = omega t.

For report figures the x axis can be the deck (support) frequency itself, Omega = omega1 + sigma in
Hz (``x = "Omega_Hz"``), the wind speed in m/s (``"U_m_s"``) or the support amplitude in m
(``"eta_m"``): `x_axis` draws them from the nondimensional column with the cable's scales that the
results carry (``si_scales`` and ``omega1`` in a run's provenance or a branch's ``info``, as
`autocable.methods.frequency_response` and every scene write them); ``units = "si"`` given as the
word (not a scales mapping) does the same for sigma, U and eta and draws the amplitudes in metres.

With ``units = "si"`` (a scene's ``[plot] units``, ``--units si`` on the command line) the same data
are drawn in SI: a_k l [m] (the peak displacement of a mode of unit maximum, at mid-span for both
retained modes), sigma omega / (2 pi) [Hz] (the detuning as a frequency), U [m/s], eta [m] and t [s],
with omega = (pi / l) sqrt(T-bar / m) the fundamental of the taut string (eq. 17).

The conversions are `autocable.model.units`' (the one module converting eqs. 17-18 to SI); this
module only turns them into axis scales and labels. `si_scales` takes the three scales of one cable
as plain numbers (or `scales_of` a `Units`), so that plotting keeps reading results only.
"""
from __future__ import annotations

import math
from typing import Mapping

__all__ = ["PAPER_LABELS", "UNITS", "AxisScale", "si_scales", "scales_of", "axis_scale", "check_units",
           "SI_AXES", "SiWordScales", "cable_of", "x_axis"]

#: The paper's symbols (eqs. 17-18): the starred quantities are U*, eta* and t*.
PAPER_LABELS = {"sigma": r"$\sigma$", "U": r"$U^*$", "eta": r"$\eta^*$", "a1": r"$a_1$", "a2": r"$a_2$",
                "t": r"$t^*$", "q1": r"$q_1$", "q2": r"$q_2$", "dq1": r"$q_1'$", "dq2": r"$q_2'$"}
#: The unit systems a plot can be drawn in.
UNITS = ("paper", "si")

#: (factor, label): the plotted value is factor * the nondimensional one.
AxisScale = tuple[float, str]


def check_units(units: str, where: str = "units") -> str:
    """``units`` if it is one of `UNITS`, else a ValueError naming ``where`` and the choices."""
    if units not in UNITS:
        raise ValueError(f"{where}: expected one of {', '.join(repr(u) for u in UNITS)}, got {units!r}")
    return units


def si_scales(length_m: float, omega_rad_s: float, critical_wind_speed_m_s: float) -> dict[str, AxisScale]:
    """The SI scale and label of every plotted quantity for a cable of length ``length_m`` [m],
    fundamental ``omega_rad_s`` [rad/s] (eq. 17) and critical wind speed ``critical_wind_speed_m_s``
    [m/s] (eq. 18), each factor taken from `autocable.model.units.Units` (all its conversions are
    linear: the factor is the conversion of 1)."""
    from autocable.model.units import Units

    for name, v in (("length_m", length_m), ("omega_rad_s", omega_rad_s),
                    ("critical_wind_speed_m_s", critical_wind_speed_m_s)):
        if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
            raise ValueError(f"si_scales: {name} must be a positive finite number, got {v!r}")
    u = Units(length_m=float(length_m), omega_rad_s=float(omega_rad_s),
              critical_wind_speed_m_s=float(critical_wind_speed_m_s), mass_per_length_kg_m=math.nan,
              air_density_kg_m3=math.nan, diameter_m=math.nan)
    return scales_of(u)


def scales_of(u) -> dict[str, AxisScale]:
    """The axis scales of an `autocable.model.units.Units`: a_k l [m] (peak displacement of a mode
    of unit maximum), sigma omega / 2 pi [Hz], U [m/s], eta [m], t [s], q_k l [m], q_k' l omega [m/s]."""
    peak, hz = u.peak_m(1.0), u.frequency_hz(1.0)
    return {
        "a1": (peak, r"$a_1 l$ [m]"), "a2": (peak, r"$a_2 l$ [m]"),
        "sigma": (hz, r"$\sigma\,\omega/2\pi$ [Hz]"),
        "U": (u.wind_m_s(1.0), r"$U$ [m/s]"),
        "eta": (u.support_m(1.0), r"$\eta$ [m]"),
        "t": (u.time_s(1.0), r"$t$ [s]"),
        "q1": (peak, r"$q_1 l$ [m]"), "q2": (peak, r"$q_2 l$ [m]"),
        "dq1": (peak / u.time_s(1.0), r"$\dot q_1 l$ [m/s]"), "dq2": (peak / u.time_s(1.0), r"$\dot q_2 l$ [m/s]"),
    }


def axis_scale(name: str, scales: Mapping[str, AxisScale] | None = None) -> AxisScale:
    """(factor, label) of quantity ``name``: from ``scales`` (`si_scales`) when given, else the
    paper's symbol with factor 1."""
    if scales and name in scales:
        return scales[name]
    return 1.0, PAPER_LABELS.get(name, name)


#: The SI x axes drawn from a nondimensional column (the names of `autocable.model.units.SI_COLUMNS`):
#: the deck (support) frequency Omega = omega1 + sigma [Hz], the wind speed U [m/s], the support
#: amplitude eta [m].
SI_AXES = {"Omega_Hz": "sigma", "U_m_s": "U", "eta_m": "eta"}


class SiWordScales(dict):
    """`scales_of` a cable, made from ``units = "si"`` given as the word: an x axis of sigma, U or
    eta is then drawn as `SI_AXES` (sigma as the deck frequency, with its offset omega1, which a
    linear scale cannot carry); a scales mapping given by hand (``si_scales``, a scene's
    ``[plot] units``) keeps sigma as the detuning in Hz."""


def cable_of(results) -> tuple | None:
    """(``Units``, omega1) of the cable behind ``results`` (a `RunResults`, or any object with
    ``provenance`` and ``branches``): from its provenance, else from the first branch whose ``info``
    has ``si_scales`` and ``omega1``; None when nothing carries them."""
    from autocable.model.units import units_from_dict

    holders = [getattr(results, "provenance", None) or {}]
    holders += [getattr(b, "info", None) or {} for b in getattr(results, "branches", ())]
    for h in holders:
        if h.get("si_scales") and h.get("omega1") is not None:
            return units_from_dict(dict(h["si_scales"])), float(h["omega1"])
    return None


def x_axis(name: str, units, cable, function: str = "plot_scene") -> tuple[str, float, float, str]:
    """(column, factor, offset, label): the x axis ``name`` is drawn as factor * column + offset.

    ``name`` in `SI_AXES` (``"Omega_Hz"``, ``"U_m_s"``, ``"eta_m"``), or a nondimensional column
    with ``units = "si"`` (the word): sigma as the deck frequency (omega1 + sigma) omega / 2 pi
    [Hz] (eq. 17), U as U* U_c [m/s] and eta as eta* l [m] (eq. 18), from ``cable`` = (Units,
    omega1) (`cable_of`). Otherwise ``units`` as in `axis_scale` (a scales mapping or None), no
    offset. An `ArgumentError` of ``function`` names ``x`` when the SI axis needs a cable the
    results do not carry."""
    si_word = (isinstance(units, str) and units == "si") or isinstance(units, SiWordScales)
    wanted = name if name in SI_AXES else ({v: k for k, v in SI_AXES.items()}.get(name) if si_word else None)
    if wanted is None:
        factor, label = axis_scale(name, None if isinstance(units, str) else units)
        if isinstance(units, str) and si_word and cable is not None:
            factor, label = axis_scale(name, scales_of(cable[0]))
        return name, factor, 0.0, label
    if cable is None:
        from autocable.model.premises import ArgumentError
        raise ArgumentError(function, "x", f"{name!r} in SI needs the cable's scales (si_scales and omega1), "
                            f"which these results do not carry; plot results of frequency_response on a model "
                            f"or of a scene, or draw x={SI_AXES.get(name, name)!r} with units=si_scales(...)")
    u, omega1 = cable
    if wanted == "Omega_Hz":
        return "sigma", u.frequency_hz(1.0), u.frequency_hz(omega1), r"deck frequency $\Omega\,\omega/2\pi$ [Hz]"
    if wanted == "U_m_s":
        return "U", u.wind_m_s(1.0), 0.0, r"wind speed $U$ [m/s]"
    return "eta", u.support_m(1.0), 0.0, r"support amplitude $\eta$ [m]"
