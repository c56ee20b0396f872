"""Spec loading: the sample model loads; each class of bad input gives one line naming the field."""
import math
import re

import pytest

from autocable.model.statics import cable_statics, regime_warnings
from autocable.spec import SpecError, load_model
from conftest import REPO, SAMPLE

ROOT = REPO


def test_sample_model_loads_in_si_units():
    spec = load_model(SAMPLE)
    assert spec.cable.length_m == 121.9
    assert spec.cable.axial_stiffness_N == pytest.approx(2.1688e9)
    assert spec.aero.rivulet_angle_deg is None          # "calibrate"
    assert spec.aero.yaw_deg == -6.569711
    assert spec.aero.lift == (-0.48, 0.84, 4.69, 0.86)


def _mutate(text: str, old: str, new: str) -> str:
    assert old in text, old
    return text.replace(old, new, 1)


BAD = [
    # (description, old text, new text, field named in the message)
    ("negative stiffness", "axial_stiffness_N = 2.1688e9", "axial_stiffness_N = -2.1688e9", "cable.axial_stiffness_N"),
    ("zero bending stiffness", "bending_stiffness_Nm2 = 2100.0", "bending_stiffness_Nm2 = 0.0", "cable.bending_stiffness_Nm2"),
    ("missing torsional stiffness", "torsional_stiffness_Nm2 = 159.0", "", "cable.torsional_stiffness_Nm2"),
    ("negative mass", "mass_per_length_kg_m = 51.8", "mass_per_length_kg_m = -51.8", "cable.mass_per_length_kg_m"),
    ("zero length", "length_m = 121.9", "length_m = 0", "cable.length_m"),
    ("negative tension", "horizontal_tension_N = 3142.0e3", "horizontal_tension_N = -1.0", "cable.horizontal_tension_N"),
    ("slope out of range", "chord_slope_deg = -35.2", "chord_slope_deg = -95.0", "cable.chord_slope_deg"),
    ("non-numeric diameter", "diameter_m = 0.119", 'diameter_m = "thick"', "cable.diameter_m"),
    ("unknown key", "gravity_m_s2 = 9.81", "gravity_m_s2 = 9.81\nstifness = 3.0", "cable.stifness"),
    ("damping ratio too large", "damping_ratio = 0.004", "damping_ratio = 1.5", "cable.damping_ratio"),
    ("lift with 3 coefficients", "lift = [-0.48, 0.84, 4.69, 0.86]", "lift = [-0.48, 0.84, 4.69]", "aero.lift"),
    ("yaw out of range", "yaw_deg = -6.569711", "yaw_deg = 120.0", "aero.yaw_deg"),
    ("both angles calibrated", "yaw_deg = -6.569711", 'yaw_deg = "calibrate"', "aero.yaw_deg"),
    ("negative air density", "air_density_kg_m3 = 1.25", "air_density_kg_m3 = -1.25", "aero.air_density_kg_m3"),
    ("unknown load length", 'load_length = "diameter"', 'load_length = "chord"', "aero.load_length"),
    ("missing section", "[aero]", "[aerodynamics]", "aerodynamics"),
    ("boolean as number", "damping_ratio = 0.004", "damping_ratio = true", "cable.damping_ratio"),
    ("infinite tension", "horizontal_tension_N = 3142.0e3", "horizontal_tension_N = inf", "cable.horizontal_tension_N"),
]


@pytest.mark.parametrize("what,old,new,field", BAD, ids=[b[0] for b in BAD])
def test_bad_spec_gives_one_line_naming_file_and_field(tmp_path, what, old, new, field):
    bad = tmp_path / "bad.toml"
    bad.write_text(_mutate(SAMPLE.read_text(), old, new))
    with pytest.raises(SpecError) as info:
        load_model(bad)
    message = str(info.value)
    assert "\n" not in message
    assert str(bad) in message
    assert field in message, message


def test_not_toml_and_missing_file(tmp_path):
    bad = tmp_path / "broken.toml"
    bad.write_text("[cable\nlength_m = 1")
    with pytest.raises(SpecError, match=r"broken.toml: not valid TOML"):
        load_model(bad)
    with pytest.raises(SpecError, match="no such file"):
        load_model(tmp_path / "absent.toml")


def test_far_from_nearly_taut_is_warned_not_refused(tmp_path):
    slack = tmp_path / "slack.toml"
    slack.write_text(_mutate(SAMPLE.read_text(), "horizontal_tension_N = 3142.0e3",
                             "horizontal_tension_N = 30.0e3"))
    st = cable_statics(load_model(slack).cable)
    warnings = regime_warnings(st)
    assert st.delta > 0.1
    assert any(re.search(r"sag parameter delta", w) for w in warnings)


def test_sample_cable_is_nearly_taut_but_breaks_tau_ordering():
    st = cable_statics(load_model(SAMPLE).cable)
    assert regime_warnings(st) == []
    # docs/model.md, M1: tau ~ 1.8e-3 against delta^3 ~ 2.3e-6; the model runs regardless.
    assert st.tau == pytest.approx(1.8e-3, rel=0.03)
    assert st.delta**3 == pytest.approx(2.3e-6, rel=0.03)
    assert st.omega_ref == pytest.approx(7.02, abs=0.01)
    assert math.isclose(st.m_star, math.pi**2 * st.tau)
