"""Steady responses of eq. (21) by shooting: the same steady states as transient
integration, the Floquet multipliers of `floquet21`, and the response classes."""
import json
import math
import warnings
from itertools import permutations
from pathlib import Path

import numpy as np
import pytest

from conftest import legacy_path

from autocable.cli import main
from autocable.methods.integration.floquet21 import floquet_multipliers, multipliers_of
from autocable.methods.integration.ode21 import Ode21Integrator
from autocable.methods.integration.shooting import RESPONSE_CLASSES, ShootingSolver, periodic_half_range
from autocable.model.derive import derive
from autocable.model.equations import Term, TwoModeODE
from autocable.spec import load_model

#: The legacy-sense sample (conftest.legacy_path): the known cases of this module (a long transient
#: that diverges past a stable orbit, the coexisting orbits of Fig. 9, the diverged class) were found
#: on that reading; the sample ("mirrored") stays bounded where they diverge.
SAMPLE = legacy_path()


@pytest.fixture(scope="module")
def sample():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return derive(load_model(SAMPLE))


@pytest.fixture(scope="module")
def solver(sample):
    return ShootingSolver(sample.ode)


@pytest.fixture(scope="module")
def transient(sample):
    return Ode21Integrator(sample.ode, engine="compiled")


def matched(a, b) -> float:
    """max |a_i - b_pi(i)| over the best pairing (4! pairings)."""
    return float(min(np.max(np.abs(np.asarray(a) - np.asarray(b)[list(p)])) for p in permutations(range(len(b)))))


# Fig. 5a (U = 0, eta* = 8.2e-5: mono-modal) and Fig. 6 (U = 0, eta* = 1.4e-3; sigma = -0.02 lies on
# a bi-modal branch, a2 > 0, reached from rest with the q2 seed only after the planar orbit's
# pitchfork instability has grown out).
CASES = [(0.0, 8.2e-5, -0.02), (0.0, 8.2e-5, 0.0), (0.0, 8.2e-5, 0.03),
         (0.0, 1.4e-3, -0.02), (0.0, 1.4e-3, 0.03)]


@pytest.mark.parametrize("U,eta,sigma", CASES)
def test_shooting_finds_the_transient_steady_state(solver, transient, sample, U, eta, sigma):
    """Shooting and transient integration (the judge, from the same start) report the same period-1
    response: a1, a2 to 1e-6 of its size (both measure the orbit on the same 64 phases per period;
    the transient's own steady test is 1e-8 relative), and the multipliers equal those `floquet21`
    computes independently (scipy DOP853 on lambdified variational equations) to 1e-8."""
    r = solver.steady(U, eta, sigma)
    q = transient.simulate(U, eta, sigma)
    assert q.steady and q.periodic
    assert r.response == "period-1" and r.periods == 1 and r.steady and r.periodic
    size = max(q.a1, q.a2)
    assert abs(r.a1 - q.a1) <= 1e-6 * size
    assert abs(r.a2 - q.a2) <= 1e-6 * size
    assert r.residual < 1e-10
    fl = floquet_multipliers(sample, U, eta, sigma, r.state0)
    assert fl.residual < 1e-9                    # floquet21 agrees the state is on a period-1 orbit
    assert matched(r.multipliers, fl.multipliers) < 1e-8
    assert r.max_modulus < 1.0


@pytest.mark.parametrize("U,eta,sigma", [(0.0, 4.1e-4, 0.01), (0.7, 4.1e-4, -0.03)])
def test_chord_steps_land_on_the_fixed_point_of_the_variational_flow(solver, U, eta, sigma):
    """Newton finishes by chord steps on the four state equations alone (`ShootingSolver._chord`):
    the point it returns is a fixed point of the period map integrated with the twenty variational
    equations too (other steps, the same tolerance) to 1e-10 of its size, and plain Newton on that
    variational flow (no coarse phase, no chord) from 10 % away finds the same point to 1e-10."""
    Omega = solver.ode.omega1 + sigma
    r = solver.steady(U, eta, sigma)
    assert r.response == "period-1" and any(a["converged"] for a in r.details["attempts"])
    y = np.asarray(r.state0)
    yT, _ = solver.flow(U, eta, Omega, y, 1)
    assert np.linalg.norm(yT - y) < 1e-10 * np.linalg.norm(y)
    z = 0.9 * y
    for _ in range(8):
        zT, M = solver.flow(U, eta, Omega, z, 1)
        z = z - np.linalg.solve(M - np.eye(4), zT - z)
    assert np.linalg.norm(z - y) < 1e-10 * np.linalg.norm(y)


