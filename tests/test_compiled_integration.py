"""The compiled DOP853 integrator (autocable/codegen/cintegrate.py) and the engines built on it:
`Ode21Integrator(engine="compiled")` (eq. 21 overlays), `Ode21Integrator.envelope` and
`ame_time_series` (Fig. 11). Checked against closed forms, against its own convergence order and
against PyDSTool's Dopri (Hairer's dop853.c) on eq. (21)."""
from __future__ import annotations

import math

import numpy as np
import pytest
import sympy as sp

from autocable.codegen.cintegrate import Repeated, compiled_integrator, sample_grid
from autocable.codegen.ckernel import KernelBuildError

X, V, W, Z, T = sp.symbols("x v w z t")


@pytest.fixture(scope="module")
def oscillator():
    """x'' + 2 z w x' + w^2 x = sin(t)."""
    return compiled_integrator("test_oscillator", ("x", "v"), ("w", "z"),
                               (V, -W**2 * X - 2 * Z * W * V + sp.sin(T)))


def forced_undamped(t, w):
    """x'' + w^2 x = sin t, x(0) = 1, x'(0) = 0."""
    return np.cos(w * t) + (np.sin(t) - np.sin(w * t) / w) / (w**2 - 1)


@pytest.fixture(scope="module")
def eq21():
    from autocable.methods.integration.ode21 import Ode21Integrator
    from autocable.model.derive import derive
    from pathlib import Path
    d = derive(Path(__file__).parent.parent / "models" / "luongo_zulli_2012.toml")
    return d, Ode21Integrator(d.ode, "dopri"), Ode21Integrator(d.ode, "compiled")


@pytest.fixture(scope="module")
def eq21_legacy(legacy_derivation):
    """The legacy-sense sample (conftest.legacy_sample), which diverges at Fig. 10's carets."""
    from autocable.methods.integration.ode21 import Ode21Integrator
    d = legacy_derivation
    return d, Ode21Integrator(d.ode, "dopri"), Ode21Integrator(d.ode, "compiled")


# -- the integrator itself ---------------------------------------------------------------------------
def test_closed_form_forced_oscillator_at_every_sample(oscillator):
    """Adaptive steps at rtol 1e-10 and dense output between them: the forced undamped response
    equals its closed form at 500 sample times to 1e-8 (measured 8e-10)."""
    g = sample_grid(0.0, 50.0, 0.1)
    r = oscillator.run([1.0, 0.0], g, [1.3, 0.0], rtol=1e-10, atol=1e-13)
    assert r.ok and len(r.t) == 501 and r.t[-1] == 50.0
    assert np.max(np.abs(r.y[:, 0] - forced_undamped(g, 1.3))) < 1e-8


def test_closed_form_damped_steady_amplitude(oscillator):
    """Damped: after the transient (z w t >> 1) the amplitude is 1 / sqrt((w^2-1)^2 + (2 z w)^2)
    to 1e-8 relative, measured as the half peak-to-peak of dense samples (parabolic peaks)."""
    from autocable.methods.integration.ode21 import half_range
    w, z = 1.3, 0.05
    g = sample_grid(0.0, 600.0, 2 * math.pi / 512)
    r = oscillator.run([0.0, 0.0], g, [w, z], rtol=1e-11, atol=1e-14)
    last = r.y[-513:, 0]                                  # the last forcing period (2 pi)
    exact = 1.0 / math.hypot(w**2 - 1, 2 * z * w)
    assert half_range(last) == pytest.approx(exact, rel=1e-8)


def test_observed_order_is_eight(oscillator):
    """Fixed steps (tolerances so loose that every step of max_step is accepted): the error at
    t = 8 falls as h^8 (observed orders 8.0 +- 0.5), at the step ends and from the dense output
    at the step midpoints."""
    errs, errs_mid = [], []
    for h in (0.8, 0.4, 0.2):
        n = int(round(8.0 / h))
        ends = np.arange(n + 1) * h
        mids = np.concatenate([[0.0], (np.arange(n) + 0.5) * h])
        r = oscillator.run([1.0, 0.0], ends, [1.3, 0.0], rtol=1e6, atol=1e6, max_step=h, first_step=h)
        rm = oscillator.run([1.0, 0.0], mids, [1.3, 0.0], rtol=1e6, atol=1e6, max_step=h, first_step=h)
        assert r.accepted == n and r.rejected == 0
        errs.append(abs(r.y[-1, 0] - forced_undamped(8.0, 1.3)))
        errs_mid.append(np.max(np.abs(rm.y[1:, 0] - forced_undamped(mids[1:], 1.3))))
    for e in (errs, errs_mid):
        orders = [math.log2(e[i] / e[i + 1]) for i in range(2)]
        assert all(7.5 < p < 8.5 for p in orders), (e, orders)


