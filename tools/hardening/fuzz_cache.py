"""Generated cases of the kind ``cache_edits``: autocable's code or a run's input edited while a
command that stores into the cache runs, then the command run again, and what it stores or serves
compared with a computation from an empty cache (docs/cache.md: "editing autocable while a run goes
on costs that run its stores, never a later run a stale result").

Each case runs real ``python -m autocable.cli`` processes on a private copy of the repository's
``autocable/``, ``models/`` and ``runs/`` (the copy first on PYTHONPATH, so the package finds its
models and scenes in the copy; the checkout is never edited) with a private ``AUTOCABLE_CACHE``:

1. the tree in its base state; the command started (``derive`` of the sample model with a fresh,
   empty cache, or ``figures --only fig03`` on a cache shared by the case's runs, with
   ``--recompute`` half the time and 0 or 1 LocalCluster worker); at a moment drawn in
   [0, ``window``] seconds one edit (`EDITS`) is applied, as an editor or ``git checkout`` writes a
   file (a new file renamed onto the old one): a code edit in a module the computation depends on or
   one it does not (a changed constant, the same change in the same number of bytes, a comment, a
   file touched without change) or an input edit (the model, the scene file, the targets file);
2. the tree restored or the edit kept (drawn), the command run again with the same cache: its result
   must equal the reference of the tree's state;
3. the tree put in the other state, the command run a third time: its result must equal that
   state's reference. Between them, runs 2 and 3 read every key the first run could have stored
   under (the code and inputs before and after the edit), so a result stored under a key whose code
   or inputs did not compute it is served by one of them and seen.

A reference is the command's result in a second private tree in that state with ``AUTOCABLE_CACHE``
an empty folder, computed once per (command, state) and kept for the run. Results compared:
``derive --json``'s output, byte for byte; a figure scene's data files (branches.csv,
special_points.csv, overlay_ame.csv, overlay.csv without its wall-clock column), each number to
1e-9 relative (a scene is deterministic; docs/cache.md).

Classes (the columns of `tools.hardening.fuzz_options`'s tables, and ``stale``): ok, traceback,
hang (a run past its time limit), wrong_exit_nonzero (a run that should have computed and did not),
stale (a result of runs 2 or 3 that is not its state's reference).
"""
from __future__ import annotations

import csv
import io
import math
import os
import random
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

__all__ = ["EDITS", "CLASSES", "Tree", "cache_case", "run_cache_edits"]

#: The columns of the table (`tools.hardening.fuzz_scheduler` shares them).
def budgeted_cases(n: int, cases, draw, started: float, budget_s: float | None):
    """(index, case) of ``cases`` (given) or of ``n`` drawn ones (``draw(i)``), none started after
    ``budget_s`` seconds from ``started`` (`time.perf_counter`): the loop of both generated kinds
    (this one and `tools.hardening.fuzz_scheduler`)."""
    for i in range(len(cases) if cases is not None else n):
        if budget_s is not None and time.perf_counter() - started > budget_s:
            return
        yield i, (cases[i] if cases is not None else draw(i))


CLASSES = ("ok", "refused_named", "failed", "traceback", "hang", "wrong_exit0", "wrong_exit_nonzero",
           "unnamed_refusal", "stale", "orphaned")

_REPO = Path(__file__).resolve().parents[2]
_MODEL = "models/luongo_zulli_2012.toml"


@dataclass(frozen=True)
class Edit:
    """A change to one file of the tree: ``old`` replaced by ``new`` (once), ``new`` appended
    (``old`` empty), or only the file's times changed (``touch``). ``changes``: the commands whose
    result the edit changes (an oracle of the edit itself, checked by the references)."""

    path: str
    old: str = ""
    new: str = ""
    touch: bool = False
    changes: tuple = ()


