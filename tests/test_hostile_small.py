"""The small defects a hostile user found, each turned into a test that fails
without its fix: onset's damping grid with a non-finite point count, a cable field set twice, a
vanishing diameter, refusals quoting a number as typed, a slowly decaying run reported as decaying
to rest, and the spec fuzz's refusals naming the field that was changed (not only a derived one).
"""
import math
import random

import numpy as np
import pytest

from autocable.cli import main
from autocable.cli.checks import response_status
from autocable.model.premises import check_model
from autocable.spec import SpecError, load_model, number_text, show
from conftest import SAMPLE

#: One line: the standards keep messages short.
MAX_LINE = 300


def _refused(capsys, argv, *needles):
    """Run the CLI in-process: exit 2, one short line on stderr containing every needle, and no
    catch-all line naming a Python exception (``autocable: error (ValueError): ...``)."""
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and len(err) < MAX_LINE, err
    assert "error (" not in err and "Traceback" not in err, err
    for n in needles:
        assert n in err, (n, err)
    return err


def _spec(tmp_path, old: str, new: str):
    text = SAMPLE.read_text()
    assert old in text, old
    path = tmp_path / "m.toml"
    path.write_text(text.replace(old, new, 1))
    return path


# -- onset's options ---------------------------------------------------------------------------------
@pytest.mark.parametrize("grid", ["0.001:0.01:nan", "0.001:0.01:inf", "0.001:0.01:-inf"])
def test_damping_grid_with_a_non_finite_count_is_refused_by_name(capsys, grid):
    """int(nan) raised a bare ValueError and int(inf) an OverflowError (a traceback line)."""
    _refused(capsys, ["onset", str(SAMPLE), "--damping", grid], "--damping", "N:", grid.rsplit(":", 1)[1])


def test_one_field_set_twice_is_refused(capsys):
    """Two --set of one field kept the last silently (a typing error hidden)."""
    _refused(capsys, ["onset", str(SAMPLE), "--set", "cable.damping_ratio=0.01", "--set",
                      " cable.damping_ratio = 0.02"], "--set", "cable.damping_ratio", "twice")


def test_vanishing_diameter_is_refused_naming_the_field(capsys):
    """D = 1e-200 m passed every check and divided by zero (D^2 underflows) in the Scruton number."""
    _refused(capsys, ["onset", str(SAMPLE), "--set", "cable.diameter_m=1e-200"], "[cable] diameter_m",
             "slenderness")


# -- numbers quoted as typed -------------------------------------------------------------------------
def test_refusals_quote_a_number_as_typed(tmp_path, capsys):
    """``repr`` spells 1e9 as 1000000000.0; the refusal quotes 1e9 (docs/robustness.md)."""
    err = _refused(capsys, ["onset", str(SAMPLE), "--max-wind", "1e9"], "--max-wind", "got 1e9")
    assert "1000000000" not in err
    path = _spec(tmp_path, "damping_ratio = ", "damping_ratio = 1e9 #")
    err = _refused(capsys, ["derive", str(path)], "cable.damping_ratio", "got 1e9")
    assert "1000000000" not in err


def test_number_text_reads_back_and_is_never_longer_than_repr():
    """Closed property on 4000 seeded floats over 600 decades: float(text) == x, and the text is the
    shortest exponent form where that is 3 characters shorter than repr (1e9 -> '1e9') and repr
    otherwise (0.5000001 and 500.0 stay: '5e2' is not what anyone typed)."""
    rng = random.Random(39)
    for _ in range(4000):
        x = rng.choice((-1, 1)) * rng.random() * 10.0 ** rng.randint(-300, 300)
        if rng.random() < 0.3:
            x = float(f"{x:.{rng.randint(0, 4)}e}")         # few digits, as people type them
        text = number_text(x)
        assert float(text) == x and len(text) <= len(repr(x)), (x, text)
    for x, want in ((1e9, "1e9"), (0.5000001, "0.5000001"), (1e-200, "1e-200"), (-2.5e-7, "-2.5e-7"),
                    (123456.0, "123456.0"), (0.1, "0.1"), (3.0, "3.0"), (500.0, "500.0"), (-1.0, "-1.0"),
                    (1e5, "1e5")):
        assert number_text(x) == want and show(x) == want
    assert show(1000000000) == "1000000000"                  # an integer as written
    assert show(float("nan")) == "nan"


