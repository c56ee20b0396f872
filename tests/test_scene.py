"""Scene files: runs/fig05a.toml end to end, the schema's one-line errors, and a branch that fails
part-way keeping its points in the written results."""
from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from scipy.integrate import solve_ivp

from autocable.methods.continuation import (ContinuationSettings, EquilibriumProblem, System,
                                            continue_equilibria)
from autocable.results import RunResults, read_results, write_results
from autocable import run_scene
from autocable.cli import add_run_parser
from autocable.scene.schema import load_scene
from autocable.spec import SpecError
from conftest import REPO, SAMPLE

FIG05A = REPO / "runs" / "fig05a.toml"
MODEL = SAMPLE


@pytest.fixture(scope="module")
def fig05a(tmp_path_factory):
    out = tmp_path_factory.mktemp("fig05a")
    return run_scene(load_scene(FIG05A), out), out


def test_fig05a_runs_and_writes_its_outputs(fig05a):
    res, out = fig05a
    for name in ("branches.csv", "special_points.csv", "run.json", "fig05a.png", "fig05a.pdf"):
        assert (out / name).stat().st_size > 0, name
    b = res.branch("I")
    assert b.kind == "equilibrium" and len(b) > 50
    assert b["sigma"][0] == pytest.approx(-0.05) and b["sigma"][-1] == pytest.approx(0.05)
    assert [e.reason for e in b.ends] == ["range", "range"]
    assert np.all(b["U"] == 0.0) and np.all(b["eta"] == 8.2e-5)
    # Fig. 5a: one stable mono-modal resonance peak near sigma = 0, no bifurcation
    assert b.stable.all() and not b.special_points
    peak = int(np.argmax(b["a1"]))
    assert abs(b["sigma"][peak]) < 5e-3 and 1e-4 < b["a1"][peak] < 1e-3
    # a1 vs a2: a2 = 0 to round-off (mode 2 is only parametrically excited, and not enough)
    assert np.max(np.abs(b["a2"])) <= 1e-15 * np.max(b["a1"])
    prov = res.provenance
    assert prov["model_hash"] and prov["versions"]["PyDSTool"] and prov["stages"]["runs"]["I"]["wall_s"] > 0
    back = read_results(out)
    rb = back.branch("I")
    assert len(rb) == len(b) and np.array_equal(rb.stable, b.stable)
    np.testing.assert_array_equal(rb["a1"], b["a1"])
    np.testing.assert_allclose(rb.eigenvalues, b.eigenvalues, rtol=0, atol=0)


def test_fig05a_stable_branch_agrees_with_direct_integration_of_the_ame(fig05a):
    """At 12 values of sigma: integrate the AME (the numeric Cartesian table of autocable.model.ame,
    not the continuation's sympy system) from a perturbed start to its steady state."""
    from autocable.model.ame_cache import derive_ame
    from autocable.model.derive import derive

    res, _ = fig05a
    b = res.branch("I")
    ame = derive_ame(derive(MODEL)).ame
    rhs = ame.cartesian_rhs()
    picks = np.unique(np.linspace(0, len(b) - 1, 12).round().astype(int))
    assert len(picks) >= 10
    worst = 0.0
    for i in picks:
        assert b.stable[i]
        p = ame.control(eta=8.2e-5, U=0.0, sigma=float(b["sigma"][i]))
        y_branch = b.states[i]
        c, s = math.cos(0.3), math.sin(0.3)
        y0 = 1.2 * np.array([c * y_branch[0] - s * y_branch[1], s * y_branch[0] + c * y_branch[1], 1e-6, 0.0])
        sol = solve_ivp(lambda _t, z: rhs.f(z, p), (0.0, 9000.0), y0, method="LSODA",
                        jac=lambda _t, z: rhs.jacobian(z, p), rtol=1e-12, atol=1e-16)
        a1 = ame.amplitudes(sol.y[:, -1])[0]
        rel = abs(a1 - b["a1"][i]) / b["a1"][i]
        worst = max(worst, rel)
        assert rel < 1e-6, (b["sigma"][i], a1, b["a1"][i])
    print(f"fig05a vs direct AME integration: worst relative a1 error {worst:.2e} over {len(picks)} sigmas")


