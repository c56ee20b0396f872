"""Where the repository's own files are (the sample model, the figure scenes), found from this
file so that the command works from any folder; one place instead of a path per module."""
from __future__ import annotations

from pathlib import Path

#: The repository's top folder (this file is autocable/_paths.py).
REPO = Path(__file__).resolve().parents[1]
#: The sample cable of Sect. 5.
SAMPLE_MODEL = REPO / "models" / "luongo_zulli_2012.toml"
#: The figure scenes (runs/fig*.toml).
RUNS_DIR = REPO / "runs"
