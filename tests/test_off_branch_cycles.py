"""A stable galloping cycle that no branch from a Hopf point reaches is found, checked against
direct integration, and followed down to its fold.

The case (found by checking the amplitude band of `onset --band --uc 8:12 --design-wind 25`):
the 190 m stay with blended curves on the exact load, eq. (12) reading, yaw -30 deg, U_c = 8 m/s,
the blend's width halved (5 deg). Its only branch from the Hopf point stays small and stable up to
the scan's top (0.49 m at 25 m/s), and the band printed 0.49 m as "the largest stable cycle";
eq. (21) integrated from a 2 m start settles on a stable 4.7 m cycle at 25 m/s, on no branch.

Independent routes: `Ode21Integrator` (the compiled plain integrator of eq. (21), not the
continuation's variational system) for the cycle's amplitude, and for its fold (on the large
cycle just above it, off it just below); the nominal curves' largest cycle (on a branch) is left
as it was.
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from autocable.methods.integration.ode21 import Ode21Integrator
from autocable.model.derive import derive
from autocable.model.onset import with_damping
from autocable.model.units import units_of
from autocable.spec import load_model
from autocable.studies import gallop as g
from autocable.studies.band import aero_of_case
from conftest import REPO

pytestmark = pytest.mark.slow

CASE = {"critical_wind_speed_m_s": 8.0, "angle_convention": "eq12", "yaw_deg": -30.0,
        "rivulet_angle_deg": None, "root": "fitted (smallest |angle|)"}


def _derive():
    spec = load_model(REPO / "models" / "stay_190m.blended.toml")
    return derive(replace(spec, aero=replace(aero_of_case(spec, CASE), load="exact")))


@pytest.fixture(scope="module")
def nominal():
    """The case with its curves as given: derivation, units, U_des (U*) and the compiled system
    every study of this module shares (`DampedSystem`; the halved blend by run-time weights, as
    the band's variants)."""
    d = _derive()
    units = units_of(d.spec, d.statics)
    return d, units, 25.0 / units.wind_m_s(1.0), g.DampedSystem(d.ode)


@pytest.fixture(scope="module")
def halved(nominal):
    """The blend's width halved (`gallop.sensitivity`'s "blend x0.5" variant), its case at 25 m/s."""
    from autocable.model.curves import curves_from_spec, with_band
    d0, units, U_des, shared = nominal
    curves = curves_from_spec(d0.spec.aero)
    half = math.degrees(curves.valid_phi[1] - curves.valid_phi[0]) / 2
    d = g._curves_variant(d0, with_band(curves, half, blend_deg=0.5 * curves.blend_deg))
    own = shared.with_curves(d.ode)
    assert own is not None
    case, branches, cont = g._case(d, d.ode, d.ode.xi_s, g.U_MAX_DEFAULT, units, U_des, None, own)
    return d, units, U_des, case, branches, cont, own


def _settled(d, U_star, q0, xi=None):
    ode = d.ode if xi is None else with_damping(d.ode, xi)
    r = Ode21Integrator(ode, engine="compiled").simulate(U_star, 0.0, 0.0, q0=tuple(q0), max_time=20000.0)
    return r


def test_the_cycle_off_the_branches_is_the_design_cycle_and_equals_direct_integration(halved):
    """The design cycle is the 4.71 m one (not the branch's 0.49 m), marked off the branches, and
    its peaks equal eq. (21) integrated from a 2 m in-plane start to 1e-6 relative."""
    d, units, U_des, case, branches, cont, own = halved
    off = case["off_branch_cycle"]
    small = off["largest_on_branches_peak_m"]
    assert 0.45 < small[0] < 0.55                                # the branch's cycle, as the band had it
    amp = case["amplitude_at_design_wind_m"]
    assert amp == off["peak_m"] and amp[0] > 4 * small[0]
    assert case["design_cycle"]["on_branch"] is False and case["design_cycle"]["stable"]
    a1_2m = 2.0 / units.peak_m(1.0)
    r = _settled(d, U_des, (a1_2m, 0.0, 0.0, 0.0))
    assert r.steady and r.periodic
    assert units.peak_m(r.a1) == pytest.approx(amp[0], rel=1e-6)
    assert units.peak_m(r.a2) == pytest.approx(amp[1], rel=1e-5)
    # and from rest the motion takes the branch's small cycle: the two coexist
    r0 = _settled(d, U_des, (0.0, 1e-6, 0.0, 0.0))
    assert units.peak_m(r0.a1) == pytest.approx(small[0], rel=1e-5)
    # the probes say where each start went
    probes = case["design_cycle"]["larger_cycle_search"]
    assert len(probes) == g.LARGER_START_FACTORS and probes[0]["start_factor"] == pytest.approx(g.LARGER_START_FIRST)
    assert any(p["peak_m"] and abs(p["peak_m"][0] - amp[0]) < 1e-6 * amp[0] for p in probes)


def test_the_fold_of_the_cycle_off_the_branches_by_direct_integration(halved):
    """`lowest_U_of` puts the large cycle's fold at U_f (1e-4 relative); below the Hopf point
    (8 m/s) the rest state is stable and the branch holds no stable cycle, so eq. (21) integrated
    from a large start settles on a galloping cycle (above 1 m) at 1.01 U_f and at 0.99 U_f decays
    towards rest (below 0.1 m and still falling exponentially at t* = 2e4, so close to the Hopf
    point). The case's lowest galloping speed is that fold."""
    d, units, U_des, case, branches, cont, own = halved
    off = case["off_branch_cycle"]
    U_f = off["lowest_U_star"]
    assert U_f is not None and off["lowest_U_m_s"] < 8.0
    assert case["lowest_galloping_U_m_s"] == pytest.approx(off["lowest_U_m_s"], rel=1e-12)
    big = off["peak_m"][0]
    start = (0.9 * big / units.peak_m(1.0), 0.0, 0.0, 0.0)
    above = _settled(d, 1.01 * U_f, start)
    assert above.steady and above.periodic and units.peak_m(above.a1) > 1.0
    below = _settled(d, 0.99 * U_f, start)
    assert units.peak_m(below.a1) < 0.1 and (below.steady or below.decay_rate > 0)


def test_nominal_curves_keep_their_branch_cycle(nominal):
    """With the blend as given the largest stable cycle at 25 m/s lies on the branch (5.27 m; the
    band's figure): every larger start settles back on it, nothing is off the branches."""
    d, units, U_des, shared = nominal
    case, _, _ = g._case(d, d.ode, d.ode.xi_s, g.U_MAX_DEFAULT, units, U_des, None, shared)
    assert "off_branch_cycle" not in case and case["design_cycle"]["on_branch"] is True
    assert case["amplitude_at_design_wind_m"][0] == pytest.approx(5.2733, rel=1e-4)
    for p in case["design_cycle"]["larger_cycle_search"]:
        assert p["landed"] == "cycle" and p["peak_m"][0] == pytest.approx(5.2733, rel=1e-4)


def test_least_damping_global_looks_for_an_isolated_cycle(halved):
    """`_isolated_below` asks whether any stable cycle gallops at 0.99 of the design wind at a
    damping ratio, from a cycle's state scaled up. At the model's damping (0.1 %) it finds one, and
    eq. (21) integrated from the same start lands on the same cycle (1e-5). At the global least
    damping of the branches (0.341 %) it finds none, and direct integration from the 4.7 m cycle's
    state there falls off it (the independent route)."""
    d, units, U_des, case, branches, cont, own = halved
    point = next(p for p in branches[0].points if p.kind != "H" and p.stable and p.orbit is not None and p.U < U_des)
    found = g._isolated_below(d, d.ode.xi_s, point, U_des, units, own)
    assert found is not None and found["U_m_s"] == pytest.approx(0.99 * 25.0, rel=1e-9)
    f = found["start_peak_m"] / units.peak_m(point.a1)
    same = _settled(d, 0.99 * U_des, f * np.asarray([point.state0[0], point.state0[2], point.state0[1],
                                                      point.state0[3]]))
    assert units.peak_m(same.a1) == pytest.approx(found["peak_m"][0], rel=1e-5)
    r = g.least_damping_global(d, 25.0, shared=own)
    assert r["at_least"] is False and r["isolated_cycle"] is None
    xi = r["least_damping_ratio_global"]
    assert 0.0033 < xi < 0.0035
    big = case["off_branch_cycle"]["peak_m"][0] / units.peak_m(1.0)
    there = _settled(d, 0.99 * U_des, (big, 0.0, 0.0, 0.0), xi=xi)
    assert not (math.isfinite(there.a1) and there.a1 > 0.5 * big)


def test_an_isolated_cycle_makes_the_global_least_damping_a_lower_bound(monkeypatch):
    """Where `_isolated_below` finds a stable cycle at 0.99 U_des (here put there, on the sample),
    `least_damping_global` keeps its number, flags it ``at_least`` and says AT LEAST; without one,
    the same number unflagged."""
    d = derive(REPO / "models" / "luongo_zulli_2012.toml")
    shared = g.DampedSystem(d.ode)
    plain = g.least_damping_global(d, 25.0, shared=shared)
    assert plain["at_least"] is False and "AT LEAST" not in plain["reading"]
    monkeypatch.setattr(g, "_isolated_below", lambda *a: {"U_m_s": 24.75, "peak_m": [4.7, 0.2], "start_peak_m": 5.0,
                                                          "damping_ratio": plain["least_damping_ratio_global"]})
    flagged = g.least_damping_global(d, 25.0, shared=shared)
    assert flagged["at_least"] is True and "AT LEAST" in flagged["reading"]
    assert flagged["least_damping_ratio_global"] == plain["least_damping_ratio_global"]


def test_the_190m_stay_has_a_second_stable_cycle_at_the_design_wind():
    """The shipped 190 m stay (blended curves, exact load, 0.1 %) at 25 m/s: besides the branch's
    2.085 / 0.424 m cycle, the largest start reaches a stable 1.848 / 1.519 m one off the branches,
    which eq. (21) integrated from the same start reaches too (1e-5); the envelope takes the larger
    of each plane. That cycle persists only down to about 23.8 m/s, above the branch's lowest
    galloping speed (8.506 m/s), which stands."""
    spec = load_model(REPO / "models" / "stay_190m.blended.toml")
    d = derive(replace(spec, aero=replace(spec.aero, load="exact")))
    units = units_of(d.spec, d.statics)
    U_des = 25.0 / units.wind_m_s(1.0)
    # the system `gallop_study` compiles for this stay (shared with its other tests through the cache)
    case, branches, cont = g._case(d, d.ode, d.ode.xi_s, g.U_MAX_DEFAULT, units, U_des, None, g.DampedSystem(d.ode))
    assert case["amplitude_at_design_wind_m"] == pytest.approx([2.0854, 0.4241], rel=1e-4)
    others = [o for o in case["other_stable_cycles"] if not o["on_branch"]]
    assert len(others) == 1
    o = others[0]
    assert o["peak_m"] == pytest.approx([1.848, 1.519], rel=1e-3)
    assert case["envelope_at_design_wind_m"] == pytest.approx([case["amplitude_at_design_wind_m"][0], o["peak_m"][1]])
    p = max((c for br in branches for c, _ in g._stable_cycles_at(cont, br, U_des)), key=lambda c: max(c.a1, c.a2))
    start = next(pr for pr in case["design_cycle"]["larger_cycle_search"]
                 if pr["peak_m"] and abs(pr["peak_m"][1] - o["peak_m"][1]) < 1e-6 * o["peak_m"][1])
    y = start["start_factor"] * p.state0
    r = _settled(d, U_des, (y[0], y[2], y[1], y[3]))
    assert r.steady and r.periodic
    assert [units.peak_m(r.a1), units.peak_m(r.a2)] == pytest.approx(o["peak_m"], rel=1e-5)
    assert 20.0 < o["lowest_U_m_s"] < 25.0
    assert case["lowest_galloping_U_m_s"] == pytest.approx(8.506, rel=1e-3)
