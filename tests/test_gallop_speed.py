"""The galloping study's cost cuts give its numbers unchanged, and its lowest galloping speed is
never the scan's lower bound read as a result.

* `DampedSystem` (one compiled system of eq. (21) with the damping ratio a run-time parameter)
  against `CycleContinuation`'s own build for that damping ratio: the same right-hand side and
  flow to round-off.
* `least_damping_global` by regula falsi (Illinois) against the bisection, the independent route:
  both brackets must hold the same root (every damping found to gallop below every damping found
  not to), so the two answers agree to the tolerance.
* A branch still descending where it ends (the 190 m stay on the paper's cubic fits with
  restrained twist: its unstable branch reaches the scan's lower bound U* = 0.02, 0.2 m/s) gives no
  lowest galloping speed but the bound "at most 0.2 m/s", in the study, its text, its plot and
  the pair table.
"""
from __future__ import annotations

import numpy as np
import pytest

from autocable.methods.integration.gallop import CycleContinuation
from autocable.model.derive import derive
from autocable.model.onset import U_MAX_DEFAULT, with_damping
from autocable.model.units import units_of
from autocable.studies.gallop import U_MIN, DampedSystem, _continuation, gallop_study, least_damping_global
from conftest import REPO

SAMPLE = REPO / "models" / "luongo_zulli_2012.toml"
STAY = REPO / "models" / "stay_190m.toml"


def test_damped_system_is_the_per_damping_build():
    """One compiled system for every damping ratio equals the build with xi as a number: the
    right-hand side of (y, Phi, s) to 1e-14 relative, the monodromy and U-sensitivity of a flow
    to 1e-11 (integration round-off), at three damping ratios; a different equation is not served."""
    d = derive(SAMPLE)
    shared = DampedSystem(d.ode)
    rng = np.random.default_rng(1)
    for xi in (d.ode.xi_s, 0.003, 0.02):
        ode = with_damping(d.ode, xi)
        own, on_shared = CycleContinuation(ode), _continuation(ode, shared)
        assert on_shared is not own and type(on_shared) is not CycleContinuation
        for _ in range(3):
            z = rng.normal(size=24) * 1e-3
            a, b = own.system().rhs(0.0, z, [1.3]), on_shared.system().rhs(0.0, z, [1.3])
            assert np.max(np.abs(a - b)) <= 1e-14 * np.max(np.abs(a))
        fa = own.flow([1e-3, 2e-3, 0.0, 1e-3], 6.0, 1.2)
        fb = on_shared.flow([1e-3, 2e-3, 0.0, 1e-3], 6.0, 1.2)
        assert np.max(np.abs(fa.M - fb.M)) <= 1e-11 * np.max(np.abs(fa.M))
        assert np.max(np.abs(fa.S - fb.S)) <= 1e-11 * np.max(np.abs(fa.S))
    other = derive(STAY)
    assert not shared.serves(other.ode)
    assert type(_continuation(other.ode, shared)) is CycleContinuation


def _bracket(result) -> tuple[float, float]:
    """(the largest damping found to gallop below the design wind, the least found not to)."""
    steps = result["steps"]
    gallop = [s["damping_ratio"] for s in steps if s["gallops_below_design_wind"]]
    calm = [s["damping_ratio"] for s in steps if not s["gallops_below_design_wind"]]
    return max(gallop), min(calm)


# the stay's comparison takes about 25 s (a dozen continuations on a 190 m stay): slow tier
@pytest.mark.parametrize("model, design", [(SAMPLE, 25.0),
                                           pytest.param(STAY, 25.0, marks=pytest.mark.slow)],
                         ids=["sample", "stay_190m"])
def test_illinois_equals_the_bisection(model, design):
    """The global least damping by regula falsi equals the bisection's to the tolerance (1e-3
    relative), and the two brackets hold a common root; the regula falsi takes fewer continuations."""
    d = derive(model)
    shared = DampedSystem(d.ode)
    fast = least_damping_global(d, design, shared=shared)
    slow = least_damping_global(d, design, shared=shared, method="bisection")
    assert fast["method"] == "illinois" and slow["method"] == "bisection"
    rtol = fast["relative_tolerance"]
    a, b = fast["least_damping_ratio_global"], slow["least_damping_ratio_global"]
    assert abs(a - b) <= rtol * max(a, b)
    lo_a, hi_a = _bracket(fast)
    lo_b, hi_b = _bracket(slow)
    assert max(lo_a, lo_b) < min(hi_a, hi_b)           # one root in both brackets
    assert hi_a - lo_a <= rtol * hi_a and a == hi_a
    assert len(fast["steps"]) < len(slow["steps"])


