"""AUTO-07p as the reference for the per-point cost of equilibrium continuation.

What it measures. The 2-dof Cartesian AME of the sample model at U = 0 is continued in sigma over
[-0.05, 0.05] at eta = 1.4e-3 (the Fig. 6 setting) and eta = 8.2e-5 (Fig. 5a), once by autocable
(`continue_equilibria`: PyCont EP-C plus autocable's own analysis, timed separately) and once by
AUTO-07p (IPS = 1, the same start, the same step sizes and tolerances). Both see the same scaled
coordinates (the chart of `autocable.methods.continuation`: U(i) = x_i / xscale and
PAR(1) = lam = (sigma - sigma0) / span), so DS, DSMIN, DSMAX and the Newton tolerances mean the
same thing to both. The result gives per-point seconds for each, their ratio, and a cross-check:
the special points (BP, LP, HB) both report, and a1 at a few sigma on both branches.

How AUTO runs. This module is the AUTO backend: it writes a standard AUTO-07p equation file
(``FUNC`` with the exact Jacobian, ``STPNT``, stubs) from the sympy right-hand side with sympy's
Fortran printer, and a standard AUTO constants file (``fort.2``, keyword form, the start in its
``U``/``PAR`` keys). They are compiled with gfortran and linked against the AUTO-07p library of
the ``bifpy`` package (PyPI), which builds AUTO-07p with gfortran at install. bifpy wants its own
environment (numpy 2), so everything that touches it runs in a subprocess with a separate Python:
``auto_python``, else the environment variable ``AUTOCABLE_AUTO_PYTHON``, else this Python if
bifpy is installed in it (bifpy 0.3.0 also ran with autocable's numpy 1.23.5 / scipy 1.10.1 pins).
Without any the benchmark returns ``{"skipped": "<why>"}``. The executable is compiled once and run
``max(COMPILED_RUNS, repeats)`` times after a warm-up per case (as many as the compiled engine's
timed runs, both taken at their best); AUTO's per-point cost is its own "Total Time" (CPU time of
the continuation, printed by AUTO) over its steps; the wall time per point (a full run minus a 3-point run, so the
process start cancels) is reported beside it. Compilation and linking are reported separately.
For context the same problem is also run through bifpy's default path (``bifpy.auto.run``: AUTO
calling Python callbacks, lambdified from the same sympy expressions), per point likewise.

The same cases are also run by autocable's compiled engine (``engine="compiled"``,
`autocable.methods.continuation.compiled_equilibria`): the whole call per step, best of 20 runs after a warm-up
(`continuation_bench.time_compiled`, ``max(COMPILED_RUNS, repeats)`` runs), its special points and a1 against AUTO's, its ratio to AUTO
(``cases[i]["ratio_compiled_to_auto"]``, worst in ``compiled["ratio_to_auto_worst"]``), and the
kernel's one-time costs from scratch (``compiled["one_time"]``: emitting the C, gcc).

(PyDSTool spec strings are written by `autocable.codegen.pydstool` only; AUTO strings are a
separate backend and live here.)
"""
from __future__ import annotations

import json
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from types import MappingProxyType
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

import numpy as np
import sympy as sp

#: Environment variable naming the Python that has bifpy installed.
AUTO_PYTHON_ENV = "AUTOCABLE_AUTO_PYTHON"

#: The cases of the benchmark: (label, U, eta), sigma in SIGMA_RANGE.
CASES = (("fig6", 0.0, 1.4e-3), ("fig5a", 0.0, 8.2e-5))
SIGMA_RANGE = (-0.05, 0.05)
#: The compiled engine's goal: at most this many times AUTO-07p's cost per point, on every case.
COMPILED_TARGET = 0.5
#: Timed runs (at least) of the compiled engine and of the AUTO-07p executable, each at its best.
COMPILED_RUNS = 20
#: sigma values where a1 is compared (AUTO labels them as UZ points in a separate, untimed run).
CHECK_SIGMAS = (-0.04, -0.02, 0.0, 0.02, 0.04)

#: AUTO-07p's point types (fort.7 column TY, mod 10; UZ is -4).
AUTO_TYPES = {1: "BP", 2: "LP", 3: "HB", 4: "RG", -4: "UZ", 9: "EP", -9: "MX"}

#: PAR layout of the generated problem: PAR(1) = lam, PAR(2) = xscale, PAR(3) = span of the
#: continued parameter, PAR(FIRST_PHYSICAL + j) = base value of the system's parameter j.
PAR_LAM, PAR_XSCALE, PAR_SPAN, FIRST_PHYSICAL = 1, 2, 3, 4

Log = Callable[[str], None]


# ================================================================================================
# the AUTO problem: equation file and constants file (pure: sympy and text only)
# ================================================================================================
def _fortran_floats(expr):
    """Every Float with 17 significant digits, so that sympy's printer writes literals that read
    back as the same doubles (its default prints 15)."""
    return expr.xreplace({f: sp.Float(f, 17) for f in expr.atoms(sp.Float)})


def _assign(target: str, expr) -> list[str]:
    text = sp.fcode(_fortran_floats(sp.sympify(expr)), assign_to=target, source_format="free",
                    standard=95)
    return [ln for ln in text.splitlines() if ln.strip()]