# --------------------------------------------------------------------------------------------
# errors: one line naming the file and the field

def _scene(tmp_path: Path, body: str) -> Path:
    path = tmp_path / "bad.toml"
    path.write_text(f'model = "{MODEL}"\n' + body)
    return path


@pytest.mark.parametrize("body, field, words", [
    ('[[run]]\nname = "I"\nparameter = "sigma"\nrange = [-0.05, 0.05]\nstrat = "trivial"\n',
     "run[0].strat", "unknown key"),
    ('colour = "red"\n[[run]]\nparameter = "sigma"\nrange = [-0.05, 0.05]\n', "colour", "unknown key"),
    ('[[run]]\nparameter = "sigma"\nrange = [-0.05, 0.05]\nat = 0.2\n', "run[0].at", "outside the range"),
    ('[[run]]\nparameter = "rho"\nrange = [-0.05, 0.05]\n', "run[0].parameter", "expected one of"),
    ('[[run]]\nparameter = "sigma"\nrange = [0.05, -0.05]\n', "run[0].range", "lo < hi"),
    ('[fixed]\neta = -1e-3\n[[run]]\nparameter = "sigma"\nrange = [-0.05, 0.05]\n', "fixed.eta", ">= 0"),
    ('[[run]]\nparameter = "sigma"\nrange = [-0.05, 0.05]\nstart = "II:H1"\n', "run[0].start", "earlier run"),
    ('[[run]]\nparameter = "sigma"\nrange = [-0.05, 0.05]\n[run.steps]\nstep = 1.0\nmax_step = 0.1\n',
     "run[0].steps", "step"),
    ('engine = "auto07p"\n[[run]]\nparameter = "sigma"\nrange = [-0.05, 0.05]\n', "engine", "compiled"),
    ('[[run]]\nparameter = "sigma"\nrange = [-0.05, 0.05]\nstart = { orbit = [1e-2] }\n', "run[0].start",
     'kind = "cycles"'),
    ('[[run]]\nkind = "cycles"\nparameter = "sigma"\nrange = [-0.05, 0.05]\n', "run[0].start", "orbit"),
    ('[[run]]\nkind = "cycles"\nparameter = "U"\nrange = [0.5, 1.5]\nstart = { orbit = [-1e-2] }\n',
     "run[0].start.orbit", ">= 0"),
])
def test_scene_schema_errors_are_one_line(tmp_path, body, field, words):
    with pytest.raises(SpecError) as err:
        load_scene(_scene(tmp_path, body))
    text = str(err.value)
    assert "\n" not in text and text.startswith(str(tmp_path / "bad.toml"))
    assert err.value.field == field and words in text


def test_an_orbit_start_needs_the_compiled_engine_and_a_periodic_orbit(tmp_path):
    """A cycles run from { orbit } with PyCont, or where the AME settles on an equilibrium: one line
    naming the run's start, before any continuation."""
    body = ('ame = "1dof"\n[fixed]\nsigma = 0.01\neta = 3.2e-4\n[[run]]\nname = "B"\nkind = "cycles"\n'
            'parameter = "U"\nrange = [0.05, 1.5]\nstart = { orbit = [1e-2] }\nat = AT\n')
    for engine, at, words in (("pycont", "1.2", 'engine = "compiled"'),
                              ("compiled", "0.5", "settled on an equilibrium")):
        with pytest.raises(SpecError) as err:
            run_scene(load_scene(_scene(tmp_path, f'engine = "{engine}"\n' + body.replace("AT", at))),
                      tmp_path / "out", plot=False)
        text = str(err.value)
        assert "\n" not in text and err.value.field == "run[0].start" and words in text, text