def test_long_transient_that_diverges_past_a_stable_orbit(solver, transient):
    """U* = 0.96, eta* = 5.7e-4, sigma = 0.01 (a point of the (U, eta) map): integration from rest
    wanders for about 26000 time units past a stable period-1 orbit (Newton finds it at every
    stage, the judge refuses it) and then diverges, at rtol 1e-10 and 1e-12 alike. Shooting's
    stages must follow it there: with its later stages at rtol 1e-6 it once reported the orbit."""
    U, eta = 0.1 + 1.4 * 24 / 39, 6e-4 * 37 / 39
    q = transient.simulate(U, eta, 0.01)
    assert not math.isfinite(q.a1) and 26000 < q.t_end < 27000
    r = solver.steady(U, eta, 0.01)
    assert r.response == "diverged"
    assert abs(r.t_end - q.t_end) < 0.01 * q.t_end
    assert any(a.get("not_attracting") for a in r.details["attempts"])


def test_bimodal_response_of_fig6(solver):
    """Fig. 6 at sigma = -0.02 (U = 0, eta* = 1.4e-3) is bi-modal: both modes respond at the size of
    a few 1e-3 (the AME branches III-V of Fig. 6), not the planar orbit the transient passes by."""
    r = solver.steady(0.0, 1.4e-3, -0.02)
    assert r.response == "period-1"
    assert r.a2 > 1e-3 and r.a1 > 1e-3


def test_linear_oscillator_closed_form():
    """A linear forced oscillator (the test system of test_periodic21): shooting lands on the closed-
    form steady response q1 = Im(Q e^{i Omega t}) to 1e-9 of |Q| and its multipliers are exp(T lambda)
    to 1e-9."""
    w1, w2, xi1, xi2, m = 1.02, 0.97, 0.03, 0.011, 0.7
    terms = (Term(1, (1, 0, 0, 0), (0, 0, 0), 0, w1**2, "linear"),
             Term(1, (0, 0, 1, 0), (0, 0, 0), 0, 2 * xi1 * w1, "damping"),
             Term(1, (0, 0, 0, 0), (0, 0, 1), 0, -m, "inertia"),
             Term(2, (0, 1, 0, 0), (0, 0, 0), 0, w2**2, "linear"),
             Term(2, (0, 0, 0, 1), (0, 0, 0), 0, 2 * xi2 * w2, "damping"))
    ode = TwoModeODE(terms=terms, omega1=w1, omega2=w2, xi_s=xi1)
    sigma, eta = 0.013, 1e-3
    Om = w1 + sigma
    Q = -m * eta * Om**2 / (w1**2 - Om**2 + 2j * xi1 * w1 * Om)
    exact = np.array([Q.imag, 0.0, (1j * Om * Q).imag, 0.0])
    r = ShootingSolver(ode).steady(0.0, eta, sigma)
    assert r.response == "period-1"
    assert np.max(np.abs(np.asarray(r.state0) - exact)) < 1e-9 * abs(Q)
    T = 2 * math.pi / Om
    expected = multipliers_of(np.diag(np.exp(T * np.linalg.eigvals(ode.linear_matrix(0.0)))))
    assert matched(r.multipliers, expected) < 1e-9
    # a1 of a sinusoid is |Q|; 64 samples with parabolic peaks are exact to ~(2 pi / 64)^4 / 100
    assert r.a1 == pytest.approx(abs(Q), rel=2e-6)


def test_periodic_half_range_of_a_sampled_cosine():
    """The cyclic parabola: a cosine sampled 64 times, its maximum at a sample or half-way between."""
    n = 64
    for shift in (0.0, 0.5, 0.25):
        x = 3.0 * np.cos(2 * math.pi * (np.arange(n) + shift) / n) + 1.0
        # the parabola through three samples at spacing h misses the peak of A cos by the quartic
        # Taylor term, at most A h^4 / 24 (h = 2 pi / 64); with shift = 0.5 the minimum's neighbours
        # wrap around the window's end, which is what the cyclic rule is for
        assert periodic_half_range(x) == pytest.approx(3.0, abs=3.0 * (2 * math.pi / n) ** 4 / 24)