# -- the spec fuzz names the changed field -----------------------------------------------------------
@pytest.mark.parametrize("old,new,field", [
    ("length_m = 121.9", "length_m = 1e300", "cable.length_m"),
    ("length_m = 121.9", "length_m = 1e9", "cable.length_m"),
    ("mass_per_length_kg_m = ", "mass_per_length_kg_m = 1e-9 #", "cable.mass_per_length_kg_m"),
    ("mass_per_length_kg_m = ", "mass_per_length_kg_m = 1e-300 #", "cable.mass_per_length_kg_m"),
    ("diameter_m = 0.119", "diameter_m = 1e-9", "cable.diameter_m"),
    ("diameter_m = 0.119", "diameter_m = 1e-300", "cable.diameter_m"),
    ("chord_slope_deg = ", "chord_slope_deg = 89.999999 #", "cable.chord_slope_deg"),
    ("axial_stiffness_N = 2.1688e9", "axial_stiffness_N = 1e300", "cable.axial_stiffness_N"),
])
def test_premise_refusal_names_the_changed_field(tmp_path, old, new, field):
    """The derived quantity's refusal lists every field it is made of: tau = H/(cos alpha EA) named
    no alpha, delta = m g l cos^2/H neither l nor alpha, lambda^2 = delta^2/tau neither m nor l; a
    diameter of 1e-9 m passed (D/l had no lower bound) and the calibration then blamed the wind angle."""
    with pytest.raises(SpecError) as err:
        check_model(load_model(_spec(tmp_path, old, new)))
    # "check [cable] mass_per_length_kg_m, ...": lambda^2's six fields fit in the one line uncut
    msg = str(err.value)
    table, key = field.split(".")
    assert f"[{table}]" in msg and key in msg and "\n" not in msg and not msg.endswith("..."), msg


# -- a slow exponential decay is decaying to rest, not "not steady" ---------------------------------
def test_decay_rate_of_synthetic_envelopes():
    """Closed forms: a pure exponential gives its rate to rounding; an approach to a cycle
    (a* + c exp(-r t) with a* comparable) slows down, a growth grows, a modulation rises and falls:
    none is a decay to rest."""
    from autocable.methods.integration.ode21 import decay_rate
    t = np.arange(1, 11) * 628.3
    r = 2e-3
    rate = decay_rate(t, [(1e-3 * math.exp(-r * x), 1e-5 * math.exp(-3 * r * x)) for x in t])
    assert rate == pytest.approx(r, rel=1e-12)
    assert decay_rate(t, [(5e-3 + 5e-3 * math.exp(-r * x), 0.0) for x in t]) is None
    assert decay_rate(t, [(1e-6 * math.exp(r * x), 0.0) for x in t]) is None
    assert decay_rate(t, [(1e-3 * (1.5 + math.sin(x / 900)), 0.0) for x in t]) is None
    assert decay_rate(t[:3], [(1e-3 * math.exp(-r * x), 0.0) for x in t[:3]]) is None   # too few chunks


@pytest.fixture(scope="module")
def slow_decay(derivation):
    """The sample cable at U* = 0.5, eta* = 0 from q = 1e-3: the trivial state is stable (U_cr = 1)
    but lightly damped; at t = 5000 the amplitude is 2.4e-7, far above the rest floor 1e-10."""
    from autocable.methods.integration.ode21 import Ode21Integrator
    integ = Ode21Integrator(derivation.ode, engine="compiled")
    return integ.simulate(0.5, 0.0, 0.0, (1e-3, 0.0, 1e-3, 0.0), max_time=5000.0)


def test_slow_decay_rate_is_the_linear_rate_at_rest(derivation, slow_decay):
    """Independent route: the least-damped eigenvalue of the Jacobian of eq. (21)'s first-order
    right-hand side at rest (sympy, exact derivative), Re = -2.008e-3; the fitted envelope decay
    agrees to 1e-3 relative (measured 2.5e-4)."""
    import sympy as sp

    from autocable.model.symbolic import PARAMETERS, STATE, T, first_order_rhs, parameter_values
    jac = sp.Matrix(first_order_rhs(derivation.ode)).jacobian(sp.Matrix(STATE))
    values = parameter_values(0.5, 0.0, derivation.ode.omega1)
    at = {s: values[str(s)] for s in PARAMETERS} | {s: 0 for s in STATE} | {T: 0}
    linear = -max(np.linalg.eigvals(np.array(jac.subs(at).evalf(), dtype=float)).real)
    r = slow_decay
    assert not r.steady and linear > 0
    assert r.decay_rate == pytest.approx(linear, rel=1e-3)
    assert "decaying to rest" in r.message and r.message.startswith("not steady")
    assert response_status(r.a1, r.steady, r.decay_rate) == "decaying"


def test_growth_near_the_onset_is_not_decaying(derivation):
    """Just above the onset (U* = 1.01) a tiny start grows: "not_steady", no decay rate."""
    from autocable.methods.integration.ode21 import Ode21Integrator
    r = Ode21Integrator(derivation.ode, engine="compiled").simulate(1.01, 0.0, 0.0, (1e-6, 0.0, 1e-6, 0.0),
                                                                    max_time=5000.0)
    assert not r.steady and math.isnan(r.decay_rate)
    assert response_status(r.a1, r.steady, r.decay_rate) == "not_steady"


