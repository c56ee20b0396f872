"""`aero.CubicLoadError.many` (the scenes' validity columns, `runner._with_twist`) against calling the
object point by point: the same numbers, bit for bit, on motions like a scene's branch (twists and
mid-span velocities across the sample's range, U from 0.05 to 1.5), with U = 0 (no wind: 0) and
non-finite amplitudes (nan) where the pointwise call gives them."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from autocable.model.aero import CubicLoadError
from autocable.model.derive import derive
from autocable.spec import load_model

MODEL = Path(__file__).resolve().parents[1] / "models" / "luongo_zulli_2012.toml"


def test_many_equals_pointwise_bit_for_bit():
    spec = load_model(MODEL)
    d = derive(spec)
    a = spec.aero
    err = CubicLoadError(a.lift, a.drag, d.statics.alpha, d.beta, d.theta0, a.angle_convention, a.load_axes)
    rng = np.random.default_rng(3)
    n = 300                                  # more than one block of 256
    tw, v1, v2 = rng.uniform(0, 0.3, n), rng.uniform(0, 0.02, n), rng.uniform(0, 0.02, n)
    U = rng.uniform(0.05, 1.5, n)
    U[:4] = 0.0
    tw[10], v1[11], v2[12] = np.nan, np.inf, -np.inf
    want = np.array([err(*x) for x in zip(tw, v1, v2, U)])
    got = err.many(tw, v1, v2, U)
    assert np.array_equal(np.isnan(got), np.isnan(want)) and np.isnan(want).sum() == 3
    assert np.all(got[:4] == 0.0)
    ok = np.isfinite(want)
    assert np.array_equal(got[ok], want[ok])
    assert float(np.max(want[ok])) > 1e-3       # errors of the size the validity table reports
    # one U for all points
    assert np.array_equal(err.many(tw[20:40], v1[20:40], v2[20:40], 0.7),
                          np.array([err(*x, 0.7) for x in zip(tw[20:40], v1[20:40], v2[20:40])]))
