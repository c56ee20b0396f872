"""Where the repository's own files are (the sample models with their targets and search spaces,
the figure scenes), found from this file so that the command works from any folder; one place
instead of a path per module.

Two layouts hold them. A repository checkout (an editable install, or the tree itself) has the
top-level folders ``models/`` and ``runs/`` next to the package; an installed wheel (``pip install
.``) has the copies its build put inside the package, ``autocable/_data/models`` and
``autocable/_data/runs`` (setup.py). A checkout's own folders win, so that an edited
``runs/fig06.toml`` is the one a checkout runs; they are recognised by the files only they hold,
because the folder above an installed package (site-packages) may hold another distribution's
``models``.
"""
from __future__ import annotations

from pathlib import Path

_PACKAGE = Path(__file__).resolve().parent
#: The repository's top folder (this file is autocable/_paths.py); in an installed wheel, the
#: folder the package is installed in.
REPO = _PACKAGE.parent
#: The copies of models/ and runs/ an installed wheel carries (written by setup.py's build step).
SHIPPED = _PACKAGE / "_data"
#: The file names that mark the folders as autocable's own (the sample cable, a figure scene).
_MARKERS = (Path("models") / "luongo_zulli_2012.toml", Path("runs") / "fig06.toml")


def data_root(checkout: Path = REPO, shipped: Path = SHIPPED) -> Path:
    """The folder holding ``models/`` and ``runs/``: the checkout's when both marker files are
    there, else the wheel's copies."""
    if all((checkout / m).is_file() for m in _MARKERS):
        return checkout
    return shipped


#: The folder holding models/ and runs/ (`data_root`).
DATA = data_root()
#: The sample models (the cable of Sect. 5 and three real stays), their targets and search spaces.
MODELS_DIR = DATA / "models"
#: The sample cable of Sect. 5.
SAMPLE_MODEL = MODELS_DIR / "luongo_zulli_2012.toml"
#: The figure scenes (runs/fig*.toml).
RUNS_DIR = DATA / "runs"
