"""The figures as objects: every special point labelled (LP included) with no label on another or
outside the axes, a legend for the line styles and markers, the Figure returned and ``ax=``
honoured, SI axes scaled by the cable's own scales, file stems kept whole, the chart's
codimension-2 points above the one-parameter markers, and the Poincare section against a closed form.
Synthetic branches with known folds: no continuation runs, seconds in all."""
import math

import numpy as np
import pytest

from autocable.results import Branch, RunResults, SpecialPoint


def _fold_branch(name="I") -> Branch:
    """An S-shaped response a1(sigma) = s with sigma = s - s^3 / 3 ... drawn with two folds at
    s = +-1 (d sigma / ds = 0), the middle part unstable, as a frequency response with jumps."""
    s = np.linspace(-2.0, 2.0, 201)
    sigma = (s - s ** 3 / 3.0) * 0.01
    a1 = (s + 2.5) * 1e-3
    stable = np.abs(s) > 1.0
    table = {"sigma": sigma, "U": np.zeros_like(s), "eta": np.full_like(s, 4e-4), "a1": a1,
             "a2": np.zeros_like(s), "r1": a1, "s1": np.zeros_like(s)}
    sps = []
    for k, sk in enumerate((-1.0, 1.0), start=1):
        i = int(np.argmin(np.abs(s - sk)))
        sps.append(SpecialPoint(branch=name, type="LP", label=f"LP{k}", parameter="sigma", value=float(sigma[i]),
                                a1=float(a1[i]), a2=0.0, state=(float(a1[i]), 0.0),
                                parameters={"sigma": float(sigma[i]), "U": 0.0, "eta": 4e-4}, index=i))
    i = 20
    sps.append(SpecialPoint(branch=name, type="H", label="H1", parameter="sigma", value=float(sigma[i]),
                            a1=float(a1[i]), a2=0.0, state=(float(a1[i]), 0.0),
                            parameters={"sigma": float(sigma[i]), "U": 0.0, "eta": 4e-4}, index=i))
    return Branch(name=name, kind="equilibrium", parameter="sigma", parameter_names=("sigma", "U", "eta"),
                  variables=("r1", "s1"), amplitude_names=("a1", "a2"), table=table, stable=stable,
                  eigenvalues=np.zeros((len(s), 0)), special_points=tuple(sps))


def _texts(fig) -> list[str]:
    return [t.get_text() for ax in fig.axes for t in ax.texts] + [t.get_text() for t in fig.texts]


def _legend(fig) -> list[str]:
    out = []
    for ax in fig.axes:
        if ax.get_legend():
            out += [t.get_text() for t in ax.get_legend().get_texts()]
    for leg in fig.legends:
        out += [t.get_text() for t in leg.get_texts()]
    return out


def test_folds_are_drawn_labelled_and_in_the_legend():
    import autocable as ac
    from matplotlib.figure import Figure
    fig = ac.plot_branches([_fold_branch()], x="sigma", y=("a1",))
    assert isinstance(fig, Figure)
    texts = _texts(fig)
    assert {"LP1", "LP2", "H1", "I"} <= set(texts)
    legend = _legend(fig)
    assert {"stable", "unstable", "fold (LP)", "Hopf point (H)"} <= set(legend)
    # the paper's symbols on the axes
    ax = fig.axes[0]
    assert ax.get_xlabel() == r"$\sigma$" and ax.get_ylabel() == r"$a_1$"


