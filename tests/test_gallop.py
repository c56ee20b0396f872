"""`autocable gallop`: the galloping cycles of eq. (21) at eta = 0 continued in U
(autocable.methods.integration.gallop, autocable.studies.gallop, autocable.cli.gallop).

Closed forms: a hand-built Rayleigh oscillator in the in-plane equation,
q1'' + (2 xi + zeta U) q1' + q1 + c3 q1'^3 [+ c5 q1'^5] = 0, beside a decoupled damped
out-of-plane mode. First-order averaging (q1 = a cos t, da/dt = -(a/2)(c1 + 3/4 c3 a^2 + 5/8 c5 a^4),
c1 = 2 xi + zeta U) gives the cycle a^2 = -4 c1 / (3 c3) with the amplitude multiplier exp(c1 T),
and with c3 < 0 < c5 a fold at a_f^2 = -3 c3 / (5 c5), c1_f = 9/40 c3^2/c5; the decoupled mode's
multipliers are exp(lambda2 T) exactly. On the sample cable: the small cycles against the Hopf normal
form, direct integration, the fold from two step sizes, the multipliers by finite differences.
"""
import json
import math

import numpy as np
import pytest

from conftest import SAMPLE

from autocable.methods.integration.gallop import CycleContinuation, HopfStart, hopf_start
from autocable.model.equations import Term, TwoModeODE
from autocable.model.onset import stability

XI, ZETA, OMEGA2, XI2 = 0.005, -0.01, 1.3, 0.01      # U_H = -2 xi / zeta = 1
C3_SUPER = 10.0
C3_SUB, C5_SUB = -10.0, 2e4


def rayleigh(c3: float, c5: float | None = None) -> TwoModeODE:
    terms = [Term(1, (1, 0, 0, 0), (0, 0, 0), 0, 1.0, "linear"),
             Term(1, (0, 0, 1, 0), (0, 0, 0), 0, 2 * XI, "damping"),
             Term(1, (0, 0, 1, 0), (0, 0, 0), 1, ZETA, "aerodynamic"),
             Term(1, (0, 0, 3, 0), (0, 0, 0), 0, c3, "aerodynamic"),
             Term(2, (0, 1, 0, 0), (0, 0, 0), 0, OMEGA2 ** 2, "linear"),
             Term(2, (0, 0, 0, 1), (0, 0, 0), 0, 2 * XI2 * OMEGA2, "damping")]
    if c5 is not None:
        terms.append(Term(1, (0, 0, 5, 0), (0, 0, 0), 0, c5, "aerodynamic"))
    return TwoModeODE(terms=tuple(terms), omega1=1.0, omega2=OMEGA2, xi_s=XI)


@pytest.fixture(scope="module")
def super_branch():
    ode = rayleigh(C3_SUPER)
    o = stability(ode).first
    return o, CycleContinuation(ode).branch(hopf_start(o), U_min=0.02, U_max=1.8)


@pytest.fixture(scope="module")
def sample_branch(derivation):
    o = stability(derivation.ode).first
    cont = CycleContinuation(derivation.ode)
    return o, cont, cont.branch(hopf_start(o), U_min=0.02, U_max=2.0)


# -- (a) closed forms ---------------------------------------------------------------------------------
def test_rayleigh_cycles_follow_averaging(super_branch):
    """The super-critical Rayleigh cycle: the normal form's slope is -4 zeta / (3 c3) (Kuznetsov's l1
    against the closed form) and every continued cycle has averaging's a^2 = -4 c1 / (3 c3), whose
    error is second order in c1 (measured 6e-6 at c1 = -8.5e-3): tolerance 1e-5 relative."""
    o, b = super_branch
    assert o.criticality == "supercritical"
    assert o.amplitude_slopes[0] == pytest.approx(-4 * ZETA / (3 * C3_SUPER), rel=1e-9)
    assert b.end_code == "U_max"
    cycles = [p for p in b.points if p.kind == ""]
    assert len(cycles) >= 10 and max(p.U for p in cycles) == pytest.approx(1.8, rel=1e-12)
    for p in cycles:
        a_avg = math.sqrt(-4 * (2 * XI + ZETA * p.U) / (3 * C3_SUPER))
        assert p.a1 == pytest.approx(a_avg, rel=1e-5), p.U
        assert p.a2 < 1e-12                            # the decoupled mode stays at rest


