"""The Python API is as strict as the command line: one checker (`autocable.model.premises`:
check_number, check_interval, check_choice, check_type, check_call) behind both, and every bad
argument of a public function an `ArgumentError` (a `SpecError`, so a `ValueError`) naming the
function, the argument and the value as given, before any work; numpy scalars are numbers, bools
are not."""
from __future__ import annotations

import numpy as np
import pytest

import autocable as ac
from autocable._paths import SAMPLE_MODEL
from autocable.model.premises import (ArgumentError, check_choice, check_interval, check_number,
                                      check_type)
from autocable.spec import SpecError, show

SAMPLE = str(SAMPLE_MODEL)


@pytest.fixture(scope="module")
def eq21():
    return ac.derive(SAMPLE)


@pytest.fixture(scope="module")
def response(eq21):
    return ac.frequency_response(eq21, U=0.0, eta=1.4e-3, sigma=(-0.05, 0.05), switch=False)


@pytest.fixture(scope="module")
def plain(response):
    """Branch I without the cable's SI scales (as a branch read from elsewhere)."""
    return response.branch("I").replace(info={})


def _with_scales(eq21, response):
    """``response`` carrying the cable's SI scales as a run's provenance does."""
    from dataclasses import asdict

    from autocable.model.units import units_of
    from autocable.results import RunResults
    return RunResults("fr", response.branches, {"si_scales": asdict(units_of(eq21.spec, eq21.statics)),
                                                "omega1": eq21.ode.omega1})


