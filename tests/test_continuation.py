"""autocable.methods.continuation on textbook systems with known answers.

* Hopf normal form: the Hopf point, its first Lyapunov coefficient and the cycles born there
  (amplitude sqrt(mu), period 2 pi / omega, Floquet multiplier exp(-2 mu T)).
* The forced Duffing oscillator in slow-flow (averaged) Cartesian form, whose equilibria satisfy the
  closed-form frequency response: folds against the closed form, the middle branch unstable.
* The same slow flow on a slow time scale (rates ~1e-5, like the AME of a lightly damped cable):
  PyCont's list loses both folds (its fold check asks for exactly one eigenvalue below 1e-4 in
  modulus) and its stability flags turn 'N' (threshold 1e-6); autocable finds both folds, flags
  them as missed by PyCont, and its stability follows the eigenvalues.
* A pitchfork in a Z2-symmetric 4-D system: the branch point and the bifurcated branch on both sides.
* Stability agrees at every point with eigenvalues of an independent finite-difference Jacobian.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
import sympy as sp

from autocable.methods.continuation import (ContinuationSettings, EquilibriumProblem, System,
                                            bialternate, continue_cycles, continue_equilibria,
                                            first_lyapunov, switch_branch)

x, y, mu = sp.symbols("x y mu")


def fd_eigenvalues(system: System, state, params, h=1e-7) -> np.ndarray:
    """Eigenvalues of a central-difference Jacobian (independent of the sympy one)."""
    state = np.asarray(state, float)
    cols = []
    for e in np.eye(len(state)):
        step = h * max(1.0, np.max(np.abs(state)))
        cols.append((system.f(state + step * e, params) - system.f(state - step * e, params)) / (2 * step))
    return np.linalg.eigvals(np.column_stack(cols))


def assert_stability_matches_eigenvalues(branch, system, margin=1e-9):
    """Every point's `stable` flag is what an independent Jacobian's eigenvalues say (points whose
    largest real part is within `margin` of zero, i.e. at a bifurcation, are not decidable)."""
    checked = 0
    for i in range(len(branch)):
        p = np.array([branch[name][i] for name in system.parameter_names])
        ev = fd_eigenvalues(system, branch.states[i], p)
        lead = np.max(ev.real)
        scale = max(np.max(np.abs(ev)), 1e-300)
        if abs(lead) <= margin * scale:
            continue
        assert bool(branch.stable[i]) == (lead < 0), (i, branch.parameter, branch.values[i], ev)
        checked += 1
    assert checked >= 0.9 * len(branch)


# --------------------------------------------------------------------------------------------
def test_bialternate_product_has_the_pair_sums_as_eigenvalues():
    rng = np.random.default_rng(1)
    for n in (2, 3, 4, 5):
        A = rng.normal(size=(n, n))
        lam = np.linalg.eigvals(A)
        want = np.sort_complex(np.array([lam[i] + lam[j] for i in range(n) for j in range(i)]))
        got = np.sort_complex(np.linalg.eigvals(bialternate(A)))
        np.testing.assert_allclose(got, want, atol=1e-10)


# --------------------------------------------------------------------------------------------
# Hopf normal form: x' = mu x - w y + a x r^2, y' = w x + mu y + a y r^2 (r^2 = x^2 + y^2).
# r' = mu r + a r^3: cycles r = sqrt(-mu/a) for mu > 0 (a < 0), period 2 pi / w, and the radial
# multiplier exp((mu + 3 a r^2) T) = exp(-2 mu T). Kuznetsov's l1 with |q| = 1 is 2 a / w.
W_H, A_H = 2.0, -1.0


@pytest.fixture(scope="module")
def hopf_run():
    r2 = x * x + y * y
    system = System("hopf_nf", ("x", "y"), (mu * x - W_H * y + A_H * x * r2, W_H * x + mu * y + A_H * y * r2),
                    {"mu": -0.2}, (("a1", ("x", "y")),))
    problem = EquilibriumProblem(system, "mu", {"mu": -0.2}, (-0.2, 0.3))
    settings = ContinuationSettings(cycle_step=5e-3, cycle_max_step=5e-2, cycle_max_points=25)
    eq = continue_equilibria(problem, settings, name="EQ")
    cycles = continue_cycles(eq, "H1")
    return system, eq, cycles


@pytest.mark.slow
def test_hopf_point_and_first_lyapunov_coefficient(hopf_run):
    system, eq, _ = hopf_run
    b = eq.branch
    assert [s.label for s in b.special_points] == ["H1"]
    h = b.special("H1")
    assert abs(h.value) < 1e-10 and h.converged and h.confirmed_by_pycont
    assert h.extra["omega"] == pytest.approx(W_H, rel=1e-12)
    assert h.extra["l1"] == pytest.approx(2 * A_H / W_H, rel=1e-10)
    assert h.extra["criticality"] == "supercritical"
    assert first_lyapunov(system, [0.0, 0.0], [0.0])[0] == pytest.approx(2 * A_H / W_H, rel=1e-12)
    # the origin: stable below the Hopf point, unstable above, from the eigenvalues mu +- i w
    away = np.abs(b["mu"]) > 1e-12                   # at mu = 0 itself stability is undecided
    assert np.all(b.stable[away] == (b["mu"][away] < 0))
    assert [e.reason for e in b.ends] == ["range", "range"]
    assert b["mu"][0] == pytest.approx(-0.2) and b["mu"][-1] == pytest.approx(0.3)


@pytest.mark.slow
def test_cycles_from_the_hopf_point_have_the_normal_form_amplitude(hopf_run):
    _, _, cycles = hopf_run
    c = cycles.branch
    assert c.kind == "cycle" and len(c) >= 10
    checked = 0
    for i in range(len(c)):
        m = c["mu"][i]
        if m < 1e-4:
            continue
        r = math.sqrt(m / -A_H)
        assert c["a1_min"][i] == pytest.approx(r, rel=1e-4)
        assert c["a1_max"][i] == pytest.approx(r, rel=1e-4)
        T = c["period"][i]
        assert T == pytest.approx(2 * math.pi / W_H, rel=1e-8)
        mults = np.sort(np.abs(c.eigenvalues[i]))
        assert mults[0] == pytest.approx(math.exp(-2 * m * T), rel=1e-6)
        assert mults[1] == pytest.approx(1.0, abs=1e-8)
        assert c.stable[i]
        checked += 1
    assert checked >= 8
    assert c.info["auto_multiplier_max_diff"] < 1e-6          # AUTO's multipliers agree
    assert c.info["closure_error_max"] < 1e-6
    assert not c.of_type("LPC") and not c.of_type("PD") and not c.of_type("NS")


# --------------------------------------------------------------------------------------------
# Forced Duffing oscillator, slow flow of q'' + 2 mu q' + w^2 q + alpha q^3 = F cos(Omega t):
# z = u + i v, z' = (-mu + i(sigma - kappa |z|^2)) z - i f  (kappa = 3 alpha / 8 w, f = F / 2 w).
# Equilibria: a^2 (mu^2 + (sigma - kappa a^2)^2) = f^2 (the frequency response, closed form).
MU_D, KAPPA, F_D = 0.1, 1.0, 0.2


def duffing(rate=1.0, name="duffing_slow"):
    u, v, s = sp.symbols("u v sigma")
    w = s - KAPPA * (u * u + v * v)
    return System(name, ("u", "v"), (rate * (-MU_D * u - w * v), rate * (-MU_D * v + w * u - F_D)),
                  {"sigma": -1.0}, (("a1", ("u", "v")),))


def duffing_folds():
    """Folds of the frequency response: with A = a^2, dG/dA = 0 and G = 0 give
    4 kappa^2 mu^2 A^4 - 4 kappa^2 f^2 A^3 + f^4 = 0 and sigma = kappa A + f^2 / (2 kappa A^2)."""
    roots = np.roots([4 * KAPPA**2 * MU_D**2, -4 * KAPPA**2 * F_D**2, 0.0, 0.0, F_D**4])
    A = np.sort(roots[(np.abs(roots.imag) < 1e-12) & (roots.real > 0)].real)
    return [(KAPPA * a + F_D**2 / (2 * KAPPA * a * a), math.sqrt(a)) for a in A]


def duffing_run(rate):
    system = duffing(rate, name=f"duffing_slow_{'slow' if rate != 1 else 'fast'}")
    problem = EquilibriumProblem(system, "sigma", {"sigma": -1.0}, (-1.0, 6.0))
    return system, continue_equilibria(problem, ContinuationSettings(max_step=4e-2), name="I",
                                       directions="forward")


@pytest.fixture(scope="module")
def duffing_fast():
    return duffing_run(1.0)


def test_duffing_folds_match_the_closed_form(duffing_fast):
    system, result = duffing_fast
    b = result.branch
    folds = sorted(b.of_type("LP"), key=lambda s: s.value)
    assert len(folds) == 2 and not b.of_type("H") and not b.of_type("BP")
    for sp_, (sigma_f, a_f) in zip(folds, duffing_folds()):
        assert sp_.value == pytest.approx(sigma_f, abs=1e-5)
        assert sp_.a1 == pytest.approx(a_f, abs=1e-5)
        assert sp_.converged and sp_.confirmed_by_pycont


def test_duffing_middle_branch_is_unstable(duffing_fast):
    system, result = duffing_fast
    b = result.branch
    A = b["a1"] ** 2
    dG = MU_D**2 + (b["sigma"] - KAPPA * A) ** 2 - 2 * KAPPA * A * (b["sigma"] - KAPPA * A)
    middle = dG < -1e-6
    assert middle.sum() >= 5
    assert not np.any(b.stable[middle])              # the saddles between the folds
    assert np.all(b.stable[dG > 1e-6])               # the outer branches are stable (mu > 0)
    assert_stability_matches_eigenvalues(b, system)
    # the frequency response holds at every point
    G = A * (MU_D**2 + (b["sigma"] - KAPPA * A) ** 2) - F_D**2
    assert np.max(np.abs(G)) < 1e-12


def test_pycont_misses_the_folds_of_a_slow_flow_autocable_finds_them():
    """Rates scaled by 1e-4: the equilibria and folds are unchanged, PyCont's list is empty."""
    system, result = duffing_run(1e-4)
    b = result.branch
    folds = sorted(b.of_type("LP"), key=lambda s: s.value)
    assert len(folds) == 2
    for sp_, (sigma_f, a_f) in zip(folds, duffing_folds()):
        assert sp_.value == pytest.approx(sigma_f, abs=1e-5)
        assert sp_.origin == "autocable" and sp_.converged
        assert sp_.confirmed_by_pycont is False and "PyCont missed it" in sp_.message
    assert_stability_matches_eigenvalues(b, system)


