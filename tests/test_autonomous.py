"""Autonomous responses of eq. (21) (eta* = 0: no forcing): a self-excited galloping cycle is
periodic with its own period, by transient integration (`ode21`, judged on its own cycles), by
autonomous shooting (`autonomous.newton_cycle`: phase condition, the period an unknown, the
trivial Floquet multiplier excluded) and in sweeps (`studies.sweep.compute_point`); the generic
shooting against the closed form of the van der Pol oscillator."""
import math

import numpy as np
import pytest
import sympy as sp

from autocable.methods.integration.autonomous import newton_cycle, split_multipliers
from autocable.methods.integration.ode21 import Ode21Integrator, is_autonomous
from autocable.methods.integration.shooting import RESPONSE_CLASSES, ShootingSolver
from autocable.model.symbolic import ETA, T, first_order_rhs


# -- the generic autonomous shooting: van der Pol, x'' - mu (1 - x^2) x' + x = 0 ----------------------

def _vdp(mu):
    from scipy.integrate import solve_ivp

    def F(y):
        return np.array([y[1], mu * (1 - y[0] ** 2) * y[1] - y[0]])

    def J(y):
        return np.array([[0.0, 1.0], [-2 * mu * y[0] * y[1] - 1.0, mu * (1 - y[0] ** 2)]])

    def flow(y, Tp):
        def f(t, z):
            return np.concatenate([F(z[:2]), (J(z[:2]) @ z[2:].reshape(2, 2)).ravel()])
        s = solve_ivp(f, (0, Tp), np.concatenate([y, np.eye(2).ravel()]), method="DOP853", rtol=1e-12,
                      atol=1e-14)
        return (s.y[:2, -1], s.y[2:, -1].reshape(2, 2)) if s.success else None
    return F, flow


@pytest.mark.parametrize("mu", [0.05, 0.1])
def test_van_der_pol_cycle_by_autonomous_shooting(mu):
    """Closed forms of the van der Pol cycle for small mu (Poincare-Lindstedt): amplitude 2 + O(mu^2),
    period 2 pi (1 + mu^2 / 16 - 5 mu^4 / 3072 + ...), so |T / 2 pi - 1 - mu^2/16| < mu^4 / 100
    (the next term is 1.6e-3 mu^4); the non-trivial multiplier exp(int_0^T div F dt) (Liouville,
    the trivial one being 1) = exp(-2 pi mu) + O(mu^2) on x = 2 cos t; the trivial multiplier is 1 to
    the flow's accuracy. Started off the cycle (x = 1.5, period 6) on the section x' = 0."""
    F, flow = _vdp(mu)
    c = newton_cycle(flow, F, [1.5, 0.0], 6.0, section=1)
    assert c.converged and c.residual < 1e-10
    amp = abs(c.state0[0])                    # on the section x' = 0: an extreme of x
    assert abs(amp - 2.0) < mu ** 2
    assert abs(c.period / (2 * math.pi) - 1 - mu ** 2 / 16) < mu ** 4 / 100
    trivial, others, check = split_multipliers(c.monodromy, F(c.state0))
    assert abs(trivial - 1) < 1e-8 and check < 1e-8
    assert len(others) == 1 and abs(others[0].imag) < 1e-12
    assert abs(others[0].real - math.exp(-2 * math.pi * mu)) < 2 * mu ** 2
    # Liouville exactly: the product of the multipliers is exp(int_0^T mu (1 - x^2) dt)
    assert abs(np.linalg.det(c.monodromy) - others[0].real * trivial.real) < 1e-8


# -- eq. (21) -----------------------------------------------------------------------------------------

def test_eq21_is_autonomous_exactly_at_eta_zero(stay190):
    """`is_autonomous` is what the right-hand side says: without eta* it has no t, with it, it has."""
    rhs = first_order_rhs(stay190.ode)
    assert all(T not in sp.expand(e.subs(ETA, 0)).free_symbols for e in rhs)
    assert any(T in e.free_symbols for e in rhs)
    assert is_autonomous(0.0) and not is_autonomous(1e-6)