def test_classification_on_known_cases(solver, sample):
    """rest at eta* = 0 below flutter (U = 0: the only response is q = 0, stable with the linear
    damping's multipliers exp(T lambda)); period-1 on Fig. 5a; diverged at U* = 1.3 > 1 = U_c
    (Sect. 3: above the critical wind the trivial equilibrium is unstable and eq. (21) with the
    sample cable has no bounded response; `Ode21Integrator` agrees)."""
    rest = solver.steady(0.0, 0.0, 0.0)
    assert rest.response == "rest"
    assert max(rest.a1, rest.a2) < 1e-10
    T = 2 * math.pi / sample.ode.omega1
    lin = multipliers_of(np.diag(np.exp(T * np.linalg.eigvals(sample.ode.linear_matrix(0.0)))))
    assert matched(rest.multipliers, lin) < 1e-8
    assert solver.steady(0.0, 8.2e-5, 0.01).response == "period-1"
    div = solver.steady(1.3, 8.2e-5, 0.0)
    assert div.response == "diverged" and math.isinf(div.a1) and not div.steady
    judge = Ode21Integrator(sample.ode, engine="compiled").simulate(1.3, 8.2e-5, 0.0)
    assert math.isinf(judge.a1)
    assert set(RESPONSE_CLASSES) == {"rest", "period-1", "period-2", "quasi-periodic", "diverged",
                                     "autonomous-periodic"}      # the last: eta* = 0 cycles (test_autonomous.py)


def _strict(text):
    def bad(name):
        raise AssertionError(f"non-strict JSON constant {name}")
    return json.loads(text, parse_constant=bad)


def test_cli_shooting_json_has_the_ode21_keys(capsys):
    """`simulate --method shooting --json` prints every key of `--method ode21 --json` plus the
    multipliers and the class, as strict JSON (a diverged response: nulls and a class)."""
    args = ["simulate", str(SAMPLE), "--U", "0", "--eta", "8.2e-5", "--sigma", "0.02", "--json"]
    assert main(args) == 0
    ode21 = _strict(capsys.readouterr().out)
    assert main(args + ["--method", "shooting"]) == 0
    shot = _strict(capsys.readouterr().out)
    assert set(ode21) <= set(shot)
    assert shot["response"] == "period-1" and shot["method"] == "shooting"
    assert len(shot["floquet_multipliers"]) == 4
    assert shot["a1"] == pytest.approx(ode21["a1"], rel=1e-6)
    assert main(["simulate", str(SAMPLE), "--U", "1.3", "--eta", "8.2e-5", "--json", "--method", "shooting"]) == 0
    div = _strict(capsys.readouterr().out)
    assert div["response"] == "diverged" and div["a1"] is None and div["floquet_multipliers"] == []


def test_period2_subharmonic_of_a_parametric_oscillator():
    """A Mathieu-Duffing oscillator, q1'' + 2 zeta w q1' + (w^2 + eta sin(Omega t)) q1 + g q1^3 = 0,
    at the principal parametric resonance Omega = 2 w (= omega1 + sigma, omega1 = 1): with
    eta / w^2 = 0.2 above the instability threshold 4 zeta = 0.04 the rest state loses stability
    through a multiplier -1 and the response is the subharmonic at Omega / 2, period 2T. Shooting
    classes it period-2, with stable multipliers of the period-2 map, and its a1 equals transient
    integration's (which reports it not period-1) to 1e-6; the orbit does not repeat after one T."""
    w, zeta, g = 0.5, 0.01, 100.0
    terms = (Term(1, (1, 0, 0, 0), (0, 0, 0), 0, w**2, "linear"),
             Term(1, (0, 0, 1, 0), (0, 0, 0), 0, 2 * zeta * w, "damping"),
             Term(1, (1, 0, 0, 0), (1, 0, 0), 0, 1.0, "structural"),
             Term(1, (3, 0, 0, 0), (0, 0, 0), 0, g, "structural"),
             Term(2, (0, 1, 0, 0), (0, 0, 0), 0, 1.0, "linear"),
             Term(2, (0, 0, 0, 1), (0, 0, 0), 0, 0.1, "damping"))
    ode = TwoModeODE(terms=terms, omega1=1.0, omega2=1.0, xi_s=zeta)
    q0 = (1e-3, 0.0, 0.0, 0.0)
    solver = ShootingSolver(ode)
    r = solver.steady(0.0, 0.05, 0.0, q0)
    assert r.response == "period-2" and r.periods == 2 and not r.periodic
    assert r.max_modulus < 1.0 and len(r.multipliers) == 4
    q = Ode21Integrator(ode, engine="compiled").simulate(0.0, 0.05, 0.0, q0)
    assert q.steady and not q.periodic
    assert r.a1 == pytest.approx(q.a1, rel=1e-6)
    y1, _ = solver.flow(0.0, 0.05, 1.0, r.state0, 1)
    assert np.linalg.norm(y1 - np.asarray(r.state0)) > 0.5 * np.linalg.norm(r.state0)


