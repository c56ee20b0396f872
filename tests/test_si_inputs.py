"""SI inputs (m/s, m, Hz) beside the nondimensional U*, eta*, sigma of eqs. (17)-(18): the
conversions of `autocable.model.units`, `autocable simulate --wind/--deck-amplitude/--deck-frequency`
and `frequency_response(wind_m_s=..., deck_amplitude_m=..., deck_frequency_Hz=...)`.

What each test checks against: the conversions against their closed forms (U* = U/U_c,
eta* = eta/l, sigma = 2 pi f/omega - omega1 with omega = (pi/l) sqrt(T/m), eq. 17); the SI run
against the nondimensional run at the converted values (the same numbers, to 1e-12); the echo of
``--json`` against what was typed."""
from __future__ import annotations

import json
import math
import re

import numpy as np
import pytest

import autocable as ac
from autocable._paths import SAMPLE_MODEL
from autocable.cli import main
from autocable.model.premises import ArgumentError, parameter_from_si
from autocable.model.units import units_of

SAMPLE = str(SAMPLE_MODEL)


@pytest.fixture(scope="module")
def eq21():
    return ac.derive(SAMPLE)


def test_conversions_are_the_closed_forms(eq21):
    """U* = U/U_c, eta* = eta/l and sigma = 2 pi f/omega - omega1, with omega = (pi/l) sqrt(T/m)
    computed here from the model file's fields (eq. 17; T = H/cos(alpha) along the chord of a
    nearly taut cable), each the inverse of the SI column it feeds (1e-12)."""
    spec = eq21.spec
    c = spec.cable
    u = units_of(spec, eq21.statics)
    T = c.horizontal_tension_N / math.cos(math.radians(c.chord_slope_deg))
    omega = math.pi / c.length_m * math.sqrt(T / c.mass_per_length_kg_m)
    # the statics' omega is that of the chord tension (the taut string; sag changes it by < 1e-3)
    assert u.omega_rad_s == pytest.approx(omega, rel=1e-3)
    w1 = eq21.ode.omega1
    assert parameter_from_si("t", "U", 18.0, u, w1) == pytest.approx(18.0 / spec.aero.critical_wind_speed_m_s,
                                                                     rel=1e-12)
    assert parameter_from_si("t", "eta", 0.1, u, w1) == pytest.approx(0.1 / c.length_m, rel=1e-12)
    f = 1.1
    assert parameter_from_si("t", "sigma", f, u, w1) == pytest.approx(2 * math.pi * f / u.omega_rad_s - w1,
                                                                      abs=1e-12)
    for s in (-0.05, 0.0, 0.031):
        assert u.detuning(u.frequency_hz(w1 + s), w1) == pytest.approx(s, abs=1e-13)
    assert u.support_star(u.support_m(1.4e-3)) == pytest.approx(1.4e-3, rel=1e-14)
    assert u.wind_star(u.wind_m_s(0.7)) == pytest.approx(0.7, rel=1e-14)


def _simulate(capsys, *options) -> dict:
    code = main(["simulate", SAMPLE, "--max-time", "3000", "--quiet", "--json", *options])
    assert code == 0
    return json.loads(capsys.readouterr().out)


def test_simulate_si_equals_the_nondimensional_run(capsys, eq21):
    """--wind/--deck-amplitude/--deck-frequency give the run of --U/--eta/--sigma at the converted
    values (amplitudes to 1e-12), and --json echoes both kinds: the SI ones as typed (1e-12)."""
    f1 = units_of(eq21.spec, eq21.statics).frequency_hz(eq21.ode.omega1)
    f = round(f1 * 0.98, 4)                     # 2 % below the first in-plane frequency
    si = _simulate(capsys, "--wind", "18", "--deck-amplitude", "0.1", "--deck-frequency", repr(f))
    assert si["U_m_s"] == pytest.approx(18.0, rel=1e-12)
    assert si["eta_m"] == pytest.approx(0.1, rel=1e-12)
    assert si["Omega_Hz"] == pytest.approx(f, rel=1e-12)
    star = _simulate(capsys, "--U", repr(si["U"]), "--eta", repr(si["eta"]), "--sigma", repr(si["sigma"]))
    for key in ("U", "eta", "sigma", "Omega"):
        assert star[key] == si[key]
    for key in ("a1", "a2", "a1_max", "a2_max"):
        assert star[key] == pytest.approx(si[key], rel=1e-12, abs=1e-300)
    assert si["a1"] > 1e-4          # a response, not rest: the comparison can fail
    # the echo read back: U_m_s, eta_m, Omega_Hz of the nondimensional run are the typed SI values
    assert star["U_m_s"] == pytest.approx(18.0, rel=1e-12) and star["Omega_Hz"] == pytest.approx(f, rel=1e-12)


