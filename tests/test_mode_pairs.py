"""Mode pairs (`autocable.model.mode_pairs`, ``cable.mode_pair``, ``--pair``, ``onset --modes-below``):
eq. (21) on the k-th in-plane and k-th out-of-plane modes.

Checked against routes written here: the taut-string frequencies f_k = (k/2l) sqrt(T/m) (out of plane,
and in plane for the antisymmetric modes), Irvine's transcendental equation solved in its tan form and
a Rayleigh-Ritz sine series (symmetric in-plane modes), its lambda^2 -> 0 limit; the slaved twist by
scipy's solve_bvp of eq. (19)_3; the pair's linear eq. (21) terms against a projection by Gauss
quadrature of shapes written here; pair 1 against `modes.linear_modes`; Den Hartog's onset of an
uncoupled in-plane mode. Then the commands: their output and their refusals."""
import json
import math
import warnings
from dataclasses import replace

import numpy as np
import pytest
from scipy.integrate import solve_bvp
from scipy.optimize import brentq

from conftest import REPO, SAMPLE

from autocable.model.mode_pairs import CROWDED_FRACTION, pair_info, pair_modes
from autocable.model.premises import PremiseWarning
from autocable.model.statics import cable_statics
from autocable.model.units import units_of
from autocable.spec import SpecError, load_model

STAY = REPO / "models" / "stay_190m.toml"


def _pair(spec, k):
    return replace(spec, cable=replace(spec.cable, mode_pair=k))


def _derive(spec, **kw):
    from autocable.model.derive import derive
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PremiseWarning)
        return derive(spec, **kw)


def _cli(capsys, *args):
    from autocable.cli import main
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture(scope="module")
def stay():
    spec = load_model(STAY)
    return spec, cable_statics(spec.cable)


# -- the groups of eq. (17) from the file's numbers, written here -----------------------------------
def _groups(cable):
    """(T [N], delta, tau, chi, lambda^2): T = H/cos(alpha), delta = m g l cos^2(alpha)/H, tau = T/EA."""
    a = math.radians(cable.chord_slope_deg)
    T = cable.horizontal_tension_N / math.cos(a)
    delta = cable.mass_per_length_kg_m * cable.gravity_m_s2 * math.cos(a) ** 2 * cable.length_m / cable.horizontal_tension_N
    tau = T / cable.axial_stiffness_N
    return T, delta, tau, cable.torsional_stiffness_Nm2 / cable.bending_stiffness_Nm2, delta ** 2 / tau


def _irvine_tan(lambda2, j):
    """The j-th symmetric root b of tan(b/2) = b/2 - (4/lambda^2)(b/2)^3, in the tan form, on the
    branch of tan(x), x = b/2, between its poles (2j-1) pi/2 and (2j+1) pi/2 (from -inf to +inf)."""
    def f(x):
        return math.tan(x) - x + 4 * x ** 3 / lambda2
    eps = 1e-10
    return 2 * brentq(f, (2 * j - 1) * math.pi / 2 + eps, (2 * j + 1) * math.pi / 2 - eps, xtol=1e-14, rtol=1e-15)


def _ritz_in_plane(delta, tau, n=600):
    """Every in-plane omega of tau v'' - delta^2 int v = m* v_tt (m* = pi^2 tau) on n sines, sorted:
    stiffness tau (j pi)^2/2 delta_ij + delta^2 g_i g_j, g_j = int sin(j pi s), mass m*/2."""
    j = np.arange(1, n + 1)
    g = (1 - np.cos(j * np.pi)) / (j * np.pi)
    K = np.diag(tau * (j * np.pi) ** 2 / 2) + delta ** 2 * np.outer(g, g)
    return np.sqrt(np.sort(np.linalg.eigvalsh(K / (math.pi ** 2 * tau / 2))))


