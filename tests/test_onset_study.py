"""`autocable onset` and `autocable.studies.onset`: the onset is a prediction when the angles are given
(independent of the U_c scale), a fitted angle is held or refitted with a message, the design damping
is where the onset meets the design wind, the AME's galloping cycle matches the normal form, and the
command line's output and errors."""
import json
import math
import warnings

import pytest

from conftest import SAMPLE
from test_onset import STAY_190

from autocable.model.onset import first_onset_U, stability, with_damping
from autocable.model.units import units_of


def _derive(tmp_path, text, name="c.toml"):
    from autocable.model.derive import derive
    p = tmp_path / name
    p.write_text(text)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return derive(p)


def _cli(capsys, *args):
    from autocable.cli import main
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


def test_onset_in_m_s_does_not_depend_on_the_U_c_scale(tmp_path):
    """With both angles given U_c only scales U* (eq. 18): the same stay with U_c = 10 and 17 m/s
    has the same onset speed, frequency and amplitude slope in SI."""
    from autocable.studies.onset import onset_report
    a = onset_report(_derive(tmp_path, STAY_190, "a.toml"))
    b = onset_report(_derive(tmp_path, STAY_190.replace("critical_wind_speed_m_s = 10.0",
                                                        "critical_wind_speed_m_s = 17.0"), "b.toml"))
    oa, ob = a["onsets"][0], b["onsets"][0]
    assert ob["U_star"] == pytest.approx(oa["U_star"] * 10 / 17, rel=1e-9)
    assert ob["U_m_s"] == pytest.approx(oa["U_m_s"], rel=1e-9)
    assert ob["frequency_Hz"] == pytest.approx(oa["frequency_Hz"], rel=1e-12)
    sa, sb = oa["amplitude_slope"]["d_peak_squared_dU_m2_per_m_s"], ob["amplitude_slope"]["d_peak_squared_dU_m2_per_m_s"]
    assert sb[0] == pytest.approx(sa[0], rel=1e-7)
    assert "prediction" in a["wind_angles"]["text"] and a["wind_angles"]["calibrated"] is None


CALIBRATED_190 = STAY_190.replace("rivulet_angle_deg = -31.886261", 'rivulet_angle_deg = "calibrate"')


def test_a_fitted_angle_is_held_and_a_refit_says_how_far_it_moved(tmp_path):
    from autocable.studies.onset import angle_statement, vary
    d = _derive(tmp_path, CALIBRATED_190)
    st = angle_statement(d)
    assert st["calibrated"] == "rivulet_angle_deg"
    assert "U_c = 10 m/s was typed in" in st["text"] and "fitted answer" in st["text"]
    fitted = math.degrees(d.theta0)
    held, msgs = vary(d, {"damping_ratio": 0.003})
    assert math.degrees(held.theta0) == pytest.approx(fitted, abs=1e-9)
    assert held.calibrated == "" and held.ode.xi_s == 0.003
    assert msgs == [f"aero.rivulet_angle_deg held at its fitted {fitted:.4f} deg (fitted on the spec as written "
                    "to put the onset at U_c = 10 m/s); --refit fits it again"]
    # held: more damping raises the onset, as eq. (21) with the same angle and the new damping says
    assert first_onset_U(held.ode) == pytest.approx(first_onset_U(with_damping(d.ode, 0.003)), rel=1e-9)
    assert first_onset_U(held.ode) > 1.3
    refit, msgs = vary(d, {"damping_ratio": 0.003}, refit=True)
    new = math.degrees(refit.theta0)
    assert abs(new - fitted) > 1.0
    assert msgs == [f"refit: aero.rivulet_angle_deg moved from {fitted:.4f} to {new:.4f} deg so that the onset "
                    "stays at the U_c typed in (10 m/s); the onset is then an input, not a result"]
    assert first_onset_U(refit.ode) == pytest.approx(1.0, abs=1e-6)


def test_design_damping_puts_the_onset_at_the_design_wind(tmp_path):
    from autocable.studies.onset import damping_curve, design_damping
    d = _derive(tmp_path, STAY_190)
    units = units_of(d.spec, d.statics)
    out = design_damping(d, 18.0)
    xi = out["least_damping_ratio"]
    assert first_onset_U(with_damping(d.ode, xi)) * 10.0 == pytest.approx(18.0, rel=1e-6)
    assert first_onset_U(with_damping(d.ode, 0.99 * xi)) * 10.0 < 18.0
    assert out["scruton"] == pytest.approx(88.0 * xi / (1.25 * 0.19 ** 2), rel=1e-12)
    assert not out["enough"]
    rows = damping_curve(d, [0.001, xi])
    assert rows[0]["U_cr_m_s"] == pytest.approx(units.wind_m_s(stability(d.ode).first.U_star), rel=1e-9)
    assert rows[1]["U_cr_m_s"] == pytest.approx(18.0, rel=1e-6)