def test_error_follows_the_tolerance(oscillator):
    """Tolerance proportionality: 100x tighter rtol gives 30x to 300x smaller global error."""
    g = sample_grid(0.0, 50.0, 0.1)
    err = []
    for rtol in (1e-7, 1e-9, 1e-11):
        r = oscillator.run([1.0, 0.0], g, [1.3, 0.0], rtol=rtol, atol=rtol * 1e-3)
        err.append(np.max(np.abs(r.y[:, 0] - forced_undamped(g, 1.3))))
    for a, b in zip(err, err[1:]):
        assert 30 < a / b < 300, err


def test_stops_bound_and_budget(oscillator):
    """The stops a blow-up needs: a bound on the first components, a budget of accepted steps."""
    g = sample_grid(0.0, 50.0, 0.1)
    r = oscillator.run([1.0, 0.0], g, [1.3, 0.0], rtol=1e-10, atol=1e-13, bound=1.5, n_bound=1)
    fine = np.linspace(0.0, 50.0, 500001)
    first = fine[np.argmax(np.abs(forced_undamped(fine, 1.3)) > 1.5)]
    # Checked after each accepted step (here about 0.3 long): it stops on the step that crosses.
    assert r.status == "bound" and abs(r.y_reached[0]) > 1.5
    assert first <= r.t_reached < first + 1.0 and r.t[-1] <= r.t_reached
    assert np.max(np.abs(r.y[:, 0] - forced_undamped(r.t, 1.3))) < 1e-8
    r = oscillator.run([1.0, 0.0], g, [1.3, 0.0], rtol=1e-10, atol=1e-13, max_steps=5)
    assert r.status == "step_budget" and r.accepted == 5 and not r.ok


def test_repeated_runs_equal_run_bit_for_bit(oscillator):
    """`Repeated` (checks and buffers once, for Newton loops) calls the same C function: its samples
    equal `run`'s exactly, from several starts and tolerances in turn; a stopped run is None."""
    g = np.array([0.0, 3.0, 7.5, 12.0])
    rep = Repeated(oscillator, g, [1.3, 0.05], max_step=1.0, bound=5.0, n_bound=1)
    for y0, rtol in (([1.0, 0.0], 1e-8), ([0.2, -0.4], 1e-11), ([1.0, 0.0], 1e-6)):
        got = rep(y0, rtol, rtol * 1e-3).copy()
        ref = oscillator.run(y0, g, [1.3, 0.05], rtol=rtol, atol=rtol * 1e-3, max_step=1.0, bound=5.0,
                             n_bound=1)
        assert ref.ok and np.array_equal(got, ref.y)
    assert rep([6.0, 0.0], 1e-8, 1e-11) is None             # starts beyond the bound: stopped
    with pytest.raises(ValueError, match="tolerances must be positive"):
        rep([1.0, 0.0], 0.0, 1e-12)
    with pytest.raises(ValueError, match="takes 2 states"):
        rep([1.0, 0.0, 0.0], 1e-8, 1e-11)
    with pytest.raises(ValueError, match="increasing"):
        Repeated(oscillator, [0.0, 0.0], [1.3, 0.05])
    with pytest.raises(ValueError, match="2 parameters"):
        Repeated(oscillator, g, [1.3])


def test_bad_input_is_one_line():
    with pytest.raises(KernelBuildError, match="undeclared symbols") as exc:
        compiled_integrator("bad", ("x",), (), (X * sp.Symbol("k"),))
    assert "\n" not in str(exc.value)


# -- eq. (21): the compiled engine against PyDSTool's Dopri ------------------------------------------
@pytest.mark.parametrize("U, eta, sigma", [(0.0, 4.1e-4, 0.01),     # Fig. 5a: mono-modal
                                           (0.0, 1.4e-3, 0.0)])     # Fig. 6: bi-modal