def test_simulate_reports_decaying(capsys):
    """The command line's status and message for the slow decay (one in-process run, ~2 s)."""
    import json
    assert main(["simulate", str(SAMPLE), "--U", "0.5", "--q0", "1e-3", "0", "1e-3", "0", "--max-time",
                 "5000", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["status"] == "decaying" and "decaying to rest" in out["message"] and not out["steady"]


# -- simulate --q0 with negative numbers in e-notation ------------------------------------------------
@pytest.mark.parametrize("tokens", [("-1e-3", "0", "-2E-6", "0"), ("-.5e-3", "-1e-300", "0", "-1.5e+0"),
                                    ("0", "0", "-1e-3", "-0.0")])
def test_q0_takes_negative_numbers_in_e_notation(tokens):
    """argparse's own negative-number pattern misses the exponent, so "-1e-3" read as an option."""
    from autocable.cli import build_parser
    args = build_parser().parse_args(["simulate", str(SAMPLE), "--q0", *tokens, "--max-time", "200"])
    assert args.q0 == [float(t) for t in tokens]


def test_q0_in_one_comma_separated_token_is_a_named_refusal(capsys):
    """``--q0=-1e-3,0,0,0`` is not a form --q0 takes (four values, separated by spaces): refused in one
    line naming --q0, not run with a misread start."""
    with pytest.raises(SystemExit) as exc:
        main(["simulate", str(SAMPLE), "--q0=-1e-3,0,0,0"])
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert "--q0" in err


# -- a user's file named like an output --------------------------------------------------------------
def test_out_without_run_json_keeps_a_users_file_named_like_an_output(tmp_path, capsys):
    """Found by the generated runs (tools/hardening/fuzz_options.py): ``damper --out`` into a folder
    holding only the user's own damper.png replaced it (a folder without run.json counted every
    output name as autocable's). Now refused naming --out, the file untouched."""
    out = tmp_path / "mine"
    out.mkdir()
    (out / "damper.png").write_text("my photo")
    _refused(capsys, ["damper", str(SAMPLE), "--position", "2", "--constant", "1e5", "--out", str(out)], "--out",
             "damper.png")
    assert (out / "damper.png").read_text() == "my photo" and sorted(p.name for p in out.iterdir()) == ["damper.png"]


# -- found by the generated runs on onset and damper ----------------------------------------------------
def test_empty_damping_grid_is_refused_not_ignored(capsys):
    """``--damping=`` (empty) was taken for "not given": exit 0 without a damping study."""
    _refused(capsys, ["onset", str(SAMPLE), "--damping="], "--damping")


@pytest.mark.parametrize("checks", ["21", "-1"])
def test_band_does_not_skip_the_checks_option(capsys, checks):
    """``onset --band --checks=21`` ran the band study and exited 0: --checks was checked only on
    the path without --band."""
    _refused(capsys, ["onset", str(SAMPLE), "--band", f"--checks={checks}"], "--checks")


def test_a_damper_too_far_out_names_the_position(capsys):
    """A damper near mid-span (x_d/L = 0.4996) cannot be followed from the undamped string: a
    failure (exit 3) that names the field and the option to change."""
    assert main(["damper", str(SAMPLE), "--position", "60.9", "--constant", "1e5"]) == 3
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "damper.position_m" in err and "--position" in err, err


def test_a_zero_dimensional_array_is_refused_by_name(derivation):
    """Found by the generated API calls: ``sigma=np.array(1e-4)`` raised a bare TypeError ("len() of
    unsized object": a 0-d array has ``__len__`` but no length); now the argument is named."""
    from autocable.methods.frequency_response import frequency_response
    from autocable.methods.integration.shooting import ShootingSolver
    from autocable.model.premises import ArgumentError
    with pytest.raises(ArgumentError, match="sigma"):
        frequency_response(derivation, eta=8.2e-5, sigma=np.array(1e-4), switch=False)
    with pytest.raises(ArgumentError, match="q0"):
        ShootingSolver(derivation.ode).steady(0.0, 8.2e-5, 0.0, np.array(0.1))


def test_strict_json_takes_numpy_booleans():
    """Found by the generated onset runs: ``onset --damping A:B --out DIR --design-wind 20 --json``
    ended in "TypeError: Object of type bool_ is not JSON serializable" (the amplitude rows' numpy
    booleans); strict JSON now writes them as true/false."""
    import json

    from autocable.cli.checks import dumps
    assert json.loads(dumps({"stable": np.bool_(True), "rows": [np.bool_(False), np.float32(0.5)]})) == \
        {"stable": True, "rows": [False, 0.5]}
