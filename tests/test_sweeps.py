"""Brute-force sweeps of eq. (21) and of the AME (the 'empty boxes' of Figs. 9-10)."""

import numpy as np
import pytest

from autocable.methods.integration.ame import AmeIntegrator
from autocable.methods.integration.ode21 import Ode21Integrator
from autocable.methods.integration.sweeps import sweep
from autocable.model.ame_cache import derive_ame
from conftest import SAMPLE

MODEL = SAMPLE


@pytest.mark.slow
def test_sweeps_show_the_hysteresis_of_fig7_settings_in_both_methods(derivation):
    """U = 0.7, eta = 4.1e-4 (Fig. 7): the continuation finds folds at sigma ~ 0.0024 and 0.019, so
    at sigma = 0.01 two stable responses coexist. Sweeping up keeps the large one, sweeping down the
    small one, in eq. (21) and in the AME alike; the two methods agree within the 2.6 % that the
    AME-vs-(21) study reports at this eta (docs/ame_vs_ode21.md)."""
    values = np.linspace(-0.01, 0.01, 5)
    fixed = {"U": 0.7, "eta": 4.1e-4}
    ode = sweep(Ode21Integrator(derivation.ode), "sigma", values, fixed)
    ame = sweep(AmeIntegrator(derive_ame(derivation).ame), "sigma", values, fixed)
    assert len(ode) == len(ame) == 10
    for pts in (ode, ame):
        assert all(p.steady and p.periodic for p in pts)
        up = {round(p.value, 6): p.a1 for p in pts if p.direction == "up"}
        down = {round(p.value, 6): p.a1 for p in pts if p.direction == "down"}
        assert up[0.01] > 5 * down[0.01]                 # two coexisting attractors
        assert up[-0.01] == pytest.approx(down[-0.01], rel=1e-6)   # one attractor far below
    for p, q in zip(ode, ame):
        assert (p.value, p.direction) == (q.value, q.direction)
        assert q.a1 == pytest.approx(p.a1, rel=0.03)


def test_sweep_rejects_bad_input(derivation):
    integ = Ode21Integrator(derivation.ode)
    with pytest.raises(ValueError, match="sweep parameter"):
        sweep(integ, "omega", [0.0], {})
    with pytest.raises(ValueError, match="unknown fixed"):
        sweep(integ, "sigma", [0.0], {"rho": 1.0})


def test_a_point_the_integrator_cannot_carry_is_kept_and_the_sweep_goes_on(derivation):
    """A `ComputationError` at one overlay point (e.g. eq. (21)'s step size collapsing while the
    response stays bounded, seen on a calibration candidate's Fig. 9) used to end the whole scene
    and lose its continuation results. Now the point is kept, with nan amplitudes, not steady, and
    the reason; the next point restarts from the default start, so it equals a fresh run there."""
    from autocable.errors import ComputationError

    class Failing(Ode21Integrator):
        def simulate(self, U, eta, sigma, *args, **kw):
            if abs(sigma) < 1e-12:
                raise ComputationError("the step size collapsed at t = 12 (integrating from t = 0 to 50)")
            return super().simulate(U, eta, sigma, *args, **kw)

    fixed = {"U": 0.0, "eta": 4.1e-4}
    pts = sweep(Failing(derivation.ode), "sigma", [-0.01, 0.0, 0.01], fixed, directions=("up",))
    assert [p.value for p in pts] == [-0.01, 0.0, 0.01]
    bad = pts[1]
    assert not bad.steady and not bad.periodic and np.isnan(bad.a1) and np.isnan(bad.a2)
    assert bad.message.startswith("integration failed: the step size collapsed at t = 12")
    fresh = sweep(Ode21Integrator(derivation.ode), "sigma", [0.01], fixed, directions=("up",))[0]
    assert pts[2].steady and pts[2].a1 == pytest.approx(fresh.a1, rel=1e-12)
