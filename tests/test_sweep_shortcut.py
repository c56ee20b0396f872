"""The period-1 shortcut of the eq. (21) overlays (`sweeps.PeriodOneShortcut`) against integrating on.

The scenes' overlays end an integration once Newton on the period map finds the stable period-1
orbit it converges to. Cross-check on the real overlay points of two figure scenes, each swept
both ways from the same starts with and without the shortcut: Fig. 7 (U* = 0.7, a resonance with
hysteresis: the jumps must land on the same attractor), Fig. 9 (amplitude-modulated responses
between period-1 ones: those must stay "not steady") and Fig. 4c (U* = 0.9, near the Hopf point:
an approach to a stable orbit too slow for the integration to call steady by max_time, which must
stay "not steady", and so must the next point's start). Stated tolerance: the same class at every
point, and at the periodic ones the amplitudes and their envelope within 1e-6 of max(a1, a2)
(the full integration stops once they change by less than 1e-8 between chunks of 100 periods).
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from autocable.methods.integration.ode21 import Ode21Integrator
from autocable.methods.integration.sweeps import PeriodOneShortcut, RecurrenceStop, sweep
from autocable.model.derive import derive
from autocable.scene.schema import load_scene
from autocable.spec import load_model

RUNS = Path(__file__).resolve().parents[1] / "runs"
TOL = 1e-6


def _both(name: str):
    scene = load_scene(RUNS / f"{name}.toml")
    ov = scene.overlay
    ode = derive(load_model(scene.model)).ode
    integrator = Ode21Integrator(ode, engine="compiled")
    values = np.linspace(ov.range[0], ov.range[1], ov.points)
    fixed = {k: v for k, v in scene.fixed.items() if k != ov.parameter}
    full = sweep(integrator, ov.parameter, values, fixed, directions=ov.directions, max_time=ov.max_time)
    shortcut = PeriodOneShortcut(integrator)
    fast = sweep(integrator, ov.parameter, values, fixed, directions=ov.directions, max_time=ov.max_time,
                 shortcut=shortcut)
    return full, fast, shortcut


@pytest.mark.parametrize("name", ["fig07", "fig09", "fig04c"])
@pytest.mark.slow
def test_shortcut_gives_the_full_integrations_answer(name):
    full, fast, shortcut = _both(name)
    assert len(full) == len(fast)
    periodic = 0
    for a, b in zip(full, fast):
        where = f"{name} {a.direction} {a.parameter} = {a.value:+.4f}"
        assert (a.direction, a.value) == (b.direction, b.value)
        assert (a.steady, a.periodic, math.isfinite(a.a1)) == (b.steady, b.periodic, math.isfinite(b.a1)), \
            f"{where}: {a.message} / {b.message}"
        if a.periodic:
            periodic += 1
            size = max(a.a1, a.a2)
            for key in ("a1", "a2", "a1_min", "a1_max", "a2_min", "a2_max"):
                assert abs(getattr(a, key) - getattr(b, key)) <= TOL * size, (where, key)
    assert periodic >= 15
    # the shortcut did the work at most periodic points (else this test checks nothing)
    assert shortcut.accepted >= periodic // 2
    assert sum("Newton on the period map" in p.message for p in fast) == shortcut.accepted


def test_shortcut_refuses_a_modulated_motion():
    """Fig. 10's overlay (U* = 1.3): amplitude-modulated responses, no stable period-1 orbit at
    sigma = 0.03; the shortcut never ends the integration there."""
    scene = load_scene(RUNS / "fig10.toml")
    ode = derive(load_model(scene.model)).ode
    integrator = Ode21Integrator(ode, engine="compiled")
    shortcut = PeriodOneShortcut(integrator)
    fixed = dict(scene.fixed)
    r = integrator.simulate(fixed["U"], fixed["eta"], 0.03, max_time=3000.0, shortcut=shortcut)
    assert shortcut.accepted == 0
    assert not r.steady and not r.periodic and math.isfinite(r.a1)


def test_a_point_started_from_q0_is_integrated_once_for_both_directions():
    """Fig. 10's overlay (U* = 1.3: modulated responses, each next point starting again from the
    start q0), shortened to t = 3000: the down sweep alone (every point integrated) and the down
    half of the up-and-down sweep, which reuses the up sweep's responses from q0, are the same
    rows; fewer integrations than rows."""
    scene = load_scene(RUNS / "fig10.toml")
    ov = scene.overlay
    integrator = Ode21Integrator(derive(load_model(scene.model)).ode, engine="compiled")
    calls = []
    plain = integrator.simulate

    def counted(*args, **kw):
        calls.append(args)
        return plain(*args, **kw)

    integrator.simulate = counted
    values = np.linspace(ov.range[0], ov.range[1], ov.points)[::2]
    fixed = dict(scene.fixed)
    both = sweep(integrator, "sigma", values, fixed, directions=("up", "down"), max_time=3000.0,
                 shortcut=PeriodOneShortcut(integrator))
    n_both = len(calls)
    down = sweep(integrator, "sigma", values, fixed, directions=("down",), max_time=3000.0,
                 shortcut=PeriodOneShortcut(integrator))
    assert len(calls) - n_both == len(values)
    assert n_both < len(both)
    again = [p for p in both if p.direction == "down"]
    assert len(again) == len(down)
    for a, b in zip(again, down):
        assert {k: v for k, v in a.__dict__.items() if k != "wall_seconds"} == \
               {k: v for k, v in b.__dict__.items() if k != "wall_seconds"}


def test_settle_prediction_sees_a_slow_mode_with_a_small_share():
    """`_settles_in_time` on a diagonal monodromy: a deviation 1e-6 along a mode contracting by 0.5
    a period reaches a tenth of the tolerance (1e-9 of a_k = 1e-3, i.e. 1e-12) in 20 periods and is
    accepted; the same plus 1e-9 along a mode contracting by 0.9999 needs ln(1e-3) / ln(0.9999) =
    69000 periods, more than the 4775 periods left before max_time = 30000: refused."""
    short = PeriodOneShortcut.__new__(PeriodOneShortcut)
    M = np.diag([0.5, 0.5, 0.9999, 0.9999])
    period = 2 * math.pi
    fast = np.array([1e-6, 1e-6, 0.0, 0.0])
    assert short._settles_in_time((1e-3, 1e-3), fast, M, period, 0.0, 30000.0, 1e-8)
    assert not short._settles_in_time((1e-3, 1e-3), fast + np.array([0, 0, 1e-9, 0]), M, period, 0.0,
                                      30000.0, 1e-8)
    # the margin: 20 periods doubled plus SETTLE_MARGIN_PERIODS must fit before max_time
    early = 30000.0 - (2 * 20 + PeriodOneShortcut.SETTLE_MARGIN_PERIODS + 2) * period
    late = 30000.0 - (2 * 20 + PeriodOneShortcut.SETTLE_MARGIN_PERIODS - 5) * period
    assert short._settles_in_time((1e-3, 1e-3), fast, M, period, early, 30000.0, 1e-8)
    assert not short._settles_in_time((1e-3, 1e-3), fast, M, period, late, 30000.0, 1e-8)


# -- the recurrence stop: a modulated motion ends as "not steady" before max_time ---------------------
@pytest.mark.parametrize("name", ["fig08", "fig10", "fig04b", "fig09"])
@pytest.mark.slow
def test_recurrence_stop_gives_the_full_integrations_class(name):
    """`RecurrenceStop` against integrating every point to max_time (both with the period-1
    shortcut), on the overlays with the most modulated responses: Figs. 8 and 10 (U* = 1.3 over
    sigma), Fig. 4b (U* over the Hopf point, the slow approach at U* = 0.9 included) and Fig. 9
    (U* = 0.7, modulated points between period-1 ones). Stated tolerance: the same class (steady,
    periodic, diverged) at every point, the periodic points' amplitudes to 1e-6 of max(a1, a2) (so
    the next points start from the same states), and the stop taken at most points that end not
    steady (else this test checks nothing)."""
    scene = load_scene(RUNS / f"{name}.toml")
    ov = scene.overlay
    integrator = Ode21Integrator(derive(load_model(scene.model)).ode, engine="compiled")
    values = np.linspace(ov.range[0], ov.range[1], ov.points)
    fixed = {k: v for k, v in scene.fixed.items() if k != ov.parameter}
    full = sweep(integrator, ov.parameter, values, fixed, directions=ov.directions, max_time=ov.max_time,
                 shortcut=PeriodOneShortcut(integrator))
    stop = RecurrenceStop(integrator)
    fast = sweep(integrator, ov.parameter, values, fixed, directions=ov.directions, max_time=ov.max_time,
                 shortcut=PeriodOneShortcut(integrator), recurrence=stop)
    not_steady = 0
    for a, b in zip(full, fast, strict=True):
        where = f"{name} {a.direction} {a.parameter} = {a.value:+.4f}"
        assert (a.steady, a.periodic, math.isfinite(a.a1)) == (b.steady, b.periodic, math.isfinite(b.a1)), \
            f"{where}: {a.message} / {b.message}"
        if a.periodic:
            assert abs(a.a1 - b.a1) <= TOL * max(a.a1, a.a2) and abs(a.a2 - b.a2) <= TOL * max(a.a1, a.a2)
        if not a.steady and math.isfinite(a.a1) and b.wall_seconds > 0:
            not_steady += 1
            assert a.message.startswith("not steady after t = ")      # integrated to max_time
    stopped = [p for p in fast if "recurrent modulated motion" in p.message]
    # a point from q0 integrated once for both directions is reused (wall_seconds 0)
    assert sum(p.wall_seconds > 0 for p in stopped) == stop.stopped >= not_steady // 2 >= 1
    # stopped at well under max_time: "not steady at t = <t> (...)"
    assert all(float(p.message.split("t = ")[1].split()[0]) < 0.6 * ov.max_time for p in stopped)


def test_recurrence_stop_refuses_a_slow_approach_and_drift():
    """The three conditions one by one on made-up chunk histories (the Newton check is not reached
    when an earlier condition fails): geometrically shrinking changes (an approach, mu^100 = 0.7 a
    chunk) are refused; steady-level changes with a drifting a2 (a decaying out-of-plane seed:
    relative change constant, amplitude falling) are refused; too few chunks are refused."""
    stop = RecurrenceStop.__new__(RecurrenceStop)
    stop._done = False
    n = 2 * RecurrenceStop.HALF
    approach = [1e-2 * 0.7 ** j for j in range(n)]
    amps = [(1e-3, 1e-4)] * n
    assert stop(1.0, 1e-3, 1.0, amps, approach, (0, 0, 0, 0), 0.0, 3e4) is None
    seed = [0.5] * n
    decaying = [(1e-3, 1e-6 * 0.5 ** j) for j in range(n)]
    assert stop(1.0, 1e-3, 1.0, decaying, seed, (0, 0, 0, 0), 0.0, 3e4) is None
    assert stop(1.0, 1e-3, 1.0, amps[:n - 1], seed[:n - 1], (0, 0, 0, 0), 0.0, 3e4) is None
    assert not stop._done


def test_a_last_chunk_shorter_than_the_window_is_not_judged():
    """Fig. 10's overlay point sigma = -0.04 (U* = 1.3) from q0 is an amplitude-modulated motion to
    the end; max_time = 30000 leaves a last chunk of 18 time units (3 forcing periods) after 47
    chunks of 100 periods, and a window of 20 periods that moved by 3 keeps its extremes: that
    chunk was judged and called the motion steady. It must not."""
    scene = load_scene(RUNS / "fig10.toml")
    integrator = Ode21Integrator(derive(load_model(scene.model)).ode, engine="compiled")
    fixed = dict(scene.fixed)
    r = integrator.simulate(fixed["U"], fixed["eta"], -0.04, max_time=30000.0)
    period = 2 * math.pi / r.Omega
    assert 30000.0 % (100 * period) < 20 * period       # the short last chunk this test is about
    assert not r.steady and r.message.startswith("not steady after t = 30000")
    assert r.a1_max > 1.05 * r.a1_min                   # modulated over the last window
