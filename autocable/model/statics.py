"""Nearly-taut statics of the inclined cable (Sect. 2.1) and its quasi-static shape (eqs. 15-16).

For a nearly taut cable (m g l / H-bar -> 0) the paper takes the chord slope alpha, a uniform
curvature kappa-bar = (m g / H-bar) cos^2(alpha) and a uniform tension T-bar = H-bar / cos(alpha).
The nondimensional groups are those of eq. (17): delta = kappa-bar l (sag parameter), tau = T-bar/EA,
chi = GJ/EI, and Irvine's lambda^2 = delta^2 / tau. The reference frequency is
omega = (pi/l) sqrt(T-bar/m) and the nondimensional mass is m* = omega^2 l^2 m / EA = pi^2 tau.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from autocable.spec import CableSpec


@dataclass(frozen=True)
class CableStatics:
    """Static state and nondimensional groups of eq. (17)."""

    alpha: float              # chord slope [rad]
    T_bar: float              # axial tension [N]
    kappa_bar: float          # curvature [1/m]
    delta: float              # kappa-bar * l
    tau: float                # T-bar / EA
    chi: float                # GJ / EI
    lambda2: float            # Irvine's parameter delta^2 / tau
    omega_ref: float          # omega = (pi/l) sqrt(T-bar/m) [rad/s]
    m_star: float             # omega^2 l^2 m / EA = pi^2 tau
    C1: float                 # quasi-static shape v-hat(s) = C1 s^2 + C2 s, s in [0, 1] (eq. 16)
    C2: float

    @property
    def frequency_hz(self) -> float:
        return self.omega_ref / (2 * math.pi)

    @property
    def alpha_deg(self) -> float:
        """The chord slope alpha in degrees (the spec's ``chord_slope_deg``; `alpha` in radians)."""
        return math.degrees(self.alpha)


def quasi_static_coefficients_si(cable: CableSpec, printed: bool = False) -> tuple[float, float]:
    """C1 [1/m^2], C2 [1/m] of eq. (16), dimensional, for v-hat(s) = C1 s^2 + C2 s with s in metres.

    With ``printed=True`` the numerator of C2 carries the paper's 12 H^3 (docs/model.md, M2), which makes
    v-hat(l) = 1 instead of cos(alpha); the default is the corrected 12 H^3 cos(alpha).
    """
    EA, m, g, l, H = (cable.axial_stiffness_N, cable.mass_per_length_kg_m, cable.gravity_m_s2,
                      cable.length_m, cable.horizontal_tension_N)
    a = math.radians(cable.chord_slope_deg)
    ca, sa = math.cos(a), math.sin(a)
    den = EA * m**2 * g**2 * l**3 * ca**5 + 12 * H**3 * l
    C1 = 3 * EA * m * g * ca**3 * (m * g * l * ca**3 - 2 * H * sa) / den
    lead = 12 * H**3 if printed else 12 * H**3 * ca
    C2 = (lead - 2 * EA * m * g * l * ca**3 * (m * g * l * ca**3 - 3 * H * sa)) / den
    return C1, C2


def cable_statics(cable: CableSpec) -> CableStatics:
    """Nearly-taut statics of Sect. 2.1 and the nondimensional quasi-static shape of eq. (15)."""
    a = math.radians(cable.chord_slope_deg)
    T_bar = cable.horizontal_tension_N / math.cos(a)
    kappa = cable.mass_per_length_kg_m * cable.gravity_m_s2 * math.cos(a) ** 2 / cable.horizontal_tension_N
    delta = kappa * cable.length_m
    tau = T_bar / cable.axial_stiffness_N
    chi = cable.torsional_stiffness_Nm2 / cable.bending_stiffness_Nm2
    omega = math.pi / cable.length_m * math.sqrt(T_bar / cable.mass_per_length_kg_m)
    # Eq. (15) nondimensionalised: delta sin(a) - delta^2 int v-hat + tau v-hat'' = 0, v-hat(0) = 0,
    # v-hat(1) = cos(a); with v-hat = C1 s^2 + C2 s this is linear in (C1, C2).
    C1 = 3 * delta * (delta * math.cos(a) - 2 * math.sin(a)) / (12 * tau + delta**2)
    C2 = math.cos(a) - C1
    return CableStatics(alpha=a, T_bar=T_bar, kappa_bar=kappa, delta=delta, tau=tau, chi=chi,
                        lambda2=delta**2 / tau, omega_ref=omega, m_star=math.pi**2 * tau, C1=C1, C2=C2)


def regime_warnings(st: CableStatics) -> list[str]:
    """Messages for a cable outside the nearly-taut regime of Sect. 2 (the model still runs)."""
    out = []
    if st.delta > 0.1:
        out.append(f"sag parameter delta = kappa*l = {st.delta:.3g} is not small (nearly-taut theory "
                   "of Sect. 2 assumes delta << 1); results are outside the model's validity")
    if st.lambda2 > 4 * math.pi**2:
        out.append(f"Irvine's lambda^2 = {st.lambda2:.3g} exceeds 4 pi^2: the first symmetric in-plane "
                   "mode is no longer the lowest, and the 1:1 resonance of Sect. 4 does not hold")
    return out