def test_sample_small_cycles_follow_the_hopf_normal_form(derivation, sample_branch):
    """Near the sample's sub-critical Hopf point (U* = 1) a1^2 = d(a1^2)/dU* (U - U_H) from the normal
    form (`autocable.model.hopf`); the ratio's error is first order in U - U_H: within 2e-3 at
    |U - U_H| = 1e-3 and ten times closer at ten times closer (1e-4: within 2e-4)."""
    o, cont, b = sample_branch
    slope = o.amplitude_slopes[0]
    assert slope < 0                                   # sub-critical: the cycles lie below U_H
    first = b.points[1]
    assert o.U_star - first.U == pytest.approx(1e-3, rel=0.1)
    ratio = first.a1 ** 2 / (slope * (first.U - o.U_star))
    assert abs(ratio - 1) < 2e-3
    U = o.U_star - 1e-4
    near = cont.cycle_at(U, first.state0 * math.sqrt(0.1), first.T, hopf_start(o))
    ratio_near = near.a1 ** 2 / (slope * (U - o.U_star))
    assert abs(ratio_near - 1) < 2e-4
    assert abs(ratio_near - 1) < 0.2 * abs(ratio - 1)


# -- (b) direct integration ---------------------------------------------------------------------------
def test_continued_cycles_equal_direct_integration(derivation):
    """`gallop_study`'s check on the sample: at three wind speeds of the stable stretch, eq. (21)
    integrated (compiled engine) from the continued cycle and from 1.2 times it lands on the cycle:
    amplitudes within 1e-5 relative."""
    from autocable.studies.gallop import gallop_study
    study = gallop_study(derivation, design_wind_m_s=30.0)
    assert len(study["check"]) == 3
    speeds = [c["U_m_s"] for c in study["check"]]
    assert len(set(speeds)) == 3
    for c in study["check"]:
        for start in ("from_cycle", "from_large_start"):
            r = c[start]
            assert r["periodic"], r["message"]
            assert r["relative_difference"] <= 1e-5, (c["U_m_s"], start, r)
    # the design-wind cycle lies on the stable branch, between its neighbours
    assert study["amplitude_at_design_wind_m"][0] > 0.1
    assert study["cases"][0]["design_cycle"]["stable"]
    dc = study["cases"][0]["design_cycle"]
    assert study["amplitude_at_design_wind_m"][0] == pytest.approx(dc["interpolated_peak_m"][0], rel=1e-2)


