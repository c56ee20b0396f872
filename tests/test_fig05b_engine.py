"""Fig. 5b runs on the compiled engine (runs/fig05b.toml): the same branch I as PyCont's on the
shipped scene, point for point (stated tolerance: a1 within 1e-6 of its peak at every compiled
point, interpolated along the PyCont branch; the same ends, stability and special points)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from autocable.scene.runner import load_scene, run_scene

REPO = Path(__file__).resolve().parents[1]


def test_fig05b_compiled_branch_is_pycont_branch(tmp_path):
    text = (REPO / "runs" / "fig05b.toml").read_text().replace('model = "../models/', f'model = "{REPO}/models/')
    assert 'engine = "compiled"' in text
    text = text[:text.index("[overlay]")]          # the branch only
    path = tmp_path / "fig05b.toml"
    path.write_text(text)
    scene = load_scene(path)
    new = run_scene(scene, tmp_path / "compiled", plot=False)
    ref = run_scene(scene, tmp_path / "pycont", plot=False, engine="pycont")
    assert new.provenance["engine"] == "compiled" and ref.provenance["engine"] == "pycont"
    a, b = ref.branch("I"), new.branch("I")
    assert b["sigma"][[0, -1]] == pytest.approx(a["sigma"][[0, -1]], abs=1e-12)
    order = np.argsort(a["sigma"])
    peak = float(np.max(a["a1"]))
    assert np.max(np.abs(b["a1"] - np.interp(b["sigma"], a["sigma"][order], a["a1"][order]))) < 1e-6 * peak
    assert float(np.max(b["a1"])) == pytest.approx(peak, rel=1e-6)
    assert bool(np.all(a.stable)) and bool(np.all(b.stable))
    assert [s.label for s in a.special_points] == [s.label for s in b.special_points]