# (call, the argument the message must name, the value it must quote) -- each a case the issue
# found raising a builtin error, or taken without a word
CASES = {
    "eta=10": (lambda e, b: ac.frequency_response(e, eta=10), "eta", 10),
    "U=1e6": (lambda e, b: ac.frequency_response(e, U=1e6, eta=1e-3), "U", 1e6),
    "eta=True": (lambda e, b: ac.frequency_response(e, eta=True), "eta", True),
    "eta=np.bool_": (lambda e, b: ac.frequency_response(e, eta=np.bool_(True)), "eta", np.bool_(True)),
    "eta missing": (lambda e, b: ac.frequency_response(e), "eta", None),
    "eta=np.float32(10)": (lambda e, b: ac.frequency_response(e, eta=np.float32(10)), "eta", np.float32(10)),
    "sigma=None": (lambda e, b: ac.frequency_response(e, eta=1e-3, sigma=None), "sigma", None),
    "sigma=(0.1,)": (lambda e, b: ac.frequency_response(e, eta=1e-3, sigma=(0.1,)), "sigma", (0.1,)),
    "sigma reversed": (lambda e, b: ac.frequency_response(e, eta=1e-3, sigma=(0.05, -0.05)), "sigma", None),
    "sigma=(0, 9)": (lambda e, b: ac.frequency_response(e, eta=1e-3, sigma=(0.0, 9.0)), "sigma[1]", 9.0),
    "sigma=(nan, 0)": (lambda e, b: ac.frequency_response(e, eta=1e-3, sigma=(float("nan"), 0.0)), "sigma[0]", None),
    "settings='x'": (lambda e, b: ac.frequency_response(e, eta=1e-3, settings="x"), "settings", "x"),
    "ame='x'": (lambda e, b: ac.frequency_response(e, eta=1e-3, ame="x"), "ame", "x"),
    "ordering='x'": (lambda e, b: ac.frequency_response(e, eta=1e-3, ordering="x"), "ordering", "x"),
    "engine='x'": (lambda e, b: ac.frequency_response(e, eta=1e-3, engine="x"), "engine", "x"),
    "switch='yes'": (lambda e, b: ac.frequency_response(e, eta=1e-3, switch="yes"), "switch", "yes"),
    "progress=3": (lambda e, b: ac.frequency_response(e, eta=1e-3, progress=3), "progress", 3),
    "source=3": (lambda e, b: ac.frequency_response(3, eta=1e-3), "source", 3),
    "AmeIntegrator(None)": (lambda e, b: ac.AmeIntegrator(None), "ame", None),
    "Ode21Integrator(None)": (lambda e, b: ac.Ode21Integrator(None), "ode", None),
    "ShootingSolver(None)": (lambda e, b: ac.ShootingSolver(None), "ode", None),
    "steady U=1e6": (lambda e, b: ac.ShootingSolver(e.ode).steady(1e6, 1e-3, 0.0), "U", 1e6),
    "steady eta=True": (lambda e, b: ac.ShootingSolver(e.ode).steady(0.0, True, 0.0), "eta", True),
    "steady rest_floor=(0.1,)": (lambda e, b: ac.ShootingSolver(e.ode).steady(0.0, 1e-3, 0.0, rest_floor=(0.1,)),
                                 "rest_floor", (0.1,)),
    "run_scene(3)": (lambda e, b: ac.run_scene(3, "out"), "scene", None),
    "run_scene out=None": (lambda e, b: ac.run_scene("runs/fig03.toml", None), "out_dir", None),
    "plot units='si' without scales": (lambda e, b: ac.plot_branches([b], x="sigma", units="si"), "units", None),
    "plot units='x'": (lambda e, b: ac.plot_branches([b], x="sigma", units="x"), "units", "x"),
    "plot ax='x'": (lambda e, b: ac.plot_branches([b], x="sigma", ax="x"), "ax", "x"),
    "plot y unknown": (lambda e, b: ac.plot_branches([b], x="sigma", y=("zz",)), "y[0]", "zz"),
    "plot y='zz'": (lambda e, b: ac.plot_branches([b], x="sigma", y="zz"), "y", "zz"),
    "plot x unknown": (lambda e, b: ac.plot_branches([b], x="zz"), "x", None),
    "plot branches='x'": (lambda e, b: ac.plot_branches("x", x="sigma"), "branches", None),
    "plot branches=[3]": (lambda e, b: ac.plot_branches([3], x="sigma"), "branches[0]", None),
    # the table of autocable.api_checks, and the classes' own checks
    "derive_ame(3)": (lambda e, b: ac.derive_ame(3), "source", 3),
    "derive_ame ordering": (lambda e, b: ac.derive_ame(e, ordering="x"), "ordering", "x"),
    "ame_system(None)": (lambda e, b: ac.ame_system(None, "2dof"), "ame", None),
    "ame_system dof": (lambda e, b: ac.ame_system(ac.derive_ame(e).ame, "3dof"), "dof", "3dof"),
    "EquilibriumProblem(None)": (lambda e, b: ac.EquilibriumProblem(None, "sigma", {}, (0, 1)), "system", None),
    "EquilibriumProblem parameter": (lambda e, b: ac.EquilibriumProblem(_system(e), "x", {}, (0, 1)), "parameter", "x"),
    "EquilibriumProblem values": (lambda e, b: ac.EquilibriumProblem(_system(e), "sigma", None, (0, 1)), "values", None),
    "EquilibriumProblem values key": (lambda e, b: ac.EquilibriumProblem(_system(e), "sigma", {"zz": 1.0}, (0, 1)),
                                      "values['zz']", None),
    "EquilibriumProblem bounds": (lambda e, b: ac.EquilibriumProblem(_system(e), "sigma", {}, (1,)), "bounds", (1,)),
    "ContinuationSettings max_step": (lambda e, b: ac.ContinuationSettings(max_step="x"), "max_step", "x"),
    "ContinuationSettings max_points": (lambda e, b: ac.ContinuationSettings(max_points=True), "max_points", True),
    "continue_equilibria problem": (lambda e, b: ac.continue_equilibria("x"), "problem", "x"),
    "continue_equilibria settings": (lambda e, b: ac.continue_equilibria(_problem(e), "x"), "settings", "x"),
    "continue_equilibria engine": (lambda e, b: ac.continue_equilibria(_problem(e), engine="x"), "engine", "x"),
    "switch_branch('x')": (lambda e, b: ac.switch_branch("x", "BP1"), "source", "x"),
    "continue_cycles(None)": (lambda e, b: ac.continue_cycles(None, "H1"), "source", None),
    "continue_folds bounds": (lambda e, b: ac.continue_folds(_result(e), "LP1", "eta", (1.0,)), "bounds", (1.0,)),
    "read_results(3)": (lambda e, b: ac.read_results(3), "out_dir", 3),
    "load_scene(3)": (lambda e, b: ac.load_scene(3), "path", 3),
    "load_sweep(None)": (lambda e, b: ac.load_sweep(None), "path", None),
    "si_scales('x')": (lambda e, b: ac.si_scales("x", 1.0, 1.0), "length_m", "x"),
    "sweep missing": (lambda e, b: ac.sweep(None), "parameter", None),
    "plot_plane(None)": (lambda e, b: ac.plot_plane(None, x="sigma", y="eta"), "results", None),
    "save_figure(None)": (lambda e, b: ac.save_figure(None, "x"), "fig", None),
    "write_results(None)": (lambda e, b: ac.write_results(None, "x"), "results", None),
    "branches_dataframe(3)": (lambda e, b: ac.branches_dataframe(3), "branches", 3),
}


