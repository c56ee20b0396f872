"""Output folders: a run stages its files and publishes them with run.json last, so that a failed,
interrupted or killed run never reads as complete, a rerun into a folder that held another scene
leaves only its own files (and never touches files autocable did not write), what killed runs left
is removed by the next run, and file modes follow the umask."""
from __future__ import annotations

import json
import os
import stat
from pathlib import Path

import pytest

from autocable import cli
from autocable._store import atomic_write_text
from autocable.paper.report import load_scene_data
from autocable.results import IncompleteResults, is_complete, read_results, run_status
from autocable.run_folder import STAGING_PREFIX
from autocable.scene.runner import run_scene
from autocable.scene.schema import load_scene
from autocable.spec import SpecError
from conftest import TRIVIAL_GALLOPING_RUN

# Two one-variable continuation runs of Fig. 3's galloping equation (a second or two each, warm cache).
_RUNS = TRIVIAL_GALLOPING_RUN
_GALLOP = '''
[[run]]
name = "galloping"
parameter = "U"
range = [1.0001, 1.3]
at = 1.2
start = { state = [0.024] }
'''
_PLOT = '''
[plot]
x = "U"
y = ["a1"]
'''


def _scene(tmp_path: Path, name: str, *, gallop: bool = True, compare: str = "") -> Path:
    path = tmp_path / "scenes" / f"{name}.toml"
    path.parent.mkdir(exist_ok=True)
    path.write_text(f'title = "{name}"\n' + _RUNS + (_GALLOP if gallop else "") + _PLOT + compare)
    return path


def _files(folder: Path) -> set[str]:
    return {p.name for p in folder.iterdir()}


def _mode(path: Path) -> int:
    return stat.S_IMODE(path.stat().st_mode)


def _dead_pid() -> int:
    """A process id no process has (for a staging folder a killed run left)."""
    pid = 4_000_000
    while True:
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return pid
        except PermissionError:
            pass
        pid += 1


@pytest.mark.slow
def test_a_run_that_fails_after_the_continuation_reads_incomplete(tmp_path):
    """A [compare] csv without the x, y columns fails after the branches are computed and written:
    the folder keeps what was computed but run.json says "failed" with the reason, and every reader
    (read_results, the figures report, is_complete) takes it as incomplete; the command exits 2."""
    bad = tmp_path / "digitised.csv"
    bad.write_text("a,b\n1,2\n")
    scene = _scene(tmp_path, "failing", compare=f'\n[compare]\ncsv = "{bad.as_posix()}"\n')
    out = tmp_path / "out"
    with pytest.raises(SpecError, match="missing columns"):
        run_scene(load_scene(scene), out)
    meta = json.loads((out / "run.json").read_text())
    assert meta["status"] == "failed" and "digitised.csv" in meta["reason"]
    assert {"branches.csv", "special_points.csv"} <= set(meta["files"])
    assert not is_complete(out) and run_status(out) == "failed"
    with pytest.raises(IncompleteResults, match="status 'failed'"):
        read_results(out)
    data = load_scene_data(out, status="ok")
    assert data.status == "incomplete" and not data.ok and "failed" in data.error
    assert not [n for n in _files(out) if n.startswith(".")]          # staging folder removed
    assert cli.main(["run", str(scene), "--out", str(out), "--quiet"]) == 2
    assert run_status(out) == "failed"


def test_a_rerun_into_another_scenes_folder_leaves_only_its_files(tmp_path):
    """Scene "first" (two runs) then scene "second" (one run) into one folder: afterwards the
    folder holds exactly second's manifest (first.png/.pdf gone), and read_results gives second's
    one branch."""
    out = tmp_path / "out"
    run_scene(load_scene(_scene(tmp_path, "first")), out)
    first = json.loads((out / "run.json").read_text())
    assert first["status"] == "complete" and "first.png" in first["files"]
    assert _files(out) == set(first["files"]) | {"run.json"}
    run_scene(load_scene(_scene(tmp_path, "second", gallop=False)), out)
    second = json.loads((out / "run.json").read_text())
    assert second["status"] == "complete" and second["name"] == "second"
    assert _files(out) == set(second["files"]) | {"run.json"}
    assert "first.png" not in _files(out) and "second.png" in _files(out)
    assert [b.name for b in read_results(out).branches] == ["trivial"]


def test_a_folder_with_files_autocable_did_not_write_is_refused_untouched(tmp_path):
    """A user's file in the output folder: the run is refused before it computes (exit 2, the
    message names --out and the file), the file and the earlier complete run stay as they were."""
    out = tmp_path / "out"
    scene = _scene(tmp_path, "mine", gallop=False)
    run_scene(load_scene(scene), out)
    (out / "notes.txt").write_text("mine")
    before = (out / "run.json").read_bytes()
    with pytest.raises(SpecError, match=r"--out: holds files autocable did not write \(notes.txt\)"):
        run_scene(load_scene(scene), out)
    assert (out / "notes.txt").read_text() == "mine" and (out / "run.json").read_bytes() == before
    assert is_complete(out)
    assert cli.main(["run", str(scene), "--out", str(out), "--quiet"]) == 2


def test_the_runs_own_inputs_may_sit_in_its_folder(tmp_path):
    """The scene file and the digitised points it compares with, inside the output folder: not
    refused, not touched, not in the manifest."""
    out = tmp_path / "out"
    out.mkdir()
    points = out / "points.csv"
    points.write_text("x,y,curve,stable\n1.1,0.01,g,1\n")
    scene = _scene(tmp_path, "inputs", compare=f'\n[compare]\ncsv = "{points.as_posix()}"\n')
    inside = out / scene.name
    inside.write_text(scene.read_text())
    run_scene(load_scene(inside), out)
    meta = json.loads((out / "run.json").read_text())
    assert meta["status"] == "complete" and "compare.json" in meta["files"]
    assert not {"points.csv", inside.name} & set(meta["files"])
    assert _files(out) == set(meta["files"]) | {"run.json", "points.csv", inside.name}


