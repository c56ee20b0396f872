"""Stability charts: pitchfork (BP) curves, the AME's response regions, the overlay of a brute-force
map of eq. (21), and the chart scene end to end.

* A Z2-symmetric textbook system with a closed-form pitchfork curve: x1' = a - x1, y1' = -y1,
  x2' = (x1 - b) x2 - x2^3, y2' = -y2 has its out-of-plane block singular at a2 = 0 exactly on a = b.
* The cable without wind (runs/chart_sigma_eta_U0.toml, coarse): the BP curve through I:BP1 and the
  fold curve through I-above:LP1 (both found at eta = 1.4e-3) must pass through the BP and LP
  points of an independent sigma-continuation at eta = 1.0e-3: the curves' crossing of eta = 1e-3,
  polished by Newton on the defining equations with finite-difference Jacobians (not the
  engine's), moves by less than the chord error and lands on the one-parameter points.
* Every BP-curve point checked independently: a2 = 0, f = 0 and the out-of-plane block of a
  finite-difference Jacobian singular.
* Region labels on a grid with a known answer (half-planes, a disc, an L), and the AME's class at
  points whose answer the curves give (below the pitchfork curve: the small forced response of I
  with a2 = 0; between the pitchforks: not I).
* The map reader on synthetic sweep.nc files (string classes; integer codes with each legend form).
"""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from autocable.methods.continuation import (ContinuationSettings, EquilibriumProblem, SymmetryError, System,
                                            ame_system, auto_state_scale, continue_branch_points,
                                            continue_equilibria)
from autocable.methods.continuation.branch_points import z2_split
from autocable.methods.regions import classify_point, label_regions
from autocable.model.ame_cache import derive_ame
from autocable.model.derive import derive
from autocable.scene.runner import load_scene, run_scene
from autocable.spec import SpecError, load_model
from conftest import scene_error

REPO = Path(__file__).resolve().parents[1]
MODEL = REPO / "models" / "luongo_zulli_2012.toml"
SCENE_U0 = REPO / "runs" / "chart_sigma_eta_U0.toml"


def fd_jacobian(system, x, p, h=1e-7):
    x = np.asarray(x, float)
    cols = []
    for e in np.eye(len(x)):
        step = h * max(1.0, np.max(np.abs(x)))
        cols.append((system.f(x + step * e, p) - system.f(x - step * e, p)) / (2 * step))
    return np.column_stack(cols)


def polish_crossing(branch, system, p1, p2, value, test, unknowns):
    """The points where the curve crosses p2 = value: linear interpolation between its points,
    then Newton at p2 = value on (f[unknowns] = 0, test = 0) in (x[unknowns], p1), finite-difference
    Jacobian. Returns [(interpolated p1, polished p1, |Newton displacement|, chord length)]."""
    names = system.parameter_names
    b = np.asarray(branch[p2]) - value
    out = []
    for i in np.nonzero(np.sign(b[:-1]) * np.sign(b[1:]) < 0)[0]:
        w = b[i] / (b[i] - b[i + 1])
        x = (1 - w) * branch.states[i] + w * branch.states[i + 1]
        v1 = (1 - w) * branch[p1][i] + w * branch[p1][i + 1]
        P = np.array([(1 - w) * branch[n][i] + w * branch[n][i + 1] for n in names])
        P[names.index(p2)] = value
        z0 = np.append(x[unknowns], v1)
        scale = np.append(np.full(len(unknowns), max(np.max(np.abs(x)), 1e-12)), max(abs(v1), 1e-3))

        def G(z):
            xx = x.copy()
            xx[unknowns] = z[:-1]
            pp = P.copy()
            pp[names.index(p1)] = z[-1]
            return np.append(system.f(xx, pp)[unknowns] / scale[0], test(xx, pp))
        z = z0.copy()
        for _ in range(30):
            g = G(z)
            A = np.column_stack([(G(z + 1e-7 * s * e) - G(z - 1e-7 * s * e)) / (2e-7 * s)
                                 for e, s in zip(np.eye(len(z)), scale)])
            dz = np.linalg.lstsq(A, -g, rcond=None)[0]
            z = z + dz
            if np.max(np.abs(dz) / scale) < 1e-13:
                break
        chord = abs(branch[p1][i + 1] - branch[p1][i]) + abs(branch[p2][i + 1] - branch[p2][i])
        out.append((v1, z[-1], abs(z[-1] - v1), chord))
    return out


