"""`autocable figures`: every figure scene of the paper (``runs/fig*.toml``, Figs. 3-11 of Luongo &
Zulli 2012) in parallel processes, the figures collected as ``DIR/figNN.png``/``.pdf`` and the
comparison with Sect. 5 written to ``DIR/report.md`` (`autocable.paper.report`).

Each scene runs in its own process through the public `autocable.scene.runner.load_scene` / `run_scene`
into ``DIR/<scene>/``. A scene that fails (a bad file, a start that does not converge, a crash of
the process) never stops the others: its one-line error goes to ``DIR/<scene>/error.txt`` (with
the traceback below it), to ``DIR/figures.json`` and to the report, and the command exits non-zero.
"""
from __future__ import annotations

import argparse
import contextlib
import math
import os
import sys
import time
import traceback
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Callable, Sequence

from autocable._paths import RUNS_DIR
from autocable.errors import EXIT_FAILED
from autocable.spec import SpecError

__all__ = ["QUICK", "SceneOutcome", "cold_group", "default_runs_dir", "discover", "expected_cost", "run_figures",
           "run_figures_in", "figures_folder", "FIGURES_LOCK",
           "add_figures_parser",
           "cmd_figures", "SUMMARY_JSON", "ERROR_TXT"]

#: The ``--quick`` subset: the closed-form galloping branch (Fig. 3) and the two mono-modal no-wind
#: responses (Figs. 5a-b), each a few seconds with a warm cache.
QUICK = ("fig03", "fig05a", "fig05b")
SUMMARY_JSON = "figures.json"
WALL_JSON = "wall_s.json"            # in cache_dir("figures"): the last wall time of each scene
ERROR_TXT = "error.txt"
TASKS_JOURNAL = ".tasks.jsonl"    # the scene starts of the last run (`autocable.executor.attempts`)

Say = Callable[[str], None]


@dataclass
class SceneOutcome:
    """How one scene ended: ``status`` is "ok" or "failed" (``error`` holds the one-line reason)."""

    name: str
    scene: str
    status: str
    wall_s: float
    error: str = ""
    files: list[str] = field(default_factory=list)
    #: When the files were computed, for a scene whose stored results were reused
    #: (`autocable.paper.reuse`); empty for a scene computed by this run.
    reused: str = ""


def default_runs_dir() -> Path:
    """The repository's ``runs/`` folder next to the package."""
    return RUNS_DIR


def discover(runs_dir: str | Path, only: Sequence[str] = (), quick: bool = False) -> list[Path]:
    """The scene files ``fig*.toml`` of ``runs_dir``, sorted, restricted to ``only`` (scene names)
    or to `QUICK`. Unknown names raise `SpecError` listing the scenes there are."""
    folder = Path(runs_dir)
    if not folder.is_dir():
        raise SpecError("--runs", "", f"no such folder: {folder}")
    scenes = sorted(folder.glob("fig*.toml"))
    by_name = {p.stem: p for p in scenes}
    if not scenes:
        raise SpecError("--runs", "", f"no scene files fig*.toml in {folder}")
    wanted = list(only) if only else (list(QUICK) if quick else list(by_name))
    if quick and not only:
        wanted = [n for n in wanted if n in by_name]
        if not wanted:
            raise SpecError("--quick", "", f"none of the quick scenes {', '.join(QUICK)} is in {folder}; "
                                           f"use --only with some of {', '.join(by_name)}")
    missing = [n for n in wanted if n not in by_name]
    if missing:
        raise SpecError("--only", "", f"no scene {', '.join(missing)} in {folder}; "
                                      f"there are {', '.join(by_name)}")
    return [by_name[n] for n in dict.fromkeys(wanted)]


def _one_line(exc: BaseException) -> str:
    if isinstance(exc, SpecError):
        return str(exc)
    text = str(exc).strip().splitlines()
    return f"{type(exc).__name__}: {text[0]}" if text else type(exc).__name__


def _collect(name: str, scene_out: Path, out: Path) -> list[str]:
    """Copy ``<scene>.png/.pdf`` (and the parameter-plane figure) up to ``out``."""
    files = []
    for stem in (name, f"{name}_plane"):
        for ext in (".png", ".pdf"):
            src = scene_out / f"{stem}{ext}"
            if src.is_file():
                _copy_atomic(src, out / src.name)
                files.append(src.name)
    return files