#: The edits a case draws from. "code" edits are in autocable/, "input" edits in models/, runs/.
EDITS = {
    # a constant of the derivation changed (the structural damping of eq. 21 doubled)
    "code:derive_damping": Edit("autocable/model/derive.py", "ode = project(st, modes, aero, K, nu, "
                                "spec.cable.damping_ratio, I,", "ode = project(st, modes, aero, K, nu, "
                                "2.0 * spec.cable.damping_ratio, I,", changes=("derive", "figures")),
    # the same change in the same number of bytes (a file whose size and mtime second may not change)
    "code:derive_damping_same_size": Edit("autocable/model/derive.py", " spec.cable.damping_ratio, I,",
                                          "2*spec.cable.damping_ratio,I,", changes=("derive", "figures")),
    # the CSV writer of the scenes' branches: the header upper-case (docs/cache.md's example)
    "code:results_header": Edit("autocable/results.py", "    w.writerow(header)\n    for row in rows:\n"
                                "        w.writerow([_fmt(x) for x in row])\n    return buf.getvalue()",
                                "    w.writerow([h.upper() for h in header])\n    for row in rows:\n"
                                "        w.writerow([_fmt(x) for x in row])\n    return buf.getvalue()",
                                changes=("figures",)),
    # (derive reports the key of its amplitude equations, which names autocable/model/'s code)
    "code:statics_comment": Edit("autocable/model/statics.py", new="\n# an edit that changes no number\n",
                                 changes=("derive",)),
    "code:plotting_comment": Edit("autocable/plotting/__init__.py", new="\n# an edit that changes no number\n"),
    "code:derive_touch": Edit("autocable/model/derive.py", touch=True),
    "code:results_touch": Edit("autocable/results.py", touch=True),
    "input:model_damping": Edit(_MODEL, "damping_ratio = 0.004 ", "damping_ratio = 0.005 ",
                                changes=("derive", "figures")),
    "input:model_comment": Edit(_MODEL, new="\n# a comment added to the model\n"),
    "input:model_touch": Edit(_MODEL, touch=True),
    "input:scene_points": Edit("runs/fig03.toml", "points = 12", "points = 9 ", changes=("figures",)),
    "input:scene_comment": Edit("runs/fig03.toml", new="\n# a comment added to the scene\n"),
    "input:targets_comment": Edit("models/luongo_zulli_2012.targets.toml", new="\n# a comment added\n"),
}


def _write(path: Path, data: bytes) -> None:
    """As an editor or git writes a file: a new file renamed onto the old one."""
    tmp = path.with_name(f".{path.name}.edit-{os.getpid()}")
    tmp.write_bytes(data)
    os.replace(tmp, path)


class Tree:
    """A private copy of the repository's autocable/, models/ and runs/ at ``root``, its files'
    original bytes kept to put any edit back."""

    def __init__(self, root: Path):
        self.root = Path(root)
        for name in ("autocable", "models", "runs"):
            shutil.copytree(_REPO / name, self.root / name, ignore=shutil.ignore_patterns("__pycache__", "_data"))
        self.original = {p: (self.root / p).read_bytes() for p in {e.path for e in EDITS.values()}}
        self.applied: str | None = None

    def apply(self, name: str) -> None:
        e = EDITS[name]
        p = self.root / e.path
        if e.touch:
            now = time.time()
            os.utime(p, (now, now))
        else:
            text = self.original[e.path].decode()
            if e.old:
                if e.old not in text:
                    raise RuntimeError(f"the edit {name} finds no {e.old!r} in {e.path}: update EDITS")
                text = text.replace(e.old, e.new, 1)
            else:
                text += e.new
            _write(p, text.encode())
        self.applied = name

    def restore(self) -> None:
        if self.applied is not None:
            e = EDITS[self.applied]
            if e.touch:
                now = time.time()
                os.utime(self.root / e.path, (now, now))
            else:
                _write(self.root / e.path, self.original[e.path])
            self.applied = None

    def set(self, state: str | None) -> None:
        """Put the tree in ``state`` (an edit's name, or None: the base)."""
        if state != self.applied:
            self.restore()
            if state is not None:
                self.apply(state)

    def env(self, cache: Path) -> dict:
        env = {k: v for k, v in os.environ.items() if not k.startswith("AUTOCABLE_")}
        env.update(PYTHONPATH=str(self.root), AUTOCABLE_CACHE=str(cache), PYTHONHASHSEED="0")
        return env