def _declare(names: Sequence[str], per_line: int = 12) -> list[str]:
    out = []
    for i in range(0, len(names), per_line):
        out.append("DOUBLE PRECISION :: " + ", ".join(names[i:i + per_line]))
    return out


@dataclass(frozen=True, eq=False)
class AutoProblem:
    """An AUTO-07p equilibrium problem generated from a `System` for one continued parameter.

    ``source`` is the equation file (free-form Fortran). In it the state is U(i) = x_i / xscale and
    the parameters are p_j = PAR(FIRST_PHYSICAL + j), the continued one plus PAR(3) * PAR(1).
    ``chart`` holds the same F, DFDU and DFDP(:, 1) as sympy expressions in the symbols U1..Un,
    PAR1..PARnpar (for AUTO driven through Python callbacks)."""

    source: str
    variables: tuple[str, ...]
    parameter_names: tuple[str, ...]
    parameter: str
    npar: int
    chart: Mapping[str, Any]

    @property
    def ndim(self) -> int:
        return len(self.variables)

    def par_index(self, name: str) -> int:
        """1-based PAR index of a system parameter's base value."""
        return FIRST_PHYSICAL + self.parameter_names.index(name)

    def start_pars(self, values: Mapping[str, float], xscale: float, span: float) -> dict[int, float]:
        """PAR (1-based index -> value) at lam = 0 for the physical ``values``."""
        pars = {PAR_LAM: 0.0, PAR_XSCALE: float(xscale), PAR_SPAN: float(span)}
        for name in self.parameter_names:
            pars[self.par_index(name)] = float(values[name])
        return pars


def auto_problem(system, parameter: str) -> AutoProblem:
    """The equation file of ``system`` (an `autocable.methods.continuation.System`) for EP
    continuation in ``parameter``: ``FUNC`` with F, DFDU (IJAC >= 1) and DFDP(:, 1) (IJAC = 2,
    the derivative in PAR(1) = lam), a ``STPNT`` that sets nothing (the start comes from the
    constants file), and empty BCND/ICND/FOPT/PVLS."""
    names = tuple(system.variables)
    pnames = tuple(system.parameter_names)
    if parameter not in pnames:
        raise ValueError(f"{parameter!r} is not a parameter of {system.name!r} (it has {list(pnames)})")
    k = pnames.index(parameter)
    n, m = len(names), len(pnames)
    xs = [sp.Symbol(v) for v in names]
    ps = [sp.Symbol(p) for p in pnames]
    # Index-named Fortran locals: case-insensitive Fortran cannot tell "U" (a parameter of the
    # AME) from the array U, nor "u" from "U".
    X = [sp.Symbol(f"X{i + 1}") for i in range(n)]
    P = [sp.Symbol(f"P{j + 1}") for j in range(m)]
    ren = dict(zip(xs + ps, X + P))
    F = sp.Matrix([sp.sympify(e).xreplace(ren) for e in system.rhs])
    J = F.jacobian(X)
    Jl = F.diff(P[k])
    xscale, span = sp.Symbol("XSCALE"), sp.Symbol("SPAN")

    body = [f"XSCALE = PAR({PAR_XSCALE})", f"SPAN = PAR({PAR_SPAN})"]
    for j in range(m):
        line = f"P{j + 1} = PAR({FIRST_PHYSICAL + j})"
        if j == k:
            line += f" + SPAN*PAR({PAR_LAM})"
        body.append(line + f"  ! {pnames[j]}")
    for i in range(n):
        body.append(f"X{i + 1} = XSCALE*U({i + 1})  ! {names[i]}")
    temps: list[str] = []

    def block(exprs, targets, prefix):
        subs, red = sp.cse(list(exprs), symbols=sp.numbered_symbols(prefix), optimizations="basic")
        lines = []
        for s, e in subs:
            temps.append(s.name)
            lines += _assign(s.name, e)
        for t, e in zip(targets, red):
            lines += _assign(t, e)
        return lines

    f_exprs = [F[i] / xscale for i in range(n)]
    j_exprs = [J[i, j] for j in range(n) for i in range(n)]
    l_exprs = [Jl[i] * span / xscale for i in range(n)]
    body += block(f_exprs, [f"F({i + 1})" for i in range(n)], "WF")
    body.append("IF (IJAC .EQ. 0) RETURN")
    jlines = block(j_exprs + l_exprs, [f"DFDU({i + 1},{j + 1})" for j in range(n) for i in range(n)]
                   + [f"DFDP({i + 1},{PAR_LAM})" for i in range(n)], "WJ")
    # DFDP may be a one-element placeholder when IJAC = 1: write it only when IJAC = 2.
    cut = next(i for i, ln in enumerate(jlines) if ln.startswith("DFDP("))
    body += jlines[:cut] + ["IF (IJAC .EQ. 1) RETURN"] + jlines[cut:]

    locals_ = ["XSCALE", "SPAN"] + [s.name for s in X + P] + temps
    header = [
        f"! AUTO-07p equation file generated by autocable.bench.auto from system {system.name!r}.",
        f"! Continued parameter: {parameter} = PAR({FIRST_PHYSICAL + k}) + PAR({PAR_SPAN})*PAR({PAR_LAM}).",
        f"! U(i) = x_i / PAR({PAR_XSCALE}); x = ({', '.join(names)}).",
        "! " + ", ".join(f"PAR({FIRST_PHYSICAL + j}) = {p}" for j, p in enumerate(pnames)) + " at lam = 0.",
    ]
    src = header + [
        "SUBROUTINE FUNC(NDIM,U,ICP,PAR,IJAC,F,DFDU,DFDP)",
        "IMPLICIT NONE",
        "INTEGER, INTENT(IN) :: NDIM, ICP(*), IJAC",
        "DOUBLE PRECISION, INTENT(IN) :: U(NDIM), PAR(*)",
        "DOUBLE PRECISION, INTENT(OUT) :: F(NDIM)",
        "DOUBLE PRECISION, INTENT(INOUT) :: DFDU(NDIM,NDIM), DFDP(NDIM,*)",
        *_declare(locals_),
        *body,
        "END SUBROUTINE FUNC",
        "",
        "SUBROUTINE STPNT(NDIM,U,PAR,T)",
        "IMPLICIT NONE",
        "INTEGER, INTENT(IN) :: NDIM",
        "DOUBLE PRECISION, INTENT(INOUT) :: U(NDIM), PAR(*)",
        "DOUBLE PRECISION, INTENT(IN) :: T",
        "! The start (U, PAR) is given by the constants file.",
        "END SUBROUTINE STPNT",
        "",
        "SUBROUTINE BCND",
        "END SUBROUTINE BCND",
        "",
        "SUBROUTINE ICND",
        "END SUBROUTINE ICND",
        "",
        "SUBROUTINE FOPT",
        "END SUBROUTINE FOPT",
        "",
        "SUBROUTINE PVLS",
        "END SUBROUTINE PVLS",
    ]
    text = "\n".join(ln if ln.startswith("!") or not ln else "      " + ln for ln in src) + "\n"

    # The same chart for AUTO's Python-callback path: symbols U1.., PAR1.. (1-based, as in AUTO).
    npar = FIRST_PHYSICAL + m - 1
    Us = [sp.Symbol(f"U{i + 1}") for i in range(n)]
    PARs = [sp.Symbol(f"PAR{i + 1}") for i in range(npar)]
    to_chart = {xscale: PARs[PAR_XSCALE - 1], span: PARs[PAR_SPAN - 1]}
    to_chart.update({X[i]: PARs[PAR_XSCALE - 1] * Us[i] for i in range(n)})
    to_chart.update({P[j]: PARs[FIRST_PHYSICAL - 1 + j] + (PARs[PAR_SPAN - 1] * PARs[PAR_LAM - 1] if j == k else 0)
                     for j in range(m)})
    chart = {"f": [e.xreplace(to_chart) for e in f_exprs],
             "dfdu": [[J[i, j].xreplace(to_chart) for j in range(n)] for i in range(n)],
             "dfdp": [e.xreplace(to_chart) for e in l_exprs]}
    return AutoProblem(text, names, pnames, parameter, npar, MappingProxyType(chart))


