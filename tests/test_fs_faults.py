"""Filesystem faults named with the option and the path, and recorded: a path under a file, a
file as a folder, a read-only place, a full disk while a run computes or publishes (run.json then
says "failed", never "running" with a dead pid), exit status as documented (2: a path to change,
3: the storage failed mid-run)."""
from __future__ import annotations

import errno
import json
import os
from pathlib import Path

import pytest

from autocable.cli import main
from conftest import SAMPLE, TRIVIAL_GALLOPING_RUN

REPO = Path(__file__).resolve().parents[1]

# One continuation run of Fig. 3's galloping equation (a second, warm cache).
_SCENE = 'title = "fs"\n' + TRIVIAL_GALLOPING_RUN + '''[plot]
x = "U"
y = ["a1"]
'''


def run_cli(capsys, *argv):
    """(exit status, stdout, stderr without premise warnings: the errors are what is checked)."""
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, "".join(line for line in err.splitlines(True) if not line.startswith("autocable: warning:"))


@pytest.fixture()
def afile(tmp_path):
    path = tmp_path / "afile"
    path.write_text("a user's file\n")
    return path


def _sweep(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(f'model = "{SAMPLE.as_posix()}"\n[grid]\neta = 8.2e-5\n')
    return path


@pytest.mark.parametrize("where", ["file", "under a file"])
@pytest.mark.parametrize("command", ["sweep", "calibrate", "simulate --csv", "figures", "run"])
def test_an_output_path_that_cannot_be_made_is_named(tmp_path, capsys, afile, command, where):
    target = afile if where == "file" else afile / "sub"
    option = "--csv" if command == "simulate --csv" else "--out"
    argv = {"sweep": ["sweep", _sweep(tmp_path), "--out", target, "--workers", "0"],
            "calibrate": ["calibrate", SAMPLE, REPO / "models" / "luongo_zulli_2012.targets.toml", "--out", target],
            "simulate --csv": ["simulate", SAMPLE, "--eta", "8.2e-5", "--max-time", "100", "--csv",
                               target if where == "under a file" else afile / "x.csv"],
            "figures": ["figures", "--out", target, "--only", "fig03"],
            "run": ["run", tmp_path / "fs.toml", "--out", target]}[command]
    (tmp_path / "fs.toml").write_text(_SCENE)
    code, out, err = run_cli(capsys, *argv, "--quiet")
    assert code == 2 and f"{option}: " in err and str(afile) in err, err
    assert "Errno" not in err and len(err.strip().splitlines()) == 1
    assert afile.read_text() == "a user's file\n"


def test_a_read_only_output_folder_is_refused_before_work(tmp_path, capsys, monkeypatch):
    """(os.access stands in for a read-only mount: the tests may run as root, who writes anywhere.)"""
    real = os.access
    ro = tmp_path / "ro"
    ro.mkdir()
    monkeypatch.setattr(os, "access", lambda p, mode, **kw: False if Path(p) == ro else real(p, mode, **kw))
    code, _, err = run_cli(capsys, "sweep", _sweep(tmp_path), "--out", ro, "--workers", "0", "--quiet")
    assert code == 2 and f"--out: cannot write into {ro} (read-only" in err
    code, _, err = run_cli(capsys, "simulate", SAMPLE, "--max-time", "100", "--csv", ro / "x.csv", "--quiet")
    assert code == 2 and f"--csv: cannot write into {ro} (read-only" in err


def _disk_full(path):
    return OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))


def test_a_full_disk_mid_run_is_exit_3_naming_out_and_run_json_says_failed(tmp_path, capsys, monkeypatch):
    """The disk fills while the tables are written (ENOSPC from inside the run) and stays full
    (publishing fails too): exit 3, one line naming --out and the file the user knows (not the
    hidden temporary), and run.json "failed" with the reason, not "running" with a dead pid."""
    import autocable.results as results
    import autocable.run_folder as rf
    from autocable.results import is_complete
    out = tmp_path / "out"

    def full(res, folder, *args, **kwargs):
        raise _disk_full(Path(folder) / ".branches.csv.abcd1234.tmp")

    def publish_full(staging, out_dir, *args, **kwargs):
        raise _disk_full(Path(out_dir) / ".run.json.abcd1234.tmp")

    monkeypatch.setattr(results, "write_results", full)
    monkeypatch.setattr(rf, "_publish", publish_full)
    (tmp_path / "fs.toml").write_text(_SCENE)
    code, out_text, err = run_cli(capsys, "run", tmp_path / "fs.toml", "--out", out, "--quiet")
    assert code == 3 and err.startswith("autocable: failed: --out: ") and "No space left on device" in err, err
    assert f"{out}/branches.csv:" in err and ".tmp" not in err and "staging" not in err and len(err.strip().splitlines()) == 1
    meta = json.loads((out / "run.json").read_text())
    assert meta["status"] == "failed" and "No space left" in meta["reason"] and "pid" not in meta
    assert not is_complete(out)


def test_a_full_disk_while_publishing_a_finished_run_says_failed(tmp_path, capsys, monkeypatch):
    import autocable.run_folder as rf
    out = tmp_path / "out"
    monkeypatch.setattr(rf, "_publish", lambda staging, out_dir, *a, **k: (_ for _ in ()).throw(
        _disk_full(Path(out_dir) / "branches.csv")))
    (tmp_path / "fs.toml").write_text(_SCENE)
    code, _, err = run_cli(capsys, "run", tmp_path / "fs.toml", "--out", out, "--quiet", "--no-plot")
    assert code == 3 and "--out: " in err
    meta = json.loads((out / "run.json").read_text())
    assert meta["status"] == "failed" and meta["reason"].startswith("publishing the results: ")


def test_a_full_disk_in_a_sweep_is_exit_3_naming_out(tmp_path, capsys, monkeypatch):
    """A point file that cannot be written (ENOSPC): exit 3, one line naming --out and the point
    file; no sweep.json (the sweep did not finish)."""
    from autocable.studies import sweep as sw

    def full(folder, key, rec):
        raise _disk_full(Path(folder) / f".{key}.json.abcd1234.tmp")
    monkeypatch.setattr(sw, "_write_point", full)
    out = tmp_path / "o"
    code, _, err = run_cli(capsys, "sweep", _sweep(tmp_path), "--out", out, "--workers", "0", "--quiet")
    assert code == 3 and "autocable: failed: --out: " in err and "/points/" in err and ".tmp" not in err, err
    assert not (out / "sweep.json").exists()