def test_compiled_equals_dopri_on_steady_amplitudes(eq21, U, eta, sigma):
    """Same start, same chunks, same sampling: the steady amplitudes agree to 1e-8 relative to a1
    (measured 4e-10 and 7e-12), both steady and period-1 after the same time."""
    _, dopri, compiled = eq21
    a, b = dopri.simulate(U, eta, sigma), compiled.simulate(U, eta, sigma)
    assert a.steady and b.steady and a.periodic and b.periodic and a.t_end == b.t_end
    assert b.a1 == pytest.approx(a.a1, rel=1e-8)
    assert abs(b.a2 - a.a2) <= 1e-8 * a.a1
    assert abs(b.a2_max - a.a2_max) <= 1e-8 * a.a1


def test_both_engines_report_the_divergence(eq21_legacy):
    """U = 1.3, sigma = 0.03 (Fig. 10's carets with the legacy sense): both diverge; the compiled
    engine stops at |q| > 0.1 within the same or an earlier chunk instead of spending the step budget."""
    _, dopri, compiled = eq21_legacy
    a, b = dopri.simulate(1.3, 1.4e-3, 0.03), compiled.simulate(1.3, 1.4e-3, 0.03)
    assert math.isinf(a.a1) and math.isinf(b.a1) and not a.steady and not b.steady
    assert "diverged" in a.message and "|q_k| > 0.1" in b.message
    assert b.t_end <= a.t_end + 100 * 2 * math.pi / a.Omega


def test_run_samples_equal_dopri(eq21):
    """`run` on the same grid: samples within 1e-9 of the response size (q1 ~ 1e-2)."""
    from autocable.model.symbolic import parameter_values
    _, dopri, compiled = eq21
    pars = parameter_values(1.3, 1.4e-3, dopri.ode.omega1 - 0.03)
    ta, ya = dopri.run((0.0, 1e-6, 0.0, 0.0), 0.0, 300.0, 0.05, pars)
    tb, yb = compiled.run((0.0, 1e-6, 0.0, 0.0), 0.0, 300.0, 0.05, pars)
    assert np.array_equal(ta, tb)
    assert np.max(np.abs(ya - yb)) <= 1e-9 * np.max(np.abs(ya[:, :2]))


def test_envelope_equals_per_period_loop(eq21):
    """`Ode21Integrator.envelope` (vectorised) equals the per-period half ranges of `run`'s samples,
    and the dopri and compiled envelopes agree to 1e-8 relative."""
    from autocable.methods.integration.ode21 import half_range
    from autocable.model.symbolic import parameter_values
    _, dopri, compiled = eq21
    U, eta, sigma = 1.3, 1.4e-3, -0.042
    te, e1, e2, msg = compiled.envelope(U, eta, sigma, (0.0, 1e-6, 0.0, 0.0), 600.0)
    td, d1, d2, _ = dopri.envelope(U, eta, sigma, (0.0, 1e-6, 0.0, 0.0), 600.0)
    assert msg == "bounded over [0, t_end]" and np.array_equal(te, td)
    assert np.max(np.abs(e1 - d1)) <= 1e-8 * np.max(d1) and np.max(np.abs(e2 - d2)) <= 1e-8 * np.max(d1)
    Om = compiled.ode.omega1 + sigma
    period = 2 * math.pi / Om
    tt, ys = compiled.run((0.0, 1e-6, 0.0, 0.0), 0.0, len(te) * period, period / 64,
                          parameter_values(U, eta, Om))
    loop = [half_range(ys[k * 64:(k + 1) * 64 + 1, 0]) for k in range(len(te))]
    assert np.allclose(e1, loop, rtol=1e-9, atol=0)


def test_envelope_reports_divergence(eq21_legacy):
    _, _, compiled = eq21_legacy
    t, a1, a2, msg = compiled.envelope(1.3, 1.4e-3, 0.03, (0.0, 1e-6, 0.0, 0.0), 5000.0)
    assert msg.startswith("eq. (21) diverges at t = ") and len(t) == len(a1) and len(t) > 0
    assert np.all(a1 < 0.1) and t[-1] < 5000.0