# --------------------------------------------------------------------------------------------
# closed form
@pytest.fixture(scope="module")
def z2_system():
    x1, y1, x2, y2, a, b = sp.symbols("x1 y1 x2 y2 a b")
    return System("z2_pitchfork", ("x1", "y1", "x2", "y2"), (a - x1, -y1, (x1 - b) * x2 - x2 ** 3, -y2),
                  {"a": 0.0, "b": 0.5}, (("a1", ("x1", "y1")), ("a2", ("x2", "y2"))))


def test_bp_curve_of_a_symmetric_system_is_the_closed_form(z2_system):
    # (a range that keeps a - b < 1: at a - b = 1 the branch has a neutral saddle, lambda = +-1)
    problem = EquilibriumProblem(z2_system, "a", {"a": -1.0, "b": 0.5}, (-1.0, 1.2))
    eq = continue_equilibria(problem, ContinuationSettings(), [-1.0, 0.0, 0.0, 0.0], name="E")
    bp = [s for s in eq.branch.of_type("BP") if s.origin == "autocable"]
    assert len(bp) == 1 and abs(bp[0].value - 0.5) < 1e-9            # a = b
    curve = continue_branch_points(eq, bp[0].label, "b", (-0.5, 1.0),
                                   ContinuationSettings(curve_step=0.02, curve_max_step=0.1))
    B = curve.branch
    assert B.kind == "branch_point" and B.parameter == "a" and B.parameter2 == "b"
    assert B.info["check_failure_count"] == 0
    assert np.max(np.abs(B["a"] - B["b"])) < 1e-10                   # the closed form a = b
    assert B["b"].min() == pytest.approx(-0.5, abs=1e-12) and B["b"].max() == pytest.approx(1.0, abs=1e-12)
    assert {e.reason for e in B.ends} == {"range"}
    assert np.all(B["x2"] == 0.0) and np.all(B["y2"] == 0.0)


def test_bp_curve_meets_the_fold_of_the_mono_modal_branch():
    """x1' = (a - x1^2) / 4 (in-plane fold at a = 0), x2' = (x1 - b) x2 - x2^3: pitchforks where
    x1 = b, i.e. on a = b^2, and the pitchfork curve crosses the in-plane fold at (a, b) = (0, 0).
    (The factor 1/4 keeps neutral saddles, lambda_i + lambda_j = 0, out of the range.)"""
    x1, y1, x2, y2, a, b = sp.symbols("x1 y1 x2 y2 a b")
    system = System("z2_fold", ("x1", "y1", "x2", "y2"), ((a - x1 ** 2) / 4, -y1, (x1 - b) * x2 - x2 ** 3, -y2),
                    {"a": 0.8, "b": 0.5}, (("a1", ("x1", "y1")), ("a2", ("x2", "y2"))))
    problem = EquilibriumProblem(system, "a", {"a": 0.8, "b": 0.5}, (-0.5, 0.8))
    eq = continue_equilibria(problem, ContinuationSettings(), [0.8 ** 0.5, 0.0, 0.0, 0.0], name="E")
    bp = [s for s in eq.branch.of_type("BP") if s.origin == "autocable"]
    assert len(bp) == 1 and abs(bp[0].value - 0.25) < 1e-9
    curve = continue_branch_points(eq, bp[0].label, "b", (-0.6, 0.8),
                                   ContinuationSettings(curve_step=0.02, curve_max_step=0.05))
    B = curve.branch
    assert B.info["check_failure_count"] == 0
    assert np.max(np.abs(B["a"] - B["b"] ** 2)) < 1e-10 and np.max(np.abs(B["x1"] - B["b"])) < 1e-10
    assert B["b"].min() < -0.5 and B["b"].max() == pytest.approx(0.8, abs=1e-12)
    lp = B.of_type("LP")
    assert len(lp) == 1 and lp[0].converged and not B.of_type("BT")
    assert abs(lp[0].value) < 1e-9 and abs(lp[0].extra["value2"]) < 1e-9