def _copy_atomic(src: Path, dst: Path) -> None:
    """Copy through a temporary file and a rename: a kill never leaves half a figure at ``dst``."""
    from autocable._store import atomic_write_bytes
    atomic_write_bytes(dst, src.read_bytes(), fsync=False)


def _run_scene(scene_path: str, scene_out: str, engine: str | None, model: str | None,
               plot: bool) -> tuple[str, str, str]:
    """In the scene's own child process: run one scene (on ``model`` instead of the scene's own, if
    given; without its figure if not ``plot``); (status, one-line error, traceback)."""
    try:
        from dataclasses import replace

        from autocable.scene.runner import load_scene, run_scene
        from autocable.studies.advise import choose_ame
        scene = load_scene(scene_path)
        if model is not None:
            scene = replace(scene, model=Path(model))
        run_scene(scene, scene_out, progress=None, engine=engine, choose_ame=choose_ame, plot=plot)
        return ("ok", "", "")
    except BaseException as exc:   # everything: the parent must learn why, and go on
        return ("failed", _one_line(exc), traceback.format_exc())


def scene_task(scene_path: str, scene_out: str, engine: str | None = None, model: str | None = None,
               plot: bool = True, timeout: float | None = None) -> tuple[str, str, str, float]:
    """One scene as an executor task (`autocable.executor`), run in a child forked by the worker
    (`executor.run_forked`: PyDSTool's working folder is process-wide, a crash in compiled code
    fails this scene only, a scene over ``timeout`` seconds is stopped). Returns (status "ok" |
    "failed", one-line error, traceback, wall seconds)."""
    import re

    from autocable.executor import run_forked
    from autocable.run_folder import pid_alive
    t0 = time.perf_counter()
    status, value, detail = run_forked(_run_scene, (scene_path, scene_out, engine, model, plot), timeout,
                                       what="scene")
    holder = re.search(r"another autocable run \(process (\d+)\)", str(value[1] if status == "ok" else value))
    if holder:
        # This scene again after its worker was lost: the earlier attempt's process, killed with
        # that worker, may not have ended yet. Wait for it a little, then run once more (another
        # live run in the folder still fails as before).
        pid, deadline = int(holder.group(1)), time.monotonic() + 10.0
        while pid_alive(pid) and time.monotonic() < deadline:
            time.sleep(0.05)
        if not pid_alive(pid):
            status, value, detail = run_forked(_run_scene, (scene_path, scene_out, engine, model, plot), timeout,
                                               what="scene")
    wall = time.perf_counter() - t0
    if status == "ok":
        return (*value, wall)
    return ("failed", f"{scene_path}: {value}", detail, wall)     # killed, or over the time limit


def _preload() -> None:
    """Import in the parent what every scene imports (numpy, scipy, sympy, matplotlib's Agg
    canvas, PyDSTool with PyCont, autocable's layers): a forked child then starts with them, and
    thirteen scenes do not pay about a second of imports each. A failed import is left for the
    child to report with its scene's name."""
    try:
        import matplotlib.backends.backend_agg  # noqa: F401
        import matplotlib.figure  # noqa: F401
        import scipy.integrate  # noqa: F401
        import scipy.optimize  # noqa: F401
        import sympy  # noqa: F401

        import autocable.methods.continuation  # noqa: F401
        import autocable.methods.integration.ode21  # noqa: F401
        import autocable.model.ame_cache  # noqa: F401
        import autocable.model.derive  # noqa: F401
        import autocable.plotting.diagrams  # noqa: F401
        import autocable.scene.runner  # noqa: F401
        from autocable.codegen.compat import import_pydstool
        import_pydstool()
        # The first figure of a process loads fonts and mathtext for both formats (0.1-0.2 s):
        # drawing one tiny figure here leaves them loaded for every child.
        import io

        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
        fig = Figure(figsize=(1, 1))
        FigureCanvasAgg(fig)
        ax = fig.add_subplot()
        ax.plot([0, 1], [0, 1], "--s", mfc="none")
        ax.set_xlabel(r"$\sigma$")
        for fmt in ("png", "pdf"):
            fig.savefig(io.BytesIO(), format=fmt)
    except Exception:   # noqa: BLE001 - the child imports again and says what failed
        pass


def _timings_file() -> Path:
    from autocable._store import cache_root
    return cache_root() / "figures" / WALL_JSON     # not created here: a read-only cache is fine


