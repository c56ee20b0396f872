"""Hostile inputs are refused where they enter, in one line naming the file and the field.

Each test is a reproduction of a wrong acceptance or an unhelpful rejection, turned around: model
specs (huge integers, long values, non-UTF-8 or non-regular files, unsafe names, a dropped
angle_convention, implausible air and coefficients), the physical premises of eq. (21) on the
derived cable (`autocable.model.premises.check_model`: errors where the model cannot apply,
warnings where it is stretched, none for the sample), and scenes (tolerances, point budgets,
values ignored or outside the premises, an over-wide sigma range).
"""
import os
import re
import subprocess
import sys
import warnings

import pytest

from autocable.cli import main
from autocable.model.premises import CABLE_LIMITS, PremiseWarning, check_model
from autocable.spec import MAX_MESSAGE, MAX_PATH, SpecError, load_model, parse_model
from conftest import REPO, SAMPLE

FIG05A = REPO / "runs" / "fig05a.toml"
#: One line: the standards keep messages short (a value quoted in full once made 4.4 kB).
MAX_LINE = 250


def _spec(tmp_path, old: str, new: str, name: str = "m.toml"):
    text = SAMPLE.read_text()
    assert old in text, old
    path = tmp_path / name
    path.write_text(text.replace(old, new, 1))
    return path


def _refused(capsys, argv, *needles):
    """Run the CLI: exit 2, one short line on stderr containing every needle."""
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    # one line: the prefix, the path (whole up to MAX_PATH) and the field with its message (whole up
    # to MAX_MESSAGE: a fix at its end is never cut by a long path)
    assert "\n" not in err and len(err) < len("autocable: error: ") + MAX_PATH + 2 + MAX_MESSAGE + 1, err
    for n in needles:
        assert n in err, (n, err)
    return err


# --------------------------------------------------------------------------------------------
# model specs
@pytest.mark.parametrize("old,new,field,rule", [
    ("axial_stiffness_N = 2.1688e9", "axial_stiffness_N = 1" + "0" * 400, "cable.axial_stiffness_N", "401 digits"),
    ("drag = [1.25, -0.65, -0.08, 6.81]", "drag = [1e300, " + ", ".join(["1e300"] * 3) + "]", "aero.drag[0]",
     "[-100, 100]"),
    ('load_length = "diameter"', 'load_length = "' + "x" * 5000 + '"', "aero.load_length", '"diameter" or "radius"'),
    ("air_density_kg_m3 = 1.25", "air_density_kg_m3 = 1e6", "aero.air_density_kg_m3", "from 0.1 to 10"),
    ("critical_wind_speed_m_s = 36.0", "critical_wind_speed_m_s = 1e6", "aero.critical_wind_speed_m_s",
     "at most 100"),
    ("lift = [-0.48, 0.84, 4.69, 0.86]", "lift = [-0.48, 0.84, 4.69, -250.0]", "aero.lift[3]", "[-100, 100]"),
])
def test_bad_value_is_one_short_line_naming_field_and_range(tmp_path, capsys, old, new, field, rule):
    path = _spec(tmp_path, old, new)
    err = _refused(capsys, ["derive", str(path)], str(path), field, rule)
    assert "Traceback" not in err


@pytest.mark.parametrize("name", ["../../escaped", "/abs/path", "a\\nb", "back\\\\slash", ".", "..",
                                  "x" * 65, ""])
def test_unsafe_model_name_is_refused_with_the_rule(tmp_path, capsys, name):
    path = _spec(tmp_path, 'name = "luongo_zulli_2012"', f'name = "{name}"')
    _refused(capsys, ["derive", str(path)], str(path), "name:", 'without "/"', "64 characters")


def test_dropped_angle_convention_is_refused_naming_both_senses(tmp_path, capsys):
    """Without it the literal sense was taken silently (Theta0 -13.9 -> 58.2 deg)."""
    path = _spec(tmp_path, 'angle_convention = "mirrored"', "")
    _refused(capsys, ["derive", str(path)], str(path), "aero.angle_convention", '"eq12"', '"mirrored"',
             '"reversed"')


def test_non_utf8_file_names_the_file(tmp_path, capsys):
    path = tmp_path / "latin1.toml"
    path.write_bytes(SAMPLE.read_bytes().replace(b"Sect. 5", b"Sect.\xa75"))
    _refused(capsys, ["derive", str(path)], str(path), "not UTF-8")


