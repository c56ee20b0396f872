"""The layering of the package (setup.cfg ``[importlinter]``): spec -> model -> codegen -> methods ->
scene -> studies -> paper -> bench -> cli, each importing only from below, and no import circle
between the modules of any one package (``acyclic_siblings`` over all of autocable). The contracts
pass on the repository; a deliberately wrong import (the physics importing the scene runner, a loop
the layering exists to prevent) makes them fail, naming the import, and so does a circle inside a
layer (the bound stage and the calibration importing each other), and so does the package importing
the hardening harness, which lives outside it (tools/hardening)."""
import shutil
import subprocess
import sys
from pathlib import Path
from conftest import REPO

LINT = ("import sys; from importlinter.cli import lint_imports; "
        "sys.exit(lint_imports(config_filename='setup.cfg', no_cache=True, no_logo=True))")


def _lint(root: Path) -> subprocess.CompletedProcess:
    # cwd first on sys.path: the copy under test is the package that is analysed
    return subprocess.run([sys.executable, "-c", LINT], cwd=root, capture_output=True, text=True,
                          env={"PYTHONPATH": str(root), "PATH": "/usr/bin:/bin"}, timeout=300)


def test_the_layering_contract_holds():
    res = _lint(REPO)
    assert res.returncode == 0, res.stdout + res.stderr
    assert "5 kept, 0 broken" in res.stdout


def test_the_contract_fails_on_a_wrong_import(tmp_path):
    shutil.copytree(REPO / "autocable", tmp_path / "autocable", ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copy(REPO / "setup.cfg", tmp_path / "setup.cfg")
    statics = tmp_path / "autocable" / "model" / "statics.py"
    statics.write_text(statics.read_text() + "\n\ndef _upward():\n    from autocable.scene.runner import run_scene\n"
                       "    return run_scene\n")
    res = _lint(tmp_path)
    assert res.returncode != 0
    assert "BROKEN" in res.stdout
    assert "autocable.model.statics -> autocable.scene.runner" in res.stdout


def test_the_package_importing_the_harness_fails(tmp_path):
    """The hardening harness lives outside the package (tools/hardening); a module of autocable
    importing it (the bench commands calling the fuzzer again) breaks the no-harness contract."""
    shutil.copytree(REPO / "autocable", tmp_path / "autocable", ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copytree(REPO / "tools", tmp_path / "tools", ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copy(REPO / "setup.cfg", tmp_path / "setup.cfg")
    commands = tmp_path / "autocable" / "bench" / "commands.py"
    commands.write_text(commands.read_text() + "\n\ndef _fuzz():\n    from tools.hardening.fuzz import run_fuzz\n"
                        "    return run_fuzz\n")
    res = _lint(tmp_path)
    assert res.returncode != 0
    assert "The package never imports the hardening harness (tools/, outside the package) BROKEN" in res.stdout
    assert "autocable.bench.commands -> tools" in res.stdout


def test_a_circle_inside_a_layer_fails(tmp_path):
    """Two modules of one package importing each other (both in the paper layer, so the layers
    contract cannot see it) break the acyclic contract, which names the package and the imports."""
    shutil.copytree(REPO / "autocable", tmp_path / "autocable", ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copy(REPO / "setup.cfg", tmp_path / "setup.cfg")
    bound = tmp_path / "autocable" / "paper" / "bound.py"
    bound.write_text(bound.read_text() + "\n\ndef _back():\n    from autocable.paper.calibration import calibrate\n"
                     "    return calibrate\n")
    res = _lint(tmp_path)
    assert res.returncode != 0
    assert "No import circles inside any package" in res.stdout and "BROKEN" in res.stdout
    assert "No cycles are allowed in autocable.paper" in res.stdout
    assert "The pipeline's layers KEPT" in res.stdout        # the circle is invisible to the layers


def test_no_private_name_crosses_a_package_border():
    """A name with a leading underscore is imported only inside its own package (the root package's
    own modules _store, _paths, _version are internal to autocable and used throughout it)."""
    import ast

    crossings = []
    for path in sorted((REPO / "autocable").rglob("*.py")):
        parts = path.relative_to(REPO).with_suffix("").parts
        here = ".".join(parts[:-1]) if parts[-1] != "__init__" else ".".join(parts[:-1])
        for node in ast.walk(ast.parse(path.read_text())):
            if not (isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("autocable")):
                continue
            source = REPO.joinpath(*node.module.split("."))
            owner = node.module.rsplit(".", 1)[0] if source.with_suffix(".py").is_file() else node.module
            for alias in node.names:
                private = alias.name.startswith("_") and not alias.name.startswith("__")
                if private and owner != here and not (owner == "autocable" and alias.name in ("_store", "_paths", "_version")):
                    crossings.append(f"{path.relative_to(REPO)}:{node.lineno} {alias.name} from {node.module}")
    assert crossings == []