@pytest.fixture(scope="module")
def gallop(stay190):
    """The galloping cycle of the 190 m stay at U* = 1.2, eta* = 0, by transient integration and by
    shooting from the same default start (rest with the q2 seed)."""
    solver = ShootingSolver(stay190.ode)
    return (Ode21Integrator(stay190.ode, engine="compiled").simulate(1.2, 0.0, 0.0),
            solver.steady(1.2, 0.0, 0.0), solver)


def test_galloping_cycle_is_periodic_by_integration(gallop):
    """Transient integration calls the cycle steady and periodic on its own period (the forcing
    period 2 pi / omega1 is not its period: the judge must not be the forcing's), with a stated
    error far below the amplitude."""
    q, _, _ = gallop
    assert q.steady and q.periodic and q.autonomous, q.message
    assert q.a1 > 1e-3 and q.a2 > 0
    assert abs(q.period - 2 * math.pi / q.Omega) > 1e-3 * q.period     # not the forcing's period
    assert 0 < q.a1_error < 1e-6 * q.a1 and 0 < q.a2_error < 1e-6 * q.a1


def test_galloping_cycle_by_autonomous_shooting_equals_integration(gallop):
    """Shooting classes it autonomous-periodic, stable by the non-trivial multipliers with the
    trivial one 1 to 1e-7; amplitude and period equal the transient's within the sum of both stated
    errors (period: the spread of the transient's cycle periods is below 1e-7 of it)."""
    q, r, _ = gallop
    assert r.response == "autonomous-periodic" and r.periodic and r.steady, r.message
    assert abs(r.trivial_multiplier - 1) < 1e-7
    assert len(r.multipliers) == 3 and r.max_modulus < 1
    assert abs(r.a1 - q.a1) <= r.a1_error + q.a1_error
    assert abs(r.a2 - q.a2) <= r.a2_error + q.a2_error
    assert abs(r.period - q.period) < 1e-7 * r.period


def test_galloping_cycle_in_a_sweep(stay190, gallop):
    """A sweep point at eta* = 0 above U_c comes out autonomous-periodic by both eq. (21) methods
    (it was quasi-periodic), with the shooting's amplitude; its code is the last, the others keep
    theirs."""
    from autocable.methods.integration.ode21 import DEFAULT_Q0
    from autocable.studies import sweep as sw
    q, r, _ = gallop
    assert sw.RESPONSE_CLASSES == RESPONSE_CLASSES and RESPONSE_CLASSES[:5] == (
        "rest", "period-1", "period-2", "quasi-periodic", "diverged")
    for method in ("shooting", "ode21"):
        rec = sw.compute_point(stay190.spec, method, 1.2, 0.0, 0.0, DEFAULT_Q0, 60000.0)
        assert rec["response"] == "autonomous-periodic", (method, rec["message"])
        # the same computation as `gallop` by the same method: its stated error bounds the difference
        err = r.a1_error if method == "shooting" else q.a1_error
        assert abs(rec["a1"] - r.a1) <= err + r.a1_error
        assert len(rec["multipliers"]) == 3 and max(math.hypot(*m) for m in rec["multipliers"]) < 1


def _hopf(ode):
    """(U*, frequency) where the rest state of eq. (21) at eta* = 0 first loses stability: the
    eigenvalues of its Jacobian (lambdified from the same right-hand side), bisected in U* on the
    sign of the largest real part."""
    from autocable.model.symbolic import PARAMETERS, STATE, parameter_values
    rhs = sp.Matrix(first_order_rhs(ode))
    A = rhs.jacobian(sp.Matrix(STATE)).subs({s: 0 for s in STATE}).subs(ETA, 0)
    jac = sp.lambdify((STATE, PARAMETERS), A, "numpy")

    def eig(U):
        p = parameter_values(U, 0.0, ode.omega1)
        return np.linalg.eigvals(np.asarray(jac((0,) * 4, tuple(p[s.name] for s in PARAMETERS)), float))

    lo, hi = 0.5, 1.5
    assert max(eig(lo).real) < 0 < max(eig(hi).real)
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if max(eig(mid).real) < 0 else (lo, mid)
    ev = eig(hi)
    return hi, abs(ev[np.argmax(ev.real)].imag)