def test_scene_errors_at_run_time_are_one_line(tmp_path):
    # a start that does not converge: Newton from amplitudes of a tenth of the cable length (the
    # largest a scene accepts; ten cable lengths are refused when the scene is read)
    far = _scene(tmp_path, '[fixed]\neta = 8.2e-5\n[[run]]\nparameter = "sigma"\nrange = [-0.05, 0.05]\n'
                           'at = 0.0\nstart = {state = [0.1, 0.1, 0.1, 0.1]}\n')
    with pytest.raises(SpecError) as err:
        run_scene(load_scene(far), tmp_path / "out", plot=False)
    assert err.value.field == "run[0].start" and "\n" not in str(err.value)
    assert "did not converge" in str(err.value)
    # continuing U from 0: the aerodynamic terms carry 1/U
    windless = _scene(tmp_path, '[fixed]\neta = 1e-4\nsigma = 0.01\n[[run]]\nparameter = "U"\nrange = [0.0, 1.5]\n')
    with pytest.raises(SpecError) as err:
        run_scene(load_scene(windless), tmp_path / "out2", plot=False)
    assert err.value.field == "run[0].range" and "1/U" in str(err.value)
    # a labelled start that does not exist
    nolabel = _scene(tmp_path, '[fixed]\neta = 8.2e-5\n[[run]]\nname = "I"\nparameter = "sigma"\n'
                               'range = [-0.05, -0.04]\n[[run]]\nname = "J"\nkind = "cycles"\nparameter = "sigma"\n'
                               'range = [-0.05, 0.05]\nstart = "I:H1"\n')
    with pytest.raises(SpecError) as err:
        run_scene(load_scene(nolabel), tmp_path / "out3", plot=False)
    assert err.value.field == "run[1].start" and "H1" in str(err.value) and "\n" not in str(err.value)


def test_run_command_with_an_integrated_start_and_a_comparison(tmp_path, capsys, fig05a):
    """`autocable run` (as the lead wires it): start by integrating the AME from a small amplitude,
    overlay digitised points; --quiet leaves stderr empty; the start agrees with Fig. 5a's branch."""
    (tmp_path / "digitised.csv").write_text("x,y,curve,stable\n-0.05,2.5e-5,I,1\n-0.045,2.8e-5,I,1\n")
    scene = _scene(tmp_path, '[fixed]\neta = 8.2e-5\n[[run]]\nname = "I"\nparameter = "sigma"\n'
                             'range = [-0.05, -0.045]\nstart = {integrate = [1e-5, 0.0]}\n'
                             'directions = "forward"\n[compare]\ncsv = "digitised.csv"\n')
    parser = argparse.ArgumentParser()
    add_run_parser(parser.add_subparsers(dest="command"))
    args = parser.parse_args(["run", str(scene), "--out", str(tmp_path / "o"), "--quiet"])
    assert args.func(args) == 0
    assert capsys.readouterr().err == ""
    for name in ("branches.csv", "special_points.csv", "run.json", "bad.png", "bad.pdf"):
        assert (tmp_path / "o" / name).exists(), name
    b = read_results(tmp_path / "o").branch("I")
    ref = fig05a[0].branch("I")
    assert b["sigma"][0] == pytest.approx(-0.05) and b["a1"][0] == pytest.approx(ref["a1"][0], rel=1e-10)


def test_run_command_refuses_an_output_folder_it_cannot_make_before_computing(tmp_path, monkeypatch):
    """--out under a file: one line naming --out, and no computation spent first."""
    import autocable.scene.runner as S
    (tmp_path / "a_file").write_text("")
    scene = _scene(tmp_path, '[fixed]\neta = 8.2e-5\n[[run]]\nname = "I"\nparameter = "sigma"\n'
                             'range = [-0.05, -0.045]\nstart = "trivial"\n')
    monkeypatch.setattr(S, "run_scene", lambda *a, **k: pytest.fail("computed before checking --out"))
    parser = argparse.ArgumentParser()
    add_run_parser(parser.add_subparsers(dest="command"))
    args = parser.parse_args(["run", str(scene), "--out", str(tmp_path / "a_file" / "o"), "--quiet"])
    with pytest.raises(SpecError) as err:
        args.func(args)
    assert err.value.path == "--out" and "cannot make the output folder" in str(err.value)
    assert "\n" not in str(err.value)