def test_envelope_keeps_what_it_had_when_the_integrator_fails_at_a_bounded_state(eq21, monkeypatch):
    """An integrator failure at moderate velocities (injected: the second chunk stops half-way with
    the step size collapsing) raises without ``keep_failed``; with it (Fig. 11's scene), the
    envelope ends at the last whole period before the failure, equal to the uninjected envelope
    there, and the message says it could not be integrated (not that it diverged)."""
    import dataclasses

    from autocable.errors import ComputationError
    _, _, compiled = eq21
    args = (1.3, 1.4e-3, -0.042, (0.0, 1e-6, 0.0, 0.0), 600.0)
    t0, a0, _, _ = compiled.envelope(*args, chunk_periods=20)
    real, calls = compiled.run_compiled, []

    def failing(*a, **k):
        r = real(*a, **k)
        calls.append(1)
        if len(calls) != 2:
            return r
        half = len(r.t) // 2
        return dataclasses.replace(r, t=r.t[:half], y=r.y[:half], status="step_too_small",
                                   t_reached=float(r.t[half - 1]), y_reached=r.y[half - 1])
    monkeypatch.setattr(compiled, "run_compiled", failing)
    with pytest.raises(ComputationError, match="could not be integrated"):
        compiled.envelope(*args, chunk_periods=20)
    calls.clear()
    t, a1, _, msg = compiled.envelope(*args, chunk_periods=20, keep_failed=True)
    assert msg.startswith("eq. (21) could not be integrated") and "velocities" not in msg
    assert 20 < len(t) < 40 and np.array_equal(t, t0[:len(t)]) and np.array_equal(a1, a0[:len(t)])


# -- Fig. 11: the AME time series ---------------------------------------------------------------------
@pytest.mark.slow
def test_fig11_ame_series_statistics(eq21):
    """Fig. 11: the AME (24) at eta = 1.4e-3, sigma = -0.042, U = 1.3 from rest (q2 = 1e-6) over
    60000 time units, 6 samples per forcing period, integrated twice at rtol = 1e-10: by autocable's
    compiled DOP853 (`ame_time_series`, what the scene uses) and by PyDSTool's Dopri (a separate
    code generator and integrator) on the same sample times. The statistics over t >= 40000 (the
    extrema of a1, a2 and the modulation period) are properties of the AME's attracting periodic
    orbit, so the phase drift along it (~3e-9 in the state at t = 60000) barely enters them: they
    agree to within 10 rtol (measured 2e-10)."""
    from autocable.codegen import compat, pydstool
    from autocable.methods.integration.ame import ame_time_series
    from autocable.methods.continuation import ame_system
    from autocable.model.ame_cache import derive_ame
    from autocable.scene.time_scene import _summary
    d, _, _ = eq21
    ame = derive_ame(d).ame
    system = ame_system(ame, "2dof", wind=True)
    values = {"U": 1.3, "eta": 1.4e-3, "sigma": -0.042}
    y0, rtol = [0.0, 0.0, 1e-6, 0.0], 1e-10
    Om = float(ame.omegas[0]) - 0.042
    dt = 2 * math.pi / Om / 6
    tt, ys = ame_time_series(system, values, y0, 60000.0, dt, rtol=rtol, atol=1e-16)
    s = _summary(tt, np.hypot(ys[:, 0], ys[:, 1]), np.hypot(ys[:, 2], ys[:, 3]), 40000.0)

    compat.import_pydstool()
    pars = tuple(zip(system.parameter_names, map(float, system.parameter_vector(values))))
    vf = pydstool.VectorField("fig11_ame", tuple(system.variables), tuple(system.rhs), pars)
    gen = pydstool.make_ode_generator(vf, "Dopri", algparams={"rtol": rtol, "atol": 1e-16})
    t2, y2 = pydstool.integrate(gen, y0, None, 0.0, 60000.0, dt)
    np.testing.assert_array_equal(t2, tt)
    s2 = _summary(t2, np.hypot(y2[:, 0], y2[:, 1]), np.hypot(y2[:, 2], y2[:, 3]), 40000.0)
    assert s["samples"] == s2["samples"] == 18373
    for key in ("a1_min", "a1_max", "a2_min", "a2_max", "modulation_period"):
        assert s2[key] == pytest.approx(s[key], rel=10 * rtol), key
    # The values (regression pins; tests/test_scene_figures.py::test_fig11_time_evolution pins the
    # scene's to the same digits).
    # (the "mirrored" sample; the legacy sense gave 2.1401e-3, 5.3423e-3, 2.8625e-3, 3.6053e-3, 35.968)
    assert s["a1_min"] == pytest.approx(2.8566e-3, rel=1e-4)
    assert s["a1_max"] == pytest.approx(5.1474e-3, rel=1e-4)
    assert s["a2_min"] == pytest.approx(3.4121e-3, rel=1e-4)
    assert s["a2_max"] == pytest.approx(3.8345e-3, rel=1e-4)
    assert s["modulation_period"] == pytest.approx(20.069, rel=1e-4)