def test_modulated_response_is_not_taken_for_an_orbit(solver, sample):
    """Fig. 9's setting near resonance (U = 0.7, eta* = 1.4e-3, sigma = 0.01): the period-1 orbit
    Newton finds there is unstable through a complex pair (a torus), and transient integration from
    rest never settles on a periodic response (its envelope keeps a wide band). Shooting must not
    report that orbit: it classes the point quasi-periodic, hands over to integration, and
    reports the modulation band."""
    r = solver.steady(0.7, 1.4e-3, 0.01, max_time=20000.0)
    assert r.response == "quasi-periodic" and r.fallback and not r.periodic
    assert any(a.get("torus") for a in r.details["attempts"])
    assert r.a1_max - r.a1_min > 0.1 * r.a1_max
    q = Ode21Integrator(sample.ode, engine="compiled").simulate(0.7, 1.4e-3, 0.01, max_time=20000.0)
    assert not q.periodic and q.a1_max - q.a1_min > 0.1 * q.a1_max


def test_neighbour_start_follows_integration_not_a_coexisting_orbit(solver, transient):
    """Started from a neighbouring point's orbit (Fig. 7's setting, U = 0.7, eta* = 4.1e-4: the
    resonant orbit at sigma = 0, then sigma = 0.01), Newton converges to a stable large orbit that
    still exists at sigma = 0.01, while integration from that start falls to the small response
    (the hysteresis of the resonance). Shooting reports what integration reaches (the judge
    rejects the other attractor), to 1e-6."""
    near = solver.steady(0.7, 4.1e-4, 0.0)
    y = near.state0
    q0 = (y[0], y[2], y[1] + 1e-6, y[3])          # (q1, q1', q2, q2') with the q2 seed
    r = solver.steady(0.7, 4.1e-4, 0.01, q0, guess=y)
    q = transient.simulate(0.7, 4.1e-4, 0.01, q0)
    assert q.steady and q.periodic and q.a1 < 0.2 * near.a1        # integration jumps down
    assert r.response == "period-1"
    assert abs(r.a1 - q.a1) <= 1e-6 * max(q.a1, q.a2) and abs(r.a2 - q.a2) <= 1e-6 * max(q.a1, q.a2)
    assert any(a.get("not_attracting") for a in r.details["attempts"])


def test_neighbour_sweep_at_fig9_follows_integration_into_bimodal_motion():
    """Fig. 9's setting (U* = 0.7, eta* = 1.4e-3) swept up in sigma, each point started from its
    neighbour's response (`autocable sweep` with ``follow``) against the transient up-sweep of the
    overlays (`methods.integration.sweeps`, an independent implementation): at sigma = -0.02 a
    coexisting bi-modal orbit with a2 = 3.4e-3 lies next to the one integration reaches (a2 =
    1.6e-3). A judge that accepted Newton's orbit because the transient had approached it over its
    last periods took the wrong one; shooting must report integration's, to 1e-6."""
    from autocable.methods.integration.ode21 import DEFAULT_Q0, Ode21Integrator
    from autocable.methods.integration.sweeps import sweep
    from autocable.spec import load_model
    from autocable.studies.sweep import carry_from, compute_point, model_context
    model = load_model(SAMPLE)
    sigmas = [-0.05, -0.04, -0.03, -0.02]
    transient = Ode21Integrator(model_context(model, "shooting")[0].ode, engine="compiled")
    ref = sweep(transient, "sigma", sigmas, {"U": 0.7, "eta": 1.4e-3}, directions=("up",))
    carried = None
    for sigma, p in zip(sigmas, ref):
        rec = compute_point(model, "shooting", 0.7, 1.4e-3, sigma, DEFAULT_Q0, 60000.0, carried)
        carried = carry_from(rec)
        assert p.periodic and rec["response"] == "period-1", (sigma, rec["response"])
        size = max(p.a1, p.a2)
        assert abs(rec["a1"] - p.a1) <= 1e-6 * size and abs(rec["a2"] - p.a2) <= 1e-6 * size, \
            (sigma, rec["a1"], rec["a2"], p.a1, p.a2)
    assert ref[-1].a2 > 1e-3        # the point where the two orbits coexist is bi-modal


def test_threads_sharing_a_solver_get_the_serial_results(solver):
    """The compiled runs reuse their buffers (`cintegrate.Repeated`); each thread has its own, so
    four threads shooting on one solver at once (ctypes lets the C calls run in parallel) report
    exactly what one thread does."""
    from concurrent.futures import ThreadPoolExecutor
    sigmas = [-0.03, -0.01, 0.0, 0.01, 0.02, 0.04] * 2
    serial = [solver.steady(0.0, 4.1e-4, s).state0 for s in sigmas]
    with ThreadPoolExecutor(4) as pool:
        threaded = list(pool.map(lambda s: solver.steady(0.0, 4.1e-4, s).state0, sigmas))
    assert threaded == serial