def test_symmetry_is_checked(z2_system):
    assert z2_split(z2_system) == ((0, 1), (2, 3))
    x1, y1, x2, y2, a, b = sp.symbols("x1 y1 x2 y2 a b")
    broken = System("z2_broken", ("x1", "y1", "x2", "y2"),
                    (a - x1, -y1, (x1 - b) * x2 - x2 ** 3 + 1e-3 * x1 ** 2, -y2),
                    {"a": 0.0, "b": 0.5}, (("a1", ("x1", "y1")), ("a2", ("x2", "y2"))))
    with pytest.raises(SymmetryError, match="not symmetric"):
        z2_split(broken)


# --------------------------------------------------------------------------------------------
# the cable
@pytest.fixture(scope="module")
def ame_systems():
    deriv = derive(load_model(MODEL))
    ame = derive_ame(deriv, ordering="paper").ame
    return ame_system(ame, "2dof", wind=False), ame_system(ame, "2dof", wind=True)


def test_the_wind_ame_has_no_pitchforks(ame_systems):
    calm, windy = ame_systems
    assert z2_split(calm) == ((0, 1), (2, 3))
    with pytest.raises(SymmetryError, match="unfold into folds"):
        z2_split(windy, {"U": 0.7, "eta": 4.1e-4, "sigma": 0.0})


@pytest.fixture(scope="module")
def chart_u0(tmp_path_factory):
    out = tmp_path_factory.mktemp("chart_u0")
    mp = out / "sweep.nc"
    synthetic_map(mp, coded=True)
    return run_scene(load_scene(SCENE_U0), out, resolution="coarse", response_map=mp), out


def one_parameter(system, eta, at):
    values = {"U": 0.0, "eta": eta, "sigma": at}
    problem = EquilibriumProblem(system, "sigma", values, (-0.05, 0.05),
                                 state_scale=auto_state_scale(system, values))
    return continue_equilibria(problem, ContinuationSettings(), np.zeros(4), name="I", engine="compiled")


@pytest.mark.slow
def test_curves_pass_through_the_special_points_of_another_continuation(chart_u0, ame_systems):
    res, _ = chart_u0
    calm = ame_systems[0]
    BP, F = res.branch("BP"), res.branch("F")
    assert BP.kind == "branch_point" and F.kind == "fold"
    assert BP.info["check_failure_count"] == 0 and F.info["check_failure_count"] == 0
    eta = 1.0e-3                               # the curves were started at eta = 1.4e-3
    below = one_parameter(calm, eta, -0.05).branch
    above = one_parameter(calm, eta, 0.05).branch
    bps = sorted(s.value for s in below.of_type("BP") if s.origin == "autocable")
    lps = [s.value for s in above.of_type("LP") if s.origin == "autocable"]
    assert len(bps) == 2 and len(lps) == 1

    def det_out(x, p):
        J = fd_jacobian(calm, x, p)
        return np.linalg.det(J[2:, 2:]) / np.linalg.norm(J) ** 2

    def det_full(x, p):
        J = fd_jacobian(calm, x, p)
        return np.linalg.det(J) / np.linalg.norm(J) ** 4
    got = polish_crossing(BP, calm, "sigma", "eta", eta, det_out, [0, 1])
    assert len(got) == 2
    for (interp, polished, moved, chord), want in zip(sorted(got, key=lambda g: g[1]), bps):
        assert moved < 0.05 * chord                    # the curve's chord passes there
        assert abs(polished - want) < 1e-8, (polished, want)
    got = polish_crossing(F, calm, "sigma", "eta", eta, det_full, [0, 1, 2, 3])
    near = min(got, key=lambda g: abs(g[1] - lps[0]))
    assert near[2] < 0.05 * near[3]
    assert abs(near[1] - lps[0]) < 1e-8, (near, lps)
    # and through the points they started from (eta = 1.4e-3) exactly
    I = res.branch("I")
    start = BP.info["start_index"]
    assert BP["eta"][start] == pytest.approx(1.4e-3, abs=1e-15)
    assert abs(BP["sigma"][start] - I.special("BP1").value) < 1e-9