# -- AmeIntegrator: the same LSODA run on a compiled f and J ------------------------------------------
@pytest.fixture(scope="module")
def ame(eq21):
    from autocable.model.ame_cache import derive_ame
    return derive_ame(eq21[0]).ame


@pytest.mark.parametrize("U", [0.0, 1.3])
def test_compiled_cartesian_equals_numpy_rows(ame, U):
    """f and J of the Cartesian AME (24) in C equal the numpy rows to 1e-14 relative, with and
    without wind (at U = 0 the aerodynamic rows and their 1/U powers are absent in both)."""
    from autocable.methods.integration.ame import compiled_cartesian
    rhs = ame.cartesian_rhs()
    ci, extend = compiled_cartesian(rhs)
    p = ame.control(eta=1.4e-3, U=U, sigma=-0.03)
    rng = np.random.default_rng(5)
    for _ in range(5):
        y = rng.normal(size=4) * 5e-3
        f0, J0 = rhs.f(y, p), rhs.jacobian(y, p)
        assert np.max(np.abs(ci.rhs(0.0, y, extend(p)) - f0)) <= 1e-14 * np.max(np.abs(f0))
        assert np.max(np.abs(ci.jac(0.0, y, extend(p)) - J0)) <= 1e-14 * np.max(np.abs(J0))


def test_ame_integrator_compiled_same_equilibrium(ame):
    """Fig. 6 point (U = 0, eta = 1.4e-3, sigma = 0): the compiled and numpy right-hand sides reach
    the same stable equilibrium at the same time, a1 equal to 1e-12 relative."""
    from autocable.methods.integration.ame import AmeIntegrator
    a = AmeIntegrator(ame, compiled=False).simulate(0.0, 1.4e-3, 0.0)
    b = AmeIntegrator(ame).simulate(0.0, 1.4e-3, 0.0)
    assert a.periodic and b.periodic and a.t_end == b.t_end
    assert b.a1 == pytest.approx(a.a1, rel=1e-12) and b.a1 == pytest.approx(0.0120687, rel=1e-5)


def test_ame_integrator_compiled_dop853_equals_scipy_dop853(ame):
    """method="DOP853": each chunk in one call of the compiled DOP853 instead of scipy's Python
    DOP853 (the same method): the same stable equilibrium at the Fig. 6 point, a1 to 1e-12."""
    from autocable.methods.integration.ame import AmeIntegrator
    a = AmeIntegrator(ame, method="DOP853", compiled=False).simulate(0.0, 1.4e-3, 0.0)
    b = AmeIntegrator(ame, method="DOP853").simulate(0.0, 1.4e-3, 0.0)
    assert a.periodic and b.periodic and a.t_end == b.t_end
    assert b.a1 == pytest.approx(a.a1, rel=1e-12)


def test_ame_integrator_compiled_dop853_reports_divergence(ame):
    """A blow-up of the AME (eta = 1e-2, U = 1.3: far outside the validity) stops at the bound
    max |y| > blowup, a divergence as with scipy's terminal event."""
    from autocable.methods.integration.ame import AmeIntegrator
    r = AmeIntegrator(ame, method="DOP853").simulate(1.3, 1e-2, 0.03, max_time=5000.0, blowup=0.05)
    assert math.isinf(r.a1) and "diverged" in r.message and r.t_end < 5000.0


@pytest.mark.parametrize("engine", ["dopri", "compiled"])
def test_max_time_off_the_sample_grid_is_not_steady(eq21, engine):
    """A max_time that is not on the sample grid leaves less than one sample interval after the
    last chunk: that remainder must end the run ("not steady"), not pass for a chunk whose
    amplitudes did not change (which reported a still-growing response as steady)."""
    from autocable.methods.integration.ode21 import Ode21Integrator
    r = Ode21Integrator(eq21[0].ode, engine).simulate(0.7, 1.4e-3, 0.01, max_time=1000.0)
    dt = 2 * math.pi / r.Omega / 64
    assert not r.steady and r.message.startswith("not steady") and 1000.0 - dt < r.t_end <= 1000.0