# -- frequencies --------------------------------------------------------------------------------------
def test_pair_frequencies_are_the_taut_string_ones_and_irvine_roots(stay):
    """Out of plane f_k = (k/2l) sqrt(T/m) for every k; in plane the same for the antisymmetric modes
    (even k) exactly, and for the symmetric ones (odd k = 2j - 1) the j-th root of Irvine's equation
    (tan form, here) and the k-th Rayleigh-Ritz eigenvalue (600 sines, here)."""
    spec, st = stay
    c = spec.cable
    T, delta, tau, _, lambda2 = _groups(c)
    assert st.lambda2 == pytest.approx(lambda2, rel=1e-12)
    units = units_of(spec, st)
    f1 = math.sqrt(T / c.mass_per_length_kg_m) / (2 * c.length_m)
    ritz = _ritz_in_plane(delta, tau)
    for k in range(1, 9):
        info = pair_info(st, k)
        assert units.frequency_hz(info.omega2) == pytest.approx(k * f1, rel=1e-12)
        assert info.out_of_plane.name == f"w{k}"
        if k % 2 == 0:
            assert info.in_plane.symmetry == "antisymmetric" and info.in_plane.k == k // 2
            assert units.frequency_hz(info.omega1) == pytest.approx(k * f1, rel=1e-12)
        else:
            j = (k + 1) // 2
            assert info.in_plane.symmetry == "symmetric" and info.in_plane.k == j
            assert info.omega1 == pytest.approx(_irvine_tan(lambda2, j) / math.pi, rel=1e-12)
            assert info.omega1 > k            # the sag term stiffens only the symmetric modes
        assert info.omega1 == pytest.approx(ritz[k - 1], rel=1e-9)


def test_symmetric_roots_tend_to_the_taut_string_as_lambda2_vanishes(stay):
    """lambda^2 -> 0 (gravity 1000 times weaker: lambda^2 ~ 4e-7): b_j -> (2j-1) pi, with the first-order
    Rayleigh correction omega_j = (2j-1) + 4 lambda^2 / ((2j-1)^3 pi^4) (relative error O(lambda^2))."""
    spec, _ = stay
    cable = replace(spec.cable, gravity_m_s2=spec.cable.gravity_m_s2 / 1000)
    st = cable_statics(cable)
    assert st.lambda2 < 1e-6
    for k in (1, 3, 5, 7):
        shift = pair_info(st, k).omega1 - k
        assert shift == pytest.approx(4 * st.lambda2 / (k ** 3 * math.pi ** 4), rel=1e-4)


def test_the_slaved_twist_of_every_pair_solves_eq_19_3(stay):
    """theta2 of pair k against scipy's solve_bvp of chi theta'' - delta^2 theta + (1 + chi) delta w'' = 0,
    theta' + delta w' = 0 at both ends, w = sin(k pi s) (so chi theta'' = delta^2 theta + (1 + chi) delta
    (k pi)^2 sin(k pi s)): the cosh (odd k) and sinh (even k) parts."""
    spec, st = stay
    _, delta, _, chi, _ = _groups(spec.cable)
    s = np.linspace(0.0, 1.0, 101)
    for k in (1, 2, 3, 4, 5):
        kp = k * math.pi

        def rhs(x, y, kp=kp):
            return np.vstack([y[1], (delta ** 2 * y[0] + (1 + chi) * delta * kp ** 2 * np.sin(kp * x)) / chi])

        def bc(ya, yb, kp=kp):
            return np.array([ya[1] + delta * kp, yb[1] + delta * kp * math.cos(kp)])

        def bc_restrained(ya, yb):
            return np.array([ya[0], yb[0]])

        x = np.linspace(0.0, 1.0, 401)
        sol = solve_bvp(rhs, bc, x, np.zeros((2, x.size)), tol=1e-8, max_nodes=200000)
        assert sol.success, sol.message
        theta = pair_modes(st, k).shapes["theta2"].evaluate(s)
        assert np.max(np.abs(sol.sol(s)[0] - theta)) < 1e-6 * np.max(np.abs(theta))
        m = pair_modes(st, k)
        assert (m.twist_C != 0.0, m.twist_D != 0.0) == ((True, False) if k % 2 else (False, True))
        # theta = 0 at both anchorages (the shipped stays): the particular part alone
        sol = solve_bvp(rhs, bc_restrained, x, np.zeros((2, x.size)), tol=1e-8, max_nodes=200000)
        assert sol.success, sol.message
        theta = pair_modes(st, k, "restrained").shapes["theta2"].evaluate(s)
        assert np.max(np.abs(sol.sol(s)[0] - theta)) < 1e-6 * np.max(np.abs(theta))