def test_directory_as_model_is_not_a_regular_file(tmp_path, capsys):
    _refused(capsys, ["derive", str(tmp_path)], str(tmp_path), "not a regular file")


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs on this system")
def test_fifo_as_model_or_scene_returns_at_once(tmp_path):
    """Opening a FIFO blocks until a writer comes: it used to hang forever. The timeout is a guard
    against that hang, not a speed check."""
    fifo = tmp_path / "model.toml"
    os.mkfifo(fifo)
    scene = tmp_path / "scene.toml"
    scene.write_text(FIG05A.read_text().split("\n[overlay]")[0].replace('"../models/luongo_zulli_2012.toml"',
                                                                        '"model.toml"'))
    code = "import sys; from autocable.cli import main; sys.exit(main(sys.argv[1:]))"
    for argv, field in ((["derive", str(fifo)], ""), (["run", str(fifo)], ""), (["run", str(scene)], "model")):
        proc = subprocess.run([sys.executable, "-c", code, *argv], capture_output=True, text=True, timeout=120,
                              env={**os.environ, "AUTOCABLE_CACHE": str(tmp_path / "cache")})
        assert proc.returncode == 2, proc.stderr
        assert "not a regular file" in proc.stderr and field in proc.stderr


# --------------------------------------------------------------------------------------------
# the premises of eq. (21) on the derived cable
@pytest.mark.parametrize("old,new,quantity,bound", [
    ("axial_stiffness_N = 2.1688e9", "axial_stiffness_N = 1.0", "static strain", "0.5"),
    ("axial_stiffness_N = 2.1688e9", "axial_stiffness_N = 1e3", "static strain", "0.5"),
    ("horizontal_tension_N = 3142.0e3", "horizontal_tension_N = 1e12", "static strain", "0.5"),
    ("length_m = 121.9", "length_m = 1e-6", "slenderness D/l", "0.1"),
    ("diameter_m = 0.119", "diameter_m = 200.0", "slenderness D/l", "0.1"),
    ("gravity_m_s2 = 9.81", "gravity_m_s2 = 1e5", "sag parameter delta", "[0, 1]"),
    ("horizontal_tension_N = 3142.0e3", "horizontal_tension_N = 3e5", "lambda^2", "39.48"),
    ("gravity_m_s2 = 9.81", "gravity_m_s2 = 1e-6", "lambda^2", "1e-12"),
    ("torsional_stiffness_Nm2 = 159.0", "torsional_stiffness_Nm2 = 1e-300", "chi = GJ/EI", "[1e-06, 10]"),
])
def test_impossible_cable_is_refused_naming_the_quantity(tmp_path, capsys, old, new, quantity, bound):
    """Each was accepted (EA = 1 N: omega1 = 1.000000000002, exit 0) or failed deep in a root finder
    ("f(a) and f(b) must have different signs" for H = 1e12 or L = 1e-6)."""
    path = _spec(tmp_path, old, new)
    err = _refused(capsys, ["derive", str(path)], str(path), quantity, bound)
    assert "different signs" not in err


@pytest.mark.parametrize("old,new,key", [
    ("axial_stiffness_N = 2.1688e9", "axial_stiffness_N = 3e8", "strain"),            # tau = 0.0128
    ("diameter_m = 0.119", "diameter_m = 2.0", "slenderness"),                          # D/l = 0.0164
    ("horizontal_tension_N = 3142.0e3", "horizontal_tension_N = 8e5", "detuning"),     # lambda^2 = 5.9
])
def test_stretched_cable_warns_naming_the_quantity(tmp_path, old, new, key):
    spec = load_model(_spec(tmp_path, old, new))
    with pytest.warns(PremiseWarning) as record:
        q = check_model(spec)
    assert CABLE_LIMITS[key][0] < q[key] < CABLE_LIMITS[key][1]
    assert len(record) == 1 and "\n" not in str(record[0].message)
    assert str(spec.path) in str(record[0].message)


def test_sample_cable_meets_every_premise_without_a_warning():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        q = check_model(load_model(SAMPLE))
    assert q["strain"] == pytest.approx(1.773e-3, rel=1e-3)
    assert q["slenderness"] == pytest.approx(0.119 / 121.9, rel=1e-12)
    assert q["lambda2"] == pytest.approx(0.09775, rel=1e-3)
    assert q["detuning"] == pytest.approx(0.0040053, rel=1e-4)      # docs/model.md, M1


def test_premise_warning_is_one_line_on_stderr(tmp_path, capsys):
    path = _spec(tmp_path, "axial_stiffness_N = 2.1688e9", "axial_stiffness_N = 3e8")
    assert main(["derive", str(path), "--json"]) == 0
    lines = [ln for ln in capsys.readouterr().err.splitlines() if "warning" in ln]
    assert len(lines) == 1
    assert lines[0].startswith("autocable: warning: ") and "static strain" in lines[0] and str(path) in lines[0]