@pytest.mark.slow
def test_bp_curve_points_checked_independently(chart_u0, ame_systems):
    res, _ = chart_u0
    calm = ame_systems[0]
    B = res.branch("BP")
    assert np.all(B["a2"] == 0.0)
    for i in range(0, len(B), 5):
        p = np.array([B[n][i] for n in calm.parameter_names])
        x = B.states[i]
        J = fd_jacobian(calm, x, p)
        sv_out = np.linalg.svd(J[2:, 2:], compute_uv=False)
        sv = np.linalg.svd(J, compute_uv=False)
        assert sv_out[-1] <= 1e-7 * sv[0], (i, sv_out, sv)
        assert np.linalg.norm(calm.f(x, p)) <= 1e-9 * sv[0] * np.max(np.abs(x))
    # and the engine's own check at every point
    assert np.all(B["check_residual"] <= 1e-8)


@pytest.mark.slow
def test_chart_scene_end_to_end(chart_u0):
    res, out = chart_u0
    for name in ("chart_sigma_eta_U0_chart.png", "chart_sigma_eta_U0_chart.pdf", "regions.csv",
                 "regions.json", "branches.csv", "chart_sigma_eta_U0_plane.png"):
        assert (out / name).stat().st_size > 0, name
    data = json.loads((out / "regions.json").read_text())
    assert data["plane"] == ["sigma", "eta"] and data["grid"] == [15, 10]       # coarse: half of 30 x 20
    assert data["fixed"]["U"] == 0.0
    assert sum(r["cells"] for r in data["regions"]) == 150
    assert data["map"]["points"] == 4 * 3 and 0 <= data["map"]["agree"] <= 12


def test_region_classes_agree_with_the_curves(chart_u0, ame_systems):
    """Below the pitchfork curve's minimum and away from the cusp: the small forced response of I,
    a2 = 0, a1 equal to I's equilibrium there. Between the two pitchforks at eta = 1.4e-3: I is
    unstable out of plane, so no start stays on it (no 'small' class)."""
    res, _ = chart_u0
    calm = ame_systems[0]
    BP = res.branch("BP")
    eta_min = float(np.min(BP["eta"]))
    assert 5e-4 < eta_min < 1.0e-3
    cls, rows = classify_point(calm, {"U": 0.0, "eta": 3e-4, "sigma": -0.03})
    assert cls == "small"
    I = one_parameter(calm, 3e-4, -0.05).branch
    want = np.interp(-0.03, I["sigma"], I["a1"])          # I is single-valued far below resonance
    for r in rows:
        assert r["a2"] < 1e-9 and abs(r["a1"] - want) < 1e-3 * want
    I14 = res.branch("I")
    lo, hi = I14.special("BP1").value, I14.special("BP2").value
    cls, rows = classify_point(calm, {"U": 0.0, "eta": 1.4e-3, "sigma": 0.5 * (lo + hi) - 0.01})
    assert "small" not in cls.split(" + "), cls


def test_region_labels_on_a_known_grid():
    xs, ys = np.linspace(0.0, 1.0, 11), np.linspace(0.0, 2.0, 21)
    X, Y = np.meshgrid(xs, ys)
    grid = np.where(X < 0.45, "A", "B").astype(object)
    grid[(X - 0.8) ** 2 + (Y - 1.0) ** 2 <= 0.1 ** 2 + 1e-12] = "C"            # a disc inside B
    regions = label_regions(grid, xs, ys)
    by = {r.label: r for r in regions}
    assert sorted(by) == ["A", "B", "C"] and len(regions) == 3
    assert by["A"].cells == 5 * 21 and (by["A"].x, by["A"].y) == pytest.approx((0.2, 1.0))
    assert (by["C"].x, by["C"].y) == pytest.approx((0.8, 1.0)) and by["C"].cells == 5
    # B surrounds C: its centroid (0.7333.., 1.0) is in C, so B's label moves to B's own nearest cell
    assert grid[int(round(by["B"].y / 0.1)), int(round(by["B"].x / 0.1))] == "B"
    assert abs(by["B"].y - 1.0) <= 0.1 + 1e-12
    # two separate regions of one class are two labels, each at its own centroid
    g2 = np.full((3, 7), "x", dtype=object)
    g2[:, 3] = "y"
    r2 = label_regions(g2, np.arange(7.0), np.arange(3.0))
    xs_ = sorted(r.x for r in r2 if r.label == "x")
    assert xs_ == pytest.approx([1.0, 5.0])
    with pytest.raises(ValueError, match="shape"):
        label_regions(g2, np.arange(6.0), np.arange(3.0))