def auto_settings(problem: AutoProblem, lam_range: tuple[float, float], *, ds: float, dsmin: float,
                  dsmax: float, nmx: int, itnw: int, epsl: float, epsu: float, epss: float,
                  jac: int = 1) -> dict[str, float]:
    """AUTO constants (bifpy's lower-case names) for EP continuation (IPS = 1) in PAR(1) over
    ``lam_range``: folds and branch points located (ILP = 1, ISP = 2), no branch switching
    (MXBF = 0), only special points written to fort.8 (NPR > NMX), no fort.9 diagnostics (IID = 0)."""
    return {"ndim": problem.ndim, "ips": 1, "ilp": 1, "ntst": 20, "ncol": 4, "iad": 3, "isp": 2,
            "iplt": 0, "nbc": 0, "nint": 0, "nmx": int(nmx), "npr": int(nmx) + 1, "mxbf": 0,
            "iid": 0, "itmx": 8, "itnw": int(itnw), "nwtn": 3, "jac": int(jac), "npar": problem.npar,
            "iads": 1, "ds": float(ds), "dsmin": float(dsmin), "dsmax": float(dsmax),
            "rl0": float(lam_range[0]), "rl1": float(lam_range[1]), "a0": 0.0, "a1": 1e30,
            "epsl": float(epsl), "epsu": float(epsu), "epss": float(epss)}


def auto_constants(problem: AutoProblem, settings: Mapping[str, float], start_u: Sequence[float],
                   start_pars: Mapping[int, float], *, uzr: Sequence[float] = ()) -> str:
    """A standard AUTO-07p constants file (``fort.2``, keyword form): ``settings`` (see
    `auto_settings`), ICP = [1], ISW = 1, the start in the ``U`` and ``PAR`` keys (AUTO applies
    them after STPNT), ``uzr``: values of PAR(1) to label (UZ points)."""
    if len(start_u) != problem.ndim:
        raise ValueError(f"start has {len(start_u)} entries, the system {problem.ndim}")
    lines = [f"{k.upper()} = {v!r}" for k, v in settings.items()]
    lines += ["ISW = 1", "ICP = [1]",
              "U = {" + ", ".join(f"{i + 1}: {float(u)!r}" for i, u in enumerate(start_u)) + "}",
              "PAR = {" + ", ".join(f"{i}: {float(v)!r}" for i, v in sorted(start_pars.items())) + "}"]
    if uzr:
        lines.append("UZR = {1: [" + ", ".join(repr(float(v)) for v in uzr) + "]}")
    return "\n".join(lines) + "\n"