def test_sample_derive_prints_no_warning(capsys):
    assert main(["derive", str(SAMPLE), "--json"]) == 0
    assert "warning" not in capsys.readouterr().err


def test_parse_model_in_memory_still_checks_the_name():
    data = {"name": "a/b"}
    with pytest.raises(SpecError, match="name"):
        parse_model(data, "<mem>")


# --------------------------------------------------------------------------------------------
# scenes
def _scene(tmp_path, text: str, name: str = "s.toml"):
    path = tmp_path / name
    path.write_text(text.replace('"../models/luongo_zulli_2012.toml"', '"' + str(SAMPLE) + '"'))
    return path


def _fig05a(extra_fixed: str = "", run_extra: str = "", range_: str = "[-0.05, 0.05]") -> str:
    text = FIG05A.read_text().split("\n[overlay]")[0]
    text = text.replace("eta = 8.2e-5\n", "eta = 8.2e-5\n" + extra_fixed, 1)
    text = text.replace("range = [-0.05, 0.05]", f"range = {range_}", 1)
    return text.replace("switch = true ", "switch = true\n" + run_extra + "\n", 1) if run_extra else text


@pytest.mark.parametrize("text,field,rule", [
    (_fig05a(run_extra="[run.steps]\ntol = 1e-300"), "run[0].steps.tol", "1e-14 to 1e-2"),
    (_fig05a(run_extra="[run.steps]\nmax_points = 1"), "run[0].steps.max_points", "from 25"),
    (_fig05a(run_extra="[run.steps]\nmax_points = 1" + "0" * 400), "run[0].steps.max_points", "from 25"),
    (_fig05a(run_extra="[run.steps]\nmax_step = 1" + "0" * 400), "run[0].steps.max_step", "401 digits"),
    (_fig05a("sigma = 0.01\n"), "fixed.sigma", "ignored"),
    (_fig05a(run_extra="[run.fixed]\nsigma = 0.01"), "run[0].fixed.sigma", "ignored"),
    (_fig05a().replace("eta = 8.2e-5", "eta = 0.5"), "fixed.eta", "[0, 0.05]"),
    (_fig05a().replace("eta = 8.2e-5", "eta = 1e3"), "fixed.eta", "[0, 0.05]"),
    (_fig05a(range_="[-1.0, 1.0]"), "run[0].range", "[-0.5, 0.5]"),
    (_fig05a().replace('start = "trivial"', "start = { integrate = [1e6, 0.0] }"), "run[0].start.integrate",
     "[-0.1, 0.1]"),
])
def test_bad_scene_is_refused_naming_the_field(tmp_path, capsys, text, field, rule):
    """tol = 1e-300 gave a one-point branch with both ends "error", max_points = 1 gave 26 points, a
    fixed sigma under a sigma run was ignored, eta = 0.5 or 1e3 ran to a1 = 552, all with exit 0."""
    path = _scene(tmp_path, text)
    with pytest.raises(SpecError) as err:
        from autocable.scene.schema import load_scene
        load_scene(path)
    assert err.value.field == field
    _refused(capsys, ["run", str(path), "--out", str(tmp_path / "o"), "--no-plot"], str(path), field, rule)
    assert not (tmp_path / "o").exists()


def test_stretched_scene_parameter_warns(tmp_path):
    from autocable.scene.schema import load_scene
    path = _scene(tmp_path, _fig05a().replace("eta = 8.2e-5", "eta = 0.01"))
    with pytest.warns(PremiseWarning, match=r"fixed\.eta = 0\.01"):
        load_scene(path)


def test_sweep_grid_and_start_outside_the_premises(tmp_path):
    from autocable.scene.sweep_schema import load_sweep
    for body, field in (("[grid]\neta = 1e3\n", "grid.eta"), ("q0 = [0.0, 0.0, 1e6, 0.0]\n", "q0[2]"),
                        ("[grid]\nsigma = 1" + "0" * 400 + "\n", "grid.sigma")):
        path = tmp_path / "w.toml"
        path.write_text(f'model = "{SAMPLE}"\n' + body)
        with pytest.raises(SpecError) as err:
            load_sweep(path)
        assert err.value.field == field and len(str(err.value)) < MAX_LINE


def _peak(tmp_path, range_: str, tag: str) -> tuple[float, int]:
    import csv
    path = _scene(tmp_path, _fig05a(range_=range_).replace("cycles = true", "cycles = false")
                  .replace("switch = true", "switch = false"), f"{tag}.toml")
    out = tmp_path / tag
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PremiseWarning)     # |sigma| = 0.5 is stretched: it says so
        assert main(["run", str(path), "--out", str(out), "--no-plot", "--quiet", "--engine", "compiled"]) == 0
    rows = list(csv.DictReader((out / "branches.csv").open()))
    return max(float(r["a1"]) for r in rows), len(rows)


