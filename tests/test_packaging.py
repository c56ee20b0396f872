"""What an installed wheel (``pip install .``, not editable) carries and runs: the sample models
with their targets and search spaces (models/) and the figure scenes (runs/) as package data under
autocable/_data (setup.py's build step), found by `autocable._paths` when the repository's folders
are not beside the package; the hardening harness (tools/) is not in it.

The wheel is built from a copy of the sources in a temporary folder (the repository's tree is left
alone). The install test (marked slow) installs it in a fresh venv and runs ``autocable figures
--quick``, ``run`` and ``onset`` from an empty folder."""
import os
import subprocess
import sys
import zipfile
from pathlib import Path
import shutil

import pytest
from conftest import REPO

#: What setup.py ships, as the repository holds it.
SHIPPED = sorted([*(REPO / "models").glob("*.toml"), *(REPO / "runs").glob("*.toml"), REPO / "runs" / "README.md"])
#: What a build needs from the repository.
SOURCES = ("autocable", "models", "runs", "setup.py", "setup.cfg", "pyproject.toml", "MANIFEST.in", "README.md")


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    """The wheel of a copy of the sources (``pip wheel --no-deps``: the build step, not the pins)."""
    src = tmp_path_factory.mktemp("src")
    for name in SOURCES:
        path = REPO / name
        if path.is_dir():
            shutil.copytree(path, src / name, ignore=shutil.ignore_patterns("__pycache__", "*.so", "_data"))
        else:
            shutil.copy(path, src / name)
    out = tmp_path_factory.mktemp("wheel")
    res = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(out), str(src)],
                         capture_output=True, text=True, timeout=600)
    assert res.returncode == 0, res.stdout + res.stderr
    (found,) = out.glob("autocable-*.whl")
    return found


def test_the_wheel_carries_the_models_and_scenes(wheel):
    """Every sample model, targets and search-space file and every scene is in the wheel under
    autocable/_data, byte for byte; the harness and the build's own script are not."""
    with zipfile.ZipFile(wheel) as z:
        names = set(z.namelist())
        for path in SHIPPED:
            inside = f"autocable/_data/{path.parent.name}/{path.name}"
            assert inside in names, inside
            assert z.read(inside) == path.read_bytes(), inside
    assert len(SHIPPED) >= 25                               # 9 model files and 20 scenes today
    assert {"autocable/_data/models/luongo_zulli_2012.targets.toml", "autocable/_data/runs/fig06.toml"} <= names
    assert not [n for n in names if n.startswith("tools/") or "/fuzz" in n or "/kill" in n]
    assert "autocable/_paths.py" in names and "setup.py" not in names


def test_the_data_folder_is_the_checkouts_when_it_has_the_files(tmp_path):
    """`data_root`: a checkout with both marker files wins; a folder above the package holding
    only an unrelated ``models/`` (as site-packages may) gives the wheel's copies."""
    from autocable._paths import DATA, REPO as PACKAGE_REPO, data_root
    checkout, shipped = tmp_path / "checkout", tmp_path / "shipped"
    (checkout / "models").mkdir(parents=True)
    (checkout / "models" / "luongo_zulli_2012.toml").write_text("")
    assert data_root(checkout, shipped) == shipped          # no runs/fig06.toml: not autocable's
    (checkout / "runs").mkdir()
    (checkout / "runs" / "fig06.toml").write_text("")
    assert data_root(checkout, shipped) == checkout
    assert DATA == PACKAGE_REPO == REPO                      # this checkout reads its own folders


def _venv_with_wheel(wheel: Path, where: Path) -> Path:
    """A fresh venv holding the wheel (not editable); its dependencies are this interpreter's (a
    path file to its site-packages, after the venv's own), so the test needs no registry."""
    import site
    import sysconfig
    subprocess.run([sys.executable, "-m", "venv", str(where)], check=True, timeout=300)
    py = where / "bin" / "python"
    res = subprocess.run([str(py), "-m", "pip", "install", "-q", "--no-deps", str(wheel)],
                         capture_output=True, text=True, timeout=600)
    assert res.returncode == 0, res.stdout + res.stderr
    purelib = subprocess.run([str(py), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                             capture_output=True, text=True, check=True).stdout.strip()
    deps = {sysconfig.get_paths()["purelib"], *site.getsitepackages()}
    Path(purelib, "zz_autocable_test_deps.pth").write_text("\n".join(sorted(deps)) + "\n")
    return where / "bin"


@pytest.mark.slow
def test_an_installed_wheel_runs_from_an_empty_folder(wheel, tmp_path):
    """From an empty folder, with the wheel installed in a fresh venv: ``figures --quick`` finds
    its scenes, ``run`` a shipped scene (its model named relative to it) and ``onset`` the shipped
    sample model; every one exits 0, and the autocable they ran is the wheel's, not the checkout."""
    bin_ = _venv_with_wheel(wheel, tmp_path / "venv")
    empty = tmp_path / "empty"
    empty.mkdir()
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    # the dependencies' programs (swig, which PyDSTool's builds call) live beside this interpreter
    env["PATH"] = os.pathsep.join([str(bin_), str(Path(sys.executable).parent), env.get("PATH", "")])
    where = subprocess.run([str(bin_ / "python"), "-c", "import autocable._paths as p; print(p.DATA)"],
                           cwd=empty, env=env, capture_output=True, text=True, check=True).stdout.strip()
    data = Path(where)
    assert data.name == "_data" and REPO not in data.parents, where
    for argv in (["figures", "--quick", "--out", "out", "--quiet"],
                 ["run", str(data / "runs" / "fig05a.toml"), "--out", "fig05a", "--quiet"],
                 ["onset", str(data / "models" / "luongo_zulli_2012.toml")]):
        res = subprocess.run([str(bin_ / "autocable"), *argv], cwd=empty, env=env, capture_output=True,
                             text=True, timeout=1800)
        assert res.returncode == 0, (argv, res.stdout[-2000:], res.stderr[-2000:])
    assert (empty / "out" / "report.md").is_file() or list((empty / "out").glob("*"))
    assert (empty / "fig05a" / "run.json").is_file()
