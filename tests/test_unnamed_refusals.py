"""The two refusals the generated `onset` runs found unnamed, each pinned by a test that
fails without its fix:

* a calibration that fails because of a tiny damping ratio or a tiny onset speed U_c named the
  rivulet angle; it now names the typed field with its value and the fix (and, through
  ``onset --set ... --refit``, the ``--set`` item as given: the model file as written calibrates);
* ``onset --modes-below 5`` on a model whose ``[damper]`` cannot be evaluated in a higher mode
  failed whole (exit 3, naming ``--position``, an option onset does not have); it now gives every
  pair it can and names, in the pair it cannot, the reason and the damper field.
"""
import json
from dataclasses import replace

import pytest

from autocable.cli import main
from autocable.model.damper import cable_of, mode_damping
from autocable.model.derive import derive
from autocable.spec import MAX_MESSAGE, SpecError, load_model
from conftest import SAMPLE

#: One line: the standards keep messages short.
MAX_LINE = 300


def _calibration_error(**changes) -> SpecError:
    spec = load_model(SAMPLE)
    cable = {k: v for k, v in changes.items() if k in ("damping_ratio",)}
    aero = {k: v for k, v in changes.items() if k in ("critical_wind_speed_m_s",)}
    spec = replace(spec, cable=replace(spec.cable, **cable), aero=replace(spec.aero, **aero))
    with pytest.raises(SpecError) as err:
        derive(spec)
    return err.value


def _whole(exc: SpecError) -> str:
    """The field and message of ``exc``: uncut (a cut message ends in '...')."""
    text = str(exc).split(": ", 1)[1]
    assert len(text) <= MAX_MESSAGE and not text.endswith("..."), text
    return text


@pytest.mark.parametrize("xi, shown", [(1e-200, "1e-200"), (1e-5, "1e-5"), (0.0001, "0.0001")])
def test_tiny_damping_names_the_damping_not_the_angle(xi, shown):
    """The sample cable calibrates with 0.4 % (and 0.1 %); from 0.01 % down every rivulet angle that
    puts the in-plane onset at U_c is unstable already far below U_c. Before: 'aero.rivulet_angle_deg:
    no angle gives ...', naming neither the damping nor its value."""
    exc = _calibration_error(damping_ratio=xi)
    text = _whole(exc)
    assert exc.field == "cable.damping_ratio"
    assert text.startswith(f"cable.damping_ratio: {shown} is too little"), text
    assert "give a larger damping_ratio" in text and "try aero.yaw_deg = 6.56971" in text


def test_tiny_onset_speed_names_u_c_and_the_lowest_onset_it_can_have():
    """U_c = 1 m/s: no rivulet angle's aerodynamic damping cancels 0.4 % by then. The message names
    aero.critical_wind_speed_m_s with its value and the lowest onset any angle gives; that number is
    checked by the calibration itself (an independent route: a scan of its roots, not the bisection
    that found it): 0.5 % above it the sample calibrates, with its onset at the U_c typed, 0.5 % below
    it the calibration fails again."""
    exc = _calibration_error(critical_wind_speed_m_s=1.0)
    text = _whole(exc)
    assert exc.field == "aero.critical_wind_speed_m_s"
    assert text.startswith("aero.critical_wind_speed_m_s: 1.0 m/s is below every angle's onset with "
                           "cable.damping_ratio = 0.004 (the lowest: "), text
    assert "give a larger U_c or a smaller damping_ratio" in text
    lowest = float(text.split("(the lowest: ")[1].split(" m/s")[0])
    assert 1.0 < lowest < 36.0
    spec = load_model(SAMPLE)
    above = derive(replace(spec, aero=replace(spec.aero, critical_wind_speed_m_s=1.005 * lowest)))
    assert above.calibrated == "rivulet_angle_deg"
    exc = _calibration_error(critical_wind_speed_m_s=0.995 * lowest)
    assert exc.field == "aero.critical_wind_speed_m_s" and "(the lowest: " in str(exc)