def test_scene_engines_agree_and_are_named_in_the_provenance(tmp_path, fig05a):
    """`engine = "compiled"` runs Fig. 5a's equilibria in autocable's C kernel: the same branch as
    the PyCont run of the shipped scene (every point within the continuation tolerance of the
    PyCont branch, same end values), the engine recorded in run.json, no PyCont confirmation."""
    from autocable.methods.continuation.equilibria import ENGINES as METHOD_ENGINES
    from autocable.scene.schema import ENGINES

    assert ENGINES == METHOD_ENGINES
    text = FIG05A.read_text().replace('model = "../models/', f'model = "{REPO}/models/')
    assert 'engine = "compiled"' not in text
    path = tmp_path / "fig05a_compiled.toml"
    path.write_text(text.replace('ame = "2dof"', 'engine = "compiled"\name = "2dof"', 1))
    res = run_scene(load_scene(path), tmp_path / "out")
    ref, new = fig05a[0].branch("I"), res.branch("I")
    assert json.loads((tmp_path / "out" / "run.json").read_text())["provenance"]["engine"] == "compiled"
    assert json.loads((fig05a[1] / "run.json").read_text())["provenance"]["engine"] == "pycont"
    assert new["sigma"][[0, -1]] == pytest.approx(ref["sigma"][[0, -1]], abs=1e-12)
    # a1 along the PyCont branch, interpolated at the compiled points (sigma is monotone on Fig. 5a)
    order = np.argsort(ref["sigma"])
    a1_ref = np.interp(new["sigma"], ref["sigma"][order], ref["a1"][order])
    assert np.max(np.abs(new["a1"] - a1_ref)) < 1e-3 * np.max(ref["a1"])
    assert bool(np.all(new.stable)) and bool(np.all(ref.stable))    # Fig. 5a: stable throughout


