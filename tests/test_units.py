"""SI conversions of eqs. (17)-(18) (`autocable.model.units`) against closed forms and a time history."""
import math

import numpy as np
import pytest

from autocable.model.modes import linear_modes
from autocable.model.units import units_of


def test_frequency_of_the_taut_string_in_hz(derivation):
    """omega2 = 1 is the taut string's fundamental: f = (1 / 2l) sqrt(T/m) in SI, computed here from
    the spec alone."""
    spec, st = derivation.spec, derivation.statics
    u = units_of(spec, st)
    c = spec.cable
    T = c.horizontal_tension_N / math.cos(math.radians(c.chord_slope_deg))
    f_string = math.sqrt(T / c.mass_per_length_kg_m) / (2 * c.length_m)
    assert u.frequency_hz(derivation.ode.omega2) == pytest.approx(f_string, rel=1e-12)
    # eq. (17): a time of one nondimensional period 2 pi is one period of the string in seconds
    assert u.time_s(2 * math.pi) == pytest.approx(1 / f_string, rel=1e-12)


def test_wind_support_and_scruton_closed_forms(derivation):
    u = units_of(derivation.spec, derivation.statics)
    assert u.wind_m_s(1.3) == pytest.approx(1.3 * 36.0, rel=1e-15)
    assert u.wind_star(u.wind_m_s(0.77)) == pytest.approx(0.77, rel=1e-15)
    # docs/model.md C3: eta* = 1.4e-3 is 0.171 m of support motion on the 121.9 m sample
    assert u.support_m(1.4e-3) == pytest.approx(0.17066, abs=1e-5)
    # Sc = m xi / (rho_a D^2) = 51.8 * 0.004 / (1.25 * 0.119^2)
    assert u.scruton(0.004) == pytest.approx(51.8 * 0.004 / (1.25 * 0.119 ** 2), rel=1e-14)
    assert u.damping_for_scruton(u.scruton(0.0123)) == pytest.approx(0.0123, rel=1e-14)
    # d(a l)^2 / dU = l^2 d(a^2)/dU* / U_c
    assert u.peak_squared_slope(2e-4) == pytest.approx(2e-4 * 121.9 ** 2 / 36.0, rel=1e-14)


def test_modes_peak_at_mid_span_with_unit_maximum(derivation):
    """The station of `peak_m`: both retained modes reach their maximum |value| 1 at s = 1/2."""
    modes = linear_modes(derivation.statics, derivation.spec.cable.twist_ends)
    s = np.linspace(0.0, 1.0, 20001)
    for name in ("phi1", "phi2"):
        phi = np.abs(modes.shapes[name].evaluate(s))
        assert s[np.argmax(phi)] == pytest.approx(0.5, abs=1e-4)
        assert phi.max() == pytest.approx(1.0, abs=1e-12)


def test_a1_l_is_the_peak_displacement_of_the_time_history(derivation):
    """A forced response of eq. (21) (Fig. 5a's setting): the displacement field l phi1(s) q1(t)
    rebuilt from the history, its peak over the span and over the last forcing periods, equals
    units.peak_m(a1) = a1 l."""
    from autocable.methods.integration.ode21 import Ode21Integrator
    ode = derivation.ode
    u = units_of(derivation.spec, derivation.statics)
    r = Ode21Integrator(ode, engine="compiled").simulate(0.0, 8.2e-5, 0.01, keep_history=True,
                                                        samples_per_period=256)
    assert r.steady
    t, q1 = r.history[0], r.history[1]
    period = 2 * math.pi / r.Omega
    last = t >= t[-1] - 20 * period
    modes = linear_modes(derivation.statics, derivation.spec.cable.twist_ends)
    s = np.linspace(0.0, 1.0, 401)
    v = u.length_m * np.outer(q1[last], modes.shapes["phi1"].evaluate(s))     # v(t, s) [m]
    peak_to_peak = v.max(axis=0) - v.min(axis=0)
    station = s[np.argmax(peak_to_peak)]
    assert station == pytest.approx(0.5, abs=1e-9)
    # sampled peaks (256 per period) against a_k's parabola-refined ones: within 1e-4 relative
    assert 0.5 * peak_to_peak.max() == pytest.approx(u.peak_m(r.a1), rel=1e-4)


