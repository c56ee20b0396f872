"""The README's API example and every script of examples/ run, and their numbers are checked
(scikit-fem's habit: examples are importable and tested, never only run for a zero exit code)."""
import importlib.util
import math
import re

import numpy as np
import pytest
from scipy.optimize import brentq

from conftest import REPO


def _example(name: str):
    spec = importlib.util.spec_from_file_location(f"example_{name}", REPO / "examples" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _out_of_plane_singularity(system, point) -> float:
    """Smallest singular value of the (r2, s2) block of the AME Jacobian over its largest: zero at a
    pitchfork of the mono-modal branch (a2 = 0 there, and the Z2 symmetry q2 -> -q2 of eq. 21 makes
    that block decouple), whatever engine found the point."""
    J = system.jac(np.asarray(point.state), system.parameter_vector(point.parameters))
    s = np.linalg.svd(J[2:, 2:], compute_uv=False)
    return s[-1] / s[0]


@pytest.mark.slow
def test_readme_api_example_reproduces_fig06(tmp_path, monkeypatch):
    """The README's block, run as written (from the repository folder, the plot into tmp_path):
    branch I of Fig. 6 has its two pitchforks, each a true singularity of the out-of-plane block
    and each the birth of a bi-modal branch (a2 > 0 away from it), and I at sigma = -0.05 equals
    the AME integrated from rest at that sigma (continuation against integration of (24))."""
    text = (REPO / "README.md").read_text()
    code = re.search(r"<!-- api-example -->\n```python\n(.*?)```", text, re.S).group(1)
    code = code.replace('"models/', f'"{REPO.as_posix()}/models/').replace('"fig06"', f'"{(tmp_path / "fig06").as_posix()}"')
    scope: dict = {}
    exec(compile(code, "README.md", "exec"), scope)
    I, bimodal, system = scope["I"], scope["bimodal"], scope["system"]
    bps = I.branch.of_type("BP")
    assert len(bps) == 2 and len(bimodal) == 2
    for bp in bps:
        assert abs(bp.a2) < 1e-12 and _out_of_plane_singularity(system, bp) < 1e-6
    for b in bimodal:
        assert np.max(b.branch["a2"]) > 1e-3          # genuinely bi-modal (Fig. 6: a2 up to ~8e-3)
    assert (tmp_path / "fig06.png").is_file() and (tmp_path / "fig06.pdf").is_file()

    import autocable as ac
    rest = ac.AmeIntegrator(ac.derive_ame(ac.derive(REPO / "models" / "luongo_zulli_2012.toml")).ame)
    r = rest.simulate(0.0, 1.4e-3, -0.05)
    assert I.branch["a1"][0] == pytest.approx(r.a1, rel=1e-6) and I.branch["sigma"][0] == pytest.approx(-0.05)


@pytest.mark.slow
def test_fig06_example_gives_the_same_pitchforks_on_both_engines(tmp_path):
    """examples/fig06.py with PyCont and with the compiled kernel: the same special points of I and
    of the bi-modal branches, to the continuation tolerance (both are refined by autocable's test
    functions on the same AME)."""
    fig06 = _example("fig06")
    runs = {}
    for engine in ("pycont", "compiled"):
        (tmp_path / engine).mkdir()
        runs[engine] = fig06.main(tmp_path / engine, engine=engine)
    (I_p, bi_p), (I_c, bi_c) = runs["pycont"], runs["compiled"]
    for a, b in zip((I_p, *bi_p), (I_c, *bi_c), strict=True):
        pa = [(p.type, p.value) for p in a.branch.special_points if p.type != "BP0"]
        pb = [(p.type, p.value) for p in b.branch.special_points if p.type != "BP0"]
        assert [t for t, _ in pa] == [t for t, _ in pb] and pa
        assert np.allclose([v for _, v in pa], [v for _, v in pb], atol=1e-7)


@pytest.mark.slow
def test_own_cable_example(tmp_path):
    """examples/own_cable.py: a spec written from scratch. omega1 is Irvine's symmetric root of the
    cable's own lambda^2 = delta^2 / tau (tan(b/2) = b/2 - 4 (b/2)^3 / lambda^2, omega1 = b / pi),
    computed here from the spec's numbers alone; at U = 0 and small eta the response is mono-modal
    and the AME agree with eq. (21) within the AME-vs-(21) study's bound at the smallest eta."""
    from autocable.studies.ame_bounds import STUDY_MAX_ERROR

    d, r21, rame = _example("own_cable").main(tmp_path)
    c = d.spec.cable
    alpha = math.radians(c.chord_slope_deg)
    delta = c.mass_per_length_kg_m * c.gravity_m_s2 * math.cos(alpha) ** 2 / c.horizontal_tension_N * c.length_m
    tau = c.horizontal_tension_N / math.cos(alpha) / c.axial_stiffness_N
    lam2 = delta**2 / tau
    x = brentq(lambda x: math.tan(x) - (x - 4 / lam2 * x**3), math.pi / 2 + 1e-9, 3 * math.pi / 2 - 1e-9)
    assert d.ode.omega1 == pytest.approx(2 * x / math.pi, rel=1e-10)
    assert d.ode.omega2 == 1.0
    assert r21.a2 < 1e-12 and rame.a2 < 1e-12
    assert abs(rame.a1 - r21.a1) / r21.a1 < STUDY_MAX_ERROR[8.2e-5]


@pytest.mark.slow
def test_ame_vs_ode21_example(tmp_path):
    """examples/ame_vs_ode21.py at Fig. 5b's setting: up and down sweeps agree (a mono-modal
    response with no hysteresis there, Sect. 5) and the AME stay within the study's bound at
    eta* = 4.1e-4 (2.62 %), with the resonance peak near sigma = 0."""
    from autocable.studies.ame_bounds import STUDY_MAX_ERROR

    ode, ame, worst = _example("ame_vs_ode21").main(tmp_path)
    assert 0 < worst <= STUDY_MAX_ERROR[4.1e-4]
    up = {p.value: p.a1 for p in ode if p.direction == "up"}
    down = {p.value: p.a1 for p in ode if p.direction == "down"}
    assert all(up[s] == pytest.approx(down[s], rel=1e-6) for s in up)
    assert max(up, key=up.get) == pytest.approx(0.0, abs=1e-12)
    assert (tmp_path / "ame_vs_ode21.png").is_file()


def test_frequency_response_example(tmp_path):
    """examples/frequency_response.py: one call gives branch I and the two bi-modal branches of
    Fig. 6's setting; the DataFrame holds every point of every branch; the SI figure's a1 axis is
    a1 l (l = 121.9 m), its data the nondimensional a1 times l."""
    res, table, fig = _example("frequency_response").main(tmp_path)
    assert [b.name for b in res.branches] == ["I", "II", "III"]
    assert len(table) == sum(len(b) for b in res.branches)
    assert table.groupby("branch")["a2"].max()[["II", "III"]].min() > 1e-3
    ax = fig.axes[0]
    assert ax.get_ylabel() == r"$a_1 l$ [m]"
    drawn = max(np.nanmax(ln.get_ydata()) for ln in ax.lines if ln.get_linestyle() in ("-", "--"))
    assert drawn == pytest.approx(121.9 * table["a1"].max(), rel=1e-12)
    assert (tmp_path / "frequency_response.png").is_file() and (tmp_path / "frequency_response.pdf").is_file()
