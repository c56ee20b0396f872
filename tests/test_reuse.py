"""Scene results reused across runs of `autocable figures` (autocable/paper/reuse.py).

Reuse is only right if a scene is a deterministic function of what the key holds: a scene computed
twice gives the same numbers (byte for byte in its data files, apart from the wall-clock columns),
the reused files are the stored ones, and any change to an input (the scene, the model, an
override, autocable's code) gives another key. A stored entry that fails its check is not used.
"""
from __future__ import annotations

import csv
import json
import shutil
from pathlib import Path

import pytest

from autocable.cli import main
from autocable.paper import reuse
from test_figures import SMALL

MODEL = (Path(__file__).resolve().parents[1] / "models" / "luongo_zulli_2012.toml")

# Branch I of Fig. 5a below resonance (test_figures' SMALL) with a short eq. (21) overlay:
# continuation and integration.
SCENE = SMALL + """[overlay]
method = "ode21"
range = [-0.05, -0.04]
points = 2
"""


#: The cache's sub-folders of derivations and builds, shared with the other tests (a private
#: cache would derive and compile the sample's equations again in every test); ``scenes/`` is
#: the test's own.
SHARED = ("derivations", "ame", "systems", "lambdas", "pydstool", "ckernel", "cintegrate")


@pytest.fixture
def runs(tmp_path, monkeypatch):
    from autocable._store import cache_root
    ambient = cache_root()
    (tmp_path / "cache").mkdir()
    for sub in SHARED:
        (ambient / sub).mkdir(parents=True, exist_ok=True)
        (tmp_path / "cache" / sub).symlink_to(ambient / sub, target_is_directory=True)
    monkeypatch.setenv("AUTOCABLE_CACHE", str(tmp_path / "cache"))
    folder = tmp_path / "runs"
    folder.mkdir()
    (folder / "figr1.toml").write_text(SCENE)
    return folder


def _figures(runs: Path, out: Path, *extra: str) -> dict:
    assert main(["figures", "--out", str(out), "--runs", str(runs), "--workers", "0", "--quiet", *extra]) == 0
    return {s["name"]: s for s in json.loads((out / "figures.json").read_text())["scenes"]}


def _rows_without_clocks(path: Path) -> list[dict]:
    with open(path, newline="") as fh:
        return [{k: v for k, v in r.items() if "wall" not in k} for r in csv.DictReader(fh)]


@pytest.mark.slow
def test_a_second_run_reuses_the_stored_scene_and_a_recomputation_gives_the_same_numbers(runs, tmp_path):
    first = _figures(runs, tmp_path / "a")
    assert first["figr1"]["status"] == "ok" and first["figr1"]["reused"] == ""
    second = _figures(runs, tmp_path / "b")
    assert second["figr1"]["reused"] != ""                       # not computed: copied
    a, b = tmp_path / "a" / "figr1", tmp_path / "b" / "figr1"
    run_b = json.loads((b / "run.json").read_text())
    assert run_b["status"] == "complete" and len(run_b["reused"]["key"]) == 64
    for name in ("branches.csv", "special_points.csv", "overlay.csv", "figr1.png"):
        assert (a / name).read_bytes() == (b / name).read_bytes(), name
    assert (tmp_path / "b" / "figr1.png").read_bytes() == (a / "figr1.png").read_bytes()
    assert "reused: computed" in (tmp_path / "b" / "report.md").read_text()
    # what makes reuse safe: computing again gives the same numbers (only the clocks differ)
    third = _figures(runs, tmp_path / "c", "--recompute")
    assert third["figr1"]["reused"] == ""
    c = tmp_path / "c" / "figr1"
    assert "reused" not in json.loads((c / "run.json").read_text())
    for name in ("branches.csv", "special_points.csv"):
        assert (a / name).read_bytes() == (c / name).read_bytes(), name
    rows = _rows_without_clocks(c / "overlay.csv")
    assert len(rows) == 4 and rows == _rows_without_clocks(a / "overlay.csv")


