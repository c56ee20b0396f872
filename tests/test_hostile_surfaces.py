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