def test_pycont_stability_flags_fail_on_a_very_slow_flow_autocable_does_not():
    """Rates scaled by 1e-6: every eigenvalue is below PyCont's 1e-6 threshold, so PyCont calls
    stable points 'N'; autocable's flags follow the eigenvalues (stable outer branches)."""
    system = duffing(1e-6, name="duffing_slow_very")
    problem = EquilibriumProblem(system, "sigma", {"sigma": -1.0}, (-1.0, 0.5))
    b = continue_equilibria(problem, ContinuationSettings(max_step=4e-2), name="I", directions="forward").branch
    assert b.info["pycont_stability_checked"] > 20
    assert b.info["pycont_stability_disagreements"] >= 0.9 * b.info["pycont_stability_checked"]
    assert b.stable.all()                            # below the lower fold: one stable branch
    assert_stability_matches_eigenvalues(b, system, margin=1e-12)


# --------------------------------------------------------------------------------------------
# Z2-symmetric pitchfork in 4-D ((x1, x2) -> (-x1, -x2)): the origin has eigenvalues mu, -1, -1, -2;
# the bifurcated equilibria are x1 = +-sqrt(mu/2), x3 = mu/2, x2 = x4 = 0, stable for mu > 0.
@pytest.fixture(scope="module")
def pitchfork():
    x1, x2, x3, x4 = sp.symbols("x1 x2 x3 x4")
    system = System("pitchfork4", ("x1", "x2", "x3", "x4"),
                    (mu * x1 - x1**3 - x1 * x3, -x2 + x1 * x4, -x3 + x1**2, -2 * x4 + x1 * x2),
                    {"mu": -1.0}, (("a1", ("x1",)), ("a2", ("x2",))))
    problem = EquilibriumProblem(system, "mu", {"mu": -1.0}, (-1.0, 1.0))
    trivial = continue_equilibria(problem, ContinuationSettings(), name="T")
    return system, trivial, switch_branch(trivial, "BP1")


