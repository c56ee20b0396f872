"""The one look of autocable's figures, and what every plot shares: the matplotlib style (serif text
and mathtext as in the journal, ticks inside on four sides, thin frameless legends), a figure on the
Agg canvas (no pyplot state), labels placed so that none overlaps another, a marker or the tick
labels, and the files written beside each other (PNG for the screen, vector PDF for print).

matplotlib is imported inside the functions: importing this module costs nothing."""
from __future__ import annotations

import contextlib
import logging
import os
import tempfile
from pathlib import Path
from typing import Sequence

__all__ = ["STYLE", "styled", "new_figure", "save_figure", "figure_stem", "place_labels", "DPI"]

#: Resolution of the PNG files (and of anything rasterised in the PDF).
DPI = 150

#: The package's matplotlib style (applied with `styled` around every plot).
STYLE = {
    "font.family": "serif",
    "font.serif": ["DejaVu Serif"],
    "mathtext.fontset": "dejavuserif",
    "font.size": 9,
    "axes.labelsize": 10,
    "axes.titlesize": 9,
    "axes.linewidth": 0.8,
    "xtick.direction": "in",
    "ytick.direction": "in",
    "xtick.top": True,
    "ytick.right": True,
    "xtick.labelsize": 8,
    "ytick.labelsize": 8,
    "xtick.major.size": 3.5,
    "ytick.major.size": 3.5,
    "legend.fontsize": 7.5,
    "legend.frameon": False,
    "legend.handlelength": 2.2,
    "lines.linewidth": 1.5,
    "lines.markersize": 5,
    "axes.formatter.use_mathtext": True,
    "axes.formatter.limits": (-3, 3),
    "pdf.fonttype": 42,           # TrueType in the PDF: text stays text (editable, searchable)
    "savefig.dpi": DPI,
}


@contextlib.contextmanager
def styled():
    """The package's style for the block (`STYLE`, restored on exit), with matplotlib's own logging
    at WARNING: a distutils build (PyDSTool's AUTO library) can leave the root logger at DEBUG with a
    handler, and matplotlib would then print its font-matching chatter."""
    import matplotlib

    logger = logging.getLogger("matplotlib")
    before = logger.level
    logger.setLevel(logging.WARNING)
    try:
        with matplotlib.rc_context(STYLE):
            yield
    finally:
        logger.setLevel(before)