def test_labels_overlap_nothing_and_stay_inside_the_axes():
    """Three branches with their labels crowded near the same folds: each label's box lies inside
    the axes (so off the tick labels) and overlaps no other label."""
    import autocable as ac
    b = _fold_branch()
    crowd = [b, b.replace(name="II", table={**b.table, "a1": b.table["a1"] + 2e-5},
                          special_points=tuple(sp.__class__(**{**sp.__dict__, "branch": "II", "a1": sp.a1 + 2e-5})
                                               for sp in b.special_points))]
    fig = ac.plot_branches(crowd, x="sigma")
    renderer = fig.canvas.get_renderer()
    ax = fig.axes[0]
    frame = ax.get_window_extent(renderer)
    boxes = [t.get_window_extent(renderer) for t in ax.texts]
    assert len(boxes) == 8          # 3 special points and a name per branch
    for k, bb in enumerate(boxes):
        assert frame.x0 <= bb.x0 and bb.x1 <= frame.x1 and frame.y0 <= bb.y0 and bb.y1 <= frame.y1, ax.texts[k].get_text()
        for other in boxes[k + 1:]:
            assert not bb.overlaps(other)


def test_plots_draw_into_a_given_axes_and_return_its_figure():
    import autocable as ac
    from autocable.plotting.style import new_figure
    fig = new_figure((4, 3))
    ax = fig.subplots()
    out = ac.plot_branches([_fold_branch()], x="sigma", ax=ax)
    assert out is fig and len(fig.axes) == 1
    assert "LP1" in [t.get_text() for t in ax.texts]
    with pytest.raises(ValueError, match="ax: expected 2 Axes"):
        ac.plot_branches([_fold_branch()], x="sigma", y=("a1", "a2"), ax=ax)


def test_a_stem_with_a_dot_is_kept_whole(tmp_path):
    import autocable as ac
    from autocable.plotting.diagrams import save_figure
    fig = ac.plot_branches([_fold_branch()], tmp_path / "fh_U0_eta0.002", x="sigma")
    assert (tmp_path / "fh_U0_eta0.002.png").read_bytes()[:4] == b"\x89PNG"
    assert (tmp_path / "fh_U0_eta0.002.pdf").read_bytes()[:5] == b"%PDF-"
    assert not (tmp_path / "fh_U0_eta0.png").exists()
    # a stem given with the format's suffix names the same pair
    assert save_figure(fig, tmp_path / "x.png") == [tmp_path / "x.png", tmp_path / "x.pdf"]


def test_si_axes_are_the_nondimensional_data_times_the_cables_scales():
    """Eqs. (17)-(18): a_1 l [m], sigma omega / 2 pi [Hz]; the drawn data are the nondimensional
    ones times these factors (l = 100 m, omega = 2 pi rad/s: 1 Hz per unit of sigma)."""
    import autocable as ac
    from autocable.plotting.units import si_scales
    b = _fold_branch()
    units = si_scales(100.0, 2 * math.pi, 36.0)
    fig = ac.plot_branches([b], x="sigma", units=units)
    ax = fig.axes[0]
    assert ax.get_ylabel() == r"$a_1 l$ [m]" and ax.get_xlabel() == r"$\sigma\,\omega/2\pi$ [Hz]"
    ys = np.concatenate([ln.get_ydata() for ln in ax.lines if ln.get_linestyle() in ("-", "--")])
    xs = np.concatenate([ln.get_xdata() for ln in ax.lines if ln.get_linestyle() in ("-", "--")])
    assert np.max(ys) == pytest.approx(100.0 * np.max(b.table["a1"]), rel=1e-12)
    assert np.max(xs) == pytest.approx(1.0 * np.max(b.table["sigma"]), rel=1e-12)
    assert units["U"] == (36.0, r"$U$ [m/s]") and units["eta"][0] == 100.0
    with pytest.raises(ValueError, match="length_m"):
        si_scales(0.0, 1.0, 1.0)


def test_the_comparisons_rms_and_max_are_written_on_the_plot():
    from autocable.plotting.diagrams import plot_scene
    b = _fold_branch()
    pts = [{"x": 0.0, "y": 2.5e-3, "curve": "I", "stable": True}]
    stats = {"curves": {"I": {"n_points": 1, "rms_distance": 0.0123, "max_distance": 0.0456}}}
    fig = plot_scene(RunResults("t", (b,)), x="sigma", compare=pts, compare_stats=stats)
    note = [t for t in _texts(fig) if "RMS" in t]
    assert note and "RMS 1.2 %" in note[0] and "max 4.6 %" in note[0] and "n = 1" in note[0]