def test_any_changed_input_gives_another_key(runs, tmp_path, monkeypatch):
    scene = runs / "figr1.toml"
    base = reuse.scene_key(reuse.scene_inputs(scene))
    assert base == reuse.scene_key(reuse.scene_inputs(scene))           # a function of the inputs only
    assert reuse.scene_key(reuse.scene_inputs(scene, engine="pycont")) != base
    assert reuse.scene_key(reuse.scene_inputs(scene, plot=False)) != base
    # the model spec: one changed digit of the damping, in a copy the scene names
    model = tmp_path / "cable.toml"
    model.write_text(MODEL.read_text())
    scene.write_text(SCENE.replace(MODEL.as_posix(), model.as_posix()))
    same_model = reuse.scene_key(reuse.scene_inputs(scene))
    assert same_model != base                                          # another file: another key
    text = model.read_text()
    assert "damping_ratio = 0.004 " in text
    model.write_text(text.replace("damping_ratio = 0.004 ", "damping_ratio = 0.0041 ", 1))
    assert reuse.scene_key(reuse.scene_inputs(scene)) != same_model
    model.write_text(text)
    assert reuse.scene_key(reuse.scene_inputs(scene)) == same_model
    assert reuse.scene_key(reuse.scene_inputs(scene, model=MODEL)) != same_model     # --model
    # the scene itself, and autocable's code
    scene.write_text(SCENE.replace("-0.03]", "-0.031]"))
    changed_scene = reuse.scene_key(reuse.scene_inputs(scene))
    assert changed_scene != base
    monkeypatch.setattr(reuse, "code_fingerprint", lambda: "0" * 64)
    assert reuse.scene_key(reuse.scene_inputs(scene)) != changed_scene
    # a scene that cannot be read has no key: it is computed (and fails with its own message)
    scene.write_text("not toml [")
    assert reuse.scene_inputs(scene) is None


def test_the_code_fingerprint_changes_with_any_source_file_and_not_with_compiled_caches(tmp_path):
    """`code_fingerprint` is `tree_sha256` of the package: one byte of a nested module, a new
    file or a renamed one changes it; Python's compiled caches do not."""
    tree = tmp_path / "pkg"
    (tree / "sub").mkdir(parents=True)
    (tree / "a.py").write_text("x = 1\n")
    (tree / "sub" / "b.py").write_text("y = 2\n")
    base = reuse.tree_sha256(tree)
    (tree / "sub" / "__pycache__").mkdir()
    (tree / "sub" / "__pycache__" / "b.cpython-311.pyc").write_bytes(b"\0\1")
    (tree / "c.pyc").write_bytes(b"\0")
    assert reuse.tree_sha256(tree) == base
    (tree / "sub" / "b.py").write_text("y = 3\n")
    assert reuse.tree_sha256(tree) != base
    (tree / "sub" / "b.py").write_text("y = 2\n")
    assert reuse.tree_sha256(tree) == base
    (tree / "sub" / "b.py").rename(tree / "sub" / "c.py")
    assert reuse.tree_sha256(tree) != base
    (tree / "sub" / "c.py").rename(tree / "sub" / "b.py")
    (tree / "d.toml").write_text("")
    assert reuse.tree_sha256(tree) != base
    assert reuse.code_fingerprint() == reuse.tree_sha256(Path(reuse.__file__).resolve().parents[1])


def test_a_stored_entry_that_fails_its_check_is_not_used(runs, tmp_path, capfd):
    _figures(runs, tmp_path / "a")
    inputs = reuse.scene_inputs(runs / "figr1.toml")
    entry = reuse.lookup(inputs)
    assert entry is not None and "branches.csv" in entry["files"]
    stored = Path(entry["folder"]) / "branches.csv"
    stored.write_text(stored.read_text().replace("1", "2", 1))          # one digit changed in the cache
    capfd.readouterr()
    again = _figures(runs, tmp_path / "b")
    assert again["figr1"]["reused"] == ""                                # computed, not copied
    assert "failed its check" in capfd.readouterr().err
    assert (tmp_path / "b" / "figr1" / "branches.csv").read_bytes() == \
        (tmp_path / "a" / "figr1" / "branches.csv").read_bytes()
    assert reuse.lookup(inputs) is not None                              # stored again, whole


def test_a_failed_scene_is_not_stored(runs, tmp_path):
    (runs / "figr1.toml").write_text(SCENE.replace('start = "trivial"', 'strat = "trivial"'))
    assert main(["figures", "--out", str(tmp_path / "a"), "--runs", str(runs), "--workers", "0", "--quiet"]) != 0
    assert not (tmp_path / "cache" / "scenes").exists() or not any((tmp_path / "cache" / "scenes").iterdir())


