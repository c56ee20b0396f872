"""Hostile input on sweep, chart, calibrate and simulate: budgets on every integration length,
refusals that name the option or field and quote the value as given, exit codes as documented."""
from __future__ import annotations

import re
import textwrap
from pathlib import Path

import pytest

from autocable.cli import main
from autocable.scene.sweep_schema import load_sweep
from autocable.spec import SpecError

REPO = Path(__file__).resolve().parents[1]
MODEL = REPO / "models" / "luongo_zulli_2012.toml"


def run_cli(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def write_sweep(folder: Path, body: str, name="s.toml") -> Path:
    path = folder / name
    path.write_text(f'model = "{MODEL}"\n' + textwrap.dedent(body))
    return path


def scene_with(tmp_path: Path, source: str, old: str, new: str) -> Path:
    text = (REPO / "runs" / source).read_text()
    assert old in text
    path = tmp_path / source
    path.write_text(text.replace(old, new).replace('"../models/', f'"{REPO}/models/'))
    return path


# -- 3: every integration length has a cap -------------------------------------------------------
@pytest.mark.parametrize("source,old,new,field", [
    ("chart_U_eta.toml", "grid = [30, 20]", "grid = [30, 20]\nt_end = 1e300", "chart.t_end"),
    ("chart_U_eta.toml", "grid = [30, 20]", "grid = [30, 20]\nt_end = 1.0000001e6", "chart.t_end"),
    ("fig11.toml", "t_end = 60000.0", "t_end = 1e300", "time.t_end"),
])
def test_scene_integration_lengths_are_capped(tmp_path, capsys, source, old, new, field):
    path = scene_with(tmp_path, source, old, new)
    code, _, err = run_cli(capsys, "chart" if "chart" in source else "run", path, "--out", tmp_path / "o")
    assert code == 2 and f"{field}: expected a time in (0, 1e+06]" in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("max_time,rule", [
    ("1e300", "expected a time in (0, 1e+06]"),
    ("-1.0", "expected a time in (0, 1e+06]"),
    ("1e-9", "expected at least one forcing period"),
])
def test_sweep_max_time_is_capped_both_ways(tmp_path, max_time, rule):
    path = write_sweep(tmp_path, f'max_time = {max_time}\n[grid]\nsigma = [-0.1, 0.0]\n')
    with pytest.raises(SpecError, match=re.escape(f"max_time: {rule}")):
        load_sweep(path)


# -- 13: a refusal quotes the value as given ---------------------------------------------------
def test_refusal_quotes_the_value_it_refuses(capsys):
    code, _, err = run_cli(capsys, "simulate", MODEL, "--sigma", "0.5000001", "--json")
    assert code == 2 and "must lie in [-0.5, 0.5]" in err and "got 0.5000001" in err


@pytest.mark.parametrize("max_time", ["1e-9", "3"])
def test_simulate_shorter_than_a_forcing_period_is_refused_not_diverged(capsys, max_time):
    code, out, err = run_cli(capsys, "simulate", MODEL, "--eta", "8.2e-5", "--max-time", max_time, "--json")
    assert code == 2 and out == "" and "--max-time: expected at least one forcing period" in err


# -- 4, 5: a --map is checked against the chart, and a file that is no map names --map ------------
CHART = REPO / "runs" / "chart_U_eta.toml"         # U in [0.1, 1.5], eta in [0, 6e-4], sigma = 0.01


def chart_map(path: Path, *, U=(0.2, 0.8, 1.4), sigma=0.01, model_hash=None, codes=None):
    """A map in `autocable sweep`'s format for runs/chart_U_eta.toml (or, with the keywords, not)."""
    import json

    import numpy as np
    import xarray as xr

    from autocable.spec import load_model
    eta = np.array([1e-4, 3e-4])
    resp = np.ones((len(U), len(eta), 1), dtype=np.int8) if codes is None else codes
    ds = xr.Dataset({"response": (("U", "eta", "sigma"), resp,
                                  {"legend": json.dumps(["rest", "period-1", "period-2", "quasi-periodic",
                                                         "diverged"])})},
                    coords={"U": np.array(U, float), "eta": eta, "sigma": np.array([sigma])},
                    attrs={"model_hash": model_hash or load_model(MODEL).content_hash()})
    ds.to_netcdf(path, engine="scipy")
    return path


def test_a_map_of_the_chart_is_read_and_points_off_it_are_counted(tmp_path):
    from autocable.scene.runner import read_chart_map
    from autocable.scene.schema import load_scene
    m = read_chart_map(load_scene(CHART), chart_map(tmp_path / "m.nc", U=(0.2, 0.8, 2.5)))
    assert len(m["x"]) == 4 and m["outside"] == 2 and set(m["response"]) == {"period-1"}


@pytest.mark.parametrize("kind,words", [
    ("off the chart", "no point of the map lies on the chart"),
    ("another model", ": model_hash: the map was computed for another model"),
    ("another sigma", ": sigma: the map's nearest sigma is 0.03, the chart is at sigma = 0.01"),
    ("float codes", ": response: float class codes"),
    ("text", "not a readable netCDF file"),
    ("truncated", "not a readable netCDF file"),
    ("empty", "not a readable netCDF file"),
])
def test_a_map_that_is_not_of_the_chart_is_refused_naming_map(tmp_path, capsys, kind, words):
    import numpy as np
    path = tmp_path / "m.nc"
    if kind == "off the chart":
        chart_map(path, U=(2.5, 2.75, 3.0))
    elif kind == "another model":
        chart_map(path, model_hash="0" * 64)
    elif kind == "another sigma":
        chart_map(path, sigma=0.03)
    elif kind == "float codes":
        chart_map(path, codes=np.full((3, 2, 1), 1.5))
    elif kind == "text":
        path.write_text("U,eta,response\n0.5,1e-4,period-1\n")
    elif kind == "truncated":
        data = chart_map(tmp_path / "whole.nc").read_bytes()
        path.write_bytes(data[: len(data) // 2])
    else:
        path.write_bytes(b"")
    code, out, err = run_cli(capsys, "chart", CHART, "--out", tmp_path / "o", "--map", path, "--quiet")
    assert code == 2 and out == ""
    assert err.startswith(f"autocable: error: --map {path}: ") and words in err, err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert not (tmp_path / "o").exists() or not any((tmp_path / "o").iterdir())


# -- 6: --scheduler is checked with short timeouts, before any work ---------------------------
def _server(mode: str):
    """A local TCP service that is not Dask: "silent" accepts and never answers, "garbage" answers
    with text; returns (address, closer)."""
    import socket
    import threading
    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen(4)
    held = []

    def serve():
        while True:
            try:
                conn, _ = srv.accept()
            except OSError:
                return
            held.append(conn)
            if mode == "garbage":
                conn.sendall(b"HTTP/1.1 200 OK\r\n" * 64)

    threading.Thread(target=serve, daemon=True).start()

    def close():
        srv.close()
        for c in held:
            c.close()
    return f"tcp://127.0.0.1:{srv.getsockname()[1]}", close


def _refused_port() -> str:
    import socket
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    return f"tcp://127.0.0.1:{port}"


@pytest.mark.parametrize("kind,words", [
    ("empty", "an empty address"),
    ("malformed", "expected host:port"),
    ("refused", "cannot connect to"),
    ("silent", "did not answer as a Dask scheduler within 1 s"),
    ("garbage", "is not a Dask scheduler"),
])
def test_scheduler_that_is_not_dask_is_refused_at_once_naming_the_option(tmp_path, capsys, monkeypatch,
                                                                         kind, words):
    import time

    from autocable import executor
    monkeypatch.setattr(executor, "SCHEDULER_TIMEOUT", 1.0)
    close = None
    if kind in ("silent", "garbage"):
        address, close = _server(kind)
    else:
        address = {"empty": "", "malformed": "tcp://nohost", "refused": _refused_port()}[kind]
    path = write_sweep(tmp_path, '[grid]\neta = 8.2e-5\n')
    t0 = time.perf_counter()
    try:
        code, out, err = run_cli(capsys, "sweep", path, "--out", tmp_path / "o", "--scheduler", address, "--quiet")
    finally:
        if close:
            close()
    assert time.perf_counter() - t0 < 5.0
    assert code == 2 and out == "" and "arguments: --scheduler: " in err and words in err, err
    assert len(err.strip().splitlines()) == 1 and not (tmp_path / "o").exists()


# -- 9: targets and search-space files validated where they are read ---------------------------
TARGETS = REPO / "models" / "luongo_zulli_2012.targets.toml"


def targets_with(tmp_path: Path, old: str, new: str) -> Path:
    text = TARGETS.read_text()
    assert old in text, old
    path = tmp_path / "t.targets.toml"
    path.write_text(text.replace(old, new, 1))
    return path


def first_screen_points() -> str:
    m = re.search(r"points = \[\[[^\n]*", TARGETS.read_text())
    assert m
    return m.group(0)


@pytest.mark.parametrize("triple,name", [("[50.0, 8e-5, 0.0]", "U"), ("[0.5, 0.9, 0.0]", "eta"),
                                         ("[0.5, 8e-5, 9.0]", "sigma")])
def test_screen_points_outside_the_model_are_refused(tmp_path, triple, name):
    from autocable.paper import targets as tg
    path = targets_with(tmp_path, first_screen_points(), f"points = [{triple}]")
    with pytest.raises(SpecError, match=re.escape(f"points[0] ({name}):") + ".*must lie in"):
        tg.load_targets(path)


@pytest.mark.parametrize("scene,field,words", [
    ("../../etc/passwd", "scene", "expected a scene name"),
    ("fig99", "scene", "no scene 'fig99'"),
])
def test_statement_scenes_must_be_scenes_without_bound(tmp_path, capsys, scene, field, words):
    path = targets_with(tmp_path, 'scene = "fig11"', f'scene = "{scene}"')
    code, out, err = run_cli(capsys, "calibrate", MODEL, path, "--out", tmp_path / "o", "--quiet")
    assert code == 2 and out == "" and f".{field}: " in err and words in err and str(path) in err, err
    assert len(err.strip().splitlines()) == 1 and not (tmp_path / "o" / "screen").exists()


def test_goal_boxes_scene_must_exist_with_bound(tmp_path, capsys):
    path = targets_with(tmp_path, 'boxes_scenes = ["fig08", "fig10"]', 'boxes_scenes = ["fig08", "fig99"]')
    code, _, err = run_cli(capsys, "calibrate", MODEL, path, "--out", tmp_path / "o", "--bound", "--quiet")
    assert code == 2 and "goal.boxes_scenes[1]: no scene 'fig99'" in err and not (tmp_path / "o" / "screen").exists()


@pytest.mark.parametrize("density", ["inf", "nan", "1e300", "0.0", "-1.25", "11.0"])
def test_air_density_must_be_finite_positive_and_air(tmp_path, capsys, density):
    space = tmp_path / "s.search.toml"
    space.write_text(f"air_density_kg_m3 = [{density}]\n")
    code, out, err = run_cli(capsys, "calibrate", MODEL, TARGETS, "--out", tmp_path / "o", "--space", space)
    assert code == 2 and out == "" and "air_density_kg_m3: expected a non-empty list of densities in (0, 10]" in err
    assert len(err.strip().splitlines()) == 1


def test_empty_space_path_is_refused_not_the_default_study(tmp_path, capsys):
    code, out, err = run_cli(capsys, "calibrate", MODEL, TARGETS, "--out", tmp_path / "o", "--space", "")
    assert code == 2 and out == "" and "--space: an empty path" in err and not (tmp_path / "o").exists()