# ------------------------------------------------------------------------------------------------
# one command and its result
# ------------------------------------------------------------------------------------------------
@dataclass
class Run:
    exit: int | None           # None: killed at the time limit
    stderr: str
    result: object = None      # what is compared: derive's JSON text, or a scene's tables
    seconds: float = 0.0


def _argv(tree: "Tree", command: str, out: Path, recompute: bool, workers: int) -> list[str]:
    if command == "derive":
        return ["derive", str(tree.root / _MODEL), "--json"]
    return ["figures", "--only", "fig03", "--workers", str(workers), "--out", str(out), "--quiet"] + \
        (["--recompute"] if recompute else [])


def _start(tree: Tree, cache: Path, argv: list[str], cwd: Path) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "autocable.cli", *argv], cwd=cwd, env=tree.env(cache),
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)


def _finish(proc: subprocess.Popen, timeout: float, t0: float) -> tuple[int | None, str, str, float]:
    try:
        out, err = proc.communicate(timeout=timeout)
        code = proc.returncode
    except subprocess.TimeoutExpired:
        _kill_group(proc)
        out, err = proc.communicate()
        code = None
    return code, out, err, time.perf_counter() - t0


def _kill_group(proc: subprocess.Popen) -> None:
    import signal
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        pass


def _scene_tables(out: Path) -> dict:
    """The data files of the fig03 scene in ``out``, as {file: rows of cells} (overlay.csv without
    its wall-clock column); missing files as None."""
    tables = {}
    for name in ("branches.csv", "special_points.csv", "overlay_ame.csv", "overlay.csv"):
        p = out / "fig03" / name
        if not p.is_file():
            tables[name] = None
            continue
        rows = list(csv.reader(io.StringIO(p.read_text())))
        if name == "overlay.csv" and rows and "wall_seconds" in rows[0]:
            k = rows[0].index("wall_seconds")
            rows = [r[:k] + r[k + 1:] for r in rows]
        tables[name] = rows
    return tables


def _cells_differ(a: str, b: str) -> bool:
    if a == b:
        return False
    try:
        x, y = float(a), float(b)
    except ValueError:
        return True
    if math.isnan(x) and math.isnan(y):
        return False
    return not math.isclose(x, y, rel_tol=1e-9, abs_tol=1e-300)


def difference(a, b) -> str:
    """"" when the results ``a`` and ``b`` agree, else the first difference, short."""
    if isinstance(a, str) or isinstance(b, str):
        if a == b:
            return ""
        la, lb = str(a).splitlines(), str(b).splitlines()
        for i, (x, y) in enumerate(zip(la, lb)):
            if x != y:
                return f"line {i + 1}: {x.strip()[:70]!r} != {y.strip()[:70]!r}"
        return f"{len(la)} lines != {len(lb)} lines"
    for name in sorted(set(a) | set(b)):
        ra, rb = a.get(name), b.get(name)
        if ra is None or rb is None:
            if ra is not rb:
                return f"{name}: {'missing' if ra is None else 'present'} here, not in the reference"
            continue
        if len(ra) != len(rb):
            return f"{name}: {len(ra)} rows, the reference {len(rb)}"
        for i, (x, y) in enumerate(zip(ra, rb)):
            if len(x) != len(y) or any(_cells_differ(u, v) for u, v in zip(x, y)):
                return f"{name} row {i}: {','.join(x)[:80]!r} != {','.join(y)[:80]!r}"
    return ""


# ------------------------------------------------------------------------------------------------
# cases
# ------------------------------------------------------------------------------------------------
@dataclass
class CacheCase:
    command: str               # "derive" or "figures"
    edit: str                  # a key of EDITS
    delay: float               # seconds after the start of run 1
    keep: bool                 # run 2 with the edit kept (else restored; run 3 the other way)
    recompute: bool = False    # figures: --recompute in run 1
    workers: int = 0           # figures: --workers

    @property
    def label(self) -> str:
        extra = f" --workers {self.workers}{' --recompute' if self.recompute else ''}" if self.command == "figures" else ""
        return (f"{self.command}{extra}: {self.edit} at {self.delay:.2f} s, then "
                f"{'kept' if self.keep else 'restored'}")