def _system(eq21):
    return ac.ame_system(ac.derive_ame(eq21).ame, "2dof", wind=False)


def _problem(eq21):
    return ac.EquilibriumProblem(_system(eq21), "sigma", {"U": 0.0, "eta": 1.4e-3, "sigma": -0.05}, (-0.05, 0.05))


def _result(eq21):
    return ac.continue_equilibria(_problem(eq21), ac.ContinuationSettings(max_step=0.02, max_points=5))


@pytest.mark.parametrize("case", sorted(CASES))
def test_bad_argument_is_named(eq21, plain, case):
    """One line, the package's own error naming the argument (``function: argument: ...``) and,
    where it is a value, quoting it as given."""
    call, name, value = CASES[case]
    with pytest.raises(ArgumentError) as info:
        call(eq21, plain)
    text = str(info.value)
    assert f": {name}: " in text, text
    assert "\n" not in text
    if value is not None:
        assert show(value) in text, text
    assert isinstance(info.value, SpecError) and isinstance(info.value, ValueError)


def test_numpy_scalars_are_numbers(eq21, response):
    """np.float32, np.float64 and np.int64 are accepted wherever a number is (the same branch as
    from Python floats, to 1e-12, with the float32 value's own rounding)."""
    eta = np.float32(1.4e-3)
    res = ac.frequency_response(eq21, U=np.int64(0), eta=eta, sigma=(np.float64(-0.05), np.float32(0.05)),
                                switch=False)
    again = ac.frequency_response(eq21, U=0.0, eta=float(eta), sigma=(-0.05, float(np.float32(0.05))), switch=False)
    np.testing.assert_allclose(res.branch("I")["a1"], again.branch("I")["a1"], rtol=1e-12)
    r = ac.ShootingSolver(eq21.ode).steady(np.int64(0), np.float32(1e-3), np.float64(-0.02), max_time=2000.0)
    assert np.isfinite(r.a1)
    assert check_number("f", "x", np.float32(2.5), 0, 3) == 2.5
    assert check_number("f", "n", np.int64(3), 1, 5, integer=True) == 3.0


def test_the_shared_checker():
    """The rules both the command line and the API use: bool is no number, NaN and infinities are
    refused, bounds (open or closed), integers, two-number ranges, choices, types."""
    for bad in (True, "1", None, float("nan"), float("inf"), [1.0]):
        with pytest.raises(ArgumentError, match="f: x: expected a number"):
            check_number("f", "x", bad)
    with pytest.raises(ArgumentError, match=r"expected a number in \(0, 1\], got 0"):
        check_number("f", "x", 0, 0, 1, lo_open=True)
    assert check_number("f", "x", 0, 0, 1) == 0.0
    with pytest.raises(ArgumentError, match="expected an integer"):
        check_number("f", "n", 2.5, integer=True)
    assert check_interval("f", "r", (np.float32(1), 2)) == (1.0, 2.0)
    for bad in ((2, 1), (1,), "ab", None, (1, None)):
        with pytest.raises(ArgumentError, match="f: r"):
            check_interval("f", "r", bad)
    assert check_choice("f", "c", "a", ("a", "b")) == "a"
    for bad in ("c", 1, None, ["a"]):
        with pytest.raises(ArgumentError, match="f: c: expected one of 'a', 'b'"):
            check_choice("f", "c", bad, ("a", "b"))
    with pytest.raises(ArgumentError, match="f: t: expected a string, got 3"):
        check_type("f", "t", 3, str, "a string")


def test_command_line_uses_the_same_checker(capsys):
    """`autocable.cli.checks.check_number` is the API's with the option's name: the same message."""
    from autocable.cli.checks import check_number as cli_check, typed_number
    with pytest.raises(ArgumentError) as cli:
        cli_check("--every", typed_number("1e12"), 1, 10**9, integer=True)
    with pytest.raises(ArgumentError) as api:
        check_number("arguments", "--every", typed_number("1e12"), 1, 10**9, integer=True)
    assert str(cli.value) == str(api.value) == "arguments: --every: expected an integer in [1, 1e+09], got 1e12"


