"""The notebook-facing API: DataFrames equal to the files, the frequency response in one call, the
default state scale, angles in degrees beside the radians, a derivation's summary and repr."""
import math

import numpy as np
import pandas as pd
import pytest

import autocable as ac
from autocable.results import FRAME_SPECIAL_COLUMNS
from conftest import SAMPLE

_TEXT = ("branch", "kind", "parameter", "parameter2")


def _csv_frame(path) -> pd.DataFrame:
    """branches.csv read as text by pandas alone: names as text (an empty parameter2 stays ""),
    every other cell a number by Python's float (exact for the CSV's repr; empty: NaN)."""
    raw = pd.read_csv(path, dtype=str, keep_default_na=False)
    for col in raw.columns:
        if col not in _TEXT:
            raw[col] = raw[col].map(lambda v: float(v) if v != "" else math.nan).astype("float64")
    return raw


@pytest.fixture(scope="module")
def response():
    """Fig. 6's setting (U = 0, eta* = 1.4e-3) in one call."""
    return ac.frequency_response(SAMPLE, U=0.0, eta=1.4e-3, sigma=(-0.05, 0.05))


def test_to_dataframe_equals_branches_csv(response, tmp_path):
    """RunResults.to_dataframe and each Branch.to_dataframe hold the columns, in order, and the
    values of branches.csv as write_results writes it (read back by pandas on its own): floats
    exactly (the CSV writes repr), stable as 0/1, empty cells as NaN."""
    ac.write_results(response, tmp_path)
    csv = _csv_frame(tmp_path / "branches.csv")
    frame = response.to_dataframe()
    # then the frame's own columns from the special points (tests/test_frame_hopf.py)
    assert list(frame.columns) == list(csv.columns) + list(FRAME_SPECIAL_COLUMNS)
    assert len(frame) == len(csv) == sum(len(b) for b in response.branches)
    for col in csv.columns:
        if col in _TEXT:
            assert frame[col].tolist() == csv[col].tolist(), col
        else:
            np.testing.assert_array_equal(frame[col].to_numpy(dtype=float), csv[col].to_numpy(), err_msg=col)
    assert frame["stable"].dtype == bool and frame["point"].dtype == np.int64
    # a run with its SI scales in the provenance (as every scene writes them): the SI columns too
    from dataclasses import asdict

    from autocable.model.units import SI_COLUMNS, units_of
    d = ac.derive(SAMPLE)
    with_si = ac.RunResults("si", response.branches, {"si_scales": asdict(units_of(d.spec, d.statics)),
                                                      "omega1": d.ode.omega1})
    ac.write_results(with_si, tmp_path / "si")
    csv_si = _csv_frame(tmp_path / "si" / "branches.csv")
    frame_si = with_si.to_dataframe()
    n_own = len(FRAME_SPECIAL_COLUMNS)
    assert list(frame_si.columns[:-n_own]) == list(csv_si.columns)
    assert list(frame_si.columns[-len(SI_COLUMNS) - n_own:-n_own]) == list(SI_COLUMNS)
    for col in SI_COLUMNS:
        np.testing.assert_array_equal(frame_si[col].to_numpy(), csv_si[col].to_numpy(), err_msg=col)
    assert frame_si["peak_in_plane_m"].to_numpy() == pytest.approx(d.spec.cable.length_m * frame_si["a1"].to_numpy(),
                                                                    rel=1e-15)
    import csv as csv_mod
    with open(tmp_path / "special_points.csv", newline="") as fh:
        rows = list(csv_mod.DictReader(fh))
    sp = response.special_points_dataframe()
    assert list(sp.columns) == list(rows[0]) and sp["label"].tolist() == [r["label"] for r in rows]
    np.testing.assert_array_equal(sp["sigma"].to_numpy(), [float(r["sigma"]) for r in rows])
    one = response.branches[1].to_dataframe()
    rows = csv[csv["branch"] == response.branches[1].name].reset_index(drop=True)
    assert len(one) == len(rows)
    for col in one.columns:            # a branch alone has only its own columns (its eigenvalues, ...)
        if col in FRAME_SPECIAL_COLUMNS:
            continue
        if col in _TEXT:
            assert one[col].tolist() == rows[col].tolist()
        else:
            np.testing.assert_array_equal(one[col].to_numpy(dtype=float), rows[col].to_numpy(), err_msg=col)