def recorded_wall_times() -> dict[str, float]:
    """Wall seconds per scene name of the last `run_figures` that ran it (the cache folder)."""
    from autocable._store import read_json
    data = read_json(_timings_file())   # a hint for the order only: numbers are taken, nothing else
    return {str(k): float(v) for k, v in data.items()
            if isinstance(v, (int, float)) and math.isfinite(v) and v >= 0} if isinstance(data, dict) else {}


def expected_cost(path: Path, recorded: dict[str, float] | None = None) -> float:
    """The expected cost of a scene, to start the long ones first (the wall time of the whole set
    is then close to the total over the cores rather than the longest scene started last): its
    wall time in ``recorded`` (`recorded_wall_times`) when known, else a rough weight in which
    periodic-orbit runs, the eq. (21) overlay and a time history weigh most (an unreadable scene
    costs nothing: it fails at once in its process)."""
    from autocable.scene.runner import load_scene
    if recorded and Path(path).stem in recorded:
        return recorded[Path(path).stem]
    try:
        scene = load_scene(path)
    except Exception:   # noqa: BLE001 - reported by the scene's own process
        return 0.0
    return (1.0 + len(scene.runs) + 3.0 * sum(r.cycles for r in scene.runs)
            + 3.0 * (scene.overlay is not None) + 8.0 * (scene.time is not None))


def cold_group(path: Path, model: str | None = None, engine: str | None = None) -> tuple | None:
    """What a scene computes once and caches for every scene like it: the derivation of its model's
    eq. (21) and amplitude equations (model and Multiple Scales ordering), the compiled system it
    continues (the AME it uses, with or without the wind terms) and its continuation engine (PyCont
    compiles a PyDSTool library of its own). None for a scene that cannot be read (it fails at
    once in its process). ``model`` and ``engine`` override the scene's own, as `run_figures` does."""
    from autocable.scene.runner import load_scene
    try:
        scene = load_scene(path)
    except Exception:   # noqa: BLE001 - reported by the scene's own process
        return None
    wind = scene.fixed.get("U", 0.0) != 0.0 or any(r.parameter == "U" for r in scene.runs)
    if scene.time is not None:
        wind = wind or scene.time.U != 0.0
    return (str(Path(model or scene.model).resolve()), scene.ordering, scene.ame, wind, engine or scene.engine)


def _error_file(folder: Path, error: str, detail: str) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / ERROR_TXT).write_text(error + "\n\n" + detail, encoding="utf-8")


class _NoTasks:
    """The executor of a run whose every scene was reused: nothing to wait for."""

    where = {"mode": "reused"}

    def completed(self):
        return iter(())

    def close(self) -> None:
        pass


def _reuse_stored(pending: list[Path], out: Path, model_arg: str | None, engine: str | None, plot: bool,
                  reuse: bool, tell: Say) -> tuple[list[Path], dict[str, dict], list[SceneOutcome]]:
    """(the scenes of ``pending`` still to compute, the inputs of every readable scene by name
    for storing the computed ones, the outcomes of the scenes published from a stored entry of
    their key instead: `autocable.paper.reuse`, only with ``reuse``)."""
    from autocable.paper.reuse import lookup, restore, scene_inputs
    left, inputs_of, reused = [], {}, []
    for path in pending:
        name = path.stem
        inputs = scene_inputs(path, model_arg, engine, plot)
        if inputs is None:      # unreadable: computed, and fails there with its own message
            left.append(path)
            continue
        inputs_of[name] = inputs
        entry = lookup(inputs) if reuse else None
        if entry is None:
            left.append(path)
            continue
        t0 = time.perf_counter()
        folder = out / name
        try:
            (folder / ERROR_TXT).unlink(missing_ok=True)
            restore(entry, folder, name, inputs)
        except Exception as exc:   # noqa: BLE001 - e.g. a folder holding foreign files: the run says why
            tell(f"{name}: the stored results were not used ({_one_line(exc)}); computing it")
            left.append(path)
            continue
        reused.append(SceneOutcome(name, str(path), "ok", time.perf_counter() - t0, "", _collect(name, folder, out),
                                   reused=str(entry.get("computed") or "?")))
    return left, inputs_of, reused


#: The lock a running `autocable figures` holds on its ``--out`` (an advisory ``flock``, released by
#: the kernel however the process ends; the file holds the holder's pid, to name it).
FIGURES_LOCK = ".autocable-figures.lock"


