"""The viscous damper near the anchorage (autocable/model/damper.py, `autocable damper`, a model's
[damper] in `autocable onset`): the exact taut string against Krenk's asymptotic formula and against
its closed-form limits (no damper: the string's k/(2L) sqrt(T/m); a locked damper: the string clamped
at x_d), the optimum's approach to x_d/(2L), Newton's residual, the support spring against Krenk &
Hogsberg's factor, the bending and sag factors against the exact tensioned beam and sagging cable,
the tensioned beam's own frequencies against their known expansion, and the command line."""
import cmath
import json
import math
from dataclasses import replace

import pytest

from conftest import REPO
from autocable.cli import main
from autocable.model import damper as dm
from autocable.spec import SpecError, load_model

STAY = REPO / "models" / "stay_190m.toml"
#: A unit string: T = m = L = 1 (sqrt(T m) = 1, z is omega in units of sqrt(T/m)/L).
UNIT = dm.StringCable(1.0, 1.0, 1.0)


def _cli(capsys, *args):
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


def _c(cable, k, r, kappa):
    """The damper constant of the damper parameter kappa = c k pi r / sqrt(T m)."""
    return kappa * cable.impedance / (k * math.pi * r)


# -- the exact taut string against closed forms ------------------------------------------------------
def test_exact_agrees_with_krenk_asymptotic_near_the_anchorage():
    # x_d/L = 0.01: the exact root differs from kappa / (1 + kappa^2) by O(x_d/L) (1.0-1.2 % measured)
    r = 0.01
    for k in (1, 2, 3):
        for kappa in (0.3, 1.0, 3.0):
            c = _c(UNIT, k, r, kappa)
            exact = dm.added_damping(UNIT, k, r, c)["added_damping"]
            asym = dm.asymptotic_damping(UNIT, k, r, c)["added_damping"]
            assert asym == pytest.approx(r * kappa / (1 + kappa ** 2), rel=1e-14)
            assert exact == pytest.approx(asym, rel=0.02), (k, kappa)


def test_the_optimum_tends_to_half_the_position():
    # Krenk (2000): the largest added damping is x_d/(2L) at c = sqrt(T m) / (k pi x_d/L), as x_d/L -> 0
    errors = []
    for r in (0.02, 0.005):
        opt = dm.optimum(UNIT, 1, r)
        errors.append(abs(opt["max_added_damping"] / r - 0.5))
        if r == 0.005:
            assert opt["max_added_damping"] / r == pytest.approx(0.5, rel=0.01)
            assert opt["optimal_constant_N_s_m"] == pytest.approx(_c(UNIT, 1, r, 1.0), rel=0.01)
    assert errors[1] < errors[0] / 3          # the error falls with x_d/L (linearly: 4x here)


def test_newton_residual_and_an_independent_evaluation():
    for k, r, eta in ((1, 0.02, 0.5), (2, 0.05, 3.0), (3, 0.01, 1e4), (1, 0.1, 0.01)):
        root = dm.string_root(k, r, eta)
        z = root["z"]
        assert root["residual"] < 1e-12
        # the frequency equation as first written (cot + cot = -i eta), not the scaled form solved
        lhs = 1 / cmath.tan(r * z) + 1 / cmath.tan((1 - r) * z)
        assert abs(lhs + 1j * eta) < 1e-9 * max(1.0, eta)
        assert 0 < z.imag and k * math.pi <= z.real <= k * math.pi / (1 - r) + 1e-12


def test_no_damper_gives_the_taut_string():
    cable = dm.cable_of(load_model(STAY))
    T, m, L = cable.tension_N, cable.mass_kg_m, cable.length_m
    for k in (1, 2, 3):
        assert dm.string_root(k, 0.02, 0.0)["z"] == k * math.pi
        res = dm.added_damping(cable, k, 3.8, 1e-9)            # a damper of 1e-9 N s/m
        assert res["added_damping"] < 1e-12
        f = k / (2 * L) * math.sqrt(T / m)
        assert res["frequency_Hz"] == pytest.approx(f, rel=1e-14)
        assert res["damped_frequency_Hz"] == pytest.approx(f, rel=1e-12)


def test_a_locked_damper_clamps_the_string_at_its_position():
    cable = dm.cable_of(load_model(STAY))
    T, m, L, xd = cable.tension_N, cable.mass_kg_m, cable.length_m, 3.8
    for k in (1, 2, 3):
        locked = dm.added_damping(cable, k, xd, math.inf)
        f = k / (2 * (L - xd)) * math.sqrt(T / m)
        assert locked["damped_frequency_Hz"] == pytest.approx(f, rel=1e-12)
        assert locked["added_damping"] < 1e-12
        stiff = dm.added_damping(cable, k, xd, 1e6 * cable.impedance)   # approaches it as c grows
        assert stiff["damped_frequency_Hz"] == pytest.approx(f, rel=1e-5)