@dataclass(frozen=True)
class Fort7Row:
    branch: int
    point: int          # AUTO's PT: negative = stable
    type: str           # BP, LP, HB, RG, UZ, EP, MX (or the number)
    label: int
    lam: float
    norm: float
    u: tuple[float, ...]

    @property
    def stable(self) -> bool:
        return self.point < 0


def parse_fort7(text: str, ndim: int) -> list[Fort7Row]:
    """The data rows of an AUTO-07p ``fort.7`` (one per continuation step; header lines, whose
    branch column is 0, are skipped)."""
    rows = []
    for line in text.splitlines():
        parts = line.split()
        if len(parts) < 6 + ndim:
            continue
        try:
            br, pt, ty, lab = (int(v) for v in parts[:4])
        except ValueError:
            continue
        if br == 0:
            continue
        vals = [float(v.replace("D", "E")) for v in parts[4:6 + ndim]]
        rows.append(Fort7Row(br, pt, AUTO_TYPES.get(ty if ty in AUTO_TYPES else ty % 10, str(ty)), lab,
                             vals[0], vals[1], tuple(vals[2:])))
    return rows


_TOTAL_TIME = re.compile(r"Total Time\s+([-+0-9.EeDd]+)")


def parse_total_time(stdout: str) -> float | None:
    """AUTO-07p's own "Total Time" line (CPU seconds of the run), or None."""
    m = _TOTAL_TIME.search(stdout)
    return float(m.group(1).replace("D", "E")) if m else None


# ================================================================================================
# the AUTO environment (a separate Python with bifpy) and the driver that runs there
# ================================================================================================
def _bifpy_here() -> bool:
    """Whether bifpy is installed in this Python (e.g. ``pip install autocable[auto]``)."""
    import importlib.util
    return importlib.util.find_spec("bifpy") is not None


def auto_python_path(auto_python: str | os.PathLike | None = None) -> tuple[str | None, str]:
    """(python, "") or (None, why): the Python that runs AUTO: ``auto_python``, else the
    environment variable AUTO_PYTHON_ENV, else this Python if bifpy is installed in it."""
    path = auto_python if auto_python is not None else os.environ.get(AUTO_PYTHON_ENV)
    if not path:
        if _bifpy_here():
            return sys.executable, ""
        return None, (f"no AUTO-07p environment: set {AUTO_PYTHON_ENV} (or pass auto_python) to a "
                      f"Python with bifpy installed (python -m venv <dir>; <dir>/bin/pip install "
                      f"bifpy; needs gfortran and make)")
    path = os.fspath(path)
    if shutil.which(path) is None:
        return None, f"no AUTO-07p environment: {AUTO_PYTHON_ENV} / auto_python {path!r} is not an executable"
    return path, ""