def _ours(out: Path, entry: Path, names: frozenset = frozenset()) -> bool:
    """Whether ``entry`` of a figures ``--out`` is something `autocable figures` writes there: a
    scene folder (named as a scene of ``names``, or its run.json or an error.txt says so), a
    figure copied up from one (``<scene>.png``/``.pdf``, ``<scene>_plane.*``), figures.json,
    report.md beside a figures.json, the journal and the lock. A scene's own folder is checked
    for foreign files by its run (`autocable.run_folder.output_folder`)."""
    import re

    from autocable._store import read_json
    from autocable.paper.report import REPORT_MD
    from autocable.results import RUN_JSON
    n = entry.name
    if n in (FIGURES_LOCK, TASKS_JOURNAL, SUMMARY_JSON) and entry.is_file():
        return True
    if n == REPORT_MD and entry.is_file():
        return (out / SUMMARY_JSON).is_file()
    if entry.is_dir() and not entry.is_symlink():
        meta = read_json(entry / RUN_JSON)
        return (n in names or (isinstance(meta, dict) and meta.get("name") == n) or (entry / ERROR_TXT).is_file()
                or not any(entry.iterdir()))
    m = re.fullmatch(r"(?P<scene>.+?)(_plane)?\.(png|pdf)", n)
    if m and entry.is_file():
        meta = read_json(out / m["scene"] / RUN_JSON)
        return m["scene"] in names or (isinstance(meta, dict) and meta.get("name") == m["scene"])
    return False


@contextlib.contextmanager
def figures_folder(out: Path, scenes: Sequence[str] = ()):
    """Hold ``out`` for one `autocable figures` run of the scenes named ``scenes``: a folder
    another live run holds is refused (one line naming ``--out`` and that run's process: two runs
    would share the journal of task starts and remove each other's temporaries); one holding
    files `autocable figures` did not write (`_ours`: besides its fixed files, what an earlier run
    listed in figures.json or a scene of this run names) is refused; the half-written temporaries
    of a killed run are removed (the lock proves their writer dead). Yields ``out``."""
    from autocable._store import read_json
    from autocable.run_folder import folder_lock, temporary_of

    with folder_lock(out, FIGURES_LOCK, "figures"):
        listed = read_json(out / SUMMARY_JSON)
        earlier = [s.get("name") for s in listed.get("scenes", []) if isinstance(s, dict)] \
            if isinstance(listed, dict) and isinstance(listed.get("scenes"), list) else []
        names = frozenset(str(n) for n in [*scenes, *earlier] if isinstance(n, str) and n)
        foreign, temporaries = [], []
        for entry in sorted(out.iterdir()):
            target = temporary_of(entry.name)
            if target and entry.is_file() and (target in (SUMMARY_JSON, "report.md")
                                               or target.endswith((".png", ".pdf"))):
                temporaries.append(entry)        # a killed run's: we hold the lock, its writer is dead
            elif not _ours(out, entry, names):
                foreign.append(entry.name)
        if foreign:
            shown = ", ".join(foreign[:5]) + (f" and {len(foreign) - 5} more" if len(foreign) > 5 else "")
            raise SpecError("arguments", "--out", f"{out} holds files autocable figures did not write ({shown}); "
                                                  "give an empty or new folder, or move them away")
        for entry in temporaries:
            entry.unlink(missing_ok=True)
        yield out


def run_figures(scenes: Sequence[Path], out_dir: str | Path, **kwargs) -> list[SceneOutcome]:
    """`run_figures_in` under the folder's lock (`figures_folder`): one writer per output folder."""
    with figures_folder(Path(out_dir), [Path(p).stem for p in scenes]):
        return run_figures_in(scenes, out_dir, **kwargs)


def _mark_unfinished(out: Path, names: Sequence[str], error: str) -> None:
    """Scenes a run stopped without (no live worker): error.txt, and their run.json "failed" where
    it still says "running" (its writer is gone, or the folder would read as busy forever)."""
    from autocable._store import atomic_write_json, read_json
    from autocable.results import RUN_JSON
    for name in names:
        folder = out / name
        try:
            _error_file(folder, f"{name}: {error}", "")
            meta = read_json(folder / RUN_JSON)
            if isinstance(meta, dict) and meta.get("status") == "running":
                meta = {k: v for k, v in meta.items() if k != "pid"}
                meta.update(status="failed", reason=error)
                atomic_write_json(folder / RUN_JSON, meta)
        except OSError:
            pass