def test_in_the_chart_a_gh_point_is_drawn_above_a_one_parameter_hopf_marker():
    from autocable.plotting.chart import plot_chart
    n = 11
    u = np.linspace(0.5, 1.5, n)
    eta = np.linspace(0.0, 1e-3, n)
    pars = {"U": 1.0, "eta": 5e-4, "sigma": 0.0}
    gh = SpecialPoint(branch="Hc", type="GH", label="GH1", parameter="U", value=1.0, a1=0.0, a2=0.0, state=(0.0, 0.0),
                      parameters=pars, index=5)
    curve = Branch(name="Hc", kind="hopf", parameter="U", parameter2="eta", parameter_names=("sigma", "U", "eta"),
                   variables=("r1", "s1"), amplitude_names=("a1", "a2"),
                   table={"U": u, "eta": eta, "sigma": np.zeros(n), "a1": np.zeros(n), "a2": np.zeros(n),
                          "r1": np.zeros(n), "s1": np.zeros(n)},
                   stable=np.ones(n, bool), eigenvalues=np.zeros((n, 0)), special_points=(gh,))
    h = SpecialPoint(branch="I", type="H", label="H1", parameter="U", value=1.0, a1=0.0, a2=0.0, state=(0.0, 0.0),
                     parameters=pars, index=0)
    one = Branch(name="I", kind="equilibrium", parameter="U", parameter_names=("sigma", "U", "eta"),
                 variables=("r1", "s1"), amplitude_names=("a1", "a2"),
                 table={"U": u, "eta": np.full(n, 5e-4), "sigma": np.zeros(n), "a1": np.zeros(n), "a2": np.zeros(n),
                        "r1": np.zeros(n), "s1": np.zeros(n)},
                 stable=np.ones(n, bool), eigenvalues=np.zeros((n, 0)), special_points=(h,))
    fig = plot_chart(RunResults("c", (curve, one)), [], [], x="U", y="eta", x_range=(0.5, 1.5), y_range=(0, 1e-3))
    ax = fig.axes[0]
    at = [ln for ln in ax.lines if len(ln.get_xdata()) == 1 and ln.get_xdata()[0] == 1.0]
    z = {ln.get_marker(): ln.get_zorder() for ln in at}
    assert z["v"] > z["s"]                           # GH (v) above the open H square
    assert [ln.get_markerfacecolor() for ln in at if ln.get_marker() == "s"] == ["none"]
    assert {"H of a one-parameter branch", "GH (codim 2)"} <= set(_legend(fig))


def test_poincare_section_of_period_one_and_quasi_periodic_signals():
    """At the forcing period a period-1 signal cos(Omega t + 0.3) is one point, cos(0.3) (to the
    linear interpolation's error, (2 pi / 64)^2 / 8 = 1.2e-3); a signal with an incommensurate
    second frequency fills an interval."""
    from autocable.plotting.diagrams import poincare_section
    Omega = 1.1
    t = np.arange(0, 400 * 2 * np.pi / Omega, 2 * np.pi / Omega / 64)
    sec = poincare_section(t, np.cos(Omega * t + 0.3), Omega)
    assert len(sec) == 400 or len(sec) == 399
    assert np.max(np.abs(sec[:, 0] - math.cos(0.3))) < 1.3e-3
    quasi = poincare_section(t, np.cos(Omega * t) + np.cos(math.sqrt(2) * t), Omega)
    assert np.ptp(quasi[:, 0]) > 1.9          # cos(sqrt(2) t_k) sweeps [-1, 1]