def test_a_support_spring_lowers_the_maximum_by_krenk_hogsberg_factor():
    # nu = k_s x_d / T: the maximum x_d/(2L) times nu/(1+nu) (Krenk & Hogsberg 2005)
    r = 0.005
    for nu in (0.5, 1.0, 4.0):
        ks = nu * UNIT.tension_N / r
        opt = dm.optimum(UNIT, 1, r, support_stiffness_N_m=ks)
        assert opt["max_added_damping"] / r == pytest.approx(0.5 * nu / (1 + nu), rel=0.01)
        assert opt["optimal_constant_N_s_m"] == pytest.approx(_c(UNIT, 1, r, nu / (1 + nu)), rel=0.01)
    rigid = dm.added_damping(UNIT, 1, r, _c(UNIT, 1, r, 1.0))["added_damping"]
    stiff = dm.added_damping(UNIT, 1, r, _c(UNIT, 1, r, 1.0), support_stiffness_N_m=1e12)["added_damping"]
    assert stiff == pytest.approx(rigid, rel=1e-8)


def test_least_constant_round_trip_and_refusal():
    cable = dm.cable_of(load_model(STAY))
    xd = 3.8
    opt = dm.optimum(cable, 1, xd)
    target = 0.6 * opt["max_added_damping"]
    c, why = dm.least_constant(cable, xd, target, 1)
    assert why == "" and 0 < c < opt["optimal_constant_N_s_m"]
    assert dm.added_damping(cable, 1, xd, c)["added_damping"] == pytest.approx(target, rel=1e-9)
    # the design value (bending and sag) needs a little more than the taut string alone
    c_corr, _ = dm.least_constant(cable, xd, target, 1, corrected=True)
    md = dm.mode_damping(cable, 1, xd, c_corr)
    assert md.added_damping_corrected == pytest.approx(target, rel=1e-9) and c_corr > c
    none, why = dm.least_constant(cable, xd, 0.02, 1)
    assert none is None and "at most" in why and "x_d/L" in why
    with pytest.raises(SpecError, match="least_constant: position_m"):
        dm.least_constant(cable, 100.0, 0.01)
    with pytest.raises(SpecError, match="least_constant: target"):
        dm.least_constant(cable, xd, -0.01)


# -- the corrections against exact routes ------------------------------------------------------------
def _beam_zeta(k, r, eta, xi):
    z = dm.beam_root(k, r, eta, xi)
    return z.imag / abs(z)


def test_tensioned_beam_frequencies_match_their_expansion():
    # a clamped tensioned beam: omega_k / omega_k,string = 1 + 2/xi + (4 + k^2 pi^2 / 2) / xi^2 + O(xi^-3)
    for xi in (1000.0, 3000.0):
        for k in (1, 2, 3):
            z = dm.beam_root(k, 0.02, 0.0, xi)
            expansion = k * math.pi * (1 + 2 / xi + (4 + k * k * math.pi ** 2 / 2) / xi ** 2)
            assert abs(z.real / expansion - 1) < 200 / xi ** 3, (xi, k)


def test_bending_factors_against_the_exact_beam():
    from scipy.optimize import minimize_scalar
    r = 0.02
    for eps in (5.0, 20.0):          # x_d / sqrt(EI/T)
        xi = eps / r
        cable = dm.StringCable(1.0, 1.0, 1.0, bending_stiffness_Nm2=1 / xi ** 2)
        Rf, Ef = dm.bending_factors(cable, r)
        assert Rf == pytest.approx(1 - 1 / (2 * eps), abs=2 / eps ** 2 + 2 / xi)   # its leading order
        small = 1e-3
        slope = _beam_zeta(1, r, small, xi) / (dm.string_root(1, r, small)["z"].imag / math.pi)
        assert slope == pytest.approx(Ef, rel=0.005)
        string_max = dm.optimum(cable, 1, r)["max_added_damping"]
        t0 = math.atan(_c(cable, 1, r, Rf / Ef))
        best = minimize_scalar(lambda t: -_beam_zeta(1, r, math.tan(t), xi),
                               bounds=(math.atan(math.tan(t0) / 3), math.atan(math.tan(t0) * 3)),
                               method="bounded", options={"xatol": 1e-6})
        assert -best.fun / string_max == pytest.approx(Rf, rel=0.005)