def run_figures_in(scenes: Sequence[Path], out_dir: str | Path, *, jobs: int | None = None,
                timeout: float | None = None, say: Say | None = None,
                engine: str | None = None, model: str | Path | None = None,
                on_done: Callable[[int, int, str, str], None] | None = None,
                workers: int | None = None, scheduler: str | None = None, executor=None,
                plot: bool = True, reuse: bool = False, keep: bool = False) -> list[SceneOutcome]:
    """Run ``scenes``, each into ``out_dir/<scene>/``, as tasks of one executor
    (`autocable.executor`: ``executor`` if given, else a LocalCluster of ``workers`` processes --
    ``jobs`` is the older name -- default one per core, 0 for this process alone, or the cluster
    of ``scheduler``), the most expensive first (`expected_cost`); copy the figures to
    ``out_dir``; write ``figures.json`` (in the order of ``scenes``, with the scenes computed more
    than once because a worker was lost). A scene still running after ``timeout`` seconds is
    stopped and reported failed. ``engine`` overrides every scene's continuation engine ("pycont" |
    "compiled", `autocable.scene.runner.run_scene`); ``model`` runs every scene on that model spec
    instead of the one the scene names; ``plot=False`` skips the figures. ``on_done(done, total,
    name, status)`` is called as each scene finishes (a progress bar).

    With ``reuse``, a scene whose inputs (`autocable.paper.reuse.scene_inputs`: its files, the
    overrides, autocable's code, the libraries) are those of a scene stored in the cache is not
    computed: its stored files are published into ``out_dir/<scene>/`` (run.json says so under
    ``reused``). With ``keep``, every scene this run computes is stored (not the scenes of a
    ``scheduler``'s workers, whose code may not be this process's), and only when the worker that
    computed it ran the code its key names (`autocable.paper.reuse.store`). When the cluster has no
    live worker for the executor's ``no_worker_timeout``, the unfinished scenes are marked failed
    (error.txt, run.json), figures.json is written and `autocable.executor.NoLiveWorker` raised.
    Without the folder's lock: `run_figures` takes it."""
    from autocable.executor import Executor, NoLiveWorker, attempts, time_left
    out = Path(out_dir)
    stopped: list = []
    out.mkdir(parents=True, exist_ok=True)
    from autocable.run_folder import reclaim
    for path in scenes:
        # a folder of this run's scene that lost its run.json (a stopped run) is ours, as for
        # figures_folder: without this its run refuses the files an earlier run of it wrote
        reclaim(out / Path(path).stem, Path(path).stem)
    tell = say or (lambda msg: None)
    if workers is None:
        workers = jobs
    recorded = recorded_wall_times()
    pending = sorted(scenes, key=lambda p: expected_cost(p, recorded), reverse=True)
    outcomes: dict[str, SceneOutcome] = {}
    total = len(pending)
    model_arg = None if model is None else str(Path(model).resolve())
    t_start = time.perf_counter()
    keys: dict[str, dict] = {}
    if reuse or keep:
        pending, keys, reused = _reuse_stored(pending, out, model_arg, engine, plot, reuse, tell)
        for o in reused:
            outcomes[o.name] = o
            tell(f"[{len(outcomes)}/{total}] {o.name}: reused (computed {o.reused}, with the same inputs)")
            if on_done is not None:
                on_done(len(outcomes), total, o.name, "reused")
        keep = keep and not scheduler
    n_reused, t_compute = len(outcomes), time.perf_counter()
    # On a cold cache, scenes of one group (`cold_group`) started side by side each derive and
    # compile the same things (the first run of all figures spent 8 s of its 39 s computing the
    # natural-ordering AME's functions twice, in Figs. 4a and 4b at once). The most expensive
    # scene of each group whose scenes have no recorded time (the recorded times live in the
    # cache: none means it is cold) goes first; the others wait until it is done, while the
    # other groups' scenes run. A warm cache runs every scene at once.
    held: dict[str, list[Path]] = {}
    leaders: dict[tuple, str] = {}
    first: list[Path] = []
    for path in pending:
        key = None if path.stem in recorded else cold_group(path, model_arg, engine)
        if key is None or key not in leaders:
            if key is not None:
                leaders[key] = path.stem
            first.append(path)
        else:
            held.setdefault(leaders[key], []).append(path)
    rank_of = {p.stem: rank for rank, p in enumerate(pending)}
    # a leader outranks every scene queued after another leader: the longest cold scenes start first
    boost = {name: total for name in leaders.values()}
    journal = out / TASKS_JOURNAL
    if not pending and executor is None:
        executor = _NoTasks()       # every scene reused: no cluster to start
        owned = False
    elif executor is None:
        if workers is None and scheduler is None and len(scenes) <= 1:
            workers = 0      # one scene: no cluster to start, it still runs in its own child process
        elif workers and not scheduler:
            workers = min(workers, max(len(scenes), 1))
        elif workers is None and not scheduler:
            workers = min(os.cpu_count() or 1, max(len(scenes), 1))
        executor = Executor(workers, scheduler, warm=_preload if len(scenes) > 1 else None, journal=journal,
                            strict_priority=True)
        owned = True
    else:
        owned = False
    paths = {}
    try:
        if owned:
            executor.__enter__()
        def submit(path: Path) -> None:
            name = path.stem
            folder = out / name
            paths[name] = path
            # The scene's run marks its folder incomplete before it computes and publishes its files
            # at the end (`autocable.run_folder.output_folder`); the error file is ours to clear.
            (folder / ERROR_TXT).unlink(missing_ok=True)
            executor.submit(f"scene:{name}", scene_task, str(Path(path).resolve()), str(folder.resolve()), engine,
                            model_arg, plot, timeout, priority=total - rank_of[name] + boost.get(name, 0))
            tell(f"{name}: queued ({path.name})")

        for path in first:
            submit(path)
        for leader, followers in held.items():
            tell(f"{', '.join(p.stem for p in followers)}: after {leader} (the same model and amplitude "
                 f"equations, not yet in the cache)")
        stopped.clear()

        def until_stopped():
            try:
                yield from executor.completed()
            except NoLiveWorker as exc:      # the cluster has no worker left: no scene stays "running"
                stopped.append(exc)

        for done in until_stopped():
            name = done.label.split(":", 1)[1]
            path = paths[name]
            if done.ok:
                status, error, detail, wall = done.value
            else:
                status, error, detail, wall = "failed", f"{path}: {done.error}", "", time.perf_counter() - t_start
            folder = out / name
            if status != "ok":
                _error_file(folder, error, detail)
                files = []
            else:
                stale = folder / ERROR_TXT
                if stale.exists():
                    stale.unlink()
                files = _collect(name, folder, out)
                if keep and name in keys:
                    from autocable.paper.reuse import scene_inputs, store
                    # stored only if no input changed while the scene ran (an edited model, say)
                    now = scene_inputs(path, model_arg, engine, plot)
                    if now == keys[name]:
                        store(keys[name], folder, wall, ran=done.code)    # the code the worker ran
                    else:
                        from autocable._store import report_not_stored
                        changed = sorted(k for k in keys[name] if (now or {}).get(k) != keys[name][k])
                        what = {"code": "autocable's code", "files": "a file it reads"}
                        report_not_stored(f"the results of scene {name}", " and ".join(
                            what.get(k, k) for k in changed) + " changed while it was computed")
            outcomes[name] = SceneOutcome(name, str(path), status, wall, error, files)
            n = len(outcomes)
            left = time_left(n - n_reused, total - n_reused, time.perf_counter() - t_compute)
            tell(f"[{n}/{total}] {name}: {'done' if status == 'ok' else 'FAILED'} in {wall:.1f} s"
                 + (f": {error}" if error else "") + (f" ({left})" if left else ""))
            if on_done is not None:
                on_done(n, total, name, status)
            for path in held.pop(name, ()):     # its group is in the cache now (or failed: then each computes)
                submit(path)
        if stopped:
            unfinished = [p for p in scenes if p.stem not in outcomes]
            _mark_unfinished(out, [p.stem for p in unfinished], str(stopped[0]))
            for p in unfinished:
                outcomes[p.stem] = SceneOutcome(p.stem, str(p), "failed", 0.0, str(stopped[0]))
    finally:
        where = dict(executor.where)
        if owned:
            executor.close()
    ordered = [outcomes[p.stem] for p in scenes]
    counts = attempts(journal) if owned else {}
    recomputed = {k.split(":", 1)[1]: n - 1 for k, n in counts.items() if n > 1}
    if recomputed:
        tell(f"figures: {sum(recomputed.values())} scene(s) computed again after a worker was lost: "
             f"{', '.join(sorted(recomputed))}")
    from autocable._store import atomic_write_json
    recorded = recorded_wall_times()
    recorded.update({o.name: round(o.wall_s, 3) for o in ordered if o.status == "ok" and not o.reused})
    try:
        atomic_write_json(_timings_file(), recorded)
    except OSError:
        pass    # a shared read-only cache: the times only order the next run's scenes
    n_workers = where.get("workers") or where.get("workers_seen") or 1
    atomic_write_json(out / SUMMARY_JSON, {"format": "autocable.paper.figures/2", "where": where, "jobs": n_workers,
                                           "recomputed": recomputed,
                                           "scenes": [asdict(o) for o in ordered]})
    if stopped:
        raise stopped[0]        # one line naming --scheduler, exit status 3 (figures.json says which scenes)
    return ordered


