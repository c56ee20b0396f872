"""to_dataframe and read_results on the results of every kind of scene that once broke them: the
1-dof AME's state a1 is also its amplitude a1 (Fig. 3), and a time scene writes no branches.csv
(Fig. 11)."""
from __future__ import annotations

import json
import shutil
import subprocess
import sys

import pytest

from autocable.results import IncompleteResults, read_results
from conftest import REPO


def _run(scene, out):
    proc = subprocess.run([sys.executable, "-m", "autocable.cli", "run", str(REPO / "runs" / scene), "--out", str(out),
                           "--quiet"], capture_output=True, text=True, timeout=600, cwd=REPO)
    assert proc.returncode == 0, proc.stderr


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


def test_a_time_scene_reads_back_with_no_branches(tmp_path):
    _run("fig11.toml", tmp_path / "f11")
    res = read_results(tmp_path / "f11")
    assert res.branches == () and res.provenance["kind"] == "time"
    assert len(res.to_dataframe()) == 0


def test_a_missing_branches_csv_is_named(tmp_path):
    _run("fig03.toml", tmp_path / "f03")
    (tmp_path / "f03" / "branches.csv").unlink()
    with pytest.raises(IncompleteResults, match=r"branches\.csv: missing.*run the scene again"):
        read_results(tmp_path / "f03")