@pytest.mark.parametrize("options, named", [
    (("--U", "0.5", "--wind", "18"), ("--wind", "--U")),
    (("--eta", "1e-3", "--deck-amplitude", "0.1"), ("--deck-amplitude", "--eta")),
    (("--sigma", "0", "--deck-frequency", "1.1"), ("--deck-frequency", "--sigma")),
    (("--wind", "1e9",), ("--wind", "1e9")),
    (("--wind", "-1",), ("--wind", "-1")),
    (("--deck-amplitude", "100",), ("--deck-amplitude", "100")),
    (("--deck-frequency", "0",), ("--deck-frequency",)),
    (("--deck-frequency", "40",), ("--deck-frequency", "40")),
    (("--max-time", "1e9",), ("--max-time", "1e9")),
    (("--q0", "1e9", "0", "0", "0"), ("--q0", "1e9")),
])
def test_simulate_refuses_by_name(capsys, options, named):
    """Both kinds of one quantity, or an SI value outside eq. (21)'s premises: exit 2, one line
    naming the option(s) and the value as typed (``1e9``, not ``1000000000.0``)."""
    code = main(["simulate", SAMPLE, "--quiet", *options])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1
    assert all(n in err for n in named), err
    assert "1000000000.0" not in err


def test_negative_numbers_in_e_notation(capsys):
    """``--q0 -1e-3 ...`` is a start, not an unknown option."""
    out = _simulate(capsys, "--q0", "-1e-3", "0", "-2e-6", "0", "--max-time", "200")
    assert out["status"] in ("steady", "not_steady", "decaying")


def test_frequency_response_in_si_equals_the_nondimensional_one(eq21):
    """frequency_response(wind_m_s, deck_amplitude_m, deck_frequency_Hz=(lo, hi)) is the response at
    the converted U*, eta*, sigma range (branch tables to 1e-12); its DataFrame's Omega_Hz spans the
    given Hz range (1e-9)."""
    u = units_of(eq21.spec, eq21.statics)
    w1 = eq21.ode.omega1
    f1 = u.frequency_hz(w1)
    hz = (round(f1 * 0.97, 4), round(f1 * 1.03, 4))
    si = ac.frequency_response(eq21, wind_m_s=0.0, deck_amplitude_m=0.17, deck_frequency_Hz=hz, switch=False)
    sig = tuple(u.detuning(f, w1) for f in hz)
    star = ac.frequency_response(eq21, U=0.0, eta=0.17 / eq21.spec.cable.length_m, sigma=sig, switch=False)
    a, b = si.branch("I"), star.branch("I")
    assert len(a) == len(b) > 10
    for col in ("sigma", "a1", "a2"):
        np.testing.assert_allclose(a[col], b[col], rtol=1e-12, atol=1e-15)
    assert si.provenance["range"] == pytest.approx(list(sig), abs=1e-13)
    frame = si.to_dataframe()
    if "Omega_Hz" in frame:         # the SI columns, where the results carry the cable's scales
        assert frame["Omega_Hz"].min() == pytest.approx(hz[0], rel=1e-9)
        assert frame["Omega_Hz"].max() == pytest.approx(hz[1], rel=1e-9)


@pytest.mark.parametrize("kwargs, named", [
    ({"U": 0.1, "wind_m_s": 3.0, "eta": 1e-3}, "wind_m_s"),
    ({"eta": 1e-3, "deck_amplitude_m": 0.1}, "deck_amplitude_m"),
    ({"eta": 1e-3, "sigma": (-0.05, 0.05), "deck_frequency_Hz": (1.0, 1.2)}, "deck_frequency_Hz"),
    ({"deck_amplitude_m": 1e3}, "deck_amplitude_m"),
    ({"eta": 1e-3, "wind_m_s": 1e6}, "wind_m_s"),
    ({"eta": 1e-3, "deck_frequency_Hz": (1.2, 1.0)}, "deck_frequency_Hz"),
    ({"eta": 1e-3, "deck_frequency_Hz": (0.2, 1.0)}, "deck_frequency_Hz[0]"),
    ({"eta": 1e-3, "deck_frequency_Hz": 1.1}, "deck_frequency_Hz"),
])
def test_frequency_response_si_refusals(eq21, kwargs, named):
    """Both kinds of a quantity, an SI value outside the premises, a reversed or scalar Hz range:
    `ArgumentError` naming the keyword."""
    with pytest.raises(ArgumentError, match=f"frequency_response: {re.escape(named)}:"):
        ac.frequency_response(eq21, **kwargs)


