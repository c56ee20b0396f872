"""The axis scales a scene's figures are drawn in: the paper's nondimensional symbols, or SI units
of the scene's cable (``[plot] units = "si"``, ``--units si``; `autocable.plotting.units`)."""
from __future__ import annotations


def figure_units(units: str, deriv):
    """None for ``units = "paper"`` (the plot's default symbols), or the SI scales of the derived
    cable ``deriv`` (`autocable.model.derive.Derivation`): its length l, fundamental omega of
    eq. (17) and critical wind speed U_c of eq. (18)."""
    if units != "si":
        return None
    from autocable.model.units import units_of
    from autocable.plotting.units import scales_of
    return scales_of(units_of(deriv.spec, deriv.statics))