def test_frequency_response_in_one_call(response):
    """Branch I with its two pitchforks (a2 = 0 at each, a2 > 1e-3 on the switched branches), the
    stability of every point, and I at sigma = -0.05 equal to the AME integrated from rest there
    (continuation against integration of eq. 24)."""
    I = response.branch("I")
    bps = I.of_type("BP")
    assert len(bps) == 2 and all(abs(p.a2) < 1e-12 for p in bps)
    assert [b.name for b in response.branches] == ["I", "II", "III"]
    assert all(np.max(b["a2"]) > 1e-3 for b in response.branches[1:])
    assert I.stable.dtype == bool and I.stable.any() and not I.stable.all()
    r = ac.AmeIntegrator(ac.derive_ame(ac.derive(SAMPLE)).ame).simulate(0.0, 1.4e-3, -0.05)
    assert I["sigma"][0] == pytest.approx(-0.05) and I["a1"][0] == pytest.approx(r.a1, rel=1e-6)
    # eq. (21) itself gives the same branch
    again = ac.frequency_response(ac.derive(SAMPLE).ode, U=0.0, eta=1.4e-3, sigma=(-0.05, 0.05), switch=False)
    np.testing.assert_array_equal(again.branch("I")["a1"], I["a1"])
    with pytest.raises(ValueError, match="sigma"):
        ac.frequency_response(SAMPLE, eta=1e-3, sigma=(0.05, -0.05))


def test_default_state_scale_is_the_ames_own():
    """Left out, the state scale of an AME problem is auto_state_scale's (the linear forced
    response |f(0)| / mean damping rate; 1e-2 unforced); any other system keeps 1."""
    ame = ac.derive_ame(ac.derive(SAMPLE)).ame
    system = ac.ame_system(ame, "2dof", wind=False)
    values = {"U": 0.0, "eta": 1.4e-3, "sigma": -0.05}
    p = ac.EquilibriumProblem(system, "sigma", values, (-0.05, 0.05))
    assert p.state_scale == ac.auto_state_scale(system, values)
    x0 = np.zeros(system.dimension)
    pv = system.parameter_vector(values)
    expected = np.linalg.norm(system.f(x0, pv)) / (abs(np.trace(system.jac(x0, pv))) / system.dimension)
    assert p.state_scale == pytest.approx(expected, rel=1e-12) and 1e-5 < p.state_scale < 1e-1
    toy = ac.System("toy", ("x",), ("mu - x**3",), {"mu": 0.0})
    assert ac.EquilibriumProblem(toy, "mu", {"mu": 0.0}, (-1.0, 1.0)).state_scale == 1.0
    # unforced (eta = 0): no forced response to measure, the AME's amplitude scale 1e-2
    assert ac.EquilibriumProblem(system, "sigma", {**values, "eta": 0.0}, (-0.05, 0.05)).state_scale == 1e-2


def test_angles_in_degrees_summary_and_repr(tmp_path):
    """The spec's yaw_deg comes back as beta_deg (the radians unchanged beside it); the calibrated
    Theta0 in degrees is the one the summary prints; the repr is one line."""
    d = ac.derive(SAMPLE)
    assert d.beta_deg == pytest.approx(d.spec.aero.yaw_deg, abs=1e-12)
    assert d.beta == pytest.approx(math.radians(d.spec.aero.yaw_deg), abs=1e-15)
    assert d.theta0_deg == pytest.approx(math.degrees(d.theta0), rel=1e-15)
    assert d.static_angle_deg == pytest.approx(math.degrees(d.static_angle), rel=1e-15)
    assert d.statics.alpha_deg == pytest.approx(d.spec.cable.chord_slope_deg, abs=1e-12)
    text = d.summary()
    assert f"Theta0 = {d.theta0_deg:.4f} deg" in text and "rivulet_angle_deg calibrated" in text
    assert f"omega1 = {d.ode.omega1:.6f}" in text
    r = repr(d)
    assert "\n" not in r and r.startswith("Derivation(model='luongo_zulli_2012'") and len(r) < 200
    # a spec with both angles given: both come back as written
    spec = SAMPLE.read_text().replace('rivulet_angle_deg = "calibrate"', "rivulet_angle_deg = -13.5")
    assert "rivulet_angle_deg = -13.5" in spec
    (tmp_path / "m.toml").write_text(spec)
    given = ac.derive(tmp_path / "m.toml")
    assert given.theta0_deg == pytest.approx(-13.5, abs=1e-12) and given.calibrated == ""
