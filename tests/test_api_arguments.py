"""The Python API applies the command line's premises: a bad argument is an `ArgumentError` (a
`SpecError`, so a `ValueError`) naming the function and the argument, before any work; no call
returns NaN as a result."""
from __future__ import annotations

import math
import warnings

import pytest

from autocable.model.premises import ArgumentError
from autocable.spec import SpecError

BAD = [
    ({"max_time": -5}, "max_time", "expected a time in (0, 1e+06]"),
    ({"max_time": 1e-9}, "max_time", "expected at least one forcing period"),
    ({"max_time": math.inf}, "max_time", "expected a finite number"),
    ({"max_time": math.nan}, "max_time", "expected a finite number"),
    ({"max_time": 2e6}, "max_time", "expected a time in (0, 1e+06]"),
    ({"max_time": "10"}, "max_time", "expected a number"),
    ({"U": math.nan}, "U", "expected a finite number"),
    ({"U": "a"}, "U", "expected a number"),
    ({"U": -1.0}, "U", "must lie in [0, 5]"),
    ({"eta": 1.0}, "eta", "must lie in [0, 0.05]"),
    ({"sigma": -2.0}, "sigma", "must lie in [-0.5, 0.5]"),
    ({"sigma": math.inf}, "sigma", "expected a finite number"),
    ({"q0": (1, 2, 3)}, "q0", "expected four numbers"),
    ({"q0": (math.nan, 0, 0, 0)}, "q0[0]", "expected a finite number"),
    ({"q0": (0, 0, 5, 0)}, "q0[2]", "expected |value| <= 0.1"),
    ({"q0": "abcd"}, "q0", "expected four numbers"),
]


@pytest.fixture(scope="module")
def solvers(sample_spec):
    from autocable.methods.integration.ame import AmeIntegrator
    from autocable.methods.integration.ode21 import Ode21Integrator
    from autocable.methods.integration.shooting import ShootingSolver
    from autocable.model.ame_cache import derive_ame
    from autocable.model.derive import derive
    d = derive(sample_spec)
    return {"Ode21Integrator.simulate": Ode21Integrator(d.ode, engine="compiled").simulate,
            "ShootingSolver.steady": ShootingSolver(d.ode).steady,
            "AmeIntegrator.simulate": AmeIntegrator(derive_ame(d).ame).simulate}


@pytest.mark.parametrize("function", ["Ode21Integrator.simulate", "ShootingSolver.steady", "AmeIntegrator.simulate"])
@pytest.mark.parametrize("bad,argument,rule", BAD)
def test_a_bad_argument_is_refused_naming_it(solvers, function, bad, argument, rule):
    kw = {"U": 0.0, "eta": 1e-4, "sigma": 0.0, "max_time": 200.0, **bad}
    U, eta, sigma = kw.pop("U"), kw.pop("eta"), kw.pop("sigma")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(ArgumentError) as err:
            solvers[function](U, eta, sigma, **kw)
    assert str(err.value).startswith(f"{function}: {argument}: ") and rule in str(err.value)
    assert isinstance(err.value, SpecError) and isinstance(err.value, ValueError) and "\n" not in str(err.value)


def test_the_issue_reproduction_is_refused_not_nan(solvers):
    """``Ode21Integrator(eq21.ode).simulate(0, 1e-4, 0, max_time=-5)`` returned a1 = nan."""
    with pytest.raises(ArgumentError, match="max_time"):
        solvers["Ode21Integrator.simulate"](0, 1e-4, 0, max_time=-5)


def test_valid_calls_return_finite_amplitudes_that_agree(solvers):
    """One forcing period is the least max_time; at Fig. 5a's point the three methods return
    finite amplitudes (no NaN as a result), eq. (21) by integration and by shooting within 1e-4
    relative, the AME within 1 % (the order of the expansion at eta* = 8.2e-5)."""
    r = solvers["Ode21Integrator.simulate"](0.0, 8.2e-5, 0.0, max_time=60000.0)
    s = solvers["ShootingSolver.steady"](0.0, 8.2e-5, 0.0, max_time=60000.0)
    a = solvers["AmeIntegrator.simulate"](0.0, 8.2e-5, 0.0, max_time=60000.0)
    for x in (r, s, a):
        assert math.isfinite(x.a1) and math.isfinite(x.a2)
    assert abs(r.a1 - s.a1) <= 1e-4 * s.a1 and abs(a.a1 - s.a1) <= 1e-2 * s.a1


def test_constructors_and_loaders_name_the_argument(sample_spec):
    from autocable.methods.integration.ode21 import Ode21Integrator
    from autocable.model.derive import derive
    from autocable.spec import load_model
    d = derive(sample_spec)
    with pytest.raises(ArgumentError, match="^Ode21Integrator: engine: expected one of"):
        Ode21Integrator(d.ode, engine="x")
    with pytest.raises(ArgumentError, match="^Ode21Integrator: ode: expected the TwoModeODE"):
        Ode21Integrator("x")
    for bad in (None, 123):
        with pytest.raises(SpecError, match="expected the path of a .toml file"):
            load_model(bad)
        with pytest.raises(SpecError, match="expected the path of a .toml file"):
            derive(bad)
    integ = Ode21Integrator(d.ode, engine="compiled")
    for t_end in (-1.0, 0.0, 1e300, math.nan):
        with pytest.raises(ArgumentError, match="^Ode21Integrator.envelope: t_end: "):
            integ.envelope(0.0, 1e-4, 0.0, (0.0, 1e-6, 0.0, 0.0), t_end)
    with pytest.raises(ArgumentError, match=r"^Ode21Integrator.envelope: y0\[1\]: "):
        integ.envelope(0.0, 1e-4, 0.0, (0.0, math.nan, 0.0, 0.0), 100.0)


def test_run_sweep_names_its_arguments(tmp_path):
    from autocable.studies.sweep import run_sweep
    with pytest.raises(ArgumentError, match="^run_sweep: spec: expected a SweepSpec"):
        run_sweep("runs/sweep_fig05a.toml", tmp_path)
    from autocable.scene.sweep_schema import load_sweep
    from conftest import SAMPLE
    path = tmp_path / "s.toml"
    path.write_text(f'model = "{SAMPLE.as_posix()}"\n')
    spec = load_sweep(path)
    for name, value in (("workers", -1), ("chunk", 0), ("workers", 1.5)):
        with pytest.raises(ArgumentError, match=f"^run_sweep: {name}: "):
            run_sweep(spec, tmp_path / "o", **{name: value})
    assert not (tmp_path / "o").exists()