def test_si_needs_the_cable(eq21):
    """eq. (21)'s ode alone has no length, U_c or omega: SI keywords refused, naming the fix."""
    with pytest.raises(ArgumentError, match="wind_m_s: .*Derivation"):
        ac.frequency_response(eq21.ode, wind_m_s=10.0, eta=1e-3)


def _scene(tmp_path, name, text):
    path = tmp_path / f"{name}.toml"
    path.write_text(f'model = "{SAMPLE}"\n' + text)
    return ac.load_scene(path)


def test_scene_in_si_is_the_scene_in_paper_units(tmp_path, eq21):
    """``units = "si"``: [fixed], a run's range and at, [overlay] range and [time] in m/s, m and Hz
    parse to the scene written in U*, eta*, sigma at the converted values (1e-12); [plot] draws SI."""
    u = units_of(eq21.spec, eq21.statics)
    w1, l, Uc = eq21.ode.omega1, eq21.spec.cable.length_m, eq21.spec.aero.critical_wind_speed_m_s
    hz = [u.frequency_hz(w1 + s) for s in (-0.05, 0.05, -0.01)]
    si = _scene(tmp_path, "si", f'units = "si"\n[fixed]\nU = {0.7 * Uc!r}\neta = {4.1e-4 * l!r}\n'
                                f'[[run]]\nname = "I"\nparameter = "sigma"\nrange = [{hz[0]!r}, {hz[1]!r}]\n'
                                f'at = {hz[2]!r}\n[overlay]\nrange = [{hz[0]!r}, {hz[1]!r}]\npoints = 3\n')
    star = _scene(tmp_path, "star", '[fixed]\nU = 0.7\neta = 4.1e-4\n[[run]]\nname = "I"\nparameter = "sigma"\n'
                                    'range = [-0.05, 0.05]\nat = -0.01\n[overlay]\nrange = [-0.05, 0.05]\npoints = 3\n')
    assert si.units == "si" and star.units == "paper"
    assert si.fixed["U"] == pytest.approx(0.7, rel=1e-12) and si.fixed["eta"] == pytest.approx(4.1e-4, rel=1e-12)
    assert si.runs[0].range == pytest.approx((-0.05, 0.05), abs=1e-12)
    assert si.runs[0].at == pytest.approx(-0.01, abs=1e-12)
    assert si.overlay.range == pytest.approx((-0.05, 0.05), abs=1e-12)
    assert si.plot.units == "si" and star.plot.units == "paper"
    t = _scene(tmp_path, "time", f'units = "si"\n[time]\nU = {1.3 * Uc!r}\neta = {1.4e-3 * l!r}\n'
                                 f'sigma = {u.frequency_hz(w1 - 0.042)!r}\nt_end = 1000.0\n')
    assert (t.time.U, t.time.eta, t.time.sigma) == pytest.approx((1.3, 1.4e-3, -0.042), rel=1e-12)


@pytest.mark.parametrize("text, field", [
    ('units = "si"\n[fixed]\neta = 100.0\n[[run]]\nparameter = "sigma"\nrange = [1.0, 1.2]\n', "fixed.eta"),
    ('units = "si"\n[fixed]\neta = 0.1\n[[run]]\nparameter = "sigma"\nrange = [0.1, 1.2]\n', r"run\[0\].range\[0\]"),
    ('units = "si"\n[fixed]\neta = 0.1\n[[run]]\nparameter = "sigma"\nrange = [1.0, 1.2]\nat = -3.0\n',
     r"run\[0\].at"),
    ('units = "metric"\n[[run]]\nparameter = "sigma"\nrange = [1.0, 1.2]\n', "units"),
])
def test_scene_in_si_refusals(tmp_path, text, field):
    """An SI value outside eq. (21)'s premises (or an unknown ``units``): one line naming the field."""
    from autocable.spec import SpecError
    with pytest.raises(SpecError, match=rf"bad\.toml: {field}: "):
        _scene(tmp_path, "bad", text)


def test_a_narrow_frequency_range_is_continued(eq21):
    """A deck frequency range of 5 mHz (sigma span 0.0045, below the default first step 0.005):
    the default settings shrink the first step with the range instead of refusing it; the branch
    covers the range (1e-9)."""
    u = units_of(eq21.spec, eq21.statics)
    f1 = u.frequency_hz(eq21.ode.omega1)
    hz = (round(f1, 3), round(f1, 3) + 0.005)
    res = ac.frequency_response(eq21, deck_amplitude_m=0.01, deck_frequency_Hz=hz, switch=False)
    sigma = res.branch("I")["sigma"]
    lo, hi = (u.detuning(f, eq21.ode.omega1) for f in hz)
    assert hi - lo < 0.005
    assert sigma.min() == pytest.approx(lo, abs=1e-9) and sigma.max() == pytest.approx(hi, abs=1e-9)
