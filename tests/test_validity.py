"""Validity of a motion (autocable.model.validity): the angle it sweeps, the twist, the cubic load's
error, and the flag, each against a closed form or an independent route."""
from __future__ import annotations

import dataclasses
import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from autocable.model.derive import derive
from autocable.model.validity import cubic_aero_forces, motion_validity
from autocable.spec import load_model

ROOT = Path(__file__).resolve().parents[1]
SAMPLE = ROOT / "models" / "luongo_zulli_2012.toml"


def _derivation(load="exact", valid_deg=None, twist_ends=None):
    spec = load_model(SAMPLE)
    base = derive(spec)
    aero = dataclasses.replace(spec.aero, load=load, yaw_deg=base.beta_deg, rivulet_angle_deg=base.theta0_deg)
    cable = spec.cable if twist_ends is None else dataclasses.replace(spec.cable, twist_ends=twist_ends)
    d = derive(dataclasses.replace(spec, aero=aero, cable=cable))
    if valid_deg is not None:
        from autocable.model.validity import exact_load_for
        ex = exact_load_for(d)
        curves = dict(ex.curves, valid_phi=[math.radians(valid_deg[0]), math.radians(valid_deg[1])])
        d = dataclasses.replace(d, ode=dataclasses.replace(d.ode, exact_load=dataclasses.replace(ex, curves=curves)))
    return d


def _theta2(d, s):
    B, C, k = d.twist
    return B * np.sin(np.pi * s) + C * np.cosh(k * (s - 0.5))


@pytest.mark.parametrize("twist_ends", ["natural", "restrained"])
def test_a_pure_twist_sweeps_phi_by_the_twist(twist_ends):
    """q2 alone (no velocity): phi - phi0 = -theta along the span (eq. 12, the model's sense), so the
    swept angle is the largest twist at the quadrature nodes (phi is measured there), within 1 % of
    the twist's peak over the span; ``twist_max_deg`` is that peak, max |theta2(s)| q2 from the
    closed-form twist law (tests/test_validity_twist.py)."""
    d = _derivation(twist_ends=twist_ends, valid_deg=(-180, 180))
    q2 = 1e-4
    v = motion_validity(d, [[0.0, q2, 0.0, 0.0], [0.0, -q2, 0.0, 0.0]], 1.0)
    s = np.linspace(0.0, 1.0, 2001)
    closed = math.degrees(np.max(np.abs(_theta2(d, s))) * q2)
    assert v["twist_max_deg"] == pytest.approx(closed, rel=1e-6)        # the grid holds s = 1/2, where both peak
    assert v["twist_max_deg"] * (1 - 1e-2) <= v["phi_swept_deg"] <= v["twist_max_deg"] * (1 + 1e-12)


def test_rest_is_inside_and_sweeps_nothing():
    v = motion_validity(_derivation(valid_deg=(-90, 90)), np.zeros((3, 4)), 1.0)
    assert v["phi_swept_deg"] == 0.0 and v["twist_max_deg"] == 0.0
    assert v["beyond_valid_range"] is False


def test_cubic_load_error_falls_as_amplitude_cubed():
    """eq. (21)'s aerodynamic forces differ from the exact ones by O(a^4) while the forces are O(a):
    the relative error falls with order 3 (fitted between 2.6 and 3.4)."""
    d = _derivation(valid_deg=(-180, 180))
    rng = np.random.default_rng(5)
    Y = rng.normal(size=(30, 4)) * np.array([1.0, 0.3, 1.0, 0.3])
    amps = 1e-3 * 0.5 ** np.arange(4)
    errs = [motion_validity(d, a * Y, 1.2)["cubic_load_error"] for a in amps]
    order = np.polyfit(np.log(amps), np.log(errs), 1)[0]
    assert 2.6 < order < 3.4, (order, errs)


def test_vectorised_cubic_forces_equal_the_term_table():
    """`cubic_aero_forces` (vectorised) equals TwoModeODE.accelerations restricted to the aerodynamic
    terms, point by point."""
    d = _derivation(load="cubic")
    aero = dataclasses.replace(d.ode, terms=tuple(t for t in d.ode.terms if t.origin == "aerodynamic"))
    rng = np.random.default_rng(2)
    Y = rng.normal(size=(10, 4)) * 1e-3
    Ed = rng.normal(size=10) * 1e-4
    F1, F2 = cubic_aero_forces(d.ode, *Y.T, 1.3, Ed)
    for i in range(10):
        want = aero.accelerations(Y[i], 1.3, 1e-3, 0.0, Ed[i] / 1e-3, 0.0)
        assert np.allclose([F1[i], F2[i]], want, rtol=1e-12, atol=1e-300)


def test_the_flag_says_when_phi_leaves_the_valid_range():
    d_narrow = _derivation(valid_deg=(10.0, 20.0))
    d_wide = _derivation(valid_deg=(-170.0, 170.0))
    phi0 = math.degrees(d_narrow.ode.exact_load.static_angle)
    assert 10.0 < phi0 < 20.0
    states = [[1e-3, 3e-4, 0.0, 0.0], [-1e-3, -3e-4, 0.0, 0.0]]     # twist +-0.14 rad = +-8.2 deg
    narrow, wide = motion_validity(d_narrow, states, 1.0), motion_validity(d_wide, states, 1.0)
    assert narrow["beyond_valid_range"] and "valid range" in narrow["reasons"][0]
    assert not wide["beyond_valid_range"]
    assert narrow["phi_range_deg"][0] < 10.0 or narrow["phi_range_deg"][1] > 20.0


def test_simulate_json_reports_the_validity_beside_peak_m():
    cmd = [sys.executable, "-m", "autocable.cli", "simulate", str(SAMPLE), "--U", "1.2", "--max-time", "20000",
           "--json", "--quiet", "--load", "exact"]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout)
    for key in ("peak_m", "phi_swept_deg", "twist_max_deg", "beyond_valid_range"):
        assert key in out
    assert out["validity"]["load"] == "exact"
    # the sample's cycle at U* = 1.2: a twist of tens of degrees, and phi swept by about as much
    assert out["twist_max_deg"] > 10.0
    assert out["phi_swept_deg"] == pytest.approx(out["twist_max_deg"], rel=0.2)
