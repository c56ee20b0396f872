"""SI inputs on the step-by-step API: `EquilibriumProblem.from_si` and
`ShootingSolver(derivation).steady(wind_m_s=..., deck_amplitude_m=..., deck_frequency_Hz=...)`,
consistent with `frequency_response`'s keywords (eqs. 17-18: U* = U/U_c, eta* = eta/l,
sigma = 2 pi f/omega - omega1).

The conversions are checked against the cable's own numbers computed here (U_c from the spec, l,
and omega = (pi/l) sqrt(T/m) from the statics), not against `autocable.model.units`, which the code
uses; a continuation from the SI-built problem gives the nondimensional problem's branch; every bad
SI argument is refused naming it.
"""
import math

import numpy as np
import pytest

import autocable as ac
from autocable.model.premises import ArgumentError
from conftest import SAMPLE

#: A bridge engineer's 145 m stay case used 8 m/s, 20 mm and a frequency near the first one; here the sample
#: cable (l = 121.9 m, U_c = 36 m/s, f1 = 1.122 Hz).
WIND, DECK = 8.0, 0.02
#: How a refusal about the arguments together names them.
_ALL = "wind_m_s, deck_amplitude_m, deck_frequency_Hz"


@pytest.fixture(scope="module")
def eq21():
    return ac.derive(SAMPLE)


@pytest.fixture(scope="module")
def system(eq21):
    return ac.ame_system(ac.derive_ame(eq21).ame, "2dof", wind=True)


def _by_hand(eq21, f_hz: float) -> float:
    """sigma of a support motion at f [Hz]: 2 pi f / omega - omega1, omega from T-bar, m and l."""
    st, c = eq21.statics, eq21.spec.cable
    omega = math.pi / c.length_m * math.sqrt(st.T_bar / c.mass_per_length_kg_m)
    return 2 * math.pi * f_hz / omega - eq21.ode.omega1


def test_si_problem_equals_the_nondimensional_one(eq21, system):
    f0 = (eq21.ode.omega1 + 0.0) * eq21.statics.frequency_hz
    lo_hz, hi_hz = f0 - 0.02, f0 + 0.02
    p = ac.EquilibriumProblem.from_si(system, eq21, wind_m_s=WIND, deck_amplitude_m=DECK,
                                      deck_frequency_Hz=(lo_hz, hi_hz))
    U = WIND / eq21.spec.aero.critical_wind_speed_m_s
    eta = DECK / eq21.spec.cable.length_m
    lo, hi = _by_hand(eq21, lo_hz), _by_hand(eq21, hi_hz)
    star = ac.EquilibriumProblem(system, "sigma", {"U": U, "eta": eta, "sigma": lo}, (lo, hi))
    assert p.parameter == "sigma"
    assert p.bounds == pytest.approx(star.bounds, rel=1e-12, abs=1e-12)
    for k in ("U", "eta", "sigma"):
        assert p.values[k] == pytest.approx(star.values[k], rel=1e-12, abs=1e-15), k
    assert p.state_scale == pytest.approx(star.state_scale, rel=1e-12)
    # the nondimensional keywords are taken as they are, mixed with SI ones (one kind per quantity)
    mixed = ac.EquilibriumProblem.from_si(system, eq21, U=U, eta=eta, deck_frequency_Hz=(lo_hz, hi_hz))
    assert mixed.values["U"] == U and mixed.bounds == p.bounds
    # the continued parameter is the one given as a range: the wind here, in m/s
    pu = ac.EquilibriumProblem.from_si(system, str(SAMPLE), wind_m_s=(2.0, 10.0), deck_amplitude_m=DECK,
                                       deck_frequency_Hz=f0)
    assert pu.parameter == "U" and pu.bounds == pytest.approx((2 / 36, 10 / 36), rel=1e-12)
    assert pu.values["sigma"] == pytest.approx(0.0, abs=1e-12) and pu.values["U"] == pu.bounds[0]


def test_a_continuation_from_the_si_problem_gives_the_same_branch(eq21):
    """Fig. 6's setting in SI (no wind, a 10 mm deck motion near the first frequency): the AME at
    U = 0 (`ame_system(..., wind=False)`, as `frequency_response` takes it without wind)."""
    system = ac.ame_system(ac.derive_ame(eq21).ame, "2dof", wind=False)
    f0 = eq21.ode.omega1 * eq21.statics.frequency_hz
    p = ac.EquilibriumProblem.from_si(system, eq21, wind_m_s=0.0, deck_amplitude_m=0.01,
                                      deck_frequency_Hz=(f0 - 0.03, f0 + 0.03))
    lo, hi = _by_hand(eq21, f0 - 0.03), _by_hand(eq21, f0 + 0.03)
    star = ac.EquilibriumProblem(system, "sigma", {"U": 0.0, "eta": 0.01 / 121.9, "sigma": lo}, (lo, hi))
    settings = ac.ContinuationSettings(max_step=(hi - lo) / 5)
    a = ac.continue_equilibria(p, settings, name="I", engine="compiled").branch
    b = ac.continue_equilibria(star, settings, name="I", engine="compiled").branch
    assert len(a) == len(b) > 10
    for col in ("sigma", "a1", "a2"):
        np.testing.assert_allclose(a[col], b[col], rtol=1e-9, atol=1e-12, err_msg=col)
    assert [s.label for s in a.special_points] == [s.label for s in b.special_points]
    assert (a.stable == b.stable).all()