def test_the_one_dof_reduction_has_the_two_dof_branch_when_a2_vanishes(fig05a):
    """Sect. 5: A2 = 0 is invariant at U = 0, so each point of Fig. 5a's branch restricted to
    (r1, s1) is an equilibrium of the 1-dof AME."""
    from autocable.methods.continuation import ame_system, equilibrium_near
    from autocable.model.ame_cache import derive_ame
    from autocable.model.derive import derive

    b = fig05a[0].branch("I")
    one = ame_system(derive_ame(derive(MODEL)).ame, "1dof", wind=False)
    for i in range(0, len(b), max(1, len(b) // 10)):
        p = one.parameter_vector({"sigma": b["sigma"][i], "U": 0.0, "eta": 8.2e-5})
        x, ok, _ = equilibrium_near(one, b.states[i][:2], p, scale=1e-4)
        assert ok and np.hypot(*x) == pytest.approx(b["a1"][i], rel=1e-10)


# --------------------------------------------------------------------------------------------
def test_a_branch_that_fails_part_way_keeps_its_points_in_the_outputs(tmp_path):
    """x = sqrt(1 - p) ends at p = 1 (the equations stop existing): the branch is cut there and
    what was computed before is written."""
    x, y, p = sp.symbols("x y p")
    system = System("sqrt_end", ("x", "y"), (sp.sqrt(1 - p) - x, -y), {"p": 0.0}, (("a1", ("x",)),))
    problem = EquilibriumProblem(system, "p", {"p": 0.0}, (0.0, 2.0))
    r = continue_equilibria(problem, ContinuationSettings(), name="cut", directions="forward")
    b = r.branch
    end = b.ends[-1]
    assert end.reason in ("no_convergence", "step_collapse") and end.message
    assert len(b) > 20 and 0.9 < b["p"].max() <= 1.0
    np.testing.assert_allclose(b["x"], np.sqrt(1 - b["p"]), atol=1e-12)
    write_results(RunResults("cut", (b,), {"note": "test"}), tmp_path)
    back = read_results(tmp_path).branch("cut")
    assert len(back) == len(b) and back.ends[-1].reason == end.reason
    np.testing.assert_array_equal(back["p"], b["p"])


def test_galloping_branch_at_eta_zero_against_the_closed_form():
    """Fig. 3 (eta = 0): EP-C of the 1-dof polar amplitude equation (23) in U gives the galloping
    branch a1 = 2 sqrt(-(2 xi_s omega1 + zeta11 U) U) / sqrt(3 zeta8 Omega^2) (docs/model.md, M5,
    Omega = omega1) to 1e-9, stable (supercritical for the sample model, zeta8 > 0). The polar form
    is used because at eta = 0 the Cartesian AME has a rotational symmetry: galloping is a circle in
    (r1, s1), an equilibrium only of the amplitude equation."""
    import math

    import numpy as np
    import sympy as sp

    from autocable.methods.continuation import (ContinuationSettings, EquilibriumProblem, System,
                                                continue_equilibria)
    from autocable.model.ame_cache import derive_ame
    from autocable.model.derive import derive

    d = derive(MODEL)
    ame1 = derive_ame(d).ame.one_dof()
    syms = ame1.symbols()
    w = d.ode.omega1
    p1 = ame1.polar_expressions()[0].subs({syms["eta"]: 0, syms["Omega"]: w, syms["sigma_1"]: 0})
    a, U = sp.Symbol("a1"), sp.Symbol("U")
    p1 = sp.expand(p1.subs({syms["a_1"]: a, syms["U"]: U}))
    assert syms["Phi_1"] not in p1.free_symbols            # eta = 0: the a1 equation decouples
    c = d.ode.coefficients()
    xi, z11, z8 = d.ode.xi_s, c["zeta11"], c["zeta8"]
    assert z8 > 0

    def closed(u):
        return 2 * math.sqrt(-(2 * xi * w + z11 * u) * u) / math.sqrt(3 * z8 * w**2)

    system = System(name="galloping_1dof_polar", variables=("a1",), rhs=(p1,),
                    parameters=(("U", 1.2),), amplitudes=(("a1", ("a1",)),))
    problem = EquilibriumProblem(system, "U", {"U": 1.2}, (1.01, 1.3), state_scale=0.01)
    res = continue_equilibria(problem, ContinuationSettings(), start=[closed(1.2)], name="galloping")
    branch = res.branch
    Us, a1 = np.asarray(branch.table["U"]), np.asarray(branch.table["a1"])
    assert len(Us) > 10 and Us.min() < 1.02 and Us.max() > 1.29
    expected = np.array([closed(u) for u in Us])
    assert np.max(np.abs(a1 - expected) / expected) < 1e-9
    assert bool(np.all(branch.stable))


def test_fig03_scene_gives_the_supercritical_galloping_branch(tmp_path):
    """runs/fig03.toml (ame = "1dof-amplitude", eta = 0): the galloping branch read back from
    branches.csv equals the closed form of eq. (25) (in the form of docs/model.md, M5) to 1e-9 and is stable;
    the trivial solution is stable below U = 1 and unstable above."""
    import math

    import numpy as np

    from autocable.model.derive import derive

    run_scene(load_scene(REPO / "runs" / "fig03.toml"), tmp_path, plot=False)
    back = read_results(tmp_path)
    ode = derive(MODEL).ode
    c = ode.coefficients()
    w, xi = ode.omega1, ode.xi_s
    gal = back.branch("galloping")
    U, a1 = np.asarray(gal.table["U"]), np.asarray(gal.table["a1"])
    closed = 2 * np.sqrt(-(2 * xi * w + c["zeta11"] * U) * U) / math.sqrt(3 * c["zeta8"] * w**2)
    assert len(U) > 20 and U.min() < 1.01 and U.max() > 1.29
    assert np.max(np.abs(a1 - closed) / closed) < 1e-9
    assert bool(np.all(gal.stable))
    below, above = back.branch("trivial"), back.branch("trivial-above")
    assert bool(np.all(below.stable[np.asarray(below.table["U"]) < 0.999]))
    assert not bool(np.any(above.stable[np.asarray(above.table["U"]) > 1.001]))


def test_one_dof_amplitude_scene_refuses_support_motion(tmp_path):
    bad = tmp_path / "bad.toml"
    text = (REPO / "runs" / "fig03.toml").read_text().replace("eta = 0.0", "eta = 1e-4")
    text = text.replace('"../models/luongo_zulli_2012.toml"', repr(str(MODEL)).replace("'", '"'))
    bad.write_text(text)
    with pytest.raises(SpecError, match="eta = 0 only"):
        run_scene(load_scene(bad), tmp_path / "o", plot=False)


def _without_overlay(text: str) -> str:
    """The scene text up to its own [overlay] table (the last table of runs/fig05a.toml)."""
    return text.split("\n[overlay]")[0]


def test_overlay_of_direct_integrations(tmp_path):
    """[overlay] sweeps eq. (21) up and down (the empty boxes of Figs. 9-10), writes overlay.csv,
    and at Fig. 5a's settings the boxes sit on the stable AME branch within the AME-vs-(21) error
    reported for this eta (1.1e-3, docs/ame_vs_ode21.md)."""
    import csv

    scene_file = tmp_path / "fig05a_overlay.toml"
    text = _without_overlay(FIG05A.read_text()).replace('"../models/luongo_zulli_2012.toml"',
                                                         repr(str(MODEL)).replace("'", '"'))
    scene_file.write_text(text + '\n[overlay]\nmethod = "ode21"\npoints = 3\nrange = [-0.04, 0.04]\n')
    out = tmp_path / "o"
    run_scene(load_scene(scene_file), out)
    rows = list(csv.DictReader((out / "overlay.csv").open()))
    assert len(rows) == 6 and {r["direction"] for r in rows} == {"up", "down"}
    branch = read_results(out).branch("I")
    sig, a1 = np.asarray(branch.table["sigma"]), np.asarray(branch.table["a1"])
    order = np.argsort(sig)
    for r in rows:
        assert r["steady"] == "True" and r["periodic"] == "True"
        expected = np.interp(float(r["value"]), sig[order], a1[order])
        assert float(r["a1"]) == pytest.approx(expected, rel=2e-3)
    assert (out / "fig05a_overlay.png").stat().st_size > 0


@pytest.mark.parametrize("body,field", [
    ('[overlay]\nmethod = "rk4"\n', "overlay.method"),
    ('[overlay]\npoints = 0\n', "overlay.points"),
    ('[overlay]\nstep = 1\n', "overlay.step"),
    ('[overlay]\ndirections = ["sideways"]\n', "overlay.directions"),
])
def test_overlay_schema_errors(tmp_path, body, field):
    scene_file = tmp_path / "bad.toml"
    text = _without_overlay(FIG05A.read_text()).replace('"../models/luongo_zulli_2012.toml"',
                                                         repr(str(MODEL)).replace("'", '"'))
    scene_file.write_text(text + "\n" + body)
    with pytest.raises(SpecError, match=field):
        load_scene(scene_file)


# --------------------------------------------------------------------------------------------
# [compare]: distances of digitised points (autocable/scene/compare.py), end to end
def _write_points(path, rows):
    path.write_text("x,y,curve,stable\n" + "".join(f"{x!r},{y!r},{c},{int(s)}\n" for x, y, c, s in rows))


def test_compare_distances_of_points_on_and_off_a_computed_branch(tmp_path, fig05a):
    """A synthetic 'digitised' CSV taken from Fig. 5a's computed branch is at distance ~0; a copy
    shifted by 1e-3 (normalised units, along each segment's normal, from segment midpoints) is at
    exactly that distance. End to end: the scene's [compare] writes compare.json and the plot."""
    import json

    from autocable.scene.compare import compare_summary

    res, _ = fig05a
    b = res.branch("I")
    x, y = np.asarray(b["sigma"]), np.asarray(b["a1"])
    xr, yr = float(x.max() - x.min()), float(y.max())
    picks = range(5, len(b) - 5, 7)
    on = [(x[i], y[i], "I", True) for i in picks]
    shift = 1e-3
    off = []
    for i in picks:
        dx, dy = (x[i + 1] - x[i]) / xr, (y[i + 1] - y[i]) / yr
        n = np.array([-dy, dx]) / math.hypot(dx, dy)
        mx, my = 0.5 * (x[i] + x[i + 1]) / xr, 0.5 * (y[i] + y[i + 1]) / yr
        off.append(((mx + shift * n[0]) * xr, (my + shift * n[1]) * yr, "shifted", False))
    rows = [{"x": a, "y": c, "curve": k, "stable": s} for a, c, k, s in on + off]
    summary = compare_summary(rows, res.branches, "sigma", "a1")
    assert summary["x_range"] == pytest.approx(xr) and summary["y_range"] == pytest.approx(yr)
    assert summary["curves"]["I"]["n_points"] == len(on) and summary["curves"]["I"]["max_distance"] <= 1e-9
    assert summary["curves"]["shifted"]["max_distance"] == pytest.approx(shift, rel=1e-6)
    assert summary["curves"]["shifted"]["rms_distance"] == pytest.approx(shift, rel=1e-6)

    _write_points(tmp_path / "digitised.csv", on + off)
    scene = tmp_path / "fig05a_compare.toml"
    text = FIG05A.read_text().replace('"../models/luongo_zulli_2012.toml"', repr(str(MODEL)).replace("'", '"'))
    scene.write_text(text + '\n[compare]\ncsv = "digitised.csv"\npanel = "a1"\n')
    out = tmp_path / "o"
    run_scene(load_scene(scene), out)
    written = json.loads((out / "compare.json").read_text())
    assert written["curves"]["I"]["max_distance"] <= 1e-9
    assert written["curves"]["shifted"]["max_distance"] == pytest.approx(shift, rel=1e-6)
    assert written["curves"]["shifted"]["n_points"] == len(off) and (out / "fig05a_compare.png").stat().st_size > 0


def test_time_scene_schema_errors(tmp_path):
    base = ('title = "t"\nmodel = "%s"\n' % str(MODEL))
    cases = [
        ('[time]\nU = 1.3\neta = 1e-3\nsigma = 0.0\n', "time.t_end"),
        ('[time]\nU = 1.3\neta = 1e-3\nsigma = 0.0\nt_end = 100.0\nstep = 1\n', "time.step"),
        ('[time]\nU = 0.0\neta = 1e-3\nsigma = 0.0\nt_end = 100.0\n', "time.U"),
        ('[time]\nU = 1.3\neta = 1e-3\nsigma = 0.0\nt_end = 100.0\nstart = "moving"\n', "time.start"),
        ('ame = "1dof"\n[time]\nU = 1.3\neta = 1e-3\nsigma = 0.0\nt_end = 100.0\n', "ame"),
        ('[fixed]\nU = 1.0\n[time]\nU = 1.3\neta = 1e-3\nsigma = 0.0\nt_end = 100.0\n', "fixed"),
        ('[time]\nU = 1.3\neta = 1e-3\nsigma = 0.0\nt_end = 100.0\n[[run]]\nparameter = "sigma"\nrange = [0, 1]\n', "run"),
    ]
    for body, field in cases:
        f = tmp_path / "t.toml"
        f.write_text(base + body)
        with pytest.raises(SpecError) as err:
            load_scene(f)
        assert err.value.field == field and "\n" not in str(err.value), (body, err.value.field)


@pytest.mark.slow
def test_a_time_scene_keeps_an_ame_that_blows_up(tmp_path):
    """The natural-ordering AME of the legacy-sense sample (conftest.legacy_path) at U* = 1.3,
    eta* = 4.1e-4 leaves every bound (its step size collapses near t = 1070): the scene is complete,
    the AME series ends there with the reason, and eq. (21)'s envelope is still written. (It used to
    fail the scene and lose both series.)"""
    from conftest import legacy_path
    scene = tmp_path / "t.toml"
    scene.write_text(f'title = "t"\nmodel = "{legacy_path()}"\nordering = "natural"\n[time]\nU = 1.3\neta = 4.1e-4\n'
                     'sigma = 0.0\nt_end = 3000.0\nstart = "rest"\node21 = true\nsummary_from = 1000.0\n'
                     'samples_per_period = 6\n')
    out = tmp_path / "o"
    run_scene(load_scene(scene), out, plot=False)
    run = json.loads((out / "run.json").read_text())
    ame = run["summary"]["ame"]
    assert run["status"] == "complete" and ame["diverged"] is True
    assert ame["message"].startswith("the AME integration stopped at t = ") and "of 3000" in ame["message"]
    t_stop = float(ame["message"].split("t = ")[1].split()[0])
    assert 1000.0 < t_stop < 3000.0 and ame["t_to"] <= t_stop
    sources = {line.split(",")[0] for line in (out / "time_series.csv").read_text().splitlines()[1:]}
    assert sources == {"ame", "ode21"}
    # Fig. 11's statements on it: no periodic AME solution, and eq. (21)'s envelope, cut where it
    # diverges (t ~ 850), is not a bounded envelope however finite its samples are
    from dataclasses import replace as _replace
    from autocable.paper import targets as tg
    from autocable.paper.report import load_scene_data
    assert run["summary"]["ode21"]["diverged"] is True
    ts = [t for t in tg.load_targets(REPO / "models" / "luongo_zulli_2012.targets.toml") if t.scene == "fig11"]
    v = {x.id: x for x in tg.decide_statements(ts, {"fig11": _replace(load_scene_data(out), name="fig11")})}
    assert v["fig11.ame_periodic"].shown == "no" and "leave every bound" in v["fig11.ame_periodic"].evidence
    assert v["fig11.envelope21"].shown == "partly" and "eq. (21) diverges at t = " in v["fig11.envelope21"].evidence


def test_modulation_period_of_a_sampled_signal():
    """Fig. 11's period: mean spacing of the upward mid-level crossings, to the sampling's linear
    interpolation error; none for a flat signal or too few crossings."""
    from autocable.scene.time_scene import modulation_period

    t = np.linspace(0.0, 1000.0, 20001)
    a = 3e-3 + 1e-3 * np.sin(2 * np.pi * t / 36.0) + 2e-4 * np.sin(4 * np.pi * t / 36.0 + 0.3)
    assert modulation_period(t, a) == pytest.approx(36.0, rel=1e-6)
    assert modulation_period(t, np.full_like(t, 3e-3)) is None
    assert modulation_period(t[:2000], a[:2000]) is None          # 100 time units: two crossings


@pytest.mark.slow
def test_ame_auto_picks_the_one_dof_reduction_for_fig05a(tmp_path):
    """`ame = "auto"`: the scene runs `autocable advise`'s probes first; Fig. 5a's settings
    are mono-modal (a2 = 0), so the 1-dof AME is chosen, run and recorded with its reasons. A
    tolerance without "auto", or outside (0, 1), is a one-line error."""
    text = FIG05A.read_text().replace('model = "../models/', f'model = "{REPO}/models/')
    path = tmp_path / "fig05a_auto.toml"
    path.write_text(text.replace('ame = "2dof"', 'ame = "auto"\name_tol = 0.02', 1))
    res = run_scene(load_scene(path), tmp_path / "out", resolution="coarse")
    prov = json.loads((tmp_path / "out" / "run.json").read_text())["provenance"]
    assert prov["ame"] == "1dof" and prov["ame_advice"]["chosen"] == "1dof"
    assert prov["ame_advice"]["requested"] == "auto" and prov["ame_advice"]["reasons"]
    assert np.max(np.abs(res.branch("I")["a2"])) == 0.0
    for body, words in (('ame = "2dof"\name_tol = 0.02\n', 'only with ame = "auto"'),
                        ('ame = "auto"\name_tol = 2.0\n', "(0, 1)")):
        bad = tmp_path / "bad_tol.toml"
        bad.write_text(f'model = "{MODEL}"\n' + body + '[[run]]\nparameter = "sigma"\nrange = [-0.05, 0.05]\n')
        with pytest.raises(SpecError) as err:
            load_scene(bad)
        assert err.value.field == "ame_tol" and words in str(err.value) and "\n" not in str(err.value)


def test_a_pycont_that_cannot_be_set_up_fails_its_run(tmp_path, monkeypatch):
    """PyCont's generator could not be built (no compiler, a PyDSTool error): the run used to end
    its branch at the start point with the scene "complete" and the command's success. It is now a
    failed run (ComputationError: the scene is published "failed", exit 3) naming the reason."""
    from dataclasses import replace

    from autocable.codegen.compat import PyDSToolError
    from autocable.errors import ComputationError
    from autocable.methods.continuation import pycont_driver
    from autocable.results import read_json
    from autocable.scene.runner import load_scene, run_scene

    def broken(*args, **kwargs):
        raise PyDSToolError("building the Dopri integrator for model 'ame2n' failed: gcc: not found",
                            what="building the Dopri integrator")

    monkeypatch.setattr(pycont_driver, "continuation_system", broken)
    scene = load_scene(Path("runs") / "fig05a.toml")
    assert scene.engine == "pycont"
    scene = replace(scene, overlay=None)
    with pytest.raises(ComputationError, match="PyCont could not be set up.*gcc: not found"):
        run_scene(scene, tmp_path / "out", plot=False)
    meta = read_json(tmp_path / "out" / "run.json")
    assert meta["status"] == "failed"
    assert "PyCont could not be set up" in meta["provenance"]["failed_runs"]["I"]