# --------------------------------------------------------------------------------------------
# the map of eq. (21)
LEGEND = ["rest", "period-1", "period-2", "quasi-periodic", "diverged"]


def synthetic_map(path, coded: bool, legend_form: str = "list"):
    """A sweep.nc as `autocable sweep` documents it: dims U, eta, sigma; response classes."""
    import xarray as xr

    sig = np.array([-0.04, -0.01, 0.02, 0.04])
    eta = np.array([5e-4, 1.2e-3, 2e-3])
    U = np.array([0.0, 0.7])
    codes = np.zeros((len(U), len(eta), len(sig)), dtype=np.int32)
    codes[0] = [[1, 1, 1, 1], [1, 2, 3, 1], [4, 1, 1, 0]]
    codes[1] = 4
    if coded:
        resp = xr.DataArray(codes, dims=("U", "eta", "sigma"))
        if legend_form == "list":
            resp.attrs["legend"] = json.dumps(LEGEND)
        elif legend_form == "text":
            resp.attrs["legend"] = "0: rest, 1: period-1, 2: period-2, 3: quasi-periodic, 4: diverged"
        elif legend_form == "cf":
            resp.attrs["flag_values"] = np.arange(5, dtype=np.int32)
            resp.attrs["flag_meanings"] = " ".join(LEGEND)
        elif legend_form == "cf+start":
            # as `autocable sweep` writes it: int8 codes, -1 = not computed, CF words with
            # underscores (and a JSON legend without -1), a start dimension
            codes = codes.astype(np.int8)
            both = np.stack([codes, codes], axis=-1)
            both[0, 0, 0, 1] = 3                     # the second start finds another attractor
            both[0, 2, 3, :] = -1                    # a point not computed
            resp = xr.DataArray(both, dims=("U", "eta", "sigma", "start"))
            resp.attrs["flag_values"] = np.arange(-1, 5, dtype=np.int8)
            resp.attrs["flag_meanings"] = "not_computed " + " ".join(c.replace("-", "_") for c in LEGEND)
            resp.attrs["legend"] = json.dumps({str(k): c for k, c in enumerate(LEGEND)})
            ds = xr.Dataset({"response": resp}, coords={"U": U, "eta": eta, "sigma": sig, "start": [0, 1]})
            ds.to_netcdf(path)
            return both
    else:
        resp = xr.DataArray(np.array(LEGEND, dtype=object)[codes].astype(str), dims=("U", "eta", "sigma"))
    ds = xr.Dataset({"response": resp, "a1": (("U", "eta", "sigma"), np.random.default_rng(0).random(codes.shape))},
                    coords={"U": U, "eta": eta, "sigma": sig})
    ds.to_netcdf(path)
    return codes


@pytest.mark.parametrize("coded, form", [(False, "list"), (True, "list"), (True, "text"), (True, "cf")])
def test_map_reader(tmp_path, coded, form):
    from autocable.plotting.chart import read_response_map
    path = tmp_path / "sweep.nc"
    codes = synthetic_map(path, coded, form)
    m = read_response_map(path, "sigma", "eta", {"U": 0.05})          # nearest U: 0
    assert m["fixed"] == {"U": 0.0} and m["requested"] == {"U": 0.05}
    assert len(m["x"]) == 12
    k = list(zip(m["x"], m["y"])).index((0.02, 1.2e-3))
    assert m["response"][k] == "quasi-periodic"
    want = [LEGEND[c] for c in codes[0].ravel()]                         # rows eta, columns sigma
    assert m["response"] == want
    m7 = read_response_map(path, "sigma", "eta", {"U": 0.7})
    assert set(m7["response"]) == {"diverged"}


def test_map_reader_folds_starts_and_skips_points_not_computed(tmp_path):
    from autocable.plotting.chart import read_response_map
    path = tmp_path / "sweep.nc"
    synthetic_map(path, True, "cf+start")
    m = read_response_map(path, "sigma", "eta", {"U": 0.0})
    assert len(m["x"]) == 11                                             # 12 points, one not computed
    k = list(zip(m["x"], m["y"])).index((-0.04, 5e-4))
    assert m["response"][k] == "period-1 + quasi-periodic"
    assert (0.04, 2e-3) not in list(zip(m["x"], m["y"]))
    assert set(m["response"]) <= {"rest", "period-1", "period-2", "quasi-periodic", "diverged",
                                  "period-1 + quasi-periodic"}