def test_sag_factors_against_the_exact_sagging_cable():
    from scipy.optimize import minimize_scalar
    r = 0.01
    lam2 = 2.0
    cable = dm.StringCable(1.0, 1.0, 1.0, lambda2=lam2)
    for k in (1, 2):
        Rs, Es = dm.sag_factors(cable, k)
        if k == 2:
            assert (Rs, Es) == (1.0, 1.0)         # an antisymmetric mode does not stretch the cable
        small = 1e-3
        zs = dm.sag_root(k, r, small, lam2)
        slope = (zs.imag / abs(zs)) / dm._zeta(dm.string_root(k, r, small)["z"])
        assert slope == pytest.approx(Es, rel=0.01)
        string_max = dm.optimum(cable, k, r)["max_added_damping"]
        t0 = math.atan(_c(cable, k, r, Rs / Es))

        def neg(t):
            z = dm.sag_root(k, r, math.tan(t), lam2)
            return -z.imag / abs(z)
        best = minimize_scalar(neg, bounds=(math.atan(math.tan(t0) / 3), math.atan(math.tan(t0) * 3)),
                               method="bounded", options={"xatol": 1e-7})
        assert -best.fun / string_max == pytest.approx(Rs, rel=0.01)
    # Irvine's crossover lambda^2 = 4 pi^2: the first symmetric mode has no slope at the anchorage
    Rs, Es = dm.sag_factors(dm.StringCable(1.0, 1.0, 1.0, lambda2=4 * math.pi ** 2), 1)
    assert Rs < 1e-12 and Es < 1e-12
    # the undamped sagging cable: Irvine's root, 2x with tan x = x - 4 x^3 / lambda^2
    z = dm.sag_root(1, r, 0.0, lam2)
    x = z.real / 2
    assert math.tan(x) == pytest.approx(x - 4 * x ** 3 / lam2, abs=1e-9)


# -- the model file, the command line, onset ---------------------------------------------------------
def _with_damper(tmp_path, body: str, name="damped.toml"):
    text = STAY.read_text().replace("[aero]", f"[damper]\n{body}\n\n[aero]", 1)
    path = tmp_path / name
    path.write_text(text)
    return path


def test_damper_table_parsed_and_hashed(tmp_path):
    plain = load_model(STAY)
    spec = load_model(_with_damper(tmp_path, "position_m = 3.8\nconstant_N_s_m = 3.0e5"))
    assert spec.damper.position_m == 3.8 and spec.damper.support_stiffness_N_m is None
    assert spec.content_hash() != plain.content_hash()
    assert replace(spec, damper=None).content_hash() == plain.content_hash()   # a model without one: as before
    assert load_model(_with_damper(tmp_path, "position_m = 3.8\nconstant_N_s_m = 3.0e5\n"
                                             "support_stiffness_N_m = 1e7")).content_hash() != spec.content_hash()


@pytest.mark.parametrize("body, field", [
    ("position_m = 96.0\nconstant_N_s_m = 1e5", "damper.position_m"),
    ("position_m = 0.0\nconstant_N_s_m = 1e5", "damper.position_m"),
    ("position_m = 3.0", "damper.constant_N_s_m"),
    ("position_m = 3.0\nconstant_N_s_m = nan", "damper.constant_N_s_m"),
    ("position_m = 3.0\nconstant_N_s_m = 1e5\nsupport_stiffness_N_m = 0", "damper.support_stiffness_N_m"),
    ("position_m = 3.0\nconstant_N_s_m = 1e5\nconstant = 1", "damper.constant"),
])
def test_bad_damper_fields_refused_in_one_line(tmp_path, capsys, body, field):
    path = _with_damper(tmp_path, body)
    code, out, err = _cli(capsys, "damper", path)
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and f": {field}: " in err and "Traceback" not in err


def test_cli_json_keys_and_numbers(capsys):
    code, out, err = _cli(capsys, "damper", STAY, "--position", 3.8, "--constant", 3e5, "--json")
    assert code == 0, err
    rep = json.loads(out)
    assert [m["k"] for m in rep["modes"]] == [1, 2, 3, 4, 5]      # f_k <= 3 Hz, f1 = 0.588 Hz
    keys = {"k", "frequency_Hz", "optimal_constant_N_s_m", "max_added_damping", "added_damping",
            "added_damping_asymptotic", "added_damping_corrected", "damped_frequency_Hz", "residual"}
    assert all(keys <= set(m) for m in rep["modes"])
    cable = dm.cable_of(load_model(STAY))
    m1 = rep["modes"][0]
    assert m1["added_damping"] == dm.added_damping(cable, 1, 3.8, 3e5)["added_damping"]
    assert m1["residual"] < 1e-12
    code, out, _ = _cli(capsys, "damper", STAY, "--position", 3.8, "--constant", 3e5, "--max-frequency", 1.0,
                        "--json")
    assert [m["k"] for m in json.loads(out)["modes"]] == [1]