def test_cycle_period_tends_to_the_hopf_period(gallop, stay190):
    """Near the onset U_H the cycle's period is 2 pi / omega_H (the Hopf frequency of the rest state's
    linearisation) plus c1 eps + c2 eps^2, eps = U / U_H - 1 (the eigenvalue's drift and the
    amplitude-frequency term, a^2 ~ eps). So at eps = 0.04, 0.02, 0.01 the deviation halves with eps
    (ratios in [1.7, 2.3]), the linear extrapolation to eps = 0 from each pair misses 2 pi / omega_H
    by O(eps^2), a quarter as much for the smaller pair (ratio in [3, 5.5]), and below 1e-5 of the
    period for (0.02, 0.01); super-critical: a1^2 / eps tends to a constant (the two differences of
    successive values shrink). The starts: the U* = 1.2 cycle scaled by sqrt(eps / 0.2)."""
    _, r0, solver = gallop
    UH, wH = _hopf(stay190.ode)
    TH = 2 * math.pi / wH
    periods, slopes = [], []
    for eps in (0.04, 0.02, 0.01):
        U = UH * (1 + eps)
        y = np.asarray(r0.state0) * math.sqrt(eps / (1.2 / UH - 1))
        r = solver.steady(U, 0.0, 0.0, (y[0], y[2], y[1], y[3]), guess=y)
        assert r.response == "autonomous-periodic", r.message
        periods.append(r.period)
        slopes.append(r.a1 ** 2 / eps)
    d = [p - TH for p in periods]
    assert 1.7 < d[0] / d[1] < 2.3 and 1.7 < d[1] / d[2] < 2.3
    e1, e2 = 2 * periods[1] - periods[0] - TH, 2 * periods[2] - periods[1] - TH
    assert 3 < e1 / e2 < 5.5 and abs(e2) < 1e-5 * TH
    assert abs(slopes[2] - slopes[1]) < abs(slopes[1] - slopes[0]) and abs(slopes[2] / slopes[0] - 1) < 0.05


def test_sample_cable_at_eta_zero_three_methods_agree(derivation):
    """The sample cable at U* = 1.2, eta* = 0: shooting, transient integration and the sweep's
    ode21 point give the same class; a cycle (if the reading gallops super-critically in eq. (21))
    with the same amplitude within the stated errors, or a divergence by all three. Which of the two
    depends on readings the calibration searches (angle sense), so only their agreement is asserted."""
    from autocable.methods.integration.ode21 import DEFAULT_Q0
    from autocable.studies import sweep as sw
    solver = ShootingSolver(derivation.ode)
    q = solver.integrator.simulate(1.2, 0.0, 0.0)
    r = solver.steady(1.2, 0.0, 0.0)
    rec = sw.compute_point(derivation.spec, "ode21", 1.2, 0.0, 0.0, DEFAULT_Q0, 60000.0)
    if r.response == "diverged":
        assert not math.isfinite(q.a1) and rec["response"] == "diverged"
    else:
        assert r.response == "autonomous-periodic" and q.periodic and q.autonomous
        assert rec["response"] == "autonomous-periodic"
        assert abs(r.a1 - q.a1) <= r.a1_error + q.a1_error


