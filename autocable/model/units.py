"""The nondimensional quantities of eqs. (17)-(18) in SI units: the one place they are converted.

Eq. (17): t* = omega t with omega = (pi/l) sqrt(T-bar/m) [rad/s], the fundamental of the taut string;
every frequency of eq. (21) (omega_k, Omega, a Hopf frequency) is in units of omega, so
f [Hz] = Omega * omega / (2 pi). Eq. (18): eta* = eta/l, U* = U/U_c. Displacements are fractions of
l: the modes have a unit maximum (Sect. 5, docs/model.md C1), so the peak displacement of mode k is
a_k l [m], at the station where the mode's maximum is. Both retained modes (the first symmetric
in-plane mode of eq. 19_1 and the first out-of-plane mode sin(pi s)) peak at mid-span.

Scruton number: Sc = m xi / (rho_a D^2), the mass-damping parameter in the form the stay-cable
design recommendations state their rain-wind criterion (Sc >= 10; >= 5 with a surface treatment
that disrupts the rivulets).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

#: Where the peak displacements a_k l are measured: both retained modes have their maximum there.
PEAK_STATION = "mid-span (s = l/2), where both retained modes have their unit maximum"


@dataclass(frozen=True)
class Units:
    """The scales of one cable: l [m], omega [rad/s], U_c [m/s], and the Scruton number's m, rho_a, D."""

    length_m: float
    omega_rad_s: float
    critical_wind_speed_m_s: float
    mass_per_length_kg_m: float
    air_density_kg_m3: float
    diameter_m: float

    # -- eq. (18) ----------------------------------------------------------------------------------
    def wind_m_s(self, U_star: float) -> float:
        """U = U* U_c [m/s]."""
        return U_star * self.critical_wind_speed_m_s

    def wind_star(self, U_m_s: float) -> float:
        """U* = U / U_c."""
        return U_m_s / self.critical_wind_speed_m_s

    def support_m(self, eta_star: float) -> float:
        """eta = eta* l [m], the support amplitude."""
        return eta_star * self.length_m

    def support_star(self, eta_m: float) -> float:
        """eta* = eta / l."""
        return eta_m / self.length_m

    # -- eq. (17) ----------------------------------------------------------------------------------
    def frequency_hz(self, frequency_star: float) -> float:
        """f = Omega omega / (2 pi) [Hz] for a nondimensional circular frequency Omega (t* = omega t)."""
        return frequency_star * self.omega_rad_s / (2 * math.pi)

    def frequency_star(self, f_hz: float) -> float:
        """Omega = 2 pi f / omega: a frequency f [Hz] in units of omega (the inverse of `frequency_hz`)."""
        return 2 * math.pi * f_hz / self.omega_rad_s

    def detuning(self, f_hz: float, omega1: float) -> float:
        """sigma = Omega - omega1 of a support motion at f [Hz] (eq. 21: the external resonance is
        Omega ~ omega1, the first in-plane frequency in units of omega)."""
        return self.frequency_star(f_hz) - omega1

    def time_s(self, t_star: float) -> float:
        """t = t* / omega [s]."""
        return t_star / self.omega_rad_s

    def peak_m(self, a: float) -> float:
        """The peak displacement a l [m] of a mode of unit maximum with modal amplitude a (at
        `PEAK_STATION`)."""
        return a * self.length_m

    def peak_squared_slope(self, slope_star: float) -> float:
        """d(a l)^2 / dU [m^2 per m/s] from d(a^2)/dU* (a post-critical amplitude slope)."""
        return slope_star * self.length_m ** 2 / self.critical_wind_speed_m_s

    # -- mass-damping -----------------------------------------------------------------------------
    def scruton(self, damping_ratio: float) -> float:
        """Sc = m xi / (rho_a D^2)."""
        return self.mass_per_length_kg_m * damping_ratio / (self.air_density_kg_m3 * self.diameter_m ** 2)

    def damping_for_scruton(self, Sc: float) -> float:
        """The damping ratio xi with Scruton number ``Sc``."""
        return Sc * self.air_density_kg_m3 * self.diameter_m ** 2 / self.mass_per_length_kg_m


def units_of(spec, statics) -> Units:
    """The `Units` of a model spec (`autocable.spec.ModelSpec`) and its statics (`CableStatics`)."""
    c, a = spec.cable, spec.aero
    return Units(length_m=c.length_m, omega_rad_s=statics.omega_ref,
                 critical_wind_speed_m_s=a.critical_wind_speed_m_s,
                 mass_per_length_kg_m=c.mass_per_length_kg_m, air_density_kg_m3=a.air_density_kg_m3,
                 diameter_m=c.diameter_m)


#: The SI columns of branches.csv and special_points.csv (`si_columns`), after the nondimensional ones.
SI_COLUMNS = ("U_m_s", "eta_m", "Omega_Hz", "peak_in_plane_m", "peak_out_of_plane_m")


def si_columns(units: Units, omega1: float, U, eta, sigma, a1, a2) -> dict:
    """The `SI_COLUMNS` of points (U*, eta*, sigma, a1, a2) (numbers or numpy arrays): U in m/s, the
    support amplitude in m, the forcing frequency Omega = omega1 + sigma in Hz, and the peak
    displacements a_k l at mid-span."""
    return {"U_m_s": units.wind_m_s(U), "eta_m": units.support_m(eta),
            "Omega_Hz": units.frequency_hz(omega1 + sigma),
            "peak_in_plane_m": units.peak_m(a1), "peak_out_of_plane_m": units.peak_m(a2)}


def units_from_dict(data: dict) -> Units:
    """A `Units` from its fields (as `dataclasses.asdict` wrote them, e.g. in a run's provenance)."""
    return Units(**{k: float(data[k]) for k in Units.__dataclass_fields__})
