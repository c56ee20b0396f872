"""``start = { search = [...] }``: every equilibrium Newton finds from a fixed grid
(autocable.methods.continuation.search), and the scene runs that start from it (Figs. 4, 7-10:
isolas and disconnected branches without a start tuned to one model)."""
import json
import math
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from autocable.methods.continuation import System
from autocable.methods.continuation.search import find_equilibria, search_grid
from autocable.scene.runner import on_known_branch
from autocable.scene.schema import load_scene
from conftest import scene_error, two_run_scene

REPO = Path(__file__).resolve().parents[1]
MODEL = REPO / "models" / "luongo_zulli_2012.toml"


def _duffing(mu=0.01, k=1.0, f=0.005):
    """The averaged forced Duffing oscillator in Cartesian form: with nu = sigma - k (u^2 + v^2),
    u' = -mu u - nu v, v' = -mu v + nu u + f. Its equilibria have a^2 = u^2 + v^2 with
    a^2 (mu^2 + (sigma - k a^2)^2) = f^2 (the backbone-bent frequency response)."""
    u, v, sigma = sp.symbols("u v sigma")
    nu = sigma - k * (u ** 2 + v ** 2)
    return System("duffing_avg", ("u", "v"), (-mu * u - nu * v, -mu * v + nu * u + f), {"sigma": 0.0},
                  amplitudes=(("a1", ("u", "v")),))


def test_finds_the_three_closed_form_responses_of_a_forced_duffing_oscillator():
    """Three coexisting responses at sigma = 0.1: the roots X = a^2 of the cubic
    X (mu^2 + (sigma - k X)^2) = f^2, the largest and smallest stable, the middle one a saddle."""
    mu, k, f, sigma = 0.01, 1.0, 0.005, 0.1
    eqs = find_equilibria(_duffing(mu, k, f), {"sigma": sigma}, scale=0.1, max_amplitude=1.0)
    # X^3 k^2 - 2 sigma k X^2 + (mu^2 + sigma^2) X - f^2 = 0
    roots = np.sort(np.sqrt(np.real(np.roots([k * k, -2 * sigma * k, mu * mu + sigma * sigma, -f * f]))))[::-1]
    assert len(eqs) == 3
    assert [e.amplitudes[0] for e in eqs] == pytest.approx(list(roots), rel=1e-10)
    assert [e.stable for e in eqs] == [True, False, True]
    assert max(e.residual for e in eqs) < 1e-14


def test_one_response_away_from_the_fold_and_the_grid_is_deterministic():
    """Below the fold (sigma = -0.05) the cubic has one real root: one equilibrium, stable."""
    eqs = find_equilibria(_duffing(), {"sigma": -0.05}, scale=0.1, max_amplitude=1.0)
    X = [r.real for r in np.roots([1.0, 0.1, 0.01 ** 2 + 0.05 ** 2, -0.005 ** 2]) if abs(r.imag) < 1e-12]
    assert len(eqs) == 1 and eqs[0].stable
    assert eqs[0].amplitudes[0] == pytest.approx(math.sqrt(X[0]), rel=1e-10)
    assert len(search_grid(4, 1.0)) == 1088 and len(search_grid(2, 1.0)) == 64
    again = find_equilibria(_duffing(), {"sigma": -0.05}, scale=0.1, max_amplitude=1.0)
    assert again == eqs


def test_batched_evaluation_equals_the_pointwise_one():
    """`System.f_many` / `jac_many` (one call for all the starts) equal `f` / `jac` row by row, also
    for a field with constant entries, which do not broadcast (the row-by-row fallback)."""
    x, y, a = sp.symbols("x y a")
    linear = System("lin", ("x", "y"), (-x + a, 2 * y), {"a": 0.5})
    for system in (_duffing(), linear):
        X = np.random.default_rng(1).normal(size=(7, 2))
        p = system.parameter_vector({})
        assert system.f_many(X, p) == pytest.approx(np.array([system.f(r, p) for r in X]), rel=1e-14)
        assert system.jac_many(X, p) == pytest.approx(np.array([system.jac(r, p) for r in X]), rel=1e-14)