def new_figure(figsize) -> "object":
    """A Figure on its own Agg canvas (no pyplot, no global figure manager)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize, dpi=DPI)
    FigureCanvasAgg(fig)
    return fig


def figure_stem(stem: str | Path) -> Path:
    """The stem of a figure's files: ``stem`` itself, whatever dots it holds (``fh_U0_eta0.002``
    stays whole), less a trailing ``.png`` or ``.pdf`` if one was given."""
    stem = Path(stem)
    if stem.suffix.lower() in (".png", ".pdf"):
        stem = stem.with_suffix("")
    return stem


def save_figure(fig, stem: str | Path) -> list[Path]:
    """Write ``<stem>.png`` and ``<stem>.pdf`` (vector) of ``fig``, both cropped to the same tight
    box, atomically; return the two paths. The box is computed once: savefig's
    ``bbox_inches="tight"`` would draw the figure an extra time for every format."""
    from matplotlib import rcParams

    stem = figure_stem(stem)
    stem.parent.mkdir(parents=True, exist_ok=True)
    fig.draw_without_rendering()    # what savefig does before measuring: legends placed, text laid out
    bbox = fig.get_tightbbox(fig.canvas.get_renderer()).padded(rcParams["savefig.pad_inches"])
    # a layout engine left on the figure makes savefig draw the whole figure once more per format
    fig.set_layout_engine(None)
    paths = []
    for ext in (".png", ".pdf"):
        p = stem.parent / (stem.name + ext)
        _save(fig, p, bbox)
        paths.append(p)
    return paths


def _save(fig, path: Path, bbox) -> None:
    """savefig to a temporary file in the same folder, then os.replace (readers never see half a file)."""
    from autocable._store import file_mode
    # ".tmp", not the format's suffix: a run's next start recognises and removes what a kill left
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        os.fchmod(fd, file_mode())     # mkstemp's 0o600 would survive the replace
        os.close(fd)
        try:
            fig.savefig(tmp, format=path.suffix.lstrip("."), dpi=DPI, bbox_inches=bbox)
        except Exception as exc:
            # A write that fails inside a backend can surface as another error of its clean-up
            # (matplotlib's PDF writer: "'Stream' object has no attribute 'pos'" after the disk
            # filled): the OSError it hides is the one to report (the CLI names the place).
            cause = _hidden_os_error(exc)
            if cause is not None and cause is not exc:
                raise cause from None
            raise
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise


def _hidden_os_error(exc: BaseException) -> OSError | None:
    """The first OSError in ``exc`` and the exceptions it was raised from or during."""
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, OSError):
            return exc
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return None


#: Where a label may sit around its point (offset in points, horizontal and vertical alignment),
#: in order of preference: below right first (the paper's habit), then the other corners, then
#: further out.
_OFFSETS = [((4, -4), "left", "top"), ((4, 4), "left", "bottom"), ((-4, 4), "right", "bottom"),
            ((-4, -4), "right", "top"), ((0, 7), "center", "bottom"), ((0, -7), "center", "top"),
            ((7, 0), "left", "center"), ((-7, 0), "right", "center"),
            ((10, -12), "left", "top"), ((10, 12), "left", "bottom"), ((-10, 12), "right", "bottom"),
            ((-10, -12), "right", "top"), ((0, 18), "center", "bottom"), ((0, -18), "center", "top"),
            ((18, -18), "left", "top"), ((-18, 18), "right", "bottom"), ((18, 18), "left", "bottom"),
            ((-18, -18), "right", "top")]


def place_labels(ax, items: Sequence[tuple[float, float, str]], *, avoid: Sequence[tuple[float, float]] = (),
                 fontsize: float = 7.0) -> list:
    """Annotate each (x, y, text) of ``items`` (data coordinates) at the first position of
    `_OFFSETS` where its box lies inside the axes (so never on a tick label) and overlaps neither a
    label placed before it nor a marker at any of ``avoid`` (x, y points, data coordinates, with
    the items' own points). A label that fits nowhere is drawn at the first position with a leader
    line further out. Call it after the figure's layout is final. Returns the Text artists."""
    from matplotlib.transforms import Bbox

    fig = ax.figure
    get_renderer = getattr(fig.canvas, "get_renderer", None)
    if get_renderer is None:
        # a canvas that cannot measure text (no Agg renderer): the labels at the first position
        return [ax.annotate(text, (x, y), textcoords="offset points", xytext=_OFFSETS[0][0], ha=_OFFSETS[0][1],
                            va=_OFFSETS[0][2], fontsize=fontsize, zorder=12) for x, y, text in items]
    renderer = get_renderer()
    frame = ax.get_window_extent(renderer)
    to_px = ax.transData.transform
    scale = fig.dpi / 72.0
    r = 4.0 * scale                       # half the size of a marker, in pixels
    markers = [Bbox.from_extents(px - r, py - r, px + r, py + r)
               for px, py in (to_px((x, y)) for x, y, *_ in (*items, *avoid))]
    placed: list = []
    texts = []
    for x, y, text in items:
        chosen = None
        for (dx, dy), ha, va in _OFFSETS:
            t = ax.annotate(text, (x, y), textcoords="offset points", xytext=(dx, dy), ha=ha, va=va,
                            fontsize=fontsize, zorder=12)
            box = t.get_window_extent(renderer)
            inside = (box.x0 >= frame.x0 + 1 and box.x1 <= frame.x1 - 1 and box.y0 >= frame.y0 + 1
                      and box.y1 <= frame.y1 - 1)
            if inside and not any(box.overlaps(b) for b in placed + markers):
                chosen = (t, box)
                break
            t.remove()
        if chosen is None:
            # nowhere free: further out, joined to its point
            t = ax.annotate(text, (x, y), textcoords="offset points", xytext=(14, 14), ha="left", va="bottom",
                            fontsize=fontsize, zorder=12,
                            arrowprops=dict(arrowstyle="-", lw=0.4, color="0.4", shrinkA=0, shrinkB=2))
            chosen = (t, t.get_window_extent(renderer))
        placed.append(chosen[1])
        texts.append(chosen[0])
    return texts
