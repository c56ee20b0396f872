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

from autocable.spec import SpecError

__all__ = ["PremiseWarning", "PARAMETER_RANGES", "check_parameters"]


class PremiseWarning(UserWarning):
    """A value where the model is stretched but still computed; ``str`` is one line naming it."""


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
        except (TypeError, ValueError):
            raise SpecError(where, label, f"expected a number, {what}, got {value!r}") from None
        if not math.isfinite(x):
            raise SpecError(where, label, f"expected a finite number, {what}, got {value!r}")
        if not lo <= x <= hi:
            raise SpecError(where, label, f"{what} must lie in [{lo:g}, {hi:g}] for eq. (21) to apply, "
                                          f"got {x:g}")
        if abs(x) > warn:
            warnings.warn(PremiseWarning(f"{where}: {label} = {x:g}: {what} beyond {warn:g}, where the "
                                         f"small-amplitude expansions of Sect. 4 are stretched"),
                          stacklevel=2)
