"""``[time]`` scenes (Fig. 11): the AME (24) integrated at one parameter point and the amplitude
envelope of eq. (21) from the same start; ``time_series.csv`` and a ``run.json`` with a summary
(per source a1/a2 min/max and the modulation period)."""
from __future__ import annotations

import math
import platform
import sys
import time
from pathlib import Path
from typing import Any

from autocable.spec import SpecError, load_model
from autocable.scene.provenance import ode21_engine, versions
from autocable.scene.schema import Scene, TimeSpec

TIME_SERIES_COLUMNS = ("source", "t", "a1", "a2")


def modulation_period(t, a) -> float | None:
    """The period of an amplitude-modulated signal a(t): the mean spacing of its upward crossings
    of the mid-level (min + max)/2, linearly interpolated. None when a(t) is flat (an equilibrium
    of the AME: relative swing below 1e-6) or crosses fewer than three times."""
    import numpy as np

    t, a = np.asarray(t, float), np.asarray(a, float)
    if len(a) < 3 or not np.all(np.isfinite(a)):
        return None
    lo, hi = float(np.min(a)), float(np.max(a))
    if hi - lo <= 1e-6 * max(abs(hi), 1e-300):
        return None
    mid = 0.5 * (lo + hi)
    up = np.nonzero((a[:-1] < mid) & (a[1:] >= mid))[0]
    if len(up) < 3:
        return None
    tc = t[up] + (mid - a[up]) / (a[up + 1] - a[up]) * (t[up + 1] - t[up])
    return float(np.mean(np.diff(tc)))


def _ame_time_series(system, spec: TimeSpec, Omega: float):
    """Integrate the AME (24) over [0, t_end] (autocable's compiled DOP853, `ame_time_series`);
    returns t, the amplitudes a1, a2 and why the integration stopped early ("" if it did not: a
    blow-up of the AME ends the series there, it does not fail the scene)."""
    import numpy as np

    from autocable.methods.integration.ame import ame_time_series
    y0 = [0.0, 0.0, 1e-6, 0.0] if spec.start is None else [spec.start[0], 0.0, spec.start[1], 0.0]
    tt, ys, why = ame_time_series(system, {"U": spec.U, "eta": spec.eta, "sigma": spec.sigma}, y0, spec.t_end,
                                  (2 * math.pi / Omega) / spec.samples_per_period, rtol=1e-10, atol=1e-16,
                                  keep_stopped=True)
    ys = np.asarray(ys, float).reshape(-1, 4)
    return tt, np.hypot(ys[:, 0], ys[:, 1]), np.hypot(ys[:, 2], ys[:, 3]), why


def _ode21_envelope(deriv, spec: TimeSpec, Omega: float):
    """Integrate eq. (21) from the same start (q_k = a_k, q_k' = 0: r_k = a_k, s_k = 0 at t = 0) and
    take the half peak-to-peak of q1, q2 over each forcing period, at the period's mid time
    (`Ode21Integrator.envelope`). Returns (t, a1, a2, message); a divergence, or a failure of the
    integrator at a bounded state, ends the arrays where it happens (the message says which)."""
    from autocable.methods.integration.ode21 import SCENE_ENGINE, Ode21Integrator
    q = (0.0, 1e-6, 0.0, 0.0) if spec.start is None else (spec.start[0], spec.start[1], 0.0, 0.0)
    # keep_failed: an integrator failure at a bounded state ends the envelope with its reason and
    # keeps the AME's series (the figure's own content) rather than failing the scene
    return Ode21Integrator(deriv.ode, engine=SCENE_ENGINE).envelope(
        spec.U, spec.eta, spec.sigma, q, spec.t_end, samples_per_period=64, Omega=Omega,
        keep_failed=SCENE_ENGINE == "compiled")


def _summary(t, a1, a2, since: float) -> dict:
    import numpy as np

    sel = t >= since
    if not np.any(sel):
        return {"samples": 0}
    return {"samples": int(sel.sum()), "t_from": float(t[sel][0]), "t_to": float(t[sel][-1]),
            "a1_min": float(a1[sel].min()), "a1_max": float(a1[sel].max()),
            "a2_min": float(a2[sel].min()), "a2_max": float(a2[sel].max()),
            "modulation_period": modulation_period(t[sel], a1[sel])}