def test_a_newer_entry_of_a_scene_replaces_the_older_one(runs, tmp_path):
    """One entry per scene run one way: editing the model and running again leaves the new entry
    only (the store does not grow with every edit), while another --engine keeps its own."""
    model = tmp_path / "cable.toml"
    model.write_text(MODEL.read_text())
    (runs / "figr1.toml").write_text(SCENE.replace(MODEL.as_posix(), model.as_posix()))
    first = reuse.scene_inputs(runs / "figr1.toml")
    _figures(runs, tmp_path / "a")
    assert reuse.lookup(first) is not None
    model.write_text(MODEL.read_text().replace("damping_ratio = 0.004 ", "damping_ratio = 0.0041 ", 1))
    second = reuse.scene_inputs(runs / "figr1.toml")
    assert _figures(runs, tmp_path / "b")["figr1"]["reused"] == ""     # another model: computed
    assert reuse.lookup(second) is not None and reuse.lookup(first) is None
    assert len(list(reuse.entry_folder(second).parent.iterdir())) == 1
    _figures(runs, tmp_path / "c", "--engine", "pycont")
    assert reuse.lookup(second) is not None                              # another slot: both kept
    assert len(list((tmp_path / "cache" / "scenes").iterdir())) == 2


@pytest.mark.slow
def test_a_scene_whose_inputs_changed_while_it_ran_is_not_stored(runs, tmp_path, monkeypatch):
    """The key is taken before the scene runs; if a file it reads changed meanwhile (a model edited
    during a long run), the results may be of either version: they are published, not stored."""
    from autocable.paper.figures import run_figures
    real = reuse.scene_inputs
    calls = []

    def edited_meanwhile(*args, **kwargs):
        inputs = real(*args, **kwargs)
        calls.append(1)
        return inputs if len(calls) == 1 else {**inputs, "files": {}}

    monkeypatch.setattr(reuse, "scene_inputs", edited_meanwhile)
    [done] = run_figures([runs / "figr1.toml"], tmp_path / "a", workers=0, reuse=True, keep=True)
    assert done.status == "ok" and len(calls) == 2
    assert not (tmp_path / "cache" / "scenes").exists()
    monkeypatch.setattr(reuse, "scene_inputs", real)
    [done] = run_figures([runs / "figr1.toml"], tmp_path / "b", workers=0, reuse=True, keep=True)
    assert reuse.lookup(real(runs / "figr1.toml")) is not None


def test_an_entry_without_its_run_json_is_not_used(runs, tmp_path, capfd):
    _figures(runs, tmp_path / "a")
    inputs = reuse.scene_inputs(runs / "figr1.toml")
    folder = reuse.entry_folder(inputs)
    (folder / "run.json").unlink()
    capfd.readouterr()
    assert reuse.lookup(inputs) is None and not folder.exists()
    assert "failed its check" in capfd.readouterr().err


@pytest.mark.parametrize("damage", ["garbage entry.json", "a name leaving the entry", "scenes is a file",
                                    "slot is a file"])
@pytest.mark.slow
def test_a_damaged_store_never_fails_a_run_nor_gives_foreign_files(runs, tmp_path, damage):
    """Whatever is found in the store's place, the scene is computed (exit 0, the numbers of a
    clean run) and nothing outside an entry is ever copied."""
    _figures(runs, tmp_path / "a")
    inputs = reuse.scene_inputs(runs / "figr1.toml")
    folder = reuse.entry_folder(inputs)
    if damage == "garbage entry.json":
        (folder / "entry.json").write_text("{not json")
    elif damage == "a name leaving the entry":
        # a well-formed entry.json (its own checksum right) naming a file outside the entry
        from autocable._store import load_checked_json, store_checked_json
        meta = load_checked_json(folder / "entry.json", None)
        secret = tmp_path / "secret.csv"
        secret.write_text("x\n")
        meta["files"]["../../secret.csv"] = reuse._file_sha(secret)
        store_checked_json(folder / "entry.json", meta)
    elif damage == "scenes is a file":
        shutil.rmtree(tmp_path / "cache" / "scenes")
        (tmp_path / "cache" / "scenes").write_text("")
    else:
        shutil.rmtree(folder.parent)
        folder.parent.write_text("")
    again = _figures(runs, tmp_path / "b")
    assert again["figr1"]["reused"] == ""                    # computed
    assert not (tmp_path / "b" / "figr1" / "secret.csv").exists()
    assert (tmp_path / "b" / "figr1" / "branches.csv").read_bytes() == \
        (tmp_path / "a" / "figr1" / "branches.csv").read_bytes()


def test_another_matplotlibrc_gives_another_key_when_figures_are_drawn(runs, tmp_path, monkeypatch):
    scene = runs / "figr1.toml"
    base, bare = reuse.scene_key(reuse.scene_inputs(scene)), reuse.scene_key(reuse.scene_inputs(scene, plot=False))
    rc = tmp_path / "matplotlibrc"
    rc.write_text("font.size : 14\n")
    monkeypatch.setenv("MATPLOTLIBRC", str(rc))
    assert reuse.scene_key(reuse.scene_inputs(scene)) != base
    assert reuse.scene_key(reuse.scene_inputs(scene, plot=False)) == bare       # no figure, no rc
