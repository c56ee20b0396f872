"""The documentation: the README is a front page (at most 150 lines) whose two set-up commands are
the ones CI runs verbatim, every example script is in the gallery, and the MkDocs site builds with
no warning (``mkdocs build --strict``; .ci/run builds it too, after installing the docs extra)."""
import importlib.util
import os
import re
import subprocess
import sys

import pytest

from conftest import REPO


def test_readme_is_a_front_page_with_the_ci_setup_commands():
    text = (REPO / "README.md").read_text()
    assert len(text.splitlines()) <= 150
    block = re.search(r"## Set-up.*?```bash\n(.*?)```", text, re.S).group(1).strip().splitlines()
    assert len(block) == 2
    ci = (REPO / ".ci" / "run").read_text().splitlines()
    assert block[0] in ci and block[1] in ci


def test_every_example_is_in_the_gallery_with_its_figures():
    page = (REPO / "docs" / "examples.md").read_text()
    for script in sorted((REPO / "examples").glob("*.py")):
        assert f'--8<-- "examples/{script.name}"' in page, script.name
    for image in re.findall(r"!\[[^\]]*\]\(([^)]+)\)", page):
        assert (REPO / "docs" / image).is_file(), image


@pytest.mark.skipif(importlib.util.find_spec("mkdocs") is None or importlib.util.find_spec("mkdocstrings") is None,
                    reason="the docs extra is not installed (pip install -e .[docs]); .ci/run builds the site")
def test_the_site_builds_strict(tmp_path):
    env = {**os.environ, "NO_MKDOCS_2_WARNING": "1", "PYTHONPATH": str(REPO)}
    res = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(tmp_path / "site")],
                         cwd=REPO, capture_output=True, text=True, env=env, timeout=600)
    assert res.returncode == 0, res.stdout + res.stderr
    assert "WARNING" not in res.stderr
    for page in ("reference/scene", "reference/model", "reference/chart", "reference/sweep", "reference/api",
                 "reproducing", "examples", "guide/own-cable"):
        assert (tmp_path / "site" / page / "index.html").is_file(), page
    scene = (tmp_path / "site" / "reference" / "scene" / "index.html").read_text()
    assert "plot.units" in scene
    statements = (tmp_path / "site" / "reproducing" / "index.html").read_text()
    assert "fig03.galloping" in statements