#: Seconds after the start of run 1 in which the edit lands (about each command's wall time here:
#: its imports, the computation and the stores).
WINDOW = {"derive": 1.2, "figures": 6.0}
#: Time limits of one run (a run past it is a hang).
RUN_LIMIT = {"derive": 60.0, "figures": 240.0}


def cache_case(rng: random.Random, figures_share: float = 0.1) -> CacheCase:
    command = "figures" if rng.random() < figures_share else "derive"
    names = sorted(EDITS)
    edit = names[rng.randrange(len(names))]
    return CacheCase(command, edit, rng.uniform(0.0, WINDOW[command]), rng.random() < 0.5,
                     recompute=rng.random() < 0.5, workers=rng.randrange(2))


@dataclass
class Outcome:
    cls: str
    detail: str = ""
    edit_seen: bool = False    # a "not stored" line: the edit landed while the run computed
    seconds: float = 0.0
    runs: list = field(default_factory=list)


_TRACEBACK = "Traceback (most recent call last)"


class CacheHarness:
    """The trees, caches and references of one `run_cache_edits`."""

    def __init__(self, base: Path):
        self.base = Path(base)
        self.tree = Tree(self.base / "tree")
        self.ref_tree = Tree(self.base / "ref-tree")
        self.shared_cache = self.base / "cache-figures"
        self.refs: dict = {}
        self.ref_seconds: dict = {}
        self._n = 0

    def _folder(self, what: str) -> Path:
        self._n += 1
        p = self.base / f"{what}-{self._n}"
        p.mkdir(parents=True)
        return p

    def _run(self, tree: Tree, command: str, cache: Path, recompute=False, workers=0, edit_at=None,
             edit=None) -> Run:
        out = self._folder("out")
        t0 = time.perf_counter()
        proc = _start(tree, cache, _argv(tree, command, out, recompute, workers), out)
        if edit is not None:
            while time.perf_counter() - t0 < edit_at and proc.poll() is None:
                time.sleep(min(0.01, max(edit_at - (time.perf_counter() - t0), 0.0)))
            tree.apply(edit)
        code, stdout, stderr, secs = _finish(proc, RUN_LIMIT[command], t0)
        result = stdout if command == "derive" else _scene_tables(out)
        shutil.rmtree(out, ignore_errors=True)
        return Run(code, stderr, result, secs)

    def reference(self, command: str, state: str | None):
        """The result of ``command`` with the tree in ``state``, computed from an empty cache."""
        key = (command, state)
        if key not in self.refs:
            self.ref_tree.set(state)
            cache = self._folder("empty-cache")
            r = self._run(self.ref_tree, command, cache)
            shutil.rmtree(cache, ignore_errors=True)
            if r.exit != 0 or _TRACEBACK in r.stderr:
                raise RuntimeError(f"the reference of {command} in state {state} failed (exit {r.exit}): "
                                   f"{r.stderr.strip()[-400:]}")
            self.refs[key], self.ref_seconds[key] = r.result, r.seconds
        return self.refs[key]

    def check_edits(self) -> list[str]:
        """Edits whose oracle fails: an edit said to change a command's result that does not, or
        one said not to that does (the references are computed here)."""
        wrong = []
        for command in ("derive", "figures"):
            base = self.reference(command, None)
            for name, e in EDITS.items():
                changed = bool(difference(self.reference(command, name), base))
                if changed != (command in e.changes):
                    wrong.append(f"{name} {'changes' if changed else 'does not change'} {command}'s result")
        return wrong

    def run_case(self, case: CacheCase) -> Outcome:
        t0 = time.perf_counter()
        self.tree.set(None)
        if case.command == "derive":
            cache = self._folder("cache")        # empty: run 1 derives and stores
        else:
            cache = self.shared_cache            # the C builds stay; the scene's entry is what is at stake
        runs = []
        try:
            r1 = self._run(self.tree, case.command, cache, case.recompute, case.workers, case.delay, case.edit)
            runs.append(r1)
            order = [case.edit, None] if case.keep else [None, case.edit]
            for state in order:
                self.tree.set(state)
                runs.append(self._run(self.tree, case.command, cache, False, case.workers))
            seen = any("not stored" in r.stderr for r in runs)
            for i, r in enumerate(runs):
                if r.exit is None:
                    return Outcome("hang", f"run {i + 1} past {RUN_LIMIT[case.command]:g} s", seen)
                if _TRACEBACK in r.stderr:
                    return Outcome("traceback", f"run {i + 1}: {r.stderr.strip()[-300:]}", seen)
                if r.exit != 0:
                    return Outcome("wrong_exit_nonzero", f"run {i + 1} exit {r.exit}: {r.stderr.strip()[-300:]}",
                                   seen)
            for i, state in enumerate(order, 2):
                why = difference(runs[i - 1].result, self.reference(case.command, state))
                if why:
                    return Outcome("stale", f"run {i} ({'edited' if state else 'base'} tree): {why}", seen)
            return Outcome("ok", "", seen)
        finally:
            self.tree.set(None)
            if cache != self.shared_cache:
                shutil.rmtree(cache, ignore_errors=True)
            self._last_seconds = time.perf_counter() - t0