# -- growth against failure: a finite-time blow-up of the velocities at bounded q ---------------------
X1, X2, V1, V2, C = sp.symbols("x1 x2 v1 v2 c")


@pytest.fixture(scope="module")
def cubic_velocity():
    """x1'' = c x1'^3 (x2 at rest): v1 = v0 / sqrt(1 - 2 c v0^2 t) blows up at t* = 1 / (2 c v0^2)
    while x1 = (1 - sqrt(1 - 2 c v0^2 t)) / (c v0) stays below 1 / (c v0)."""
    return compiled_integrator("test_cubic_velocity", ("x1", "x2", "v1", "v2"), ("c",),
                               (V1, V2, C * V1**3, sp.Integer(0)))


def test_a_velocity_blow_up_at_bounded_q_is_growth_not_failure(cubic_velocity):
    from autocable.methods.integration.ode21 import DIVERGED, VELOCITY_DIVERGED, _stopped, grew
    v0, c = 0.1, 1000.0
    t_star, x_star = 1 / (2 * c * v0**2), 1 / (c * v0)
    assert x_star < DIVERGED                       # the modal coordinate never reaches the bound
    r = cubic_velocity.run([0.0, 0.0, v0, 0.0], sample_grid(0.0, 1.0, 0.01), [c], rtol=1e-10, atol=1e-14,
                           bound=DIVERGED, n_bound=2)
    assert not r.ok and r.status != "bound"
    # it stops at the closed form's blow-up time (to 1e-6 relative), at x1 just below 1 / (c v0)
    assert abs(r.t_reached / t_star - 1) < 1e-6 and abs(r.y_reached[0]) < x_star
    assert abs(r.y_reached[2]) > VELOCITY_DIVERGED and grew(r)
    assert "the velocities blow up in finite time" in _stopped(r, 0.0, 1.0)
    # the same law with the sign turned decays: it runs to the end
    ok = cubic_velocity.run([0.0, 0.0, v0, 0.0], sample_grid(0.0, 1.0, 0.01), [-c], rtol=1e-10, atol=1e-14,
                            bound=DIVERGED, n_bound=2)
    assert ok.ok and not grew(ok)
    # a spent step budget at moderate velocities is a numerical failure, not growth
    short = cubic_velocity.run([0.0, 0.0, v0, 0.0], sample_grid(0.0, 1.0, 0.01), [-c], rtol=1e-10, atol=1e-14,
                               bound=DIVERGED, n_bound=2, max_steps=3)
    assert short.status == "step_budget" and not grew(short)


def test_a_candidate_whose_velocities_blow_up_diverges_in_the_envelope_and_the_overlay():
    """A calibration candidate (natural twist, reference axes, literal sense, beta = 0, Theta0 =
    60.999 deg) at Fig. 11's point: eq. (21)'s velocities blow up at t of about 30 with |q_k| below
    0.1. The envelope reports a divergence (it used to fail the scene) and the steady-response
    integration a diverged response (it used to raise). The time is a regression pin."""
    from pathlib import Path

    from autocable.methods.integration.ode21 import Ode21Integrator
    from autocable.model.derive import derive
    from autocable.paper import calibration as cal
    from autocable.spec import load_model
    spec = load_model(Path(__file__).parent.parent / "models" / "luongo_zulli_2012.toml")
    r = cal.Readings("natural", "reference", "eq12", "diameter", 1.25)
    d = derive(cal.candidate_spec(spec, r, 0.0, 60.999161043529476))
    ode = Ode21Integrator(d.ode, engine="compiled")
    t, a1, a2, message = ode.envelope(1.3, 1.4e-3, -0.042, (0.0, 1e-6, 0.0, 0.0), 200.0)
    assert message.startswith("eq. (21) diverges at t = 30.3") and "blow up in finite time" in message
    assert len(t) and np.all(np.isfinite(a1)) and t[-1] < 30.3
    resp = ode.simulate(1.3, 1.4e-3, -0.042, (0.0, 0.0, 1e-6, 0.0), max_time=200.0)
    assert math.isinf(resp.a1) and "blow up in finite time" in resp.message