def test_on_known_branch_tells_two_nearby_branches_apart():
    """States are compared, not amplitudes: at Fig. 7's sigma = -0.03 two stable bi-modal
    equilibria lie 1-2 % apart in (a1, a2) but on different branches."""
    from autocable.results import Branch

    def branch(name, p, xs):
        xs = np.asarray(xs, float)
        table = {"sigma": np.asarray(p, float), "r1": xs[:, 0], "s1": xs[:, 1], "r2": xs[:, 2], "s2": xs[:, 3],
                 "a1": np.hypot(xs[:, 0], xs[:, 1]), "a2": np.hypot(xs[:, 2], xs[:, 3])}
        return Branch(name, "equilibrium", "sigma", ("sigma",), ("r1", "s1", "r2", "s2"), ("a1", "a2"), table,
                      np.ones(len(p), bool), np.zeros((len(p), 4), complex))

    b = branch("II", [-0.031, -0.029], [[-4.36e-3, 7.9e-4, 2.57e-3, -1.8e-4], [-4.36e-3, 7.9e-4, 2.57e-3, -1.8e-4]])
    assert on_known_branch([b], "sigma", -0.03, [-4.36e-3, 7.9e-4, 2.57e-3, -1.8e-4]) == "II"
    # the mirror image (the out-of-plane mode's sign) is the same branch
    assert on_known_branch([b], "sigma", -0.03, [-4.36e-3, 7.9e-4, -2.57e-3, 1.8e-4]) == "II"
    # an equilibrium with amplitudes within 2 % but another phase is not on it
    assert on_known_branch([b], "sigma", -0.03, [-4.0e-3, 1.9e-3, 2.2e-3, 1.4e-3]) == ""
    # outside the branch's parameter span: not on it
    assert on_known_branch([b], "sigma", 0.0, [-4.36e-3, 7.9e-4, 2.57e-3, -1.8e-4]) == ""


def test_a_search_that_finds_nothing_new_is_not_a_failure(tmp_path):
    """Fig. 5a's setting (U = 0, eta* = 8.2e-5) has one mono-modal response at each sigma, on I:
    the search run has no branch, a run starting from it is skipped, the scene is complete and
    run.json says what was searched."""
    from autocable.scene.runner import run_scene

    extra = '[[run]]\nname = "II-H"\nkind = "cycles"\nparameter = "sigma"\nrange = [-0.05, 0.05]\nstart = "II:H1"\n'
    f = tmp_path / "s.toml"
    f.write_text(two_run_scene("{ search = [0.0, 0.02] }", extra, engine="compiled", title="search test"))
    run_scene(load_scene(f), tmp_path / "out", plot=False, resolution="coarse")
    run = json.loads((tmp_path / "out" / "run.json").read_text())
    assert [b["name"] for b in run["branches"]] == ["I"]
    assert run["status"] == "complete"
    timing = run["provenance"]["stages"]["runs"]["II"]
    assert "no stable equilibrium off the earlier branches at sigma = 0, 0.02" in timing["search"]


def test_search_finds_fig4a_island_that_the_tuned_start_found():
    """The island II of Fig. 4a (U* in [0.6495, 0.8806], folds and Hopf points) from the search at
    U* = 0.85 is the branch that Newton from the state tuned by hand (6.243296e-4, 4.957535e-3,
    5.318726e-6, -1.455669e-4) reaches: Newton on the AME from both starts gives one state. On the
    legacy-sense sample (conftest.legacy_path), on which that state was tuned."""
    from conftest import legacy_path
    from autocable.methods.continuation import ame_system
    from autocable.methods.continuation.equilibrium_analysis import equilibrium_near
    from autocable.model.ame_cache import derive_ame
    from autocable.model.derive import derive
    from autocable.spec import load_model

    ame = derive_ame(derive(load_model(legacy_path())), ordering="natural").ame
    system = ame_system(ame, "2dof", wind=True)
    values = {"U": 0.85, "sigma": 0.01, "eta": 1.6e-4}
    eqs = find_equilibria(system, values, scale=0.005)
    tuned, ok, _ = equilibrium_near(system, [6.243296e-4, 4.957535e-3, 5.318726e-6, -1.455669e-4],
                                    system.parameter_vector(values), scale=0.005)
    assert ok
    stable = [e for e in eqs if e.stable]
    assert len(stable) == 2                  # branch I's small response and the island's point
    island = max(stable, key=lambda e: e.amplitudes[0])
    assert np.asarray(island.state) == pytest.approx(tuned, rel=1e-9, abs=1e-15)


