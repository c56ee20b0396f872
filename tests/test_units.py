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
