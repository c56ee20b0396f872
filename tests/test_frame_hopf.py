"""The Hopf criticality in the branches' DataFrames: `Branch.to_dataframe`
and `RunResults.to_dataframe` end with ``special`` (a special point's label at its row), ``l1`` and
``criticality`` (at a Hopf point's row), branches.csv keeping its documented columns; a run read back
from disk gives the same frame as the live result.

Checked on the Hopf normal form (l1 = 2 a / w in closed form, Kuznetsov's normalisation: the system
tests/test_report_ready.py and tests/test_continuation.py use) and on a frequency response of the
sample cable in the setting of Figs. 7-9 (wind above onset, U* = 1.1, with support motion), whose
branch has sub- and super-critical Hopf points.
"""
import math
import warnings

import numpy as np
import pandas as pd
import pytest

import autocable as ac
from autocable.results import BRANCHES_CSV, FRAME_SPECIAL_COLUMNS, RunResults, read_results, write_results
from conftest import HOPF_W, SAMPLE, hopf_normal_form_branch




def _check_rows(frame: pd.DataFrame, branches) -> int:
    """Every special point at its row (``index``), every Hopf row's l1 and word equal to the point's
    (and the word to the sign of l1); every other row empty. The number of Hopf rows."""
    assert list(frame.columns[-3:]) == list(FRAME_SPECIAL_COLUMNS)
    start, hopf = 0, 0
    for b in branches:
        part = frame.iloc[start:start + len(b)].reset_index(drop=True)
        start += len(b)
        assert (part["branch"] == b.name).all()
        at = {}
        for p in b.special_points:
            at.setdefault(p.index, []).append(p)
        for i in range(len(b)):
            points = at.get(i, [])
            assert part["special"][i] == " ".join(p.label for p in points)
            h = [p for p in points if p.type == "H"]
            if h:
                hopf += 1
                l1 = h[0].extra["l1"]
                assert part["l1"][i] == l1 and part["criticality"][i] == h[0].criticality
                assert part["criticality"][i] == ("subcritical" if l1 > 0 else "supercritical")
            else:
                assert math.isnan(part["l1"][i]) and part["criticality"][i] == ""
    assert start == len(frame)
    return hopf


@pytest.mark.parametrize("a, word", [(-1.0, "supercritical"), (0.5, "subcritical")])
def test_normal_form_hopf_row_has_the_closed_form_l1(a, word):
    b = hopf_normal_form_branch(a)
    frame = b.to_dataframe()
    rows = frame[frame["special"] != ""]
    assert rows["special"].tolist() == ["H1"]
    row = rows.iloc[0]
    assert row["l1"] == pytest.approx(2 * a / HOPF_W, rel=1e-10) and row["criticality"] == word
    # the row is the point before the located Hopf point (mu = 0): mu crosses 0 between it and the next
    i = int(row["point"])
    assert frame["mu"][i] <= 0.0 <= frame["mu"][i + 1] or abs(frame["mu"][i]) < 1e-9
    assert _check_rows(frame, [b]) == 1


@pytest.fixture(scope="module")
def windy():
    """The sample cable above its onset (U* = 1.1) with support motion eta* = 1e-3, sigma in
    [-0.05, 0.05]: branch I has Hopf points of both criticalities (0.1 s)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return ac.frequency_response(ac.derive(SAMPLE), U=1.1, eta=1e-3, sigma=(-0.05, 0.05))


def test_cable_hopf_rows_carry_l1_and_the_word_and_the_stability_changes_there(windy):
    frame = windy.to_dataframe()
    hopf = _check_rows(frame, windy.branches)
    words = set(frame["criticality"]) - {""}
    assert hopf >= 2 and words == {"subcritical", "supercritical"}, words
    # independent of the labels: at every Hopf row a complex pair of eigenvalues crosses the imaginary
    # axis between the row and the next (the located point lies between them): the real part of a
    # complex pair changes sign from the row to the next (or is zero at the next row, where a
    # continuation point landed on the Hopf point itself)
    re = frame[[c for c in frame.columns if c.startswith("ev") and c.endswith("_re")]].to_numpy()
    im = frame[[c for c in frame.columns if c.startswith("ev") and c.endswith("_im")]].to_numpy()
    for i in np.flatnonzero(frame["criticality"].to_numpy() != ""):
        a, b = re[i][im[i] > 1e-9], re[i + 1][im[i + 1] > 1e-9]
        assert any(x * min(b, key=lambda y: abs(y - x)) <= 0 or min(abs(b)) < 1e-12 for x in a), i
    # a single branch's frame has the same three columns for its rows
    one = windy.branches[0].to_dataframe()
    pd.testing.assert_frame_equal(one[list(FRAME_SPECIAL_COLUMNS)],
                                  frame[list(FRAME_SPECIAL_COLUMNS)].iloc[:len(one)].reset_index(drop=True))


def test_frame_read_back_from_disk_equals_the_live_one_and_the_csv_keeps_its_columns(windy, tmp_path):
    write_results(windy, tmp_path)
    back = read_results(tmp_path)
    live, disk = windy.to_dataframe(), back.to_dataframe()
    pd.testing.assert_frame_equal(live, disk, check_exact=True)
    header = (tmp_path / BRANCHES_CSV).read_text().splitlines()[0].split(",")
    assert not set(FRAME_SPECIAL_COLUMNS) & set(header)
    assert list(live.columns) == header + list(FRAME_SPECIAL_COLUMNS)