def run_cache_edits(n: int = 1000, seed: int = 0, base=None, log=None, figures_share: float = 0.1,
                    budget_s: float | None = None, cases: list | None = None) -> dict:
    """``n`` seeded `cache_case` cases, classified: {"table": {"cache_edits": {class: count}}, ...}
    with the seconds, the references' count and cost, how many edits landed while a run computed
    (a "not stored" line), and the first problems. ``budget_s``: no case starts after so many
    seconds (``cases`` then says how many ran). ``cases``: these `CacheCase` instead of ``n``
    drawn ones, with only the references they need (the edits' own oracle, `CacheHarness.check_edits`,
    is then not run)."""
    say = log or (lambda s: None)
    tmp = None
    if base is None:
        tmp = base = tempfile.mkdtemp(prefix="autocable-cache-edits-")
    row = dict.fromkeys(CLASSES, 0)
    examples, seen, per_command = [], 0, {"derive": [0, 0.0], "figures": [0, 0.0]}
    t0 = time.perf_counter()
    try:
        h = CacheHarness(Path(base))
        wrong_edits = h.check_edits() if cases is None else []
        if cases is not None:
            n = len(cases)
        if wrong_edits:
            raise RuntimeError("the edits' own oracle fails: " + "; ".join(wrong_edits))
        t_refs = time.perf_counter() - t0
        say(f"cache_edits: {len(h.refs)} references in {t_refs:.0f} s")
        t1 = time.perf_counter()
        done = 0
        for i, case in budgeted_cases(n, cases, lambda i: cache_case(random.Random(f"{seed}:cache_edits:{i}"),
                                                                     figures_share), t0, budget_s):
            done += 1
            o = h.run_case(case)
            row[o.cls] += 1
            seen += o.edit_seen
            per_command[case.command][0] += 1
            per_command[case.command][1] += h._last_seconds
            if o.cls != "ok":
                say(f"cache_edits case {i}: {o.cls}: {case.label}: {o.detail[:600]}")
                if len(examples) < 12:
                    examples.append({"class": o.cls, "case": case.label, "problem": o.detail[:400]})
            if (i + 1) % 50 == 0:
                say(f"cache_edits {i + 1}/{n} ({time.perf_counter() - t1:.0f} s) {row}")
        secs = time.perf_counter() - t1
    finally:
        if tmp:
            shutil.rmtree(tmp, ignore_errors=True)
    return {"seed": seed, "cases": done, "cases_asked": n, "table": {"cache_edits": row},
            "seconds": {"cache_edits": round(secs, 1), "references": round(t_refs, 1)},
            "seconds_per_case": {c: round(s / k, 2) for c, (k, s) in per_command.items() if k},
            "cases_per_command": {c: k for c, (k, s) in per_command.items()},
            "edits_seen_while_computing": seen, "references": len(h.refs), "examples": examples}
