"""Everything autocable needs to run PyDSTool 0.91 on Python 3.11: the only compatibility code.

PyDSTool's last release predates Python 3.10 and misbehaves in five ways this module contains
(docs/pydstool_notes.md has the details and the measurements):

* it imports the ``parser`` and ``symbol`` modules, removed in Python 3.10: `import_pydstool`
  registers stand-ins;
* its compiled builds fail in any folder whose path contains a dot (e.g. ``~/.cache``):
  `build_generator_library` works around it, and gives numpy.distutils the options
  (`BUILD_OPTIONS`) that spare each build its probe of CPU features PyDSTool never dispatches to;
* it writes build artefacts (``dop853_temp/``, ``radau5_temp/``, ``auto_temp/``, ``build/``,
  ``fort.*``, ``*.so``) into the current directory and imports them from there: `build_dir` is the
  one place in autocable that changes directory;
* it talks: compiler banners, SWIG, ``print()`` from PyCont ("Test function going crazy"):
  `quiet` silences it at the file-descriptor level and keeps the text for error messages;
* it fails with raw tracebacks from deep inside its numerics: `pydstool_errors` turns them into one
  `PyDSToolError` with a one-line message;
* it re-parses every state and parameter name on every right-hand side and Jacobian call that
  PyCont makes: `memoize_name_map` gives a generator a name map that parses each name once.

Nothing here patches site-packages. fd-level redirection and ``os.chdir`` are process-wide, so
these helpers are not thread-safe; PyDSTool itself is not either.
"""
from __future__ import annotations

import atexit
import contextlib
import functools
import logging
import numbers
import ctypes
import os
import sys
import tempfile
import types
import warnings
from pathlib import Path
from typing import Iterator

from autocable._store import atomic_write_text
from autocable.errors import CacheError

__all__ = [
    "PyDSToolError",
    "Chatter",
    "import_pydstool",
    "quiet",
    "build_dir",
    "pydstool_errors",
    "pydstool_session",
    "build_generator_library",
    "memoize_name_map",
]

#: Environment variable that lets PyDSTool's chatter through `quiet` (for developers).
DEBUG_ENV = "AUTOCABLE_DEBUG"
#: How many characters of captured chatter an error keeps.
TAIL_CHARS = 2000


class PyDSToolError(RuntimeError):
    """A failure inside PyDSTool or PyCont, reported in one line.

    ``what`` says what autocable was doing, ``chatter`` holds the tail of what PyDSTool and the
    compiler printed meanwhile (often the real reason, e.g. a gcc error), and ``__cause__`` keeps
    the original exception for developers.
    """

    def __init__(self, message: str, *, what: str = "", chatter: str = ""):
        super().__init__(message)
        self.what = what
        self.chatter = chatter


# --------------------------------------------------------------------------------------------
# import

def _parser_expr(source, *args, **kwargs):
    raise PyDSToolError(
        "PyDSTool tried to parse an expression with the removed 'parser' module "
        f"(source: {str(source)[:80]!r}); autocable's generated specs must not contain powers "
        "('**', '^', 'pow') - write them as products",
        what="parsing a PyDSTool expression",
    )


def _stand_in_modules() -> dict[str, types.ModuleType]:
    """Minimal replacements for the stdlib modules ``parser`` and ``symbol`` (gone in 3.10).

    PyDSTool's ``parseUtils`` reads ``symbol.sym_name`` at import, compares types against
    ``parser.STType`` and calls ``parser.expr`` only to rewrite powers and in its symbolic
    differentiation (``Diff``), neither of which autocable uses.
    """
    parser = types.ModuleType("parser", "autocable stand-in for the stdlib 'parser' module (removed in Python 3.10)")
    parser.STType = type("STType", (), {})  # never instantiated: isinstance checks are False
    parser.ParserError = SyntaxError
    parser.expr = _parser_expr
    parser.suite = _parser_expr
    parser.st2list = _parser_expr
    parser.st2tuple = _parser_expr
    symbol = types.ModuleType("symbol", "autocable stand-in for the stdlib 'symbol' module (removed in Python 3.10)")
    symbol.sym_name = {}
    return {"parser": parser, "symbol": symbol}