def test_another_live_run_in_the_folder_is_refused(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "run.json").write_text(json.dumps({"status": "running", "pid": os.getppid(), "files": []}))
    with pytest.raises(SpecError, match=f"another autocable run \\(process {os.getppid()}\\)"):
        run_scene(load_scene(_scene(tmp_path, "x", gallop=False)), out)


def test_what_killed_runs_left_is_removed_by_the_next_run(tmp_path):
    """A killed run's staging folder (its process gone), the hidden temporary files of atomic
    writes killed half-way (``.fig06.png.XXXXXXXX.png`` of earlier versions, ``.run.json.*.tmp``)
    and the "running" marker: the next run removes them and publishes a complete folder."""
    out = tmp_path / "out"
    out.mkdir()
    staging = out / f"{STAGING_PREFIX}{_dead_pid()}"
    staging.mkdir()
    (staging / "branches.csv").write_text("half")
    for name in (".tidy.png.k3x_9abq.png", ".run.json.ab12cd34.tmp", ".branches.csv.zz99yy88.tmp",
                 ".overlay.csv.q1w2e3r4.tmp"):
        (out / name).write_text("half")
    (out / "run.json").write_text(json.dumps({"status": "running", "pid": _dead_pid(),
                                              "files": ["branches.csv"]}))
    (out / "branches.csv").write_text("from the killed run")
    run_scene(load_scene(_scene(tmp_path, "tidy", gallop=False)), out)
    meta = json.loads((out / "run.json").read_text())
    assert meta["status"] == "complete"
    assert _files(out) == set(meta["files"]) | {"run.json"}
    assert not [n for n in _files(out) if n.startswith(".")]


def test_a_hidden_file_that_is_no_temporary_file_of_autocable_is_not_removed(tmp_path):
    """``.holiday.jpg.abcdefgh.tmp`` looks like a temporary file but of no file a run writes: the
    folder is refused and the file stays."""
    out = tmp_path / "out"
    out.mkdir()
    (out / ".holiday.jpg.abcdefgh.tmp").write_text("mine")
    with pytest.raises(SpecError, match=r"\.holiday\.jpg\.abcdefgh\.tmp"):
        run_scene(load_scene(_scene(tmp_path, "z", gallop=False)), out)
    assert (out / ".holiday.jpg.abcdefgh.tmp").read_text() == "mine"


@pytest.mark.slow
def test_a_run_killed_at_random_moments_never_reads_complete(tmp_path):
    """`python -m tools.hardening kill` with 4 trials (SIGKILL and SIGINT alternating, over the measured
    run time): no folder reads as complete unless its files are complete and consistent, no
    leftover survives the next run, and a last run publishes a complete, clean folder."""
    from tools.hardening.kill import kill_bench
    result = kill_bench(_scene(tmp_path, "killed"), trials=4, resolution="coarse", engine=None,
                        folder=tmp_path / "out")
    assert result["trials"] == 4
    assert result["read_as_complete_while_incomplete"] == 0
    assert result["leftovers_after_rerun"] == 0
    assert result["final_run_complete_and_clean"] is True
    for r in result["records"]:
        assert r["status"] != "complete" or r["verdict"].startswith(("finished", "killed before")), r
    # a SIGINT that reached the run publishes "interrupted"; a SIGKILL leaves "running"
    assert set(result["statuses"]) <= {"running", "interrupted", "complete"}


@pytest.mark.parametrize("umask, expected", [(0o022, 0o644), (0o027, 0o640)])
def test_file_modes_follow_the_umask(tmp_path, umask, expected):
    """Every file of a run (tables, run.json, figures), an atomic write and a sweep point get
    0o666 less the umask (mkstemp's 0o600 used to survive the rename)."""
    from autocable.studies.sweep import _write_point
    old = os.umask(umask)
    try:
        out = tmp_path / "out"
        run_scene(load_scene(_scene(tmp_path, "modes", gallop=False)), out)
        written = atomic_write_text(tmp_path / "note.txt", "x")
        (tmp_path / "points").mkdir()
        _write_point(tmp_path / "points", "k", {"a": 1})
    finally:
        os.umask(old)
    files = sorted(out.iterdir())
    assert {p.name for p in files} >= {"run.json", "branches.csv", "modes.png", "modes.pdf"}
    assert {p.name: _mode(p) for p in files} == {p.name: expected for p in files}
    assert _mode(written) == expected and _mode(tmp_path / "points" / "k.json") == expected


def test_ctrl_c_during_the_run_publishes_interrupted(tmp_path, monkeypatch):
    """KeyboardInterrupt while the figure is drawn (after the tables are written): run.json says
    "interrupted", the tables are kept, the folder reads incomplete, the interrupt goes on."""
    import autocable.plotting.diagrams as diagrams

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt
    monkeypatch.setattr(diagrams, "plot_scene", interrupted)
    out = tmp_path / "out"
    with pytest.raises(KeyboardInterrupt):
        run_scene(load_scene(_scene(tmp_path, "stopped", gallop=False)), out)
    meta = json.loads((out / "run.json").read_text())
    assert (meta["status"], meta["reason"]) == ("interrupted", "interrupted")
    assert set(meta["files"]) == {"branches.csv", "special_points.csv"} and not is_complete(out)
    assert _files(out) == {"run.json", "branches.csv", "special_points.csv"}