def test_simulation_figure_has_history_phase_plane_and_section():
    from autocable.plotting.diagrams import plot_simulation
    Omega = 1.0
    t = np.arange(0, 50 * 2 * np.pi, 2 * np.pi / 64)
    q1 = 1e-3 * np.cos(Omega * t)
    q2 = 1e-4 * np.sin(Omega * t)
    fig = plot_simulation((t, q1, q2, -1e-3 * np.sin(t), 1e-4 * np.cos(t)), Omega=Omega, response="period-1")
    assert len(fig.axes) == 4
    sec = fig.axes[3].lines[0]
    # the steady part starts halfway (the default): every section point is the state at that phase
    t0 = 0.5 * t[-1]
    assert len(sec.get_xdata()) == 25
    assert np.allclose(sec.get_xdata(), 1e-3 * np.cos(t0), atol=1.3e-6)
    assert np.allclose(sec.get_ydata(), 1e-4 * np.sin(t0), atol=1.3e-7)
    assert "envelope (max, min per forcing period)" in _legend(fig)


@pytest.mark.slow
def test_the_folds_of_figure_7s_frequency_response_are_labelled(legacy_sample):
    """Fig. 7's setting (U* = 0.7, eta* = 4.1e-4) computed: branch I folds twice (at an LP the
    continued sigma turns back: its value is an extreme of sigma along the branch, within the
    branch's own points around it), and the diagram names both folds in its texts and its legend."""
    import warnings

    import autocable as ac
    from conftest import SAMPLE
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        # the legacy-sense sample (conftest.legacy_sample): its Fig. 7 branch I has two folds
        res = ac.frequency_response(legacy_sample, U=0.7, eta=4.1e-4, sigma=(-0.05, 0.05), switch=False)
    I = res.branch("I")
    lps = I.of_type("LP")
    assert len(lps) == 2
    s = I["sigma"]
    for p in lps:
        near = s[max(p.index - 3, 0):p.index + 4]
        assert p.value >= near.max() - 1e-9 or p.value <= near.min() + 1e-9
    fig = ac.plot_branches(res.branches, x="sigma", y=("a1",))
    assert {p.label for p in lps} <= set(_texts(fig))
    assert "fold (LP)" in _legend(fig)


def test_a_scene_in_si_units_takes_the_cables_own_scales(tmp_path):
    """[plot] units = "si" (or --units si): the scales are the derived cable's l, omega (eq. 17) and
    U_c (eq. 18); "paper" keeps the nondimensional symbols."""
    import autocable as ac
    from autocable.scene.figure_units import figure_units
    from conftest import SAMPLE
    d = ac.derive(SAMPLE)
    assert figure_units("paper", d) is None
    si = figure_units("si", d)
    assert si["a1"][0] == d.spec.cable.length_m == 121.9
    assert si["sigma"][0] == pytest.approx(d.statics.omega_ref / (2 * math.pi), rel=1e-15)
    assert si["U"][0] == 36.0 and si["t"][0] == pytest.approx(1 / d.statics.omega_ref, rel=1e-15)


def test_a_full_disk_inside_the_pdf_writer_is_reported_as_the_os_error(tmp_path, monkeypatch):
    """matplotlib's PDF writer, when the disk fills, raises from its clean-up an AttributeError
    ("'Stream' object has no attribute 'pos'") whose context is the OSError: saving a figure
    reports that OSError (which the CLI turns into one line naming --out) and leaves no temporary
    file. Any other error is left as it is."""
    import errno

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from autocable.plotting.diagrams import save_figure

    def full(*args, **kwargs):
        try:
            raise OSError(errno.ENOSPC, "No space left on device")
        except OSError:
            raise AttributeError("'Stream' object has no attribute 'pos'")

    fig, ax = plt.subplots()
    ax.plot([0, 1], [0, 1])
    monkeypatch.setattr(fig, "savefig", full)
    with pytest.raises(OSError) as err:
        save_figure(fig, tmp_path / "x.png")
    assert err.value.errno == errno.ENOSPC and list(tmp_path.iterdir()) == []
    monkeypatch.setattr(fig, "savefig", lambda *a, **k: (_ for _ in ()).throw(ValueError("not a disk")))
    with pytest.raises(ValueError, match="not a disk"):
        save_figure(fig, tmp_path / "x.png")
    plt.close(fig)