# -- eq. (21) on the pair -----------------------------------------------------------------------------
def _terms(ode):
    return {(t.equation, t.powers, t.forcing, t.u_power, t.origin): t.coefficient for t in ode.terms}


def test_pair_1_is_the_papers_pair(stay):
    """`pair_modes(st, 1)` (built from modes_n) projects to the eq. (21) of `modes.linear_modes`: every
    coefficient to 1e-12 relative; and a model with mode_pair = 1 written out derives the same ODE."""
    from autocable.model.aero import expand_load_jet
    from autocable.model.galerkin import aero_scales, project
    from autocable.model.modes import linear_modes
    from autocable.model.shapes import ClosedFormIntegrator
    spec, st = stay
    d = _derive(spec)
    aero = expand_load_jet(spec.aero.lift, spec.aero.drag, st.alpha, d.beta, d.theta0, spec.aero.angle_convention,
                           spec.aero.load_axes)
    K, nu = aero_scales(spec.aero, spec.cable, st)
    odes = [project(st, m, aero, K, nu, spec.cable.damping_ratio, ClosedFormIntegrator(m.shapes))
            for m in (linear_modes(st), pair_modes(st, 1))]
    a, b = (_terms(o) for o in odes)
    assert a.keys() == b.keys() and len(a) > 80
    for key in a:
        assert b[key] == pytest.approx(a[key], rel=1e-12, abs=1e-300)
    assert _terms(_derive(_pair(spec, 1)).ode) == _terms(d.ode)