#: Runs in the AUTO Python (standard library, bifpy and bifpy's numpy/sympy). Reads a JSON request
#: on stdin, writes result.json into the request's work folder; a failure is {"error": "<one line>"}.
_DRIVER = r'''
import json, os, pathlib, re, shutil, subprocess, sys, time

req = json.load(sys.stdin)


def fail(msg):
    pathlib.Path(req["workdir"], "result.json").write_text(json.dumps({"error": " ".join(str(msg).split())}))
    sys.exit(0)


try:
    import bifpy.auto
    from importlib.metadata import version
    bifpy_version = version("bifpy")
except Exception as exc:
    fail(f"bifpy is not importable in {sys.executable}: {type(exc).__name__}: {exc}")
try:
    from bifpy.auto._process import _native_build_paths
    main_o, lib_a, inc = (str(p) for p in _native_build_paths())
except Exception:
    lib = pathlib.Path(bifpy.auto.__file__).parent / "_lib"
    main_o, lib_a, inc = str(lib / "main.o"), str(lib / "libbifpy.a"), str(lib / "include")
for p in (main_o, lib_a, inc):
    if not os.path.exists(p):
        fail(f"bifpy {bifpy_version} has no AUTO-07p build artefact {p} (this benchmark links "
             f"AUTO-07p's main.o and libbifpy.a as bifpy's transpile=True path does)")
fc = shutil.which("gfortran")
if fc is None:
    fail("gfortran is not on PATH (apt-get install gfortran)")
gver = subprocess.run([fc, "--version"], capture_output=True, text=True).stdout.splitlines()[:1]
work = pathlib.Path(req["workdir"])
(work / "model.f90").write_text(req["source"])
flags = req.get("fflags", [])
t = time.perf_counter()
c = subprocess.run([fc, *flags, "-c", "-I", inc, "-o", "model.o", "model.f90"], cwd=work,
                   capture_output=True, text=True)
t_compile = time.perf_counter() - t
if c.returncode:
    fail("gfortran could not compile the equation file: " + c.stderr.strip()[-400:])
t = time.perf_counter()
c = subprocess.run([fc, *flags, "-o", "model_exe", main_o, "model.o", lib_a], cwd=work,
                   capture_output=True, text=True)
t_link = time.perf_counter() - t
if c.returncode:
    fail("linking against bifpy's AUTO-07p library failed: " + c.stderr.strip()[-400:])
exe = str(work / "model_exe")
out = {"bifpy_version": bifpy_version, "gfortran": gver[0] if gver else "", "fflags": flags,
       "compile_s": t_compile, "link_s": t_link, "native": {}, "interpreted": {}}
for case in req["native"]:
    d = work / case["name"]
    d.mkdir(exist_ok=True)
    (d / "fort.2").write_text(case["fort2"])
    runs = []
    for i in range(int(case.get("runs", 1))):
        for f in ("fort.7", "fort.8", "fort.9"):
            (d / f).unlink(missing_ok=True)
        t = time.perf_counter()
        r = subprocess.run([exe], cwd=d, capture_output=True, text=True)
        wall = time.perf_counter() - t
        if r.returncode:
            fail(f"AUTO-07p exited with status {r.returncode} in case {case['name']}: "
                 + (r.stdout + r.stderr).strip()[-400:])
        m = re.search(r"Total Time\s+([-+0-9.EeDd]+)", r.stdout)
        runs.append({"wall_s": wall, "auto_s": float(m.group(1).replace("D", "E")) if m else None})
    out["native"][case["name"]] = {"runs": runs, "fort7": (d / "fort.7").read_text(),
                                   "stdout": r.stdout[-4000:]}

# The same problem through bifpy's default path: AUTO-07p calling Python callbacks (ctypes).
spec = req.get("interpreted")
if spec:
    import tempfile

    import numpy as np
    import sympy
    from bifpy import auto
    tempfile.tempdir = str(work)          # bifpy's own temporary folders go where ours are removed
    n, npar = int(spec["ndim"]), int(spec["npar"])
    U = sympy.symbols(f"U1:{n + 1}")
    P = sympy.symbols(f"PAR1:{npar + 1}")
    ch = spec["chart"]
    fn = sympy.lambdify((U, P), [sympy.sympify(e) for e in ch["f"]], modules="numpy", cse=True)
    jn = sympy.lambdify((U, P), [[sympy.sympify(e) for e in row] for row in ch["dfdu"]],
                        modules="numpy", cse=True)
    ln = sympy.lambdify((U, P), [sympy.sympify(e) for e in ch["dfdp"]], modules="numpy", cse=True)

    def func(state, parameters):
        return np.asarray(fn(state[:n], parameters[:npar]), dtype=float)

    def jac(state, parameters):
        return (np.asarray(jn(state[:n], parameters[:npar]), dtype=float),
                np.asarray(ln(state[:n], parameters[:npar]), dtype=float).reshape(n, 1))

    for case in spec["cases"]:
        u0 = [float(v) for v in case["u"]]
        p0 = {int(k): float(v) for k, v in case["par"].items()}

        def stpnt(state, parameters, t, u0=u0, p0=p0):
            for i, v in enumerate(u0):
                state[i] = v
            for k, v in p0.items():
                parameters[k - 1] = v

        walls, points = [], None
        for i in range(int(case.get("runs", 1))):
            t = time.perf_counter()
            try:
                res = auto.run(func, stpnt, case["settings"], icu=[1], jac=jac)
            except Exception as exc:
                fail(f"bifpy's auto.run failed in case {case['name']}: {type(exc).__name__}: {exc}")
            walls.append(time.perf_counter() - t)
            points = sum(len(b.points) for b in res.branches)
        out["interpreted"][case["name"]] = {"runs": walls, "points": points}
(work / "result.json").write_text(json.dumps(out))
'''


def run_auto(auto_python: str, source: str, native: Sequence[Mapping[str, Any]],
             interpreted: Mapping[str, Any] | None = None, *, fflags: Sequence[str] = ("-O2",),
             timeout: float = 900.0) -> dict:
    """In the AUTO Python: compile ``source`` once, run each ``native`` case (``name``, ``fort2``,
    ``runs``) with the compiled executable, then each ``interpreted`` case through bifpy's
    ``auto.run`` with Python callbacks. Returns the driver's result (``{"error": ...}`` on failure)."""
    with tempfile.TemporaryDirectory(prefix="autocable-auto-") as tmp:
        req = {"workdir": tmp, "source": source, "native": list(native), "fflags": list(fflags),
               "interpreted": dict(interpreted) if interpreted else None}
        try:
            done = subprocess.run([auto_python, "-c", _DRIVER], input=json.dumps(req),
                                  capture_output=True, text=True, timeout=timeout)
        except (OSError, subprocess.TimeoutExpired) as exc:
            return {"error": f"could not run {auto_python}: {type(exc).__name__}: {exc}"}
        result = Path(tmp, "result.json")
        if not result.exists():
            tail = (done.stderr.strip().splitlines() or ["no output"])[-1]
            return {"error": f"{auto_python} failed (status {done.returncode}): {tail}"}
        return json.loads(result.read_text())


# ================================================================================================
# the benchmark
# ================================================================================================
def _start_equilibrium(system, values: Mapping[str, float], scale: float) -> np.ndarray:
    """The equilibrium at the start: integrate from rest to its steady state (scipy LSODA, exact
    Jacobian), then polish with scipy's root finder."""
    from scipy.integrate import solve_ivp
    from scipy.optimize import root

    p = system.parameter_vector(values)
    x0 = np.zeros(system.dimension)
    rate = abs(np.trace(system.jac(x0, p))) / max(system.dimension, 1) or 1.0
    sol = solve_ivp(lambda t, x: system.f(x, p), (0.0, 40.0 / rate), x0, method="LSODA",
                    jac=lambda t, x: system.jac(x, p), rtol=1e-10, atol=1e-12 * scale)
    r = root(lambda x: system.f(x, p) / scale, sol.y[:, -1], jac=lambda x: system.jac(x, p) / scale,
             tol=1e-14)
    if not r.success or not np.all(np.isfinite(r.x)):
        raise RuntimeError(f"no start equilibrium at {dict(values)}: {r.message}")
    return r.x