def test_map_reader_errors_are_one_line(tmp_path):
    from autocable.plotting.chart import read_response_map
    path = tmp_path / "sweep.nc"
    synthetic_map(path, True, "none")
    with pytest.raises(SpecError) as err:
        read_response_map(path, "sigma", "eta", {"U": 0.0})
    assert "\n" not in str(err.value) and err.value.field == "response.legend" and "no name" in str(err.value)
    with pytest.raises(SpecError) as err:
        read_response_map(path, "sigma", "rho", {})
    assert err.value.field == "rho"


def test_agreement_counts_matching_classes():
    from autocable.plotting.chart import agreement
    rows = [{"s": 0.0, "e": 0.0, "class": "small"}, {"s": 1.0, "e": 0.0, "class": "modulated"},
            {"s": 0.0, "e": 1.0, "class": "bi-modal + diverged"}, {"s": 1.0, "e": 1.0, "class": "diverged"}]
    m = {"x": np.array([0.0, 1.0, 0.1, 0.9]), "y": np.array([0.0, 0.0, 0.9, 1.0]),
         "response": ["period-1", "period-1", "diverged", "quasi-periodic"]}
    score = agreement(rows, "s", "e", m)
    assert score == {"points": 4, "agree": 2, "fraction": 0.5}


# --------------------------------------------------------------------------------------------
# the scene file and the command
@pytest.mark.parametrize("body, field, words", [
    ('[chart]\nplane = ["sigma", "sigma"]\n', "chart.plane", "two different"),
    ('[chart]\ngrid = [1, 5]\n', "chart.grid", "whole numbers"),
    ('[chart]\nx_range = [0.05, -0.05]\n', "chart.x_range", "lo < hi"),
    ('[chart]\nplane = ["U", "eta"]\nx_range = [0.0, 1.0]\ny_range = [0, 1e-3]\n', "chart.x_range", "U must stay > 0"),
    ('[chart]\ncolour = "red"\n', "chart.colour", "unknown key"),
    ('[chart]\nstarts = [1, 2]\n', "chart.starts", "[a1, a2] pairs"),
])
def test_chart_schema_errors_are_one_line(tmp_path, body, field, words):
    err = scene_error(tmp_path / "bad.toml",
                      f'model = "{MODEL}"\n[fixed]\neta = 1.4e-3\n[[run]]\nname = "I"\nparameter = "sigma"\n'
                      f'range = [-0.05, 0.05]\n[[run]]\nname = "B"\nkind = "curve"\nstart = "I:BP1"\n'
                      f'parameter = "sigma"\nrange = [-0.05, 0.05]\nparameter2 = "eta"\nrange2 = [0, 2e-3]\n' + body)
    assert err.field == field and words in str(err)


def test_chart_command_needs_a_chart_table(tmp_path):
    env_py = sys.executable
    r = subprocess.run([env_py, "-m", "autocable.cli", "chart", str(REPO / "runs" / "fig05a.toml"),
                        "--out", str(tmp_path / "o")], capture_output=True, text=True, cwd=REPO)
    assert r.returncode == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "fig05a.toml" in lines[0] and "chart" in lines[0] and "[chart]" in lines[0]


def test_a_bad_map_is_refused_before_anything_is_computed(tmp_path):
    bad = tmp_path / "sweep.nc"
    synthetic_map(bad, True, "none")                     # integer codes without a legend
    with pytest.raises(SpecError) as err:
        run_scene(load_scene(SCENE_U0), tmp_path / "out", resolution="coarse", response_map=bad)
    assert "\n" not in str(err.value) and str(bad) in str(err.value) and err.value.field == "response.legend"
    assert not (tmp_path / "out" / "branches.csv").exists()