class _Quadrature:
    """int_0^1 of products of shapes written here, by 200-node Gauss-Legendre: phi1 the pair's in-plane
    mode (unit maximum), phi2 = sin(k pi s), theta2 from solve_bvp (as in the test above)."""

    def __init__(self, st, k, lambda2, delta, chi, twist_ends="natural"):
        x, w = np.polynomial.legendre.leggauss(200)
        s, self.w = 0.5 * (x + 1), 0.5 * w
        kp = k * math.pi
        if k % 2:
            b = _irvine_tan(lambda2, (k + 1) // 2)
            c = math.cos(b / 2)
            phi1 = (np.cos(b * (s - 0.5)) - c) / (1 + abs(c))
        else:
            phi1 = np.sin(kp * s)

        def rhs(x, y):
            return np.vstack([y[1], (delta ** 2 * y[0] + (1 + chi) * delta * kp ** 2 * np.sin(kp * x)) / chi])

        def bc(ya, yb):
            if twist_ends == "restrained":
                return np.array([ya[0], yb[0]])
            return np.array([ya[1] + delta * kp, yb[1] + delta * kp * math.cos(kp)])

        grid = np.linspace(0.0, 1.0, 401)
        sol = solve_bvp(rhs, bc, grid, np.zeros((2, grid.size)), tol=1e-10, max_nodes=200000)
        self.values = {"phi1": phi1, "phi2": np.sin(kp * s), "theta2": sol.sol(s)[0]}

    def __call__(self, key):
        return float(np.dot(self.w, np.prod([self.values[n] for n in key], axis=0)))


def _linear(ode, k, j):
    """The linear, unforced lhs coefficients of state j in equation k, by origin, summed."""
    out = {}
    for t in ode.terms:
        if t.equation == k and not t.eta_power and sum(t.powers) == 1 and t.powers[j] == 1:
            out[t.origin] = out.get(t.origin, 0.0) + t.coefficient
    return out


@pytest.mark.parametrize("k", [2, 3, 4, 5])
def test_linear_terms_of_pair_k_against_an_independent_projection(stay, k):
    """Eq. (21) of pair k, linear part: the stiffness terms are omega1^2 (Irvine root, tan form) and
    omega2^2 = k^2; the aerodynamic ones (velocity terms ~ U, the twist's stiffness ~ U^2) equal
    `galerkin.linear_aero_matrix` on the Gauss quadrature of the shapes written here (1e-7: the twist
    by solve_bvp), and the closed-form route equals the `QuadratureIntegrator` route (1e-8)."""
    from autocable.model.aero import linear_load
    from autocable.model.galerkin import linear_aero_matrix
    spec, st = stay
    _, delta, _, chi, lambda2 = _groups(spec.cable)
    d = _derive(_pair(spec, k))
    ode = d.ode
    om1 = _irvine_tan(lambda2, (k + 1) // 2) / math.pi if k % 2 else float(k)
    assert ode.omega1 == pytest.approx(om1, rel=1e-12) and ode.omega2 == k
    assert _linear(ode, 1, 0)["linear"] == pytest.approx(om1 ** 2, rel=1e-9)
    assert _linear(ode, 2, 1)["linear"] == pytest.approx(k ** 2, rel=1e-9)
    assert _linear(ode, 1, 2)["damping"] == pytest.approx(2 * spec.cable.damping_ratio * om1, rel=1e-12)
    a = spec.aero
    lin = linear_load(a.lift, a.drag, st.alpha, d.beta, d.theta0, a.angle_convention, a.load_axes)
    ref = linear_aero_matrix(_Quadrature(st, k, lambda2, delta, chi, spec.cable.twist_ends), d.aero_scale, d.velocity_ratio, st.m_star, lin)
    for (eq, j), c in ref.items():
        got = _linear(ode, eq, j).get("aerodynamic", 0.0)
        assert got == pytest.approx(c, rel=1e-7, abs=1e-12 * max(abs(v) for v in ref.values())), (eq, j)
    quad = _derive(_pair(spec, k), integrator="quadrature").ode
    qa, qb = _terms(ode), _terms(quad)
    scale = {eq: max(abs(v) for key, v in qa.items() if key[0] == eq) for eq in (1, 2)}
    # a term that vanishes by symmetry is absent from the closed form and round-off in quadrature
    for key in qa.keys() | qb.keys():
        assert qb.get(key, 0.0) == pytest.approx(qa.get(key, 0.0), rel=1e-8, abs=1e-12 * scale[key[0]]), key


def test_the_fitted_angle_is_the_first_pairs_and_the_cache_key_holds_the_pair(stay, tmp_path, monkeypatch):
    """Pair k > 1 keeps the rivulet angle fitted on pair 1 (not fitted again), every pair has its own
    cache entry (a second call reads it: same eq. 21), and the ODE says which pair it is."""
    monkeypatch.setenv("AUTOCABLE_CACHE", str(tmp_path / "cache"))
    spec, _ = stay
    d1, d3 = _derive(spec), _derive(_pair(spec, 3))
    assert d1.calibrated == d3.calibrated == "rivulet_angle_deg"
    assert d3.theta0 == d1.theta0 and d3.beta == d1.beta
    assert d3.ode.omega1 != d1.ode.omega1 and d3.ode.provenance["mode_pair"] == 3 and d3.mode_pair == 3
    again = _derive(_pair(spec, 3))
    assert again.from_cache and not d3.from_cache and _terms(again.ode) == _terms(d3.ode)
    assert len(list((tmp_path / "cache" / "derivations").glob("eq21-*.json"))) == 2


def test_den_hartog_onset_of_an_uncoupled_in_plane_pair():
    """The sample cable gallops in plane alone (in-plane share 1): then every pair's onset is the one-mode
    eq. (25) value U* = -2 xi_s omega1 / zeta11, zeta11 = -K nu c is the same for every pair (the
    velocity load projected on a mode, divided by its own modal mass), so U_cr grows as the pair's
    in-plane frequency, Den Hartog's criterion at a fixed damping ratio."""
    from autocable.model.onset import one_mode, stability
    spec = load_model(SAMPLE)
    base = one_mode(_derive(spec).ode)
    for k in (1, 2, 3, 4):
        d = _derive(_pair(spec, k))
        om = one_mode(d.ode)
        assert om["zeta11"] == pytest.approx(base["zeta11"], rel=1e-12)
        first = stability(d.ode, U_max=4.5).first
        assert first.in_plane_share > 0.999 and first.mechanism == "in-plane galloping"
        assert first.U_star == pytest.approx(-2 * spec.cable.damping_ratio * d.ode.omega1 / om["zeta11"], rel=1e-6)


def test_crowded_pairs_are_named_not_refused(stay):
    """Pair 25 of the 190 m stay has its neighbours (in-plane and out-of-plane modes 24 and 26) 4 % away,
    within CROWDED_FRACTION: derive warns once naming cable.mode_pair and the modes, and computes."""
    spec, st = stay
    info = pair_info(st, 25)
    assert CROWDED_FRACTION == 0.05
    gaps = sorted(round(g, 6) for *_, g in info.crowded_with)
    assert len(info.crowded_with) == 4 and gaps == pytest.approx([1 / 25] * 4, rel=1e-5)   # 1 / 25 of omega = 25
    assert not pair_info(st, 5).crowded_with
    from autocable.model.derive import derive
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", PremiseWarning)
        d = derive(_pair(spec, 25))
    texts = [str(w.message) for w in caught if issubclass(w.category, PremiseWarning) and "mode_pair" in str(w.message)]
    assert len(texts) == 1 and "cable.mode_pair = 25" in texts[0] and "out-of-plane 24" in texts[0]
    assert d.ode.omega2 == 25


# -- the commands -------------------------------------------------------------------------------------
@pytest.mark.slow
def test_onset_modes_below_3_hz_on_the_190m_stay(capsys, stay):
    """One row per pair below 3 Hz (five: the string's f_k = k 0.588 Hz), frequencies increasing, the
    first row the onset of `autocable onset` itself, the columns left to the galloping study null."""
    spec, st = stay
    code, out, _ = _cli(capsys, "onset", STAY, "--modes-below", 3, "--design-wind", 25, "--json")
    assert code == 0
    rep = json.loads(out)
    T, *_ = _groups(spec.cable)
    f1 = math.sqrt(T / spec.cable.mass_per_length_kg_m) / (2 * spec.cable.length_m)
    expected = max(k for k in range(1, 20) if k * f1 < 3.0)
    rows = rep["pairs"]
    assert [r["k"] for r in rows] == list(range(1, expected + 1)) and expected == 5
    f_in = [r["frequency_Hz"]["in_plane"] for r in rows]
    f_out = [r["frequency_Hz"]["out_of_plane"] for r in rows]
    assert all(a < b for a, b in zip(f_in, f_in[1:])) and all(a < b for a, b in zip(f_out, f_out[1:]))
    assert max(min(a, b) for a, b in zip(f_in, f_out)) < 3.0
    for r in rows:
        # filled by the galloping study (autocable.studies.pairs_galloping): a damping ratio for every pair
        assert r["least_damping_global"] is not None and 0.0 <= r["least_damping_global"] < 1.0
        assert r["crowded_with"] == [] and r["least_damping_linear"] is not None
    code, out, _ = _cli(capsys, "onset", STAY, "--design-wind", 25, "--json")
    single = json.loads(out)
    assert rows[0]["onset_U_m_s"] == single["onsets"][0]["U_m_s"]
    assert rows[0]["lyapunov"] == single["onsets"][0]["lyapunov"] and rows[0]["criticality"] == "subcritical"
    assert rows[0]["least_damping_linear"] == single["design"]["least_damping_ratio"]
    code, out, _ = _cli(capsys, "onset", STAY, "--modes-below", 3)
    assert code == 0 and "Mode pairs below 3 Hz" in out and len([l for l in out.splitlines() if l.startswith("   5 ")]) == 1


def test_pair_options_run(capsys, tmp_path):
    """onset --pair 2, derive --pair 3 --json and simulate --pair 2 run; the pair's frequency is reported
    and the forcing of simulate is near the pair's in-plane frequency."""
    code, out, _ = _cli(capsys, "onset", STAY, "--pair", 2)
    assert code == 0 and "on mode pair 2 (1.177 Hz in plane" in out and "held for mode pair 2" in out
    code, out, _ = _cli(capsys, "derive", STAY, "--pair", 3, "--json")
    rep = json.loads(out)
    assert code == 0 and rep["mode_pair"] == 3 and rep["ame"] is None and rep["omega2"] == 3.0
    code, out, _ = _cli(capsys, "simulate", STAY, "--pair", 2, "--U", 0.5, "--eta", 1e-4, "--sigma", 0.0,
                        "--max-time", 300, "--json", "--quiet")
    rep = json.loads(out)
    assert code == 0 and rep["mode_pair"] == 2 and rep["Omega"] == 2.0 and "not mid-span" in rep["peak_station"]


@pytest.mark.parametrize("args, option", [
    (("onset", STAY, "--pair", 0), "--pair"),
    (("derive", STAY, "--pair", 51), "--pair"),
    (("onset", STAY, "--modes-below", 3, "--pair", 2), "--pair"),
    (("onset", STAY, "--modes-below", -1), "--modes-below"),
    (("onset", STAY, "--modes-below", 300), "--modes-below"),
    (("simulate", STAY, "--pair", 2, "--method", "ame"), "--method"),
    (("simulate", STAY, "--pair", 2, "--modes", 2), "--pair"),
])
def test_bad_pair_options_are_one_line(capsys, args, option):
    code, out, err = _cli(capsys, *args)
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and f"arguments: {option}:" in err


@pytest.mark.parametrize("value", ['"x"', "0", "2.0", "true", "51"])
def test_a_bad_mode_pair_in_the_file_is_one_line(capsys, tmp_path, value):
    text = STAY.read_text().replace('[cable]\n', f'[cable]\nmode_pair = {value}\n')
    path = tmp_path / "m.toml"
    path.write_text(text)
    with pytest.raises(SpecError) as err:
        load_model(path)
    assert "cable.mode_pair" in str(err.value) and "integer k from 1 to 50" in str(err.value)
    code, _, e = _cli(capsys, "onset", path)
    assert code == 2 and e.count("\n") == 1 and "cable.mode_pair" in e


def test_the_amplitude_equations_refuse_pair_2(capsys, tmp_path):
    """The AME (22)-(24) are the first pair's: a model file with mode_pair = 2 runs `onset` but not the AME."""
    from autocable.model.ame_cache import derive_ame
    path = tmp_path / "pair2.toml"
    path.write_text(STAY.read_text().replace('[cable]\n', '[cable]\nmode_pair = 2\n'))
    d = _derive(load_model(path))
    with pytest.raises(SpecError) as err:
        derive_ame(d)
    assert str(err.value).startswith(f"{path}: cable.mode_pair: the amplitude equations")
    code, out, _ = _cli(capsys, "onset", path)
    assert code == 0 and "mode pair 2" in out
    code, out, err = _cli(capsys, "simulate", path, "--modes", 2)
    assert code == 2 and err.count("\n") == 1 and "arguments: --modes: " in err and "mode_pair = 2" in err