def test_wide_sigma_range_keeps_fig05a_peak(tmp_path):
    """Fig. 5a over a range ten times the figure's gives the same resonance peak to 1 % (the
    peak of the figure's scene is 3.350e-4). Over [-1, 1] (refused above: sigma = -1 is a forcing
    frequency of 0.004, far outside the Multiple Scales) the peak came out at 2.085e-4."""
    narrow, _ = _peak(tmp_path, "[-0.05, 0.05]", "narrow")
    wide, n = _peak(tmp_path, "[-0.5, 0.5]", "wide")
    assert narrow == pytest.approx(3.350e-4, rel=1e-3)
    assert wide == pytest.approx(narrow, rel=1e-2)
    assert n > 100


def test_non_utf8_compare_csv_names_the_file(tmp_path):
    from autocable.scene.schema import CompareSpec, read_compare
    path = tmp_path / "digitised.csv"
    path.write_bytes(b"x,y,curve,stable\n0.01,2\xe9-4,I,1\n")
    with pytest.raises(SpecError, match=re.escape(str(path)) + ": not UTF-8"):
        read_compare(CompareSpec(path))


def test_every_step_key_has_bounds():
    """A step key without bounds would reach the runner unchecked (a KeyError at load before)."""
    from autocable.methods.continuation.settings import STEP_KEYS
    from autocable.scene.schema import _STEP_BOUNDS
    assert set(_STEP_BOUNDS) == set(STEP_KEYS)


def test_a_calibration_no_angle_satisfies_names_the_file_and_field(capsys, tmp_path):
    """A structural damping of 30 % leaves no rivulet angle with the onset at U_c (the wind's
    damping cannot cancel it at U_c): an input the user must change, so exit 2 naming the file and
    field (it went through the catch-all as a CalibrationError before). (The horizontal chord this
    test used has no such angle with the legacy "reversed" sense only.) The message names the typed
    values that no angle can meet, U_c and the damping ratio, and the fixes."""
    path = _spec(tmp_path, "damping_ratio = 0.004 ", "damping_ratio = 0.3 ")
    err = _refused(capsys, ["derive", str(path), "--json"], str(path), "aero.critical_wind_speed_m_s: 36.0 m/s",
                   "cable.damping_ratio = 0.3", "or a smaller damping_ratio")
    assert "CalibrationError" not in err


def test_scene_state_start_has_the_ame_dimension_and_model_path_is_plain(capsys, tmp_path):
    """A `state` start with 3 numbers on the 2-dof AME (4 variables) and a model path with a NUL
    byte are refused when the scene is read, naming the field."""
    text = (REPO / "runs" / "fig05b.toml").read_text().replace(
        '"../models/', f'"{REPO}/models/')
    scene = tmp_path / "s.toml"
    scene.write_text(text.replace('start = "trivial"', "start = { state = [0.0, 0.0, 0.0] }", 1))
    _refused(capsys, ["run", str(scene), "--out", str(tmp_path / "o")], str(scene), ".start.state",
             "4 state variables")
    scene.write_text(text.replace(f'"{REPO}/models/luongo_zulli_2012.toml"', '"nul\\u0000.toml"', 1))
    _refused(capsys, ["run", str(scene), "--out", str(tmp_path / "o")], str(scene), "model",
             "control characters")


def test_empty_model_path_and_non_finite_compare_points(capsys, tmp_path):
    """`derive ""` is refused as an empty path (it read as the folder "." before); a [compare] csv
    with nan/inf points is refused naming the csv and the row (it failed as a JSON error after the
    continuation before)."""
    _refused(capsys, ["derive", ""], "MODEL", "an empty path")
    _refused(capsys, ["run", " ", "--out", str(tmp_path / "o")], "SCENE", "an empty path")
    from autocable.scene.schema import CompareSpec, read_compare
    csv_path = tmp_path / "points.csv"
    csv_path.write_text("x,y\n0.01,2e-4\nnan,inf\n")
    with pytest.raises(SpecError) as err:
        read_compare(CompareSpec(csv=csv_path))
    assert str(csv_path) in str(err.value) and "row 3" in str(err.value) and "finite" in str(err.value)


def test_csv_into_a_folder_is_refused_before_the_integration(capsys, tmp_path):
    """`simulate --csv FOLDER` failed after the integration with IsADirectoryError (found by the
    fuzz run with seed 1): now refused at once, naming the option."""
    _refused(capsys, ["simulate", str(SAMPLE), "--csv", str(tmp_path)], "--csv", "is a folder")