# -- (c) the fold ---------------------------------------------------------------------------------------
def test_fold_from_two_step_sizes_and_a_multiplier_through_one(derivation, sample_branch):
    """The sample's folds of cycles up to U* = 1.2 found with the default steps and with steps three
    times shorter agree to 1e-6 in U*: the lowest (the lowest galloping speed) at U* = 0.7389 and a
    close pair at U* = 0.8400 and 0.8405 (a stable window between them, which the step control near
    |t_U| ~ 0 exists to catch). At the lowest fold a non-trivial multiplier is +1: with the trivial one
    it forms a Jordan block, so the two split by the square root of the monodromy's error (up to
    1.2e-5 measured, tolerance 1e-4) while their mean is 1 to 1e-8. The cycles on either side have
    one real multiplier above 1 (unstable) and none (stable)."""
    o, cont, b = sample_branch
    fine = cont.branch(hopf_start(o), U_min=0.02, U_max=1.2, h_max=0.05, h0=0.02)
    coarse = sorted(f.U for f in b.folds if f.U < 1.2)
    finer = sorted(f.U for f in fine.folds)
    assert len(coarse) == len(finer) == 3
    assert max(abs(u - v) for u, v in zip(coarse, finer)) < 1e-6
    assert coarse[0] == pytest.approx(0.7389, abs=1e-3)
    assert coarse[1] == pytest.approx(0.8400, abs=1e-4) and coarse[2] == pytest.approx(0.8405, abs=1e-4)
    f1 = min(b.folds, key=lambda f: f.U)
    assert f1.U_change < 1e-8
    assert b.lowest_U == f1.U
    assert abs(f1.multiplier_nearest_one - 1) < 1e-4 and abs(f1.point.trivial - 1) < 1e-4
    for f in b.folds:
        assert abs((f.multiplier_nearest_one + f.point.trivial) / 2 - 1) < 1e-8
    i = next(k for k, p in enumerate(b.points) if p is f1.point)
    before, after = b.points[i - 1], b.points[i + 1]
    assert not before.stable and after.stable
    assert before.multipliers[0].real > 1 and abs(before.multipliers[0].imag) < 1e-9
    assert after.max_modulus < 1
    window = [p for p in b.points if coarse[1] < p.U < coarse[2] and p.kind == "" and 0.0092 < p.a1 < 0.0097]
    assert window and all(p.stable for p in window)


def test_rayleigh_fold_equals_averaging():
    """The sub-critical Rayleigh-quintic cycle folds at averaging's U_f = (9/40 c3^2/c5 - 2 xi) / zeta
    with a_f^2 = -3 c3 / (5 c5): within 1e-8 in U* and 1e-6 in a (averaging's error is second order
    in the small coefficients, ~1e-6 here); the branch starts from a Hopf point given by hand
    (Kuznetsov's formula takes up to cubic terms)."""
    ode = rayleigh(C3_SUB, C5_SUB)
    A = ode.linear_matrix(1.0)
    lam, V = np.linalg.eig(A)
    i = next(k for k in range(4) if lam[k].imag > 0 and abs(lam[k].real) < 1e-12)
    hopf = HopfStart(1.0, float(lam[i].imag), tuple(V[:, i] / np.linalg.norm(V[:, i])))
    b = CycleContinuation(ode).branch(hopf, U_min=0.02, U_max=1.5)
    assert len(b.folds) == 1
    U_f = (9 / 40 * C3_SUB ** 2 / C5_SUB - 2 * XI) / ZETA
    assert b.folds[0].U == pytest.approx(U_f, abs=1e-8)
    assert b.folds[0].point.a1 == pytest.approx(math.sqrt(-3 * C3_SUB / (5 * C5_SUB)), rel=1e-6)
    assert b.lowest_U == b.folds[0].U


# -- (d) Floquet multipliers -----------------------------------------------------------------------------
def test_rayleigh_multipliers_closed_form(super_branch):
    """Stable Rayleigh cycles: the amplitude multiplier is exp(c1 T) (averaging, 1e-5) inside the unit
    circle, the decoupled mode's pair exp(lambda2 T) exactly (1e-8), the trivial one 1 (1e-8)."""
    _, b = super_branch
    lam2 = complex(-XI2 * OMEGA2, OMEGA2 * math.sqrt(1 - XI2 ** 2))
    for p in (q for q in b.points if q.kind == ""):
        assert p.stable and p.max_modulus < 1
        mu = sorted(p.multipliers, key=lambda m: abs(m.imag))
        assert mu[0].real == pytest.approx(math.exp((2 * XI + ZETA * p.U) * p.T), abs=1e-5)
        for m in mu[1:]:
            assert abs(m - (np.exp(lam2 * p.T) if m.imag > 0 else np.exp(lam2.conjugate() * p.T))) < 1e-8
        assert abs(p.trivial - 1) < 1e-8


