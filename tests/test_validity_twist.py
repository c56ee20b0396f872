"""The largest twist of a motion (`autocable.model.validity.motion_validity`, ``twist_max_deg``) is
the peak over the whole span, not over the quadrature nodes.

The slaved twist of the first pair is theta(s) = theta2(s) q2 with theta2(s) = B sin(pi s) +
C cosh(kappa (s - 1/2)) (eq. 20; (B, C, kappa) = `Derivation.twist`). With the twist restrained at
the anchorages C = 0 and the peak is |B| at mid-span, which no Gauss node of an even rule holds
(the 190 m stay's 24 nodes: 0.5 % below it); with natural ends the peak is taken from the closed
form on a grid of 2,000,001 points (spacing 5e-7: its error below 1e-12 relative at a smooth peak).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from autocable.model.derive import derive
from autocable.model.validity import exact_load_for, motion_validity, twist_peak
from conftest import REPO


def _closed_form_peak(d) -> float:
    B, C, kappa = d.twist
    s = np.linspace(0.0, 1.0, 2_000_001)
    return float(np.max(np.abs(B * np.sin(np.pi * s) + C * np.cosh(kappa * (s - 0.5)))))


@pytest.mark.parametrize("name, ends", [("stay_190m", "restrained"), ("luongo_zulli_2012", "natural")])
def test_twist_max_is_the_span_peak(name, ends):
    d = derive(REPO / "models" / f"{name}.toml")
    assert d.spec.cable.twist_ends == ends and d.mode_pair == 1
    peak = _closed_form_peak(d)
    if ends == "restrained":
        B, C, _ = d.twist
        assert C == 0.0 and peak == pytest.approx(abs(B), rel=1e-12)      # the mid-span value
    assert twist_peak(d) == pytest.approx(peak, rel=1e-10)
    states = [[0.0, 1e-3, 0.0, 0.0], [2e-4, -2.5e-3, 1e-3, -1e-3], [0.0, 2e-3, 0.0, 0.0]]
    v = motion_validity(d, states, 1.0)
    assert v["twist_max_deg"] == pytest.approx(math.degrees(2.5e-3 * peak), rel=1e-10)
    # the quadrature nodes alone fall short where the peak lies between them (restrained: by 0.5 %)
    nodes = float(np.max(np.abs(exact_load_for(d).theta2)))
    assert nodes <= peak * (1 + 1e-12)
    if ends == "restrained":
        assert nodes < peak * (1 - 1e-3)
