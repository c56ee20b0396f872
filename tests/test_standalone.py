"""The repository stands alone: no file refers to a document outside it, and every citation of
docs/model.md (the corrections to the paper, its conventions and the inputs it does not give) points
at an item that exists there, every test that page names exists.

Files are the tracked ones (`git ls-files`), or, outside a git checkout, the tree without build and
cache folders. The forbidden patterns are assembled from pieces so that this file does not match
itself.
"""
from __future__ import annotations

import re
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
MODEL_MD = REPO / "docs" / "model.md"

#: Folders never scanned when walking the tree (build output, caches, environments).
SKIP_DIRS = {".git", ".venv", "venv", "out", ".cache", "__pycache__", ".pytest_cache", "build", "dist"}
#: Markdown files the code writes into output folders (not tracked, but legitimately named).
#: Markdown files written by the tools, not kept in the repository: report.md (`autocable figures`)
#: and the file references the docs site generates from the schemas (docs/_hooks/generate.py).
GENERATED_MD = {"report.md", "scene.md", "chart.md", "sweep.md"}

_ERR = "ERR" + "ATA"
#: (pattern, what it is) for references to documents that live outside the repository.
OUTSIDE = [
    (re.compile(_ERR), "the paper's misprint list outside the repository (cite docs/model.md)"),
    (re.compile(r"\.\./" + "shared" + r"\b|\bshared" + "/paper"), "a shared folder outside the repository"),
    (re.compile("DES" + r"IGN\.md|PYD" + r"STOOL\.md"), "a design or notes file outside the repository"),
    (re.compile(r"(?<![\w.~])/(?:" + "work" + "|" + "tmp" + r")/"), "an absolute machine path"),
    (re.compile(r"\bthe " + "shared" + r" (?:PyDSTool )?notes\b"), "notes outside the repository"),
    (re.compile(r"\b[Ii]" + r"ssue [0-9]+\b|\([Ii]" + r"ssue \""), "a tracker issue a clone cannot read"),
]

#: A citation of docs/model.md: optional anchor, then item ids such as "M3", "C1 and U2", "M3, M4".
CITATION = re.compile(r"model\.md(#[a-z0-9_-]+)?((?:(?:\s*,|\s+and|\s+or)?\s*(?:items?\s+)?\b[MCUF]\d*\b)*)")
ITEM_ID = re.compile(r"\b[MCUF]\d*\b")
HEADING = re.compile(r"^## ([MCUF]\d*)\. ", re.M)
TEST_REF = re.compile(r"(tests/test_\w+\.py)::(\w+)")
MD_NAME = re.compile(r"[\w./-]+\.md\b")


def _tracked_files() -> list[Path]:
    try:
        out = subprocess.run(["git", "ls-files", "-z"], cwd=REPO, capture_output=True, check=True,
                             timeout=60).stdout.decode()
        names = [n for n in out.split("\0") if n]
    except (OSError, subprocess.SubprocessError):
        names = []
    if names:
        return [REPO / n for n in names if (REPO / n).is_file()]
    found = []
    for p in REPO.rglob("*"):
        rel = p.relative_to(REPO).parts
        if p.is_file() and not any(part in SKIP_DIRS or part.endswith(".egg-info") for part in rel):
            found.append(p)
    return found


def _text(path: Path) -> str | None:
    data = path.read_bytes()
    if b"\0" in data:
        return None
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        return None


@pytest.fixture(scope="module")
def texts() -> dict[str, str]:
    out = {}
    for p in _tracked_files():
        t = _text(p)
        if t is not None:
            out[p.relative_to(REPO).as_posix()] = t
    return out


def outside_references(text: str) -> list[str]:
    """Each reference in ``text`` to a document outside the repository, as 'line N: what (match)'."""
    hits = []
    for pattern, what in OUTSIDE:
        for m in pattern.finditer(text):
            line = text.count("\n", 0, m.start()) + 1
            hits.append(f"line {line}: {what} ({m.group(0)!r})")
    return hits


def cited_items(text: str) -> list[tuple[str, str]]:
    """(anchor or '', item id) of every docs/model.md citation in ``text``."""
    out = []
    for m in CITATION.finditer(text):
        if m.group(1):
            out.append((m.group(1)[1:], ""))
        out += [("", i) for i in ITEM_ID.findall(m.group(2) or "")]
    return out


def _slug(heading: str) -> str:
    """GitHub's anchor of a heading: lower case, punctuation dropped, spaces to hyphens."""
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def test_the_checks_can_fail():
    """The detectors find what they are meant to find (so the repository scans below can fail)."""
    assert outside_references("see " + "../" + "shared" + "/paper/" + _ERR + ".md, item 3")
    assert outside_references("(" + _ERR + " item 5's form)")
    assert outside_references("written to /" + "tmp/x")
    assert outside_references("what autocable found beyond the " + "shared notes")
    assert not outside_references("docs/model.md, M3; ~/.cache/autocable; out/figures/report.md")
    assert cited_items("docs/model.md, M3 and M4; model.md, items C1, U2") == [
        ("", "M3"), ("", "M4"), ("", "C1"), ("", "U2")]
    assert cited_items("docs/model.md#m1-ea") == [("m1-ea", "")]
    assert cited_items("(docs/model.md, F)") == [("", "F")]


def test_no_file_refers_to_a_document_outside_the_repository(texts):
    assert len(texts) > 50
    bad = {name: hits for name, t in texts.items() if (hits := outside_references(t))}
    assert not bad, bad


def test_every_markdown_file_named_exists(texts):
    """A name like docs/ordering.md or ame_vs_ode21.md must be a markdown file of the repository
    (or report.md, which `autocable figures` writes)."""
    present = {Path(n).name for n in texts if n.endswith(".md")} | GENERATED_MD
    bad = {}
    for name, t in texts.items():
        missing = sorted({m for m in MD_NAME.findall(t) if Path(m).name not in present})
        if missing:
            bad[name] = missing
    assert not bad, bad


def test_every_cited_model_item_exists(texts):
    assert MODEL_MD.is_file()
    page = MODEL_MD.read_text()
    ids = HEADING.findall(page)
    assert len(ids) == len(set(ids)), "duplicate item headings in docs/model.md"
    assert {"M1", "M7", "C1", "U1", "F"} <= set(ids)
    slugs = {_slug(h) for h in re.findall(r"^#+ (.+)$", page, re.M)}
    cited, bad = 0, []
    for name, t in texts.items():
        for anchor, item in cited_items(t):
            cited += 1
            if item and item not in ids:
                bad.append(f"{name}: docs/model.md, {item}")
            if anchor and anchor not in slugs:
                bad.append(f"{name}: docs/model.md#{anchor}")
    assert not bad, bad
    assert cited > 20           # the code, tests and specs do cite it


def test_every_test_named_in_model_md_exists():
    page = MODEL_MD.read_text()
    refs = TEST_REF.findall(page)
    assert len(refs) > 20
    missing = []
    for path, name in refs:
        f = REPO / path
        if not f.is_file() or not re.search(rf"^def {name}\(", f.read_text(), re.M):
            missing.append(f"{path}::{name}")
    assert not missing, missing
