"""Premises of the two-mode model (`autocable.model.premises._check_missing_modes`): a cable whose
left-out modes lie nearer the retained pair (or the forcing near omega1) than the pair's own detuning
is refused naming the mode and its frequency, with a warning band before it."""
import math
import warnings

import pytest

from autocable.cli import main
from autocable.model.premises import PremiseWarning, check_model
from autocable.spec import load_model
from conftest import SAMPLE

#: A 577 m stay (made up: 100 kg/m, EA = 4 GN, chord at 25 deg) with H chosen for lambda^2 = 35, near
#: the 4 pi^2 crossover: omega1 = 1.92, against the antisymmetric in-plane mode at omega = 2.
STAY_577 = """name = "stay577"
[cable]
length_m = 577.0
chord_slope_deg = -25.0
horizontal_tension_N = {H}
mass_per_length_kg_m = 100.0
diameter_m = 0.2
axial_stiffness_N = 4.0e9
bending_stiffness_Nm2 = 15000.0
torsional_stiffness_Nm2 = 1100.0
damping_ratio = 0.002
[aero]
air_density_kg_m3 = 1.25
rivulet_diameter_ratio = 0.1
lift = [-0.48, 0.84, 4.69, 0.86]
drag = [1.25, -0.65, -0.08, 6.81]
critical_wind_speed_m_s = 10.0
angle_convention = "eq12"
yaw_deg = 30.0
rivulet_angle_deg = 20.0
"""


def _H(lambda2):
    """H giving Irvine's lambda^2 = (m g l cos^2 a / H)^2 EA cos(a) / H for the stay above."""
    a = math.radians(-25.0)
    x = 100.0 * 9.81 * 577.0 * math.cos(a) ** 2
    return (x * x * 4.0e9 * math.cos(a) / lambda2) ** (1 / 3)


def test_the_577_m_stay_is_refused_naming_the_missing_mode(tmp_path, capsys):
    path = tmp_path / "stay577.toml"
    H = _H(35.0)
    path.write_text(STAY_577.format(H=H))
    assert main(["derive", str(path)]) == 2
    err = [ln for ln in capsys.readouterr().err.splitlines() if "error" in ln]
    assert len(err) == 1
    # the antisymmetric in-plane mode is the taut string's second one: f = (1/l) sqrt(T/m)
    T = H / math.cos(math.radians(-25.0))
    f2 = math.sqrt(T / 100.0) / 577.0
    assert "two modes cannot describe this cable" in err[0]
    assert "in-plane antisymmetric" in err[0] and f"{f2:.4g} Hz" in err[0]
    assert "(omega = 2)" in err[0]


def test_a_warning_band_before_the_refusal(tmp_path):
    """lambda^2 = 12: omega1 = 1.41, the left-out modes 0.59 away against a detuning 0.41."""
    path = tmp_path / "stay577.toml"
    path.write_text(STAY_577.format(H=_H(12.0)))
    with pytest.warns(PremiseWarning) as record:
        q = check_model(load_model(path))
    said = [str(w.message) for w in record if "two-mode model" in str(w.message)]
    assert len(said) == 1 and "in-plane antisymmetric" in said[0]
    assert q["detuning"] < q["missing_mode_gap"] < 2 * q["detuning"]


def test_the_sample_is_far_from_any_left_out_mode():
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        q = check_model(load_model(SAMPLE))
    assert not [w for w in caught if "two-mode model" in str(w.message)]
    # omega1 = 1.004: the antisymmetric mode at 2 is 0.996 away, 249 detunings
    assert q["missing_mode_gap"] == pytest.approx(2 - 1.0040053, rel=1e-6)


@pytest.mark.parametrize("name", ["luongo_zulli_2012", "dongting_lake_a12", "stay_190m", "meiko_nishi"])
def test_the_model_files_meet_the_two_mode_premise(name):
    """Every model file under models/ (the sample and the real stays of docs/cables.md) is far from
    the refusal: its nearest left-out mode lies more than 2 detunings away."""
    from conftest import REPO
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        q = check_model(load_model(REPO / "models" / f"{name}.toml"))
    assert q["missing_mode_gap"] > 2 * q["detuning"]
