"""to_dataframe and read_results on the results of every kind of scene: those that once broke
them (the 1-dof AME's state a1 is also its amplitude a1, Fig. 3; a time scene writes no
branches.csv, Fig. 11) and one scene with every kind of run (equilibria, a switched bi-modal branch,
a curve of pitchforks, cycles from a Hopf point) in SI. Run time: about 60 s on two shared cores
(four small or coarse scene runs in subprocesses)."""
from __future__ import annotations

import json
import shutil
import subprocess
import sys

from pathlib import Path

import numpy as np
import pytest

import autocable as ac
from autocable.results import IncompleteResults, read_results
from conftest import REPO, SAMPLE


def _run(scene, out, *extra, quiet=True):
    path = scene if isinstance(scene, Path) else REPO / "runs" / scene
    proc = subprocess.run([sys.executable, "-m", "autocable.cli", "run", str(path), "--out", str(out),
                           *(["--quiet"] if quiet else []), *extra], capture_output=True, text=True, timeout=600,
                          cwd=REPO)
    assert proc.returncode == 0, proc.stderr
    return proc


#: One scene with every kind of run on the sample cable (compiled engine; coarse in the test).
EVERY_KIND = f"""title = "Every run kind"
model = "{SAMPLE.as_posix()}"
ame = "2dof"
engine = "compiled"
[fixed]
U = 0.0
eta = 1.4e-3
[[run]]
name = "I"
parameter = "sigma"
range = [-0.05, 0.05]
start = "trivial"
[[run]]
name = "III"
kind = "switch"
start = "I:BP1"
parameter = "sigma"
range = [-0.05, 0.05]
[[run]]
name = "P"
kind = "curve"
start = "I:BP1"
parameter = "sigma"
range = [-0.05, 0.05]
parameter2 = "eta"
range2 = [0.0, 2.5e-3]
[[run]]
name = "W"
parameter = "U"
range = [0.05, 1.5]
start = "trivial"
cycles = true
[run.fixed]
sigma = 0.01
eta = 1.6e-4
[plot]
x = "sigma"
y = ["a1", "a2"]
units = "si"
"""


def test_every_run_kind_makes_dataframes_and_reads_back(tmp_path):
    """Equilibria, a switched branch, a pitchfork curve and cycles: one DataFrame of every point with
    unique columns, each kind's own columns filled (a2 on the bi-modal branch, det_J and parameter2
    on the curve, the min/max over each cycle), the SI columns equal to the conversion of eqs.
    (17)-(18) (a1 l, U U_c, (omega1 + sigma) omega / 2 pi), the coarse run's cycle branch cut at
    its 20 cycles named in attrs["truncated"], the Hopf point's criticality in the special points'
    frame and in the printed summary, which is in SI (units = "si")."""
    scene = tmp_path / "every_kind.toml"
    scene.write_text(EVERY_KIND)
    proc = _run(scene, tmp_path / "out", "--resolution", "coarse", "--no-plot", quiet=False)
    res = read_results(tmp_path / "out")
    kinds = {b.name: b.kind for b in res.branches}
    assert kinds == {"I": "equilibrium", "III": "equilibrium", "P": "branch_point", "W": "equilibrium",
                     "W-H1": "cycle"}
    frame = res.to_dataframe()
    assert frame.columns.is_unique and len(frame) == sum(len(b) for b in res.branches)
    by = {name: frame[frame["branch"] == name] for name in kinds}
    assert by["III"]["a2"].max() > 1e-3 and by["I"]["a2"].abs().max() < 1e-12
    assert (by["P"]["parameter2"] == "eta").all() and by["P"]["det_J"].notna().all()
    assert by["I"]["det_J"].isna().all()
    cyc = by["W-H1"]
    assert cyc["period"].notna().all() and (cyc["a1_min"] <= cyc["a1_max"]).all()
    # SI columns against the conversion, computed here from the model (eqs. 17-18)
    d = ac.derive(SAMPLE)
    f0, l, uc = d.statics.frequency_hz, d.spec.cable.length_m, d.spec.aero.critical_wind_speed_m_s
    np.testing.assert_allclose(frame["peak_in_plane_m"], l * frame["a1"], rtol=1e-15)
    np.testing.assert_allclose(frame["U_m_s"], uc * frame["U"], rtol=1e-15)
    np.testing.assert_allclose(frame["Omega_Hz"], f0 * (d.ode.omega1 + frame["sigma"]), rtol=1e-13)
    for b in res.branches:
        one = b.to_dataframe()
        assert one.columns.is_unique and len(one) == len(b)
        assert "si_scales" in b.info and b.info["omega1"] == pytest.approx(d.ode.omega1, rel=1e-15)
    notes = frame.attrs["truncated"]
    assert [b.name for b in res.branches if b.truncated] == ["W-H1"]
    assert len(notes) == 1 and notes[0].startswith("branch W-H1 (forward) stopped at max_points")
    sp = res.special_points_dataframe()
    h = sp[(sp["branch"] == "W") & (sp["label"] == "H1")].iloc[0]
    assert h["criticality"] == ("subcritical" if h["l1"] > 0 else "supercritical")
    assert (sp[sp["label"] != "H1"]["criticality"] == "").all()
    # the summary on stdout: in SI, with the Hopf criticality and the cut cycle branch
    w = res.branch("W").special("H1")
    assert f"U = {w.value * uc:.8g} m/s" in proc.stdout and f"{h['criticality']}, l1 = " in proc.stdout
    bp = res.branch("I").special("BP1")
    assert f"Omega = {f0 * (d.ode.omega1 + bp.value):.8g} Hz" in proc.stdout
    assert "forward: max_points at U = " in proc.stdout
    # and said as it happened, on one line (not a Python warning with its source line)
    said = [ln for ln in proc.stderr.splitlines() if "stopped at max_points" in ln]
    assert len(said) == 1 and said[0].startswith("autocable: warning: branch W-H1 (forward) stopped at max_points")
    assert "TruncatedBranchWarning" not in proc.stderr


@pytest.mark.slow
def test_fig03_results_make_dataframes(tmp_path):
    _run("fig03.toml", tmp_path / "f03")
    res = read_results(tmp_path / "f03")
    frame = res.to_dataframe()
    assert frame.columns.is_unique
    assert len(frame) == sum(len(b) for b in res.branches)
    for b in res.branches:
        one = b.to_dataframe()
        assert one.columns.is_unique and len(one) == len(b)
        assert list(one["a1"]) == pytest.approx(list(b.table["a1"]), rel=0, abs=0)


@pytest.mark.slow
def test_a_time_scene_reads_back_with_no_branches(tmp_path):
    _run("fig11.toml", tmp_path / "f11")
    res = read_results(tmp_path / "f11")
    assert res.branches == () and res.provenance["kind"] == "time"
    assert len(res.to_dataframe()) == 0


@pytest.mark.slow
def test_a_missing_branches_csv_is_named(tmp_path):
    _run("fig03.toml", tmp_path / "f03")
    (tmp_path / "f03" / "branches.csv").unlink()
    with pytest.raises(IncompleteResults, match=r"branches\.csv: missing.*run the scene again"):
        read_results(tmp_path / "f03")