def import_pydstool() -> types.ModuleType:
    """Import and return the ``PyDSTool`` package (with ``PyCont``) on Python >= 3.10.

    Registers the stand-in ``parser``/``symbol`` modules only where ``sys.modules`` lacks them, and
    silences the DeprecationWarnings PyDSTool's old numpy aliases trigger at import. The real
    ``sys.__stdout__``/``__stderr__`` are put in place during the first import because PyDSTool
    binds ``sys.stdout`` at import time (``core.context_managers.RedirectStdout``) and later calls
    ``fileno()`` on it: a stream that a test harness or `quiet` closes afterwards would break every
    later build. Idempotent.
    """
    if "PyDSTool" in sys.modules and "PyDSTool.PyCont" in sys.modules:
        return sys.modules["PyDSTool"]
    if sys.version_info >= (3, 10):  # before that the real modules exist
        for name, module in _stand_in_modules().items():
            sys.modules.setdefault(name, module)
    saved = sys.stdout, sys.stderr
    if sys.__stdout__ is not None and sys.__stderr__ is not None:
        sys.stdout, sys.stderr = sys.__stdout__, sys.__stderr__
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DeprecationWarning)
            warnings.simplefilter("ignore", PendingDeprecationWarning)
            import PyDSTool
            import PyDSTool.PyCont  # noqa: F401  (loads ContClass and the bifurcation machinery)
    except Exception as exc:
        raise PyDSToolError(
            f"importing PyDSTool failed: {_one_line(exc)} (PyDSTool 0.91 needs numpy<1.24 and "
            "scipy<1.15; see install_requires in setup.cfg)", what="importing PyDSTool") from exc
    finally:
        sys.stdout, sys.stderr = saved
    return PyDSTool


# --------------------------------------------------------------------------------------------
# chatter

class Chatter:
    """What was written to fd 1/2 inside one `quiet` block (empty when ``AUTOCABLE_DEBUG=1``)."""

    def __init__(self, reader: int | None):
        self._reader = reader
        self._final: str | None = None

    @property
    def text(self) -> str:
        """Everything captured so far (C stdio buffers are flushed first)."""
        if self._final is not None:
            return self._final
        if self._reader is None:
            return ""
        _flush_all()
        size = os.fstat(self._reader).st_size
        return os.pread(self._reader, size, 0).decode("utf-8", errors="replace")

    def tail(self, chars: int = TAIL_CHARS) -> str:
        """The last ``chars`` characters of `text`, stripped."""
        return self.text[-chars:].strip()

    def _freeze(self) -> None:
        self._final = self.text


class _FdWriter:
    """A text stream that writes straight to a file descriptor and is never closed.

    Stands in for ``sys.stdout``/``sys.stderr`` inside `quiet`, so ``print()`` goes through the
    redirected fd even when a harness (pytest) has replaced ``sys.stdout`` with its own object.
    Anything that keeps a reference to it after `quiet` ends still writes somewhere valid.
    """

    encoding = "utf-8"
    errors = "replace"

    def __init__(self, fd: int):
        self._fd = fd

    def write(self, text: str) -> int:
        data = text.encode(self.encoding, self.errors)
        view = memoryview(data)
        while view:
            view = view[os.write(self._fd, view):]
        return len(text)

    def writelines(self, lines) -> None:
        for line in lines:
            self.write(line)

    def flush(self) -> None:
        pass

    def fileno(self) -> int:
        return self._fd

    def isatty(self) -> bool:
        return False

    def writable(self) -> bool:
        return True

    def readable(self) -> bool:
        return False

    @property
    def closed(self) -> bool:
        return False


def _libc():
    try:
        return ctypes.CDLL(None)
    except OSError:
        return None


def _flush_all() -> None:
    """Flush Python's and C's stdio buffers so nothing crosses a redirection boundary."""
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (AttributeError, ValueError, OSError):
            pass
    libc = _libc()
    if libc is not None:
        libc.fflush(None)