def test_plot_branches_y_string_is_one_panel(response):
    """``y="a1"`` draws one panel a1 (not panels "a" and "1")."""
    fig = ac.plot_branches(response.branches, x="sigma", y="a1")
    assert len(fig.axes) == 1 and "a_1" in fig.axes[0].get_ylabel()


def test_plot_branches_units_si_draws_si(eq21, response):
    """``units="si"`` on results that carry the cable's scales (a `frequency_response` of a
    derivation passed whole, a run read back) draws metres and hertz: the same data as ``units=si_scales(...)``."""
    response = _with_scales(eq21, response)
    fig = ac.plot_branches(response, x="sigma", y=("a1",), units="si")
    assert "[m]" in fig.axes[0].get_ylabel() and "[Hz]" in fig.axes[0].get_xlabel()
    u = ac.si_scales(eq21.spec.cable.length_m, eq21.statics.omega_ref, eq21.spec.aero.critical_wind_speed_m_s)
    ref = ac.plot_branches(response, x="sigma", y=("a1",), units=u)
    np.testing.assert_allclose(fig.axes[0].lines[0].get_ydata(), ref.axes[0].lines[0].get_ydata(), rtol=1e-15)
    a1 = response.branch("I")["a1"]
    assert np.nanmax(fig.axes[0].lines[0].get_ydata()) <= np.nanmax(a1) * eq21.spec.cable.length_m * (1 + 1e-12)


def test_run_scene_takes_a_path(tmp_path):
    """``run_scene("runs/fig03.toml", out)``: the path is loaded as `load_scene` does (the same
    branches as from the loaded scene)."""
    from autocable._paths import RUNS_DIR
    path = RUNS_DIR / "fig03.toml"
    a = ac.run_scene(str(path), tmp_path / "a", plot=False, resolution="coarse")
    b = ac.run_scene(ac.load_scene(path), tmp_path / "b", plot=False, resolution="coarse")
    assert [x.name for x in a.branches] == [x.name for x in b.branches] and len(a.branches) > 0
    np.testing.assert_array_equal(a.branches[0]["a1"], b.branches[0]["a1"])


def test_the_api_table_matches_the_functions():
    """Every function of `autocable.api_checks.RULES` is public and has the arguments the table
    names (a renamed argument would otherwise go unchecked), and is handed out guarded with the
    plain function's docstring and signature."""
    import inspect

    from autocable.api_checks import RULES
    for name, rules in RULES.items():
        assert name in ac._API, name
        fn = getattr(ac, name)
        params = inspect.signature(fn).parameters
        assert set(rules) <= set(params), (name, set(rules) - set(params))
        plain = fn.__wrapped__
        assert fn.__doc__ == plain.__doc__ and inspect.signature(fn) == inspect.signature(plain)


def test_guarded_calls_give_the_same_results(eq21):
    """A guarded function returns what the plain one does (the check only reads the arguments)."""
    from autocable.methods.continuation import continue_equilibria
    settings = ac.ContinuationSettings(max_step=0.02, max_points=40)
    a = ac.continue_equilibria(_problem(eq21), settings, engine="compiled")
    b = continue_equilibria(_problem(eq21), settings, engine="compiled")
    np.testing.assert_array_equal(a.branch["a1"], b.branch["a1"])


_BAD = [None, "8", True, np.bool_(False), float("nan"), float("inf"), -1.0, 1e300, 2 ** 2000, 1 + 2j, [1.0],
        {"x": 1}, np.array([1.0, 2.0])]


@pytest.mark.parametrize("keyword", ["wind_m_s", "deck_amplitude_m", "deck_frequency_Hz"])
def test_si_keywords_refuse_every_bad_value(eq21, keyword):
    """Each SI keyword with each of a pool of bad values (types, non-finite, negative, huge, the
    wrong shape): an ArgumentError naming the keyword (or one end of the Hz range), never another
    error, before any work."""
    base = {"deck_amplitude_m": 0.01}
    for bad in _BAD + ([(1.0,), (1.1, 1.0), (None, 1.2), (0.0, 1.2), (1.0, float("nan"))]
                       if keyword == "deck_frequency_Hz" else []):
        kwargs = {**base, keyword: (bad, 1.2) if keyword == "deck_frequency_Hz" and np.ndim(bad) == 0
                  and not isinstance(bad, (str, dict)) and bad is not None else bad}
        with pytest.raises(ArgumentError) as info:
            ac.frequency_response(eq21, switch=False, **kwargs)
        assert f": {keyword}" in str(info.value), (bad, str(info.value))