def test_pitchfork_branch_point(pitchfork):
    system, trivial, _ = pitchfork
    b = trivial.branch
    bps = b.of_type("BP")
    assert len(bps) == 1 and not b.of_type("LP") and not b.of_type("H")
    assert abs(bps[0].value) < 1e-10 and bps[0].converged and bps[0].confirmed_by_pycont
    away = np.abs(b["mu"]) > 1e-12
    assert np.all(b.stable[away] == (b["mu"][away] < 0))
    assert_stability_matches_eigenvalues(b, system)


def test_branch_switching_finds_both_sides_of_the_pitchfork(pitchfork):
    system, _, switched = pitchfork
    b = switched.branch
    assert [e.reason for e in b.ends] == ["range", "range"]
    x1, m = b["x1"], b["mu"]
    assert np.max(np.abs(x1**2 - m / 2)) < 1e-10
    assert np.max(np.abs(b["x3"] - m / 2)) < 1e-10
    assert np.max(np.abs(b["x2"])) < 1e-12 and np.max(np.abs(b["x4"])) < 1e-12
    assert (x1 > 0.5).any() and (x1 < -0.5).any()    # both sides, each up to mu = 1
    assert m.max() == pytest.approx(1.0) and m.min() == pytest.approx(0.0, abs=1e-12)
    assert b.stable[m > 1e-8].all()
    assert b.special("BP0").value == pytest.approx(0.0, abs=1e-10)
    assert b.info["switched_from"] == "T:BP1"
    assert_stability_matches_eigenvalues(b, system)