def _autocable_a1_at(result, sigma: float) -> float | None:
    """a1 of autocable's branch at ``sigma`` (first crossing; Newton at fixed sigma from the
    interpolated point), or None if the branch does not reach it."""
    from autocable.methods.continuation import equilibrium_near

    br = result.branch
    sysm = result.problem.system
    s = np.asarray(br.table[br.parameter])
    X = np.column_stack([br.table[v] for v in br.variables])
    for i in range(len(s) - 1):
        if (s[i] - sigma) * (s[i + 1] - sigma) <= 0 and s[i] != s[i + 1]:
            w = (sigma - s[i]) / (s[i + 1] - s[i])
            p = sysm.parameter_vector({**result.problem.values, br.parameter: sigma})
            x, ok, _ = equilibrium_near(sysm, X[i] + w * (X[i + 1] - X[i]), p,
                                        scale=result.problem.state_scale)
            return float(sysm.amplitude_values(x)[0]) if ok else None
    return None


def _a1_difference(system, result, sigma: float, x_auto) -> dict:
    """Relative a1 difference between a result's branch and AUTO's point at ``sigma``."""
    a_auto = float(system.amplitude_values(x_auto)[0])
    a_ac = _autocable_a1_at(result, sigma)
    return {"sigma": sigma, "relative_difference": None if a_ac is None else abs(a_ac - a_auto) / abs(a_auto)}


def _stability_changes(sigma: Sequence[float], stable: Sequence[bool]) -> list[list[float]]:
    """[sigma_i, sigma_i+1] of consecutive points whose stability differs."""
    return [[float(sigma[i]), float(sigma[i + 1])] for i in range(len(stable) - 1)
            if bool(stable[i]) != bool(stable[i + 1])]


def _special_diffs(auto_sp: list[dict], ac_sp: list[dict], span: float) -> list[dict]:
    """Pair each AUTO special point with autocable's nearest of the same type."""
    out = []
    used = set()
    for a in auto_sp:
        cands = [(abs(c["value"] - a["value"]), j) for j, c in enumerate(ac_sp)
                 if c["type"] == a["type"] and j not in used]
        if not cands:
            out.append({"type": a["type"], "auto": a["value"], "autocable": None, "difference": None,
                        "a1_auto": a["a1"], "a1_autocable": None})
            continue
        d, j = min(cands)
        used.add(j)
        out.append({"type": a["type"], "auto": a["value"], "autocable": ac_sp[j]["value"],
                    "difference": ac_sp[j]["value"] - a["value"], "relative_to_range": d / span,
                    "a1_auto": a["a1"], "a1_autocable": ac_sp[j]["a1"],
                    "a1_relative_difference": abs(ac_sp[j]["a1"] - a["a1"]) / max(abs(a["a1"]), 1e-300)})
    for j, c in enumerate(ac_sp):
        if j not in used:
            out.append({"type": c["type"], "auto": None, "autocable": c["value"], "difference": None,
                        "a1_auto": None, "a1_autocable": c["a1"]})
    return out


def _marginal(full: Sequence[float], short: Sequence[float], n_full: int, n_short: int) -> float:
    """Seconds per point from the best full and best short run (fixed costs cancel)."""
    return (min(full) - min(short)) / max(n_full - n_short, 1)