def test_map_period_1_points_with_both_modes_are_bi_modal(tmp_path):
    """A period-1 point is bi-modal when the map's structural flag says its a2 is not slaved to a1,
    whatever a2 / a1: here the point with a2 = 0.5 a1 is slaved (a coupled cable's forced
    response), the one with a2 = 1e-4 a1 is not (near the pitchfork it was born at); a map without
    the flag marks neither (tests/test_regions_structure.py for the rule itself)."""
    import xarray as xr
    from autocable.plotting.chart import agreement, read_response_map
    sig, eta = np.array([0.0, 0.01, 0.02]), np.array([1e-3])
    resp = np.array([[["period-1", "period-1", "quasi-periodic"]]])    # (U, eta, sigma)
    a1 = np.array([[[4e-3, 4e-3, 4e-3]]])
    a2 = np.array([[[2e-3, 4e-3 * 1e-4, 2e-3]]])                       # 0.5 a1, 1e-4 a1, 0.5 a1
    flag = np.array([[[0, 1, -1]]], dtype=np.int8)
    dims = ("U", "eta", "sigma")
    ds = xr.Dataset({"response": (dims, resp), "a1": (dims, a1), "a2": (dims, a2), "bimodal": (dims, flag)},
                    coords={"U": [0.0], "eta": eta, "sigma": sig})
    ds.to_netcdf(tmp_path / "sweep.nc")
    m = read_response_map(tmp_path / "sweep.nc", "sigma", "eta", {"U": 0.0})
    assert m["response"] == ["period-1", "period-1 bi-modal", "quasi-periodic"]
    rows = [{"sigma": 0.0, "eta": 1e-3, "class": "bi-modal"}, {"sigma": 0.01, "eta": 1e-3, "class": "bi-modal"},
            {"sigma": 0.02, "eta": 1e-3, "class": "bi-modal"}]
    assert agreement(rows, "sigma", "eta", m)["agree"] == 1                # the slaved point disagrees
    ds.drop_vars("bimodal").to_netcdf(tmp_path / "old.nc")
    assert read_response_map(tmp_path / "old.nc", "sigma", "eta", {"U": 0.0})["response"] == [
        "period-1", "period-1", "quasi-periodic"]


def test_chart_sigma_eta_starts_find_the_labels_its_curves_use(tmp_path):
    """runs/chart_sigma_eta.toml's one-parameter runs on the sample (the curve runs and the
    classification left out: seconds): run II starts from a search, not from a start tuned to one
    model, and finds a branch that is not I (a closed one on this sample); every labelled point the
    curve runs start from exists, and each is what its run says: I:LP1 where the resonance peak
    turns back (sigma increasing from rest up to it, just right of the chart's sigma = 0.05), I:LP6
    its lower fold (the last fold, below a1 = 2e-3, near resonance), Ih's fold and Hopf point below
    resonance."""
    text = (REPO / "runs" / "chart_sigma_eta.toml").read_text()
    scene_text = text[:text.index('[[run]]\nname = "Fh"')].replace('"../models/luongo_zulli_2012.toml"',
                                                                   json.dumps(str(MODEL)))
    path = tmp_path / "chart_runs.toml"
    path.write_text(scene_text)
    scene = load_scene(path)
    assert [r.name for r in scene.runs] == ["I", "II", "Ih"] and scene.runs[1].start.kind == "search"
    curve_starts = [r.start.label for r in load_scene(REPO / "runs" / "chart_sigma_eta.toml").runs
                    if r.kind == "curve"]
    res = run_scene(scene, tmp_path / "out", plot=False)
    branches = {b.name: b for b in res.branches}
    assert "II" in branches
    assert [e.reason for e in branches["II"].ends] == ["closed", "closed"]
    for label in curve_starts:
        name, point = label.split(":")
        assert point in {s.label for s in branches[name].special_points}, label
    I = branches["I"]
    lp = {s.label: s for s in I.special_points if s.type == "LP"}
    assert 0.05 < lp["LP1"].value < 0.06
    sigma = np.asarray(I["sigma"])[:lp["LP1"].index + 1]
    assert np.all(np.diff(sigma) > 0)          # from rest up the peak, and back at LP1
    assert max(lp) == "LP6" and lp["LP6"].a1 < 2e-3 and abs(lp["LP6"].value) < 0.01
    Ih = {s.label: s for s in branches["Ih"].special_points}
    assert Ih["LP1"].value < 0 and Ih["H1"].value < 0