def _debug() -> bool:
    return os.environ.get(DEBUG_ENV, "").strip() not in ("", "0")


@contextlib.contextmanager
def quiet() -> Iterator[Chatter]:
    """Silence everything written to fd 1 and 2 (C, SWIG, compiler, ``print``) for the block.

    Yields a `Chatter` whose ``text`` holds what was written. Deprecation warnings (PyDSTool's
    numpy aliases, distutils, setuptools) are ignored inside. Both fds and ``sys.stdout``/
    ``sys.stderr`` are restored on exit, also on exceptions. With ``AUTOCABLE_DEBUG=1`` nothing is
    redirected. Nested use is fine (the inner block captures its own text).
    """
    if _debug():
        yield Chatter(None)
        return
    _flush_all()
    fd, path = tempfile.mkstemp(prefix="autocable-chatter-", suffix=".log")
    try:
        # O_APPEND: C stdio, Python and child processes (gcc) share one offset without clobbering.
        target = os.open(path, os.O_WRONLY | os.O_APPEND)
        reader = os.open(path, os.O_RDONLY)
    finally:
        os.close(fd)
        os.unlink(path)  # the open fds keep the data; nothing is left behind even after a crash
    saved_out, saved_err = os.dup(1), os.dup(2)
    saved_streams = sys.stdout, sys.stderr
    chatter = Chatter(reader)
    try:
        os.dup2(target, 1)
        os.dup2(target, 2)
        sys.stdout, sys.stderr = _FdWriter(1), _FdWriter(2)
        with warnings.catch_warnings():
            # PyDSTool's deprecated numpy aliases and distutils/setuptools' own deprecation notices
            # are chatter too (a harness like pytest would otherwise still report them).
            for category in (DeprecationWarning, PendingDeprecationWarning, FutureWarning):
                warnings.simplefilter("ignore", category)
            warnings.filterwarnings("ignore", message=r".*(deprecated|Deprecat).*")
            yield chatter
    finally:
        _flush_all()
        chatter._freeze()
        sys.stdout, sys.stderr = saved_streams
        os.dup2(saved_out, 1)
        os.dup2(saved_err, 2)
        for extra in (saved_out, saved_err, target, reader):
            os.close(extra)


# --------------------------------------------------------------------------------------------
# build folder

@contextlib.contextmanager
def build_dir(path: str | os.PathLike) -> Iterator[Path]:
    """Run the block inside ``path``, the folder where PyDSTool writes and imports its builds.

    Creates ``path``, changes into it, puts it first on ``sys.path`` (built extension modules are
    imported from there) and puts the running interpreter's ``bin`` folder first on ``PATH`` (so the
    ``swig`` installed from PyPI into the venv is found). CWD, ``sys.path`` and ``PATH`` are
    restored on exit, also on exceptions. The only ``os.chdir`` in autocable.
    """
    folder = Path(path).expanduser().resolve()
    if not folder.is_dir():     # an existing folder is only read (a read-only cache works warm)
        folder.mkdir(parents=True, exist_ok=True)
    old_cwd = os.getcwd()
    old_sys_path = list(sys.path)
    had_path, old_path = "PATH" in os.environ, os.environ.get("PATH", "")
    bindir = os.path.dirname(sys.executable)
    os.environ["PATH"] = os.pathsep.join([bindir, old_path]) if old_path else bindir
    sys.path.insert(0, str(folder))
    try:
        os.chdir(folder)
        yield folder
    finally:
        os.chdir(old_cwd)
        sys.path[:] = old_sys_path
        if had_path:
            os.environ["PATH"] = old_path
        else:
            os.environ.pop("PATH", None)


def build_generator_library(generator) -> None:
    """Compile a compiled-integrator generator (Dopri, Radau) made with ``nobuild=True``.

    Call it inside `build_dir`. PyDSTool names the extension module after the *absolute* path of
    its build folder (``<cwd>/dop853_temp._dop853_<name>_vf``) and numpy.distutils splits that
    name at every '.', so any folder whose path contains a dot (``~/.cache``, ``/home/j.doe``) gets
    its SWIG output and library written to a mangled path and the build fails. Handing PyDSTool the
    build folder relative to the current directory keeps the module name dot-free.
    """
    builder = generator._builder  # PyDSTool's build helper; created on first access
    builder.tempdir = os.path.relpath(builder.tempdir)
    _build_options(Path.cwd())
    generator.makeLib()