@pytest.mark.parametrize("run, field, fix", [
    ('kind = "cycles"\nstart = { search = [0.0] }', "run[0].start", "equilibria"),
    ('start = { search = [0.2] }', "run[0].start.search", "outside the run's range"),
    ('start = { search = [0.0] }\nat = 0.0', "run[0].at", "search values say where"),
    ('start = { search = [] }', "run[0].start.search", "list of numbers"),
])
def test_bad_search_start_is_one_line(tmp_path, run, field, fix):
    err = scene_error(tmp_path / "bad.toml", f'model = "{MODEL}"\nengine = "compiled"\n[fixed]\nU = 0.0\neta = 1e-4\n'
                      f'[[run]]\nname = "A"\nparameter = "sigma"\nrange = [-0.05, 0.05]\n{run}\n')
    assert err.field == field and fix in str(err) and "bad.toml" in str(err)


def test_search_needs_the_cartesian_ame(tmp_path):
    """The amplitude-only AME (Fig. 3's) has no phases to search over: refused when the file is read."""
    err = scene_error(tmp_path / "amp.toml", f'model = "{MODEL}"\name = "1dof-amplitude"\n[fixed]\neta = 0.0\n'
                      'sigma = 0.0\n[[run]]\nname = "A"\nparameter = "U"\nrange = [0.5, 1.5]\n'
                      'start = { search = [1.2] }\n')
    assert err.field == "run[0].start" and 'ame = "2dof"' in str(err)


def test_trivial_start_moves_where_newton_from_rest_converges(tmp_path):
    """``start = "trivial"`` on a model whose small forced response does not reach the range's start:
    Fig. 10's setting (U* = 1.3, eta* = 1.4e-3) with the consistent "mirrored" angle sense, where the
    branch through the small response is a closed curve inside (-0.05, 0.05). Newton from rest fails
    at sigma = -0.05 and the run starts at the first sigma of the range where it converges; the branch
    found is closed and never reaches -0.05, which is why no start there could converge."""
    from autocable.scene.runner import TRIVIAL_TRIES, run_scene
    from conftest import SAMPLE
    model = tmp_path / "mirrored.toml"
    model.write_text(SAMPLE.read_text().replace('angle_convention = "reversed"', 'angle_convention = "mirrored"'))
    scene = tmp_path / "fig10_I.toml"
    scene.write_text(f'title = "Fig. 10, run I"\nmodel = "{model.as_posix()}"\name = "2dof"\nengine = "compiled"\n'
                     '[fixed]\nU = 1.3\neta = 1.4e-3\n[[run]]\nname = "I"\nparameter = "sigma"\n'
                     'range = [-0.05, 0.05]\nstart = "trivial"\n')
    said = []
    res = run_scene(load_scene(scene), tmp_path / "out", plot=False, progress=said.append)
    moved = [s for s in said if "did not converge" in s and "Newton from rest converges at sigma = " in s]
    assert len(moved) == 1, said
    v = float(moved[0].split("converges at sigma = ")[1].split(":")[0])
    grid = np.linspace(-0.05, 0.05, TRIVIAL_TRIES)
    assert -0.05 < v < 0.0 and np.min(np.abs(grid - v)) < 1e-9
    b = [x for x in res.branches if x.name == "I"][0]
    sigma = np.asarray(b.table["sigma"], float)
    assert sigma.min() > -0.05 + 1e-4
    assert any(e.reason == "closed" for e in b.ends)