def test_sample_multipliers_by_finite_differences(sample_branch):
    """On the sample, one unstable cycle (below the fold) and one stable one (above it): the
    multipliers from the variational equations equal those of the monodromy by central differences
    of the flow (an independent route, 1e-5), outside the unit circle for the unstable cycle and
    inside for the stable one."""
    o, cont, b = sample_branch
    i = next(k for k, p in enumerate(b.points) if p.kind == "LPC")
    unstable = b.points[i - 3]
    stable = next(p for p in b.points[i + 1:] if p.kind == "" and p.U > 0.9)
    for p, is_stable in ((unstable, False), (stable, True)):
        assert p.stable is is_stable
        eps = 1e-6 * float(np.linalg.norm(p.state0))
        M = np.empty((4, 4))
        for j in range(4):
            e = np.zeros(4)
            e[j] = eps
            M[:, j] = (cont.flow(p.state0 + e, p.T, p.U).yT - cont.flow(p.state0 - e, p.T, p.U).yT) / (2 * eps)
        fd = np.linalg.eigvals(M)
        for m in list(p.multipliers) + [p.trivial]:
            assert np.min(np.abs(fd - m)) < 1e-5
        assert (p.max_modulus < 1) is is_stable


# -- (e) the command ----------------------------------------------------------------------------------
def _cli(capsys, *args):
    from autocable.cli import main
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.mark.slow
def test_gallop_command_json_matches_the_study(capsys, tmp_path, derivation):
    """--json carries the keys of the brief and the numbers of the study; --out writes the files
    and refuses a folder with files autocable did not write."""
    from autocable.studies.gallop import gallop_study
    code, out, err = _cli(capsys, "gallop", SAMPLE, "--design-wind", "30", "--json", "--quiet",
                          "--damping", "0.004,0.003", "--out", tmp_path / "g")
    assert code == 0, err
    data = json.loads(out)
    for key in ("lowest_galloping_U_m_s", "amplitude_at_design_wind_m", "beyond_valid_range",
                "frequency_at_design_wind_Hz", "hysteresis_m_s", "branches", "check"):
        assert key in data
    assert set(data["branches"]) == {"0.004", "0.003"}
    study = gallop_study(derivation, design_wind_m_s=30.0, checks=False)
    assert data["lowest_galloping_U_m_s"] == pytest.approx(study["lowest_galloping_U_m_s"], rel=1e-12)
    assert data["amplitude_at_design_wind_m"] == pytest.approx(study["amplitude_at_design_wind_m"], rel=1e-12)
    assert data["hysteresis_m_s"] == pytest.approx([study["lowest_galloping_U_m_s"], 36.0], rel=1e-12)
    # the lower damping gallops from a lower wind
    assert data["cases"][1]["lowest_galloping_U_m_s"] < data["cases"][0]["lowest_galloping_U_m_s"]
    files = sorted(p.name for p in (tmp_path / "g").iterdir())
    assert {"gallop.json", "branches.csv", "gallop.png", "gallop.pdf", "run.json"} <= set(files)
    assert json.loads((tmp_path / "g" / "gallop.json").read_text())["lowest_galloping_U_m_s"] == \
        data["lowest_galloping_U_m_s"]
    (tmp_path / "h").mkdir()
    (tmp_path / "h" / "notes.txt").write_text("mine")
    code, out, err = _cli(capsys, "gallop", SAMPLE, "--out", tmp_path / "h", "--quiet")
    assert code == 2 and "--out" in err and "notes.txt" in err and len(err.strip().splitlines()) == 1


@pytest.mark.parametrize("argv, option", [
    (("--damping", "0"), "--damping"),
    (("--damping", "abc"), "--damping"),
    (("--damping", "0.01,2"), "--damping"),
    (("--design-wind", "-3"), "--design-wind"),
    (("--design-wind", "nan"), "--design-wind"),
    (("--max-wind", "1e6"), "--max-wind"),
    (("--max-wind", "20", "--design-wind", "25"), "--design-wind"),
    (("--out", ""), "--out"),
])
def test_gallop_command_refuses_bad_options(capsys, argv, option):
    code, out, err = _cli(capsys, "gallop", SAMPLE, *argv)
    assert code == 2
    assert option in err and len(err.strip().splitlines()) == 1 and "Traceback" not in err