#: numpy.distutils' options for PyDSTool's builds, which distutils reads from ``setup.cfg`` in the
#: current directory. Without them every build probes the compiler for each CPU feature it could
#: dispatch to (AVX, AVX512, ...: about 40 test compiles, 4 s of a 6 s build), although PyDSTool's
#: sources have no dispatched code, and numpy.distutils keeps the answers only when its process
#: exits, so long-lived scene workers probe again on every build. The baseline (SSE-SSE3 on
#: x86-64) and with it the compile flags of PyDSTool's sources stay as they were.
BUILD_OPTIONS = "[build_ext]\ncpu_dispatch = none\n"


def _build_options(folder: Path) -> None:
    cfg = folder / "setup.cfg"
    try:
        if not cfg.is_file() or cfg.read_text(encoding="utf-8") != BUILD_OPTIONS:
            atomic_write_text(cfg, BUILD_OPTIONS)     # scene workers may build side by side
    except OSError:
        pass        # a read-only cache folder: the build probes as before


def memoize_name_map(generator) -> None:
    """Give ``generator`` a copy of its name map (``_FScompatibleNames``) that remembers each name.

    Why. A PyDSTool generator maps every state and parameter name through a ``symbolMapClass`` on
    each ``Rhs`` and ``Jacobian`` call, and the map *parses* each name string with PyDSTool's
    tokenizer: in one Fig. 5a EP-C run PyCont's calls made 58,384 parses, most of its time. What a
    string maps to depends only on the string and the lookup table, so a memo of the string case
    returns the same values (the table's own mutators clear it; tests/test_compat.py compares it
    with PyDSTool's map on strings, expressions, dicts and lists). Pickling or copying the map
    gives PyDSTool's plain class back."""
    current = generator._FScompatibleNames
    if getattr(type(current), "memoizes_names", False):
        return
    generator._FScompatibleNames = _memo_map_class(type(current))(current)


@functools.lru_cache(maxsize=None)
def _memo_map_class(base: type) -> type:
    """The memoising subclass of PyDSTool's ``symbolMapClass`` (made once per process: PyDSTool is
    imported lazily, so the class cannot be written at module level)."""

    class MemoNameMap(base):
        memoizes_names = True

        def __init__(self, symbolMap=None):
            super().__init__(symbolMap)
            self._memo = {}

        def __call__(self, arg):
            if isinstance(arg, str):
                try:
                    return self._memo[arg]
                except KeyError:
                    out = self._memo[arg] = base.__call__(self, arg)
                    return out
            if type(arg) is dict:
                # PyDSTool's own dict case, less its per-number copy and exception: keys and
                # values through self(...), a changed key moved (numbers map to themselves).
                res = dict(arg)
                for k, v in arg.items():
                    new_k = self(k)
                    res[new_k] = v if isinstance(v, numbers.Number) else self(v)
                    if k != new_k:
                        del res[k]
                return res
            # Other containers map their items through self(...): the string case again.
            return base.__call__(self, arg)

        def __setitem__(self, symbol, mappedsymbol):
            self._memo.clear()
            base.__setitem__(self, symbol, mappedsymbol)

        def __delitem__(self, symbol):
            self._memo.clear()
            base.__delitem__(self, symbol)

        def update(self, amap):
            self._memo.clear()
            base.update(self, amap)

        def __reduce__(self):
            return (base, (dict(self.lookupDict),))

    return MemoNameMap


# --------------------------------------------------------------------------------------------
# errors

def _one_line(exc: BaseException) -> str:
    text = str(exc).strip()
    if isinstance(exc, SystemExit):  # distutils' setup() exits with "error: command 'gcc' failed"
        text = str(exc.code).strip() if exc.code is not None else "build aborted"
    first = text.splitlines()[0].strip() if text else ""
    if len(first) > 200:
        first = first[:197] + "..."
    return f"{type(exc).__name__}: {first}" if first else type(exc).__name__


