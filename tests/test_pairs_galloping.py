"""The mode-pair table's galloping columns (`onset --modes-below F --design-wind U`)."""
from __future__ import annotations

import pytest

from autocable.model.derive import derive
from autocable.studies.gallop import gallop_study
from autocable.studies.pairs_galloping import galloping_lines, pairs_with_galloping
from conftest import REPO

# Its one test runs the galloping study on a mode pair (cycles continued in U, about 25 s under load):
# the whole file is in the slow tier.
pytestmark = pytest.mark.slow


def test_every_pair_row_gets_its_galloping_columns():
    """Each row's lowest galloping speed and amplitude are those of the galloping study run on that
    pair alone, and the first pair's is below its onset (a sub-critical onset's fold)."""
    d = derive(REPO / "models" / "luongo_zulli_2012.toml")
    f1 = 1.2      # Hz: the sample's first pair only (1.12 Hz; the second is at 2.24 Hz)
    report = pairs_with_galloping(d, f1, 30.0, 5.0)
    assert [r["k"] for r in report["pairs"]] == [1]
    row = report["pairs"][0]
    direct = gallop_study(d, 30.0, checks=False)
    assert row["lowest_galloping_U_m_s"] == pytest.approx(direct["lowest_galloping_U_m_s"], rel=1e-9)
    assert row["amplitude_at_design_wind_m"] == pytest.approx(direct["amplitude_at_design_wind_m"], rel=1e-9)
    assert row["lowest_galloping_U_m_s"] < row["onset_U_m_s"]
    assert 0.0 < row["least_damping_global"] < 1.0
    assert "pending_columns" not in report
    text = "\n".join(galloping_lines(report))
    assert f"{row['lowest_galloping_U_m_s']:.4g}" in text
    # the design-wind cycle's validity travels with the row: the study's own numbers
    cycle = direct["cases"][0]["design_cycle"]
    assert row["phi_swept_deg"] == pytest.approx(cycle["phi_swept_deg"], rel=1e-9)
    assert row["twist_max_deg"] == pytest.approx(cycle["twist_max_deg"], rel=1e-9)
    assert row["missing_ingredient"] == [m["ingredient"] for m in direct["missing_ingredient"]]
    assert f"phi +-{row['phi_swept_deg']:.3g} deg" in text