def test_simulate_json_carries_si(capsys, derivation):
    """`simulate --json`: U_m_s, eta_m, Omega_Hz and peak_m, each against the closed form from the spec
    (T = H / cos(alpha), omega = (pi/l) sqrt(T/m))."""
    import json
    from autocable.cli import main
    from conftest import SAMPLE
    assert main(["simulate", str(SAMPLE), "--U", "0.7", "--eta", "4.1e-4", "--sigma", "0.01", "--json",
                 "--method", "ame"]) == 0
    out = json.loads(capsys.readouterr().out)
    c = derivation.spec.cable
    T = c.horizontal_tension_N / math.cos(math.radians(c.chord_slope_deg))
    omega = math.pi / c.length_m * math.sqrt(T / c.mass_per_length_kg_m)
    assert out["U_m_s"] == pytest.approx(0.7 * 36.0, rel=1e-14)
    assert out["eta_m"] == pytest.approx(4.1e-4 * 121.9, rel=1e-14)
    assert out["Omega_Hz"] == pytest.approx((derivation.ode.omega1 + 0.01) * omega / (2 * math.pi), rel=1e-12)
    assert out["peak_m"] == pytest.approx([out["a1"] * 121.9, out["a2"] * 121.9], rel=1e-14)
    assert "mid-span" in out["peak_station"]


def test_branch_tables_carry_si_columns(tmp_path, derivation):
    import csv
    from dataclasses import asdict
    from autocable.results import Branch, RunResults, SpecialPoint, write_results
    n = 3
    table = {"sigma": np.array([-0.01, 0.0, 0.01]), "U": np.full(n, 0.5), "eta": np.full(n, 1e-4),
             "a1": np.array([1e-3, 2e-3, 3e-3]), "a2": np.zeros(n),
             "r1": np.zeros(n), "s1": np.zeros(n), "r2": np.zeros(n), "s2": np.zeros(n)}
    sp = SpecialPoint(branch="I", type="LP", label="LP1", parameter="sigma", value=0.0, a1=2e-3, a2=0.0,
                      state=(0.0,) * 4, parameters={"sigma": 0.0, "U": 0.5, "eta": 1e-4}, index=1)
    b = Branch(name="I", kind="equilibrium", parameter="sigma", parameter_names=("sigma", "U", "eta"),
               variables=("r1", "s1", "r2", "s2"), amplitude_names=("a1", "a2"), table=table,
               stable=np.ones(n, bool), eigenvalues=np.zeros((n, 0), complex), special_points=(sp,))
    u = units_of(derivation.spec, derivation.statics)
    prov = {"si_scales": asdict(u), "omega1": derivation.ode.omega1}
    write_results(RunResults("t", (b,), prov), tmp_path)
    rows = list(csv.DictReader(open(tmp_path / "branches.csv")))
    for i, r in enumerate(rows):
        assert float(r["U_m_s"]) == pytest.approx(0.5 * 36.0, rel=1e-14)
        assert float(r["eta_m"]) == pytest.approx(1e-4 * 121.9, rel=1e-14)
        assert float(r["Omega_Hz"]) == pytest.approx(
            (derivation.ode.omega1 + table["sigma"][i]) * derivation.statics.omega_ref / (2 * math.pi), rel=1e-14)
        assert float(r["peak_in_plane_m"]) == pytest.approx(table["a1"][i] * 121.9, rel=1e-14)
    sp_row = next(csv.DictReader(open(tmp_path / "special_points.csv")))
    assert float(sp_row["peak_in_plane_m"]) == pytest.approx(2e-3 * 121.9, rel=1e-14)
    assert float(sp_row["U_m_s"]) == pytest.approx(18.0, rel=1e-14)
    # without the scales (an older run's provenance) the tables are as before
    write_results(RunResults("t", (b,), {}), tmp_path / "old")
    assert "U_m_s" not in open(tmp_path / "old" / "branches.csv").readline()


def test_sweep_axes_in_si(derivation):
    from types import SimpleNamespace
    from autocable.studies.sweep import _si_coordinates
    spec = SimpleNamespace(U=[0.0, 1.3], eta=[8.2e-5], sigma=[-0.02, 0.02])
    c = _si_coordinates(spec, derivation.spec)
    assert c["U_m_s"][0] == "U" and c["U_m_s"][2]["units"] == "m s-1"
    assert np.allclose(c["U_m_s"][1], [0.0, 46.8], rtol=1e-14)
    assert np.allclose(c["eta_m"][1], [8.2e-5 * 121.9], rtol=1e-14)
    assert np.allclose(c["Omega_Hz"][1], (derivation.ode.omega1 + np.array([-0.02, 0.02]))
                       * derivation.statics.omega_ref / (2 * math.pi), rtol=1e-14)
    assert c["Omega_Hz"][2]["units"] == "Hz"