def test_lowest_speed_is_not_the_scans_bound(tmp_path):
    """The 190 m stay on the cubic fits (restrained twist): the branch from the Hopf point at
    10 m/s is unstable and still descending at the scan's lower bound U* = `U_MIN` (0.2 m/s =
    0.02 U_c), so its lowest galloping speed is not known: null, with the bound "at most 0.2 m/s"
    (its number U_MIN U_c) and the reason, in the study, its text and plot, and the pair table.
    Before the bound was reported, lowest_galloping_U_m_s read 0.2."""
    from autocable.cli.gallop import gallop_text
    from autocable.plotting.gallop import plot_gallop
    from autocable.studies.pairs_galloping import galloping_lines, pairs_with_galloping
    d = derive(STAY)
    units = units_of(d.spec, d.statics)
    bound = U_MIN * d.spec.aero.critical_wind_speed_m_s
    assert units.wind_m_s(U_MIN) == pytest.approx(bound, rel=1e-12)
    study = gallop_study(d, 25.0, checks=False)
    assert study["lowest_galloping_U_m_s"] is None
    assert study["lowest_galloping_U_at_most_m_s"] == pytest.approx(bound, rel=1e-9)
    assert study["lowest_galloping_U_bound"] == "at most 0.2 m/s"
    assert "lower bound 0.2 m/s" in study["lowest_galloping_note"]
    hp = study["cases"][0]["hopf_points"][0]
    assert hp["lowest_galloping_U_m_s"] is None and hp["lowest_U_reached_m_s"] == pytest.approx(bound, rel=1e-9)
    assert hp["hysteresis_m_s"][0] is None and hp["hysteresis_m_s"][1] == pytest.approx(10.0, rel=1e-6)
    text = "\n".join(gallop_text(study))
    assert "lowest galloping speed   not known: at most 0.2 m/s" in text
    assert "lowest galloping speed   0.2 m/s" not in text
    assert plot_gallop(study, tmp_path / "open_branch")
    # the pair table (first pair only: 0.60 / 0.59 Hz, the second at 1.18 Hz)
    report = pairs_with_galloping(d, 0.65, 25.0, U_MAX_DEFAULT)
    row = report["pairs"][0]
    assert row["lowest_galloping_U_m_s"] is None
    assert row["lowest_galloping_U_bound"] == "at most 0.2 m/s"
    lines = "\n".join(galloping_lines(report))
    assert "<= 0.2" in lines and "lower bound 0.2 m/s" in lines


def test_a_fold_still_gives_the_lowest_speed():
    """Where the branch turns (the sample's sub-critical onset at 36 m/s folds back), the lowest
    galloping speed is the fold's, a number below the onset, and no bound is reported."""
    d = derive(SAMPLE)
    study = gallop_study(d, 30.0, checks=False)
    low = study["lowest_galloping_U_m_s"]
    assert low is not None and low < 36.0
    assert study["lowest_galloping_U_bound"] is None and study["lowest_galloping_U_at_most_m_s"] is None
    hp = study["cases"][0]["hopf_points"][0]
    assert any(abs(f["U_m_s"] - low) < 1e-9 for f in hp["folds"])


def test_curves_variant_by_weights_equals_its_own_build():
    """The sensitivity's curves variants on the exact rung (band widened, blend halved) as new
    run-time weights of the nominal build (`DampedSystem.with_curves`) equal their own symbolic
    builds: the (y, Phi, s) right-hand side to 1e-13 relative at random states, and the case's
    lowest galloping speed and design-wind amplitude to 1e-9 / 1e-7 relative (Newton's and the
    amplitudes' own tolerances). A different equation or rung is refused (None)."""
    import math

    from autocable.cli.derivation import derivation
    from autocable.model.curves import curves_from_spec, with_band
    from autocable.studies.gallop import _case, _curves_variant
    d = derivation(REPO / "models" / "stay_190m.blended.toml", None, "exact")
    units = units_of(d.spec, d.statics)
    shared = DampedSystem(d.ode)
    curves = curves_from_spec(d.spec.aero)
    half = math.degrees(curves.valid_phi[1] - curves.valid_phi[0]) / 2
    rng = np.random.default_rng(3)
    for h, blend in ((half + 5.0, curves.blend_deg), (half, 0.5 * curves.blend_deg)):
        dv = _curves_variant(d, with_band(curves, h, blend_deg=blend))
        fast = shared.with_curves(dv.ode)
        assert fast is not None
        own = CycleContinuation(with_damping(dv.ode, 0.003))
        for _ in range(4):
            z = rng.normal(size=24) * 10.0 ** rng.uniform(-4.0, 0.0)
            a, b = own.system().rhs(0.0, z, [1.7]), fast.at(0.003).rhs(0.0, z, [1.7])
            assert np.max(np.abs(a - b)) <= 1e-13 * np.max(np.abs(a))
    # the last variant (the blend halved) continued both ways
    xi, U_des = d.ode.xi_s, units.wind_star(25.0)
    by_weights = _case(dv, dv.ode, xi, U_MAX_DEFAULT, units, U_des, None, fast)[0]
    by_build = _case(dv, dv.ode, xi, U_MAX_DEFAULT, units, U_des, None, None)[0]
    assert by_weights["lowest_galloping_U_m_s"] == pytest.approx(by_build["lowest_galloping_U_m_s"], rel=1e-9)
    assert by_weights["amplitude_at_design_wind_m"] == pytest.approx(by_build["amplitude_at_design_wind_m"], rel=1e-7)
    # refused: the cubic rung (no exact load) and another equation
    assert shared.with_curves(derive(STAY).ode) is None
    assert shared.with_curves(derivation(REPO / "models" / "meiko_nishi.blended.toml", None, "exact").ode) is None
