"""MkDocs hook: the pages generated from the code at build time.

* ``reference/{model,scene,chart,sweep}.md``: the file references, from the schemas
  (`autocable.scene.reference`; tests/test_reference.py keeps every field documented);
* ``<!-- statements -->`` in a page: the statements of Sect. 5 as the targets file lists them.
"""
from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from mkdocs.structure.files import File  # noqa: E402

from autocable.scene.reference import KINDS, reference_page  # noqa: E402

TARGETS = ROOT / "models" / "luongo_zulli_2012.targets.toml"


def on_files(files, config):
    for kind in KINDS:
        files.append(File.generated(config, f"reference/{kind}.md", content=reference_page(kind)))
    return files


def _statements() -> str:
    from autocable.paper.targets import SOURCES, load_targets

    rows = ["| id | figure | Sect. 5 says | counted as shown when | source |", "|---|---|---|---|---|"]
    for t in load_targets(TARGETS):
        if t.kind != "statement":
            continue
        cells = [f"`{t.id}`", t.scene, t.says, t.threshold, t.source]
        rows.append("| " + " | ".join(str(c).replace("|", "\\|").replace("*", "\\*") for c in cells) + " |")
    notes = [f"- **{k}**: {v}." for k, v in SOURCES.items()]
    return "\n".join(rows + [""] + notes)


def on_page_markdown(markdown, page, config, files):
    if "<!-- statements -->" in markdown:
        markdown = markdown.replace("<!-- statements -->", _statements())
    return markdown