@pytest.mark.parametrize("kwargs, named, says", [
    (dict(wind_m_s=-8.0, deck_amplitude_m=DECK, deck_frequency_Hz=(1.1, 1.14)), "wind_m_s", "got -8.0"),
    (dict(wind_m_s=True, deck_amplitude_m=DECK, deck_frequency_Hz=(1.1, 1.14)), "wind_m_s", "got True"),
    (dict(wind_m_s=8.0, deck_amplitude_m=20.0, deck_frequency_Hz=(1.1, 1.14)), "deck_amplitude_m", "got 20.0"),
    (dict(wind_m_s=8.0, deck_amplitude_m=DECK, deck_frequency_Hz=(1.14, 1.1)), "deck_frequency_Hz", "lo < hi"),
    (dict(wind_m_s=8.0, deck_amplitude_m=DECK, deck_frequency_Hz=(0.1, 1.14)), "deck_frequency_Hz[0]", "got 0.1"),
    (dict(wind_m_s=8.0, deck_amplitude_m=DECK, deck_frequency_Hz=(1.1, "x")), "deck_frequency_Hz[1]", "got 'x'"),
    (dict(wind_m_s=8.0, deck_amplitude_m=DECK, deck_frequency_Hz=1.12), _ALL, "0 ranges"),
    (dict(wind_m_s=(5.0, 9.0), deck_amplitude_m=DECK, deck_frequency_Hz=(1.1, 1.14)), _ALL, "2 ranges"),
    (dict(U=0.2, wind_m_s=8.0, deck_amplitude_m=DECK, deck_frequency_Hz=(1.1, 1.14)), "wind_m_s", "twice"),
    (dict(wind_m_s=8.0, deck_frequency_Hz=(1.1, 1.14)), "eta", "deck_amplitude_m"),
])
def test_bad_si_arguments_are_refused_by_name(eq21, system, kwargs, named, says):
    with pytest.raises(ArgumentError) as err:
        ac.EquilibriumProblem.from_si(system, eq21, **kwargs)
    text = str(err.value)
    assert text.startswith(f"EquilibriumProblem.from_si: {named}") and says in text, text
    assert "\n" not in text


def test_si_needs_the_cable_and_an_ame(eq21, system):
    with pytest.raises(ArgumentError, match=r"from_si: cable: SI values need the cable"):
        ac.EquilibriumProblem.from_si(system, eq21.ode, wind_m_s=8.0, deck_amplitude_m=DECK,
                                      deck_frequency_Hz=(1.1, 1.14))
    with pytest.raises(ArgumentError, match=r"from_si: cable: expected a Derivation"):
        ac.EquilibriumProblem.from_si(system, 3, eta=1e-4, sigma=(0.0, 0.1))
    with pytest.raises(ArgumentError, match=r"from_si: system: expected a System"):
        ac.EquilibriumProblem.from_si("x", eq21, eta=1e-4, sigma=(0.0, 0.1))


def test_shooting_in_si_equals_shooting_nondimensional(eq21):
    """One steady response (U = 0, a 10 mm deck motion 0.01 above the first frequency in sigma): the
    solver built from the Derivation with SI keywords, and from its ode with U*, eta*, sigma."""
    f = (eq21.ode.omega1 + 0.01) * eq21.statics.frequency_hz
    si = ac.ShootingSolver(eq21).steady(wind_m_s=0.0, deck_amplitude_m=0.01, deck_frequency_Hz=f)
    star = ac.ShootingSolver(eq21.ode).steady(0.0, 0.01 / eq21.spec.cable.length_m, _by_hand(eq21, f))
    assert si.sigma == pytest.approx(0.01, abs=1e-13) and si.eta == pytest.approx(star.eta, rel=1e-13)
    assert si.response == star.response
    assert si.a1 == pytest.approx(star.a1, rel=1e-9) and si.a2 == pytest.approx(star.a2, rel=1e-9, abs=1e-15)
    with pytest.raises(ArgumentError, match=r"steady: wind_m_s: SI values need the cable"):
        ac.ShootingSolver(eq21.ode).steady(wind_m_s=1.0, eta=1e-4, sigma=0.0)
    with pytest.raises(ArgumentError, match=r"steady: sigma: missing: give sigma or deck_frequency_Hz"):
        ac.ShootingSolver(eq21).steady(U=0.0, deck_amplitude_m=0.01)
    with pytest.raises(ArgumentError, match=r"steady: deck_frequency_Hz: .* got 9.0"):
        ac.ShootingSolver(eq21).steady(U=0.0, eta=1e-4, deck_frequency_Hz=9.0)