# ================================================================================================
# command line
# ================================================================================================
def add_figures_parser(subparsers) -> None:
    """``autocable figures --out DIR [--runs DIR] [--only a,b] [--quick] [--workers N] [--scheduler A] [--quiet]``."""
    f = subparsers.add_parser("figures", help="run every figure scene (runs/fig*.toml) in parallel, "
                                              "collect figNN.png/.pdf and write report.md")
    f.add_argument("--out", required=True, help="output folder: figNN.png/.pdf, <scene>/ data, report.md")
    f.add_argument("--runs", help="folder of the scene files fig*.toml (default: the repository's runs/)")
    f.add_argument("--only", help="comma-separated scene names, e.g. fig05a,fig06")
    f.add_argument("--quick", action="store_true", help=f"the quick subset: {', '.join(QUICK)}")
    f.add_argument("--workers", type=int, help="Dask worker processes of a LocalCluster, one scene at a time "
                                               "each (default: one per core; 0: in this process, one "
                                               "scene after the other)")
    f.add_argument("--jobs", type=int, dest="workers", help=argparse.SUPPRESS)    # the older name of --workers
    f.add_argument("--scheduler", metavar="ADDRESS", help="run the scenes on an existing Dask cluster: its "
                   "scheduler's address (tcp://host:8786) or scheduler file (its workers need autocable "
                   "installed and this folder's paths)")
    f.add_argument("--timeout", type=float, help="stop a scene after this many seconds (default: none)")
    f.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    f.add_argument("--model", help="run every scene on this model spec instead of the one each scene names "
                                   "(e.g. a candidate of `autocable calibrate`)")
    f.add_argument("--targets", help="the targets file report.md decides (default: <model>.targets.toml "
                                     "beside the scenes' model)")
    f.add_argument("--engine", choices=("pycont", "compiled"),
                   help="override every scene's engine of equilibria, switching and cycles from Hopf points")
    f.add_argument("--recompute", action="store_true",
                   help="compute every scene, even one whose results are stored in the cache from a run with "
                        "the same inputs (scene, model, options, autocable's code and libraries); by default "
                        "those are reused")
    f.set_defaults(func=cmd_figures)