def bench_auto(model_path: str, auto_python: str | None = None, repeats: int = 3,
               log: Log | None = None, interpreted: bool = True) -> dict:
    """Per-point cost of EP continuation: AUTO-07p (bifpy's build, compiled equations) against
    autocable (PyCont EP-C and autocable's analysis, separately), the special-point and a1
    cross-check, and (``interpreted``) AUTO-07p driven by bifpy's default Python callbacks.

    Returns ``{"skipped": "<why>"}`` when no AUTO Python is available (see `auto_python_path`)
    or AUTO could not be built or run there."""
    say = log or (lambda s: None)
    python, why = auto_python_path(auto_python)
    if python is None:
        return {"skipped": why}

    from autocable.codegen.ckernel import build_timing
    from autocable.methods.continuation import (ContinuationSettings, EquilibriumProblem,
                                                ame_system, auto_state_scale, continue_equilibria)
    from autocable.bench.continuation import time_compiled
    from autocable.model.ame_cache import derive_ame
    from autocable.model.derive import derive

    repeats = max(1, int(repeats))
    system = ame_system(derive_ame(derive(model_path)).ame, "2dof", wind=False)
    settings = ContinuationSettings()
    t = time.perf_counter()
    problem = auto_problem(system, "sigma")
    t_generate = time.perf_counter() - t
    lo, hi = SIGMA_RANGE
    span = hi - lo

    def lam(value):
        return (value - lo) / span

    consts = auto_settings(problem, (lam(lo), lam(hi)), ds=settings.step, dsmin=settings.min_step,
                           dsmax=settings.max_step, nmx=settings.max_points,
                           itnw=settings.max_corrector_iters, epsl=settings.tol, epsu=settings.tol,
                           epss=settings.test_tol)
    short = {**consts, "nmx": 3, "npr": 4}
    native, callbacks, prepared = [], [], {}
    for label, U, eta in CASES:
        values = {"sigma": lo, "U": U, "eta": eta}
        scale = auto_state_scale(system, {**values, "sigma": 0.0})
        x0 = _start_equilibrium(system, values, scale)
        prepared[label] = (values, scale, x0)
        u0, p0 = list(x0 / scale), problem.start_pars(values, scale, span)
        # The executable as often as the compiled engine below (best of as many runs each).
        runs = max(COMPILED_RUNS, repeats) + 1
        native += [{"name": label, "runs": runs, "fort2": auto_constants(problem, consts, u0, p0)},
                   {"name": label + "-short", "runs": runs,
                    "fort2": auto_constants(problem, short, u0, p0)},
                   {"name": label + "-uz", "runs": 1, "fort2": auto_constants(
                       problem, consts, u0, p0, uzr=[lam(v) for v in CHECK_SIGMAS])}]
        callbacks += [{"name": label, "settings": consts, "u": u0, "par": p0, "runs": repeats + 1},
                      {"name": label + "-short", "settings": short, "u": u0, "par": p0, "runs": repeats + 1}]
    spec = None
    if interpreted:
        spec = {"ndim": problem.ndim, "npar": problem.npar, "cases": callbacks,
                "chart": {"f": [sp.srepr(e) for e in problem.chart["f"]],
                          "dfdu": [[sp.srepr(e) for e in row] for row in problem.chart["dfdu"]],
                          "dfdp": [sp.srepr(e) for e in problem.chart["dfdp"]]}}
    say(f"AUTO-07p: compile and run in {python} ...")
    auto = run_auto(python, problem.source, native, spec)
    if "error" in auto:
        return {"skipped": f"AUTO-07p did not run: {auto['error']}"}
    say(f"  equation file compiled in {auto['compile_s']:.2f} s, linked in {auto['link_s']:.2f} s")

    cases = []
    for label, U, eta in CASES:
        values, scale, x0 = prepared[label]

        def phys(row):
            return float(lo + span * row.lam), np.asarray(row.u) * scale

        full, brief = auto["native"][label], auto["native"][label + "-short"]
        rows = parse_fort7(full["fort7"], problem.ndim)
        n_short = len(parse_fort7(brief["fort7"], problem.ndim))
        steps = max(len(rows) - 1, 1)
        cpu = [r["auto_s"] for r in full["runs"][1:]]                   # the first run is the warm-up
        auto_pp = min(cpu) / steps if all(c is not None for c in cpu) else math.nan
        marginal = _marginal([r["wall_s"] for r in full["runs"][1:]],
                             [r["wall_s"] for r in brief["runs"][1:]], len(rows), n_short)
        auto_special = []
        for row in rows:
            if row.type in ("BP", "LP", "HB"):
                value, x = phys(row)
                auto_special.append({"type": "H" if row.type == "HB" else row.type, "value": value,
                                     "a1": float(system.amplitude_values(x)[0])})
        uz = [phys(r) for r in parse_fort7(auto["native"][label + "-uz"]["fort7"], problem.ndim)
              if r.type == "UZ"]
        interp = None
        if auto.get("interpreted"):
            a, b = auto["interpreted"][label], auto["interpreted"][label + "-short"]
            interp = {"points": a["points"], "best_run_s": min(a["runs"][1:]),
                      "seconds_per_point": _marginal(a["runs"][1:], b["runs"][1:], a["points"], b["points"])}

        say(f"autocable: {label} (eta = {eta:g}), a warm-up and {repeats} timed runs ...")
        ep = EquilibriumProblem(system, "sigma", values, SIGMA_RANGE, state_scale=scale)
        continue_equilibria(ep, settings, start=x0, name="I", directions="forward")
        best = None
        for _ in range(repeats):
            r = continue_equilibria(ep, settings, start=x0, name="I", directions="forward")
            if best is None or r.timings["pycont_s"] < best.timings["pycont_s"]:
                best = r
        n_ac = int(best.timings["points"])
        pycont_pp = best.timings["pycont_s"] / max(n_ac - 1, 1)
        analysis_pp = best.timings["analysis_s"] / max(n_ac, 1)
        ac_special = [{"type": p.type, "value": float(p.value), "a1": float(p.a1)}
                      for p in best.branch.special_points if p.type in ("BP", "LP", "H")]
        checks = []
        for value, x in uz:
            a_auto = float(system.amplitude_values(x)[0])
            a_ac = _autocable_a1_at(best, value)
            checks.append({"sigma": value, "a1_auto": a_auto, "a1_autocable": a_ac,
                           "relative_difference": None if a_ac is None else abs(a_ac - a_auto) / abs(a_auto)})
        case = {
            "case": label, "U": U, "eta": eta, "state_scale": scale, "start_state": [float(v) for v in x0],
            "auto": {"points": len(rows), "end_sigma": phys(rows[-1])[0] if rows else math.nan,
                     "seconds_per_point": auto_pp, "total_cpu_s": min(cpu) if cpu else math.nan,
                     "runs_cpu_s": cpu, "wall_seconds_per_point": marginal,
                     "process_wall_s": min(r["wall_s"] for r in full["runs"][1:]),
                     "special_points": auto_special,
                     "stable_points": sum(r.stable for r in rows),
                     "stability_changes": _stability_changes([phys(r)[0] for r in rows],
                                                             [r.stable for r in rows])},
            "auto_python_callbacks": interp,
            "autocable": {"points": n_ac, "end_sigma": float(best.branch.ends[-1].value),
                          "pycont_seconds_per_point": pycont_pp,
                          "analysis_seconds_per_point": analysis_pp,
                          "seconds_per_point": pycont_pp + analysis_pp,
                          "pycont_s": best.timings["pycont_s"], "analysis_s": best.timings["analysis_s"],
                          "special_points": ac_special,
                          "stable_points": int(np.sum(best.branch.stable)),
                          "stability_changes": _stability_changes(best.branch.table["sigma"],
                                                                  best.branch.stable)},
            "ratio_pycont_to_auto": pycont_pp / auto_pp,
            "ratio_total_to_auto": (pycont_pp + analysis_pp) / auto_pp,
            "ratio_total_to_auto_python_callbacks":
                (pycont_pp + analysis_pp) / interp["seconds_per_point"] if interp else None,
            "special_points": _special_diffs(auto_special, ac_special, span),
            "a1_check": checks,
        }
        # The compiled engine (autocable.methods.continuation.compiled_equilibria): the whole call per step.
        comp = time_compiled(ep, settings, x0, repeats=max(COMPILED_RUNS, repeats))
        cres = comp.pop("result")
        c_special = [{"type": p.type, "value": float(p.value), "a1": float(p.a1)}
                     for p in cres.branch.special_points if p.type in ("BP", "LP", "H")]
        case["compiled"] = {
            **comp, "end_sigma": float(cres.branch.ends[-1].value), "special_points": c_special,
            "special_points_vs_auto": _special_diffs(auto_special, c_special, span),
            "stable_points": int(np.sum(cres.branch.stable)),
            "stability_changes": _stability_changes(cres.branch.table["sigma"], cres.branch.stable),
            "kernel_undecided_stability": cres.branch.info["kernel_undecided_stability"],
            "a1_check": [_a1_difference(system, cres, v, x) for v, x in uz]}
        case["ratio_compiled_to_auto"] = comp["seconds_per_point"] / auto_pp
        case["ratio_compiled_cpu_to_auto"] = comp["cpu_seconds_per_point"] / auto_pp
        cases.append(case)
        say(f"  compiled engine: {comp['seconds_per_point'] * 1e6:.1f} us/point wall, "
            f"{comp['cpu_seconds_per_point'] * 1e6:.1f} us/point CPU ({comp['points']} points): "
            f"{case['ratio_compiled_to_auto']:.2f}x AUTO")
        say(f"  AUTO {auto_pp * 1e3:.4f} ms/point ({len(rows)} points)"
            + (f", AUTO with Python callbacks {interp['seconds_per_point'] * 1e3:.3f} ms/point" if interp else "")
            + f"; autocable: PyCont {pycont_pp * 1e3:.2f} + analysis {analysis_pp * 1e3:.2f} ms/point "
              f"({n_ac} points): {case['ratio_total_to_auto']:.0f}x AUTO")
    worst = max(c["ratio_total_to_auto"] for c in cases)
    worst_c = max(c["ratio_compiled_to_auto"] for c in cases)
    say("compiled engine: one-time costs from scratch (emit C, gcc) ...")
    one_time = build_timing(system)
    return {
        "compiled": {"one_time": one_time, "ratio_to_auto_worst": worst_c,
                     "target": {"ratio_to_auto": COMPILED_TARGET, "met": bool(worst_c <= COMPILED_TARGET)},
                     "timing": "seconds_per_point: the whole continue_equilibria(engine='compiled') call "
                               "(start Newton, C loop with test functions, Routh counts and "
                               "eigenvalues of every point, special points located (C) and "
                               "classified, l1, Branch) over its steps, best of the timed runs "
                               "(wall); cpu_seconds_per_point the same in process CPU time"},
        "model": model_path, "system": system.name, "parameter": "sigma", "range": list(SIGMA_RANGE),
        "auto": {"python": python, "bifpy_version": auto.get("bifpy_version"),
                 "gfortran": auto.get("gfortran"), "equation_file_fflags": auto.get("fflags"),
                 "equation_file_generation_s": t_generate, "compile_s": auto["compile_s"],
                 "link_s": auto["link_s"], "constants": {k.upper(): v for k, v in consts.items()},
                 "timing": "seconds_per_point: AUTO's own Total Time (CPU) over its steps, best of "
                           "the timed runs; wall_seconds_per_point: process wall time, full run minus "
                           "a 3-point run, over the extra points"},
        "autocable_settings": {"step": settings.step, "min_step": settings.min_step,
                               "max_step": settings.max_step, "tol": settings.tol,
                               "test_tol": settings.test_tol,
                               "max_corrector_iters": settings.max_corrector_iters},
        "repeats": repeats, "cases": cases,
        "ratio_total_to_auto_worst": worst,
        "target": {"ratio_total_to_auto": 2.0, "met": bool(worst <= 2.0)},
    }