@contextlib.contextmanager
def pydstool_errors(what: str, chatter: Chatter | None = None) -> Iterator[None]:
    """Re-raise any failure in the block as `PyDSToolError` ("<what> failed: <reason>").

    ``what`` names the step in the user's words ("building the Dopri integrator for 'duffing'").
    ``chatter`` (from an enclosing `quiet`) supplies the text PyDSTool printed; its tail goes into
    the error's ``chatter`` attribute. `PyDSToolError` and `autocable.errors.CacheError` (an
    unwritable cache: the user's fix, not PyDSTool's failure) pass through unchanged,
    KeyboardInterrupt is never caught. distutils' SystemExit on a failed compile is converted too.
    """
    try:
        yield
    except (PyDSToolError, CacheError):
        raise
    except (Exception, SystemExit) as exc:
        tail = chatter.tail() if chatter is not None else ""
        message = f"{what} failed: {_one_line(exc)}"
        hint = _hint(tail)
        if hint:
            message += f" ({hint})"
        raise PyDSToolError(message, what=what, chatter=tail) from exc


def _hint(tail: str) -> str:
    """A short pointer to the likely cause found in the chatter, if a known pattern is there."""
    lowered = tail.lower()
    if "swig" in lowered and ("not found" in lowered or "no such file" in lowered):
        return "swig not found: install swig==4.2.1 into the venv"
    for line in tail.splitlines():
        if "error:" in line:
            return line.strip()[:160]
    return ""


@contextlib.contextmanager
def pydstool_session(what: str, folder: str | os.PathLike) -> Iterator[Chatter]:
    """`build_dir` + `quiet` + `pydstool_errors`: the way to run any PyDSTool call that may build.

    Use it around generator construction, first integration, and PyCont curves that compile AUTO
    (LC-C), e.g. ``with pydstool_session("continuing cycles", pydstool_cache()): cc.newCurve(...)``.
    """
    with build_dir(folder), _distutils_log_restored(), quiet() as chatter, \
            pydstool_errors(what, chatter), _compiler_opt_caches_written():
        yield chatter


@contextlib.contextmanager
def _compiler_opt_caches_written() -> Iterator[None]:
    """Write numpy.distutils' compiler-option caches at the end of the build, not at exit.

    A numpy.distutils build makes a ``CCompilerOpt`` that writes its cache file from an ``atexit``
    hook. On a full disk that write fails after autocable has printed its own one-line message,
    and Python prints the hook's traceback at exit. Here the cache is written when the build ends,
    inside `quiet` (a cache that cannot be written is simply not kept: it only saves probing the
    compiler next time), and the hook is taken off (``atexit.unregister``; numpy is not modified).
    """
    try:
        yield
    finally:
        module = sys.modules.get("numpy.distutils.ccompiler_opt")
        for opt in list(getattr(module, "_share_cache", {}).values()) if module is not None else []:
            flush = getattr(opt, "cache_flush", None)
            if flush is None:
                continue
            atexit.unregister(flush)
            try:
                flush()
            except OSError:
                pass


@contextlib.contextmanager
def _distutils_log_restored() -> Iterator[None]:
    """Restore numpy.distutils' log threshold after a build.

    PyDSTool builds with ``--verbose``, which leaves the threshold at INFO; numpy.distutils then
    prints a compiler-optimisation report from an ``atexit`` hook, after every `quiet` has ended.
    Back at the default (WARN) that report is dropped.
    """
    log = sys.modules.get("numpy.distutils.log")
    before = log.get_threshold() if log is not None else None
    # A distutils build can also leave Python's root logger at DEBUG (then every library logs its
    # chatter, e.g. matplotlib's font search): put it back too.
    root = logging.getLogger()
    root_level = root.level
    try:
        yield
    finally:
        root.setLevel(root_level)
        log = sys.modules.get("numpy.distutils.log")
        if log is not None:
            log.set_threshold(before if before is not None else log.WARN, force=True)