#: The thread-count variables of the BLAS/OpenMP libraries numpy and scipy load.
BLAS_THREAD_VARS = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def blas_thread_env(jobs: int, cores: int, environ, numpy_loaded: bool) -> dict[str, str]:
    """The BLAS thread counts to set before ``jobs`` scene processes share ``cores``: cores // jobs
    threads each, for every variable the user has not set; nothing when numpy is already loaded
    (OpenBLAS reads its count when it loads) or when each process has every core anyway.

    Why: every scene process's OpenBLAS otherwise starts a thread per core, and two processes on
    two cores then fight over them in the many small eigenvalue and solve calls of the
    continuation (measured: warm `autocable figures` 14.4-14.7 s with the default, 12.2-12.4 s
    with one thread per process)."""
    per = max(1, cores // max(1, jobs))
    if numpy_loaded or per >= cores:
        return {}
    return {v: str(per) for v in BLAS_THREAD_VARS if v not in environ}


def _where_text(out: Path) -> str:
    """Where the scenes ran, from figures.json: "2 workers", "serial", "scheduler tcp://...". """
    from autocable._store import read_json
    where = (read_json(out / SUMMARY_JSON) or {}).get("where") or {}
    mode = where.get("mode")
    if mode == "scheduler":
        return f"on the scheduler {where.get('address')}, {where.get('workers_seen', '?')} workers"
    if mode == "reused":
        return "every scene reused from the cache: none computed"
    if mode == "LocalCluster":
        return f"{where.get('workers')} worker processes"
    return "in this process, one at a time"


def cmd_figures(args) -> int:
    """Run the scenes, write report.md, print the summary; exit status 3 (`EXIT_FAILED`: what was
    computed is kept) if any scene failed."""
    from autocable.executor import check_workers
    check_workers("--workers", args.workers)           # 0: this process, one scene after the other
    if args.scheduler is not None:
        from autocable.executor import check_scheduler
        check_scheduler(args.scheduler)
    # Before anything imports numpy: on the serial path this process forks the scene processes
    # after loading it (a LocalCluster's workers get one BLAS thread each from Dask's nanny).
    os.environ.update(blas_thread_env(int(args.workers or os.cpu_count() or 1), os.cpu_count() or 1, os.environ,
                                      "numpy" in sys.modules))
    from autocable.paper.report_md import write_report
    if args.timeout is not None and not 0 < args.timeout < float("inf"):   # also refuses nan
        raise SpecError("--timeout", "", f"expected a positive number of seconds, got {args.timeout}")
    if not str(args.out).strip():
        raise SpecError("--out", "", "an empty path; give the output folder")
    only = [s.strip() for s in args.only.split(",") if s.strip()] if args.only else []
    scenes = discover(Path(args.runs) if args.runs else default_runs_dir(), only, args.quick)
    model = getattr(args, "model", None)
    targets = getattr(args, "targets", None)
    if model is not None:
        from autocable.spec import load_model
        load_model(model)                   # a bad model: one line before any scene starts
    if targets is not None:
        from autocable.paper.targets import load_targets
        load_targets(targets)
    out = Path(args.out)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise SpecError("arguments", "--out", f"cannot make the folder {out}: {exc.strerror or exc}; give a "
                                              "folder that can be created") from None
    if not os.access(out, os.W_OK | os.X_OK):
        raise SpecError("arguments", "--out", f"cannot write into {out} (read-only or not permitted); give a "
                                              "writable folder")
    from autocable.progress import BarProgress, progress_for
    bar = progress_for("figures", len(scenes), quiet=args.quiet, count=True)
    if isinstance(bar, BarProgress):
        # a terminal: the bar, and only the failures as lines
        def say(msg):
            if "FAILED" in msg:
                print(msg, file=sys.stderr, flush=True)

        def on_done(done, total, name, status):
            bar.update(done, f"{name} {status}")
    else:
        # a log or a pipe: one line per scene started and finished
        say = None if args.quiet else (lambda msg: print(msg, file=sys.stderr, flush=True))
        on_done = None
    t0 = time.perf_counter()
    try:
        with figures_folder(out, [p.stem for p in scenes]):     # one writer: scenes, figures.json, report.md
            outcomes = run_figures_in(scenes, out, workers=args.workers, scheduler=args.scheduler,
                                      timeout=args.timeout, say=say,
                                      engine=getattr(args, "engine", None), model=model, on_done=on_done,
                                      reuse=not getattr(args, "recompute", False), keep=True)
            wall = time.perf_counter() - t0
            report = write_report(out, targets)
    finally:
        if isinstance(bar, BarProgress):
            bar.close()
    failed = [o for o in outcomes if o.status != "ok"]
    if not args.quiet:
        print(f"{len(outcomes) - len(failed)} of {len(outcomes)} scenes done in {wall:.1f} s "
              f"({_where_text(out)}); report: {report}")
        for o in outcomes:
            print(f"  {o.name:<8} {o.status:<6} {o.wall_s:7.1f} s  "
                  + (", ".join(o.files) if o.status == "ok" else o.error)
                  + (f"  (reused: computed {o.reused})" if o.reused else ""))
        n_reused = sum(1 for o in outcomes if o.reused)
        if n_reused:
            print(f"{n_reused} scene(s) reused from the cache, computed earlier with the same inputs; "
                  f"--recompute computes them again")
    else:
        for o in failed:
            print(f"autocable: {o.name} failed: {o.error}", file=sys.stderr)
    return EXIT_FAILED if failed else 0