def test_near_onset_shooting_finishes_what_integration_cannot(gallop):
    """At U* = 1.05 the cycle is approached so slowly from rest that integration is not steady at
    t = 60000 (still 1 % short); shooting ends on the cycle by autonomous shooting from where the
    transient stopped, and integration started on that cycle is steady, periodic and equal to it
    within the stated errors (an independent check of the shot cycle)."""
    _, _, solver = gallop
    r = solver.steady(1.05, 0.0, 0.0)
    assert r.response == "autonomous-periodic", r.message
    y = r.state0
    q = solver.integrator.simulate(1.05, 0.0, 0.0, (y[0], y[2], y[1], y[3]))
    assert q.steady and q.periodic and q.autonomous, q.message
    assert abs(r.a1 - q.a1) <= r.a1_error + q.a1_error
    assert abs(r.period - q.period) < 1e-7 * r.period


def test_eta_zero_row_of_a_sweep_is_periodic(tmp_path, stay190):
    """`autocable sweep` over U* = 0.9, 1.1, 1.2 at eta* = 0 (the row of a chart above U_c): rest
    below the onset, autonomous-periodic above it (was quasi-periodic), in sweep.nc with its legend,
    and the chart reads them as such (AME galloping predicts it)."""
    pytest.importorskip("xarray")
    import xarray as xr
    from conftest import STAY190
    from autocable.plotting.chart import AME_TO_MAP, read_response_map
    from autocable.scene.sweep_schema import load_sweep
    from autocable.studies.sweep import run_sweep
    (tmp_path / "stay190.toml").write_text(STAY190)
    (tmp_path / "s.toml").write_text('model = "stay190.toml"\nmethod = "shooting"\n[grid]\n'
                                     'U = [0.9, 1.1, 1.2]\neta = [0.0]\nsigma = [0.0]\n')
    run_sweep(load_sweep(tmp_path / "s.toml"), tmp_path / "out", workers=0)
    with xr.open_dataset(tmp_path / "out" / "sweep.nc", engine="scipy") as ds:
        legend = dict(zip(ds["response"].attrs["flag_values"].tolist(), ds["response"].attrs["flag_meanings"].split()))
        codes = ds["response"].values.ravel().tolist()
        assert [legend[c] for c in codes] == ["rest", "autonomous_periodic", "autonomous_periodic"]
        assert np.all(ds["a1"].values.ravel()[1:] > 1e-3)
    m = read_response_map(tmp_path / "out" / "sweep.nc", "U", "eta", {"sigma": 0.0})
    assert m["response"] == ["rest", "autonomous-periodic", "autonomous-periodic"]
    assert "autonomous-periodic" in AME_TO_MAP["galloping"]


def test_own_cycles_measure_a_closed_form_cycle():
    """`cycles.own_cycles` on q1 = A sin(w t), q2 = B cos(w t) (q2's extremes exactly at q1's zero
    crossings, the cycle's phase drifting against the sample grid as a galloping cycle's does):
    the period 2 pi / w and both amplitudes to the fourth-order Hermite accuracy h^4 / 384 of the
    amplitude (with the half-sampling estimate of `orbit_amplitudes` below that), the section
    states repeating."""
    from autocable.methods.integration.cycles import orbit_amplitudes, own_cycles
    A, B, w = 5.7e-3, 6.8e-4, 1.0289528
    h = 2 * math.pi / 1.0178 / 128
    t = np.arange(0, 20 * 2 * math.pi / 1.0178, h) + 0.3
    ys = np.column_stack([A * np.sin(w * t), B * np.cos(w * t), A * w * np.cos(w * t), -B * w * np.sin(w * t)])
    c = own_cycles(t, ys)
    bound = (h * w) ** 4 / 384
    assert c.coordinate == 0 and c.count >= 19
    assert abs(c.period - 2 * math.pi / w) < 1e-9
    assert abs(c.amplitudes[0] - A) < bound * A and abs(c.amplitudes[1] - B) < bound * B
    assert c.section_change < 1e-5
    T = 2 * math.pi / w
    tt = np.linspace(0, T, 257)
    one = np.column_stack([A * np.sin(w * tt), B * np.cos(w * tt), A * w * np.cos(w * tt), -B * w * np.sin(w * tt)])
    amps, errs = orbit_amplitudes(tt, one)
    assert abs(amps[0] - A) <= max(errs[0], 1e-15) * 2 and abs(amps[1] - B) <= max(errs[1], 1e-15) * 2