def test_ame_galloping_cycle_meets_the_normal_form_at_the_onset(tmp_path):
    """Two routes to the post-critical amplitude: the AME's relative equilibrium just above the onset
    (U = 1.0005 U_cr) and the Hopf normal form of eq. (21) (a1^2 = slope (U - U_cr)): within 1 %."""
    from autocable.studies.onset import ame_galloping
    d = _derive(tmp_path, STAY_190)
    first = stability(d.ode).first
    U = first.U_star * 1.0005
    rows = ame_galloping(d.ode, [U])
    assert rows and rows[0]["stable"]
    assert rows[0]["a1"] == pytest.approx(math.sqrt(first.amplitude_slopes[0] * (U - first.U_star)), rel=1e-2)
    assert rows[0]["a2"] == pytest.approx(math.sqrt(first.amplitude_slopes[1] * (U - first.U_star)), rel=1e-2)


def test_onset_command_json_and_errors(capsys):
    code, out, err = _cli(capsys, "onset", SAMPLE, "--json")
    assert code == 0, err
    o = json.loads(out)["onsets"][0]
    for key in ("U_m_s", "U_star", "frequency_Hz", "mechanism", "criticality", "lyapunov", "amplitude_slope",
                "eigenvector"):
        assert key in o
    assert o["U_m_s"] == pytest.approx(36.0 * o["U_star"], rel=1e-14)
    assert o["criticality"] in ("supercritical", "subcritical")
    for argv, option in ((("--damping", "0.01:0.001"), "--damping"), (("--refit",), "--refit"),
                         (("--set", "cable.gravity_m_s2=3"), "--set"), (("--design-wind", "-3"), "--design-wind")):
        code, out, err = _cli(capsys, "onset", SAMPLE, *argv)
        errors = [line for line in err.splitlines() if "error" in line]
        assert code == 2 and len(errors) == 1 and option in errors[0], err
    code, out, err = _cli(capsys, "derive", SAMPLE)
    assert code == 0 and "Onset of galloping" in out and "U_cr = " in out
    code, out, err = _cli(capsys, "derive", SAMPLE, "--json")
    onset = json.loads(out)["onset"]
    assert code == 0 and onset["onsets"][0]["U_star"] == pytest.approx(o["U_star"], rel=1e-14)


@pytest.mark.slow
def test_onset_command_refit_and_damping_files(tmp_path, capsys):
    import csv
    spec = tmp_path / "c.toml"
    spec.write_text(CALIBRATED_190)
    code, out, err = _cli(capsys, "onset", spec, "--set", "cable.damping_ratio=0.003", "--refit")
    assert code == 0, err
    assert "refit: aero.rivulet_angle_deg moved from " in out and "stays at the U_c typed in (10 m/s)" in out
    code, out, err = _cli(capsys, "onset", spec, "--damping", "0.0005:0.006:12", "--design-wind", "18",
                          "--checks", "0", "--out", tmp_path / "out")
    assert code == 0, err
    assert "the damping study holds aero.rivulet_angle_deg at its fitted" in out
    rows = list(csv.DictReader(open(tmp_path / "out" / "damping.csv")))
    assert len(rows) == 12
    for r in rows:
        xi = float(r["damping_ratio"])
        assert float(r["scruton"]) == pytest.approx(88.0 * xi / (1.25 * 0.19 ** 2), rel=1e-12)
    onset = [float(r["U_cr_m_s"]) for r in rows if r["U_cr_m_s"]]
    assert onset == sorted(onset)                      # more damping, later onset (this stay)
    report = json.loads((tmp_path / "out" / "onset.json").read_text())
    assert report["design"]["design_wind_m_s"] == 18.0
    assert (tmp_path / "out" / "onset.png").stat().st_size > 10_000


def test_bench_onset_reports_the_grid(tmp_path):
    """`autocable bench onset` runs its 50-point grid and says whether it met the target (the time
    itself is the benchmark's, not asserted here)."""
    from autocable.bench.commands import run_bench
    r = run_bench("onset", str(SAMPLE), repeats=1)
    assert r["damping_grid_points"] == 50 and r["damping_grid_s"] > 0
    assert r["meets_target"] == (r["damping_grid_s"] < r["target_damping_grid_s"])