def run_time_scene(scene: Scene, out_dir, say, plot: bool, resolution: str):
    """Fig. 11: a1(t), a2(t) of the AME and the amplitude envelope of eq. (21), on the same axes."""
    import csv
    import io

    from autocable._store import atomic_write_json, atomic_write_text
    from autocable.methods.continuation import ame_system
    from autocable.model.ame_cache import derive_ame
    from autocable.model.derive import derive
    from autocable.results import RunResults

    spec = scene.time
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    t_all = time.perf_counter()
    stages: dict[str, Any] = {}
    t0 = time.perf_counter()
    model = load_model(scene.model)
    deriv = derive(model)
    stages["derive_s"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    cached = derive_ame(deriv, ordering=scene.ordering)
    ame = cached.ame
    stages["ame_s"] = time.perf_counter() - t0
    omega1 = float(ame.omegas[0])
    Omega = omega1 + spec.sigma
    if not Omega > 0:
        raise SpecError(scene.path, "time.sigma", f"sigma = {spec.sigma:g} gives a non-positive forcing "
                                                  f"frequency Omega = omega1 + sigma")
    start = "rest (q2 = 1e-6)" if spec.start is None else f"a = {list(spec.start)}"
    say(f"time evolution at U = {spec.U:g}, eta = {spec.eta:g}, sigma = {spec.sigma:g} from {start}, "
        f"t in [0, {spec.t_end:g}]")
    t0 = time.perf_counter()
    system = ame_system(ame, "2dof", wind=True)
    ta, a1, a2, why = _ame_time_series(system, spec, Omega)
    stages["ame_integration_s"] = time.perf_counter() - t0
    series = {"ame": (ta, a1, a2)}
    summary: dict[str, Any] = {"ame": {**_summary(ta, a1, a2, spec.summary_from), "diverged": bool(why),
                                       "message": why or "bounded over [0, t_end]"}}
    if why:
        say(f"  {why}")
    say(f"  AME: a1 in [{summary['ame'].get('a1_min', math.nan):.4e}, {summary['ame'].get('a1_max', math.nan):.4e}], "
        f"a2 in [{summary['ame'].get('a2_min', math.nan):.4e}, {summary['ame'].get('a2_max', math.nan):.4e}], "
        f"modulation period {summary['ame'].get('modulation_period')}")
    if spec.ode21:
        t0 = time.perf_counter()
        te, e1, e2, message = _ode21_envelope(deriv, spec, Omega)
        stages["ode21_integration_s"] = time.perf_counter() - t0
        series["ode21"] = (te, e1, e2)
        diverged = message.startswith("eq. (21) diverges")
        failed = message.startswith("eq. (21) could not be integrated")
        summary["ode21"] = {**_summary(te, e1, e2, spec.summary_from), "diverged": diverged,
                            "failed": failed, "message": message}
        say(f"  eq. (21): {message}; envelope a1 in [{summary['ode21'].get('a1_min', math.nan):.4e}, "
            f"{summary['ode21'].get('a1_max', math.nan):.4e}], a2 in [{summary['ode21'].get('a2_min', math.nan):.4e}, "
            f"{summary['ode21'].get('a2_max', math.nan):.4e}]")
    summary["window"] = f"t >= {spec.summary_from:g} (summary_from): after the transient"
    summary["ame_settings"] = {"integrator": "compiled DOP853 (autocable.codegen.cintegrate)", "rtol": 1e-10,
                               "atol": 1e-16, "samples_per_period": spec.samples_per_period,
                               "ode21_engine": ode21_engine()}
    summary["ode21_envelope"] = "half peak-to-peak of q_k over each forcing period (64 samples, parabolic peaks)"
    buf = io.StringIO()
    w = csv.writer(buf)
    w.writerow(TIME_SERIES_COLUMNS)
    for src, (tt, x1, x2) in series.items():
        for row in zip(tt, x1, x2):
            w.writerow([src] + [repr(float(v)) for v in row])
    atomic_write_text(out / "time_series.csv", buf.getvalue())
    files = []
    if plot:
        t0 = time.perf_counter()
        from autocable.plotting.diagrams import plot_time_series, save_figure
        from autocable.scene.figure_units import figure_units
        # A modulation period is tens of time units against a run of tens of thousands: beside the
        # whole run, a window of the last few periods shows the periodic solution itself.
        period = summary.get("ame", {}).get("modulation_period")
        t_last = float(series["ame"][0][-1]) if len(series["ame"][0]) else 0.0
        zoom = ((t_last - 5.0 * period, t_last) if period and math.isfinite(period)
                and 5.0 * period < t_last - spec.summary_from else None)
        files = save_figure(plot_time_series(series, y=scene.plot.y, title=scene.plot.title, zoom=zoom,
                                             ode21_message=summary.get("ode21", {}).get("message", ""),
                                             ode21_diverged=summary.get("ode21", {}).get("diverged", False),
                                             units=figure_units(scene.plot.units, deriv)),
                            out / scene.name)
        stages["plot_s"] = time.perf_counter() - t0
        say(f"plot: {', '.join(str(f) for f in files)}")
    stages["total_s"] = time.perf_counter() - t_all
    provenance = {
        "scene": str(scene.path), "scene_name": scene.name, "title": scene.title, "scene_text": scene.text,
        "model": str(scene.model), "model_name": model.name, "model_hash": model.content_hash(),
        "ode_hash": deriv.ode.content_hash(), "ame_key": cached.key, "ame": scene.ame, "ordering": scene.ordering,
        "omega1": omega1,
        "omega2": float(ame.omegas[1]), "Omega": Omega, "kind": "time", "ode21_engine": ode21_engine(),
        "parameters": {"U": spec.U, "eta": spec.eta, "sigma": spec.sigma, "t_end": spec.t_end,
                       "start": "rest" if spec.start is None else list(spec.start)},
        "resolution": resolution,
        "amplitude_convention": "a_k = sqrt(r_k^2 + s_k^2) (AME); half peak-to-peak of q_k per forcing "
                                "period (eq. 21); Omega = omega1 + sigma",
        "versions": versions(), "platform": platform.platform(), "argv": list(sys.argv), "stages": stages,
    }
    res = RunResults(scene.name, (), {**provenance, "summary": summary})
    from autocable.results import finite_or_none
    atomic_write_json(out / "run.json", {"format": "autocable.run/1", "name": scene.name,
                                         "provenance": finite_or_none(provenance), "branches": [],
                                         "special_points": [], "summary": finite_or_none(summary)})
    return res