def test_own_cycles_find_the_period_of_a_doubly_crossing_coordinate():
    """q1 = A sin(2 w t) driven by q2 = B sin(w t) (an out-of-plane cycle with its quadratic in-plane
    response, A > B so q1 bounds the cycles): q1 crosses zero upwards twice a period, and the period
    is 2 pi / w, not half of it (the section states repeat every second crossing only)."""
    from autocable.methods.integration.cycles import own_cycles
    A, B, w = 6e-3, 4e-3, 1.0289528
    h = 2 * math.pi / 1.0178 / 256
    t = np.arange(0, 20 * 2 * math.pi / 1.0178, h)
    ys = np.column_stack([A * np.sin(2 * w * t), B * np.sin(w * t), 2 * w * A * np.cos(2 * w * t),
                          w * B * np.cos(w * t)])
    c = own_cycles(t, ys)
    assert c.coordinate == 0
    assert abs(c.period - 2 * math.pi / w) < 1e-8 and c.section_change < 1e-5
    assert abs(c.amplitudes[0] - A) < 1e-7 * A and abs(c.amplitudes[1] - B) < 1e-7 * B


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_cycle_extremes_of_all_cycles_at_once_equal_those_of_each_cycle_alone(seed):
    """The one-pass extremes of every cycle (`cycle_extremes`) are exactly (bit for bit) those of
    each cycle taken alone (`hermite_extremes`), on uneven samples of a modulated two-frequency
    signal, with cycle bounds between samples and on a sample; and on a coarsely sampled sine
    (h = 0.5) the Hermite-refined extremes are +-1 to the interpolant's h^4 error, where the
    samples alone miss by up to 1 - cos(h/2) = 0.03."""
    from autocable.methods.integration.cycles import cycle_extremes, hermite_crossings, hermite_extremes
    rng = np.random.default_rng(seed)
    t = np.cumsum(rng.uniform(0.05, 0.25, 4000))
    x = np.sin(t) * (1 + 0.3 * np.sin(0.05 * t)) + 0.2 * np.sin(2.7 * t)
    xd = np.cos(t) * (1 + 0.3 * np.sin(0.05 * t)) + 0.015 * np.sin(t) * np.cos(0.05 * t) + 0.54 * np.cos(2.7 * t)
    c = hermite_crossings(t, x, xd)
    c[3] = t[np.searchsorted(t, c[3])]                  # a bound exactly on a sample
    hi, lo = cycle_extremes(t, x, xd, c)
    want = [hermite_extremes(t, x, xd, a, b) for a, b in zip(c[:-1], c[1:])]
    assert len(c) > 50
    assert hi.tolist() == [w[0] for w in want] and lo.tolist() == [w[1] for w in want]
    ts = rng.uniform(0, 0.5) + 0.5 * np.arange(200)
    c = hermite_crossings(ts, np.sin(ts), np.cos(ts))
    hi, lo = cycle_extremes(ts, np.sin(ts), np.cos(ts), c)
    assert len(hi) > 10
    assert np.max(np.abs(hi - 1)) < 2e-4 and np.max(np.abs(lo + 1)) < 2e-4
    assert max(1 - np.max(np.sin(ts[(ts >= a) & (ts < b)])) for a, b in zip(c[:-1], c[1:])) > 1e-3
    with pytest.raises(ValueError, match="without a sample"):
        cycle_extremes(ts, np.sin(ts), np.cos(ts), [ts[3] + 0.1, ts[3] + 0.2])