@pytest.mark.parametrize("engine", ["pycont", "compiled"])
def test_a_test_function_brent_cannot_resolve_does_not_end_the_branch(engine):
    """x1' = a - x1, y1' = -y1, x2' = (x1 - b) x2 - x2^3, y2' = -y2: along x = (a, 0, 0, 0) the
    pitchfork is at a = b (closed form), where x2's eigenvalue a - b crosses zero; the real pair
    -1, a - b passes a neutral saddle of the bialternate test function on the way, which once made
    Brent's method raise and lose the branch. Now the branch runs over its range and the pitchfork is
    located at a = b."""
    sysm = System("neutral_saddle_check", ("x1", "y1", "x2", "y2"), ("a - x1", "-y1", "(x1 - b)*x2 - x2**3", "-y2"),
                  (("a", -1.0), ("b", 0.5)))
    r = continue_equilibria(EquilibriumProblem(sysm, "a", {"a": -1.0, "b": 0.5}, (-1.0, 2.0)),
                            ContinuationSettings(), np.zeros(4), engine=engine)
    bps = r.branch.of_type("BP")
    assert len(bps) == 1 and bps[0].value == pytest.approx(0.5, abs=1e-9)
    assert r.branch["a"][0] == pytest.approx(-1.0) and r.branch["a"][-1] == pytest.approx(2.0)