@pytest.mark.parametrize("argv, option", [
    ([], "--position"),
    (["--position", "3"], "--constant"),
    (["--position", "95", "--constant", "1e5"], "--position"),
    (["--position", "-1", "--constant", "1e5"], "--position"),
    (["--position", "3", "--constant", "0"], "--constant"),
    (["--position", "3", "--constant", "inf"], "--constant"),
    (["--position", "3", "--constant", "1e5", "--max-frequency", "0.3"], "--max-frequency"),
    (["--position", "3", "--constant", "1e5", "--max-frequency", "nan"], "--max-frequency"),
    (["--position", "3", "--constant", "1e5", "--max-frequency", "500"], "--max-frequency"),
    (["--position", "3", "--constant", "1e5", "--design-wind", "0"], "--design-wind"),
    (["--position", "3", "--constant", "1e5", "--out", ""], "--out"),
])
def test_bad_options_refused_in_one_line(capsys, argv, option):
    code, out, err = _cli(capsys, "damper", STAY, *argv)
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and f": {option}: " in err and "Traceback" not in err


def test_a_damper_far_from_the_anchorage_is_said_not_guessed(capsys):
    # x_d/L = 0.42: mode 1 turns overdamped before c is reached (k x_d/L near 1/2): exit 3, one line
    code, out, err = _cli(capsys, "damper", STAY, "--position", 80, "--constant", 3e4)
    assert code == 3 and out == "" and err.count("\n") == 1 and "overdamped" in err
    # x_d = 40 m is a node of mode 5 (x_d/L = 0.21): modes 1-4 are reported, mode 5 is named in a note
    code, out, err = _cli(capsys, "damper", STAY, "--position", 40, "--constant", 3e4, "--json")
    rep = json.loads(out)
    assert code == 0 and [m["k"] for m in rep["modes"]] == [1, 2, 3, 4]
    assert rep["notes"] and rep["notes"][0].startswith("mode 5 is not reported")


def test_out_folder_written_and_foreign_files_refused(tmp_path, capsys):
    out = tmp_path / "d"
    code, _, err = _cli(capsys, "damper", STAY, "--position", 3.8, "--constant", 3e5, "--out", out)
    assert code == 0, err
    assert {p.name for p in out.iterdir()} == {"damper.json", "damper.png", "damper.pdf", "run.json"}
    rep = json.loads((out / "damper.json").read_text())
    assert len(rep["curves"]) == len(rep["modes"]) and json.loads((out / "run.json").read_text())["status"] == "complete"
    (out / "notes.txt").write_text("mine")
    code, _, err = _cli(capsys, "damper", STAY, "--position", 3.8, "--constant", 3e5, "--out", out)
    assert code == 2 and "notes.txt" in err and err.count("\n") == 1


def test_design_wind_least_constant_keeps_the_onset_above_it(tmp_path, capsys):
    """End to end: the least constant for a 25 m/s design wind, written into the model's [damper],
    puts eq. (21)'s onset at the design wind (onset's own bisection, 1e-8 in xi), and 3 % less
    constant puts it below."""
    code, out, err = _cli(capsys, "damper", STAY, "--position", 3.8, "--design-wind", 25, "--json")
    assert code == 0, err
    ds = json.loads(out)["design"]
    assert ds["target_added_damping"] == pytest.approx(ds["least_damping_ratio"] - 0.001, rel=1e-12)
    c = ds["least_constant_N_s_m"]
    for factor, above in ((1.0 + 1e-4, True), (0.97, False)):
        path = _with_damper(tmp_path, f"position_m = 3.8\nconstant_N_s_m = {c * factor!r}", f"d{factor}.toml")
        code, out, err = _cli(capsys, "onset", path, "--json")
        assert code == 0, err
        rep = json.loads(out)
        assert rep["damper"]["total_damping"] == pytest.approx(rep["damping_ratio"], rel=1e-15)
        first = min([o["U_m_s"] for o in rep["onsets"]] + [math.inf])
        assert (first > 25.0) is above, (factor, first)
    code, out, err = _cli(capsys, "onset", path)
    assert code == 0 and "damper at 3.8 m" in out and "adds" in out
    # --modes-below: the pair's row carries the same damper (pair 1 only: below 0.7 Hz)
    code, out, err = _cli(capsys, "onset", path, "--modes-below", 0.7, "--json")
    assert code == 0, err
    row = json.loads(out)["pairs"][0]
    assert row["damper_added_damping"] == pytest.approx(rep["damper"]["added_damping"], rel=1e-12)
    assert row["onset_U_m_s"] == pytest.approx(first, rel=1e-9)