def test_refit_with_a_tiny_damping_names_the_set_item(capsys):
    """``onset --refit --set cable.damping_ratio=1e-200`` (the generated runs' case): one line naming
    --set, the item as typed and the fixes. The model file as written calibrates, so its path and its
    0.004 are not what the message may blame."""
    assert main(["onset", str(SAMPLE), "--json", "--refit", "--set", "cable.damping_ratio=1e-200"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and len(err) < MAX_LINE and "Traceback" not in err, err
    assert err.startswith("autocable: error: arguments: --set: cable.damping_ratio=1e-200 (--refit) is too little"), err
    assert "give a larger damping_ratio, or drop --refit (keeps aero.rivulet_angle_deg = -13.88)" in err
    assert str(SAMPLE) not in err and not err.endswith("...")


def test_refit_whose_change_leaves_no_angle_names_the_set_item(capsys):
    """A change the calibration blames on another field (a 1 mm diameter: U_c = 36 m/s then lies below
    every angle's onset): the --set item and the fix, in one uncut line."""
    assert main(["onset", str(SAMPLE), "--refit", "--set", "cable.diameter_m=1e-3"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and not err.endswith("..."), err
    assert "--set: cable.diameter_m=0.001 with --refit" in err and "drop --refit" in err


# -- onset --modes-below with a [damper] that one mode cannot take -----------------------------------
@pytest.fixture(scope="module")
def damped(tmp_path_factory):
    """The sample cable with a viscous damper 20 m from the lower anchorage (x_d/L = 0.164): mode 3
    has k x_d/L = 0.49, where the taut-string root is not followed (the generated runs' model)."""
    path = tmp_path_factory.mktemp("damped") / "model.toml"
    path.write_text(SAMPLE.read_text().rstrip("\n") + "\n\n[damper]\nposition_m = 20.0\nconstant_N_s_m = 2e5\n")
    return path


def test_modes_below_gives_the_pairs_it_can_and_names_the_one_it_cannot(capsys, damped):
    """Before: exit 3 for the whole table, naming --position. Now: the four pairs below 5 Hz, pair 3
    with no onset (null), computed false and a damper_note naming damper.position_m and --modes-below;
    every other pair's damper damping equals the damper's own mode_damping for that mode (the
    damper's module, called here directly: the corrected exact value), its onset computed."""
    assert main(["onset", str(damped), "--json", "--modes-below", "5"]) == 0
    out = capsys.readouterr()
    rep = json.loads(out.out)
    rows = {r["k"]: r for r in rep["pairs"]}
    assert sorted(rows) == [1, 2, 3, 4]
    bad = rows[3]
    assert bad["computed"] is False and bad["onset_U_m_s"] is None and bad["damper_added_damping"] is None
    assert "damper.position_m = 20 m" in bad["damper_note"] and "--modes-below" in bad["damper_note"]
    assert "k x_d/L = 0.492" in bad["damper_note"]
    assert "--position" not in bad["damper_note"]          # a `damper` option, not an onset one
    assert any(w.startswith("mode pair 3: not computed") for w in rep["warnings"])
    assert bad["frequency_Hz"]["in_plane"] == pytest.approx(3.3527, abs=1e-4)
    spec = load_model(damped)
    cable = cable_of(spec)
    for k in (1, 2, 4):
        r = rows[k]
        assert "damper_note" not in r and r["mechanism_short"] != "not computed (damper)"
        md = mode_damping(cable, k, 20.0, 2e5, None)
        assert r["damper_added_damping"] == pytest.approx(md.added_damping_corrected, rel=1e-12)
    # the readable table says it too, on the pair's own line
    assert main(["onset", str(damped), "--modes-below", "5"]) == 0
    text = capsys.readouterr().out
    assert "not computed (damper)" in text and "pair 3: not computed" in text


def test_band_with_an_onset_speed_no_angle_reaches_names_u_c_in_each_case(capsys):
    """``onset --band --uc 5`` on the sample (5 m/s is below every angle's onset with 0.4 % in both
    readings and yaw signs): each case is a failed calibration ("no calibration", as a wrong yaw
    sign's is) whose reason names aero.critical_wind_speed_m_s = 5.0 m/s, the lowest onset and the
    fix; before, the reason named the rivulet angle only."""
    assert main(["onset", str(SAMPLE), "--band", "--uc", "5", "--json"]) == 0
    band = json.loads(capsys.readouterr().out)["band"]
    assert band["failed"] == len(band["cases"]) == 4
    for c in band["cases"]:
        assert c["status"] == "no calibration"
        assert c["reason"].startswith("aero.critical_wind_speed_m_s: 5.0 m/s is below every angle's onset"), c
        lowest = float(c["reason"].split("(the lowest: ")[1].split(" m/s")[0])
        assert lowest > 5.0 and "give a larger U_c" in c["reason"]
