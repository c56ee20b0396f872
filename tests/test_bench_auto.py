"""autocable.bench.auto: the generated equation file evaluated numerically, the constants file,
the fort.7 reader, a missing AUTO environment (a one-line "skipped"), and the cross-check itself:
the special points and branch values of the 2-dof AME (Figs. 5a and 6) against AUTO-07p.

The equation file is checked twice: by a small interpreter of its assignments here (always), and,
when gfortran is on PATH, by compiling FUNC into a tiny program and reading what it prints.

The cross-check needs AUTO-07p: a Python with bifpy (``python -m venv .venv-auto &&
.venv-auto/bin/pip install bifpy==0.3.0``, gfortran and make on PATH) named by the environment
variable AUTOCABLE_AUTO_PYTHON (`autocable.bench.auto.AUTO_PYTHON_ENV`). .ci/run sets it up, and
in CI (CI=true) a missing AUTO fails these tests instead of skipping them.
"""
from __future__ import annotations

import importlib.util
import math
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from autocable.bench.auto import (AUTO_PYTHON_ENV, PAR_LAM, PAR_SPAN, PAR_XSCALE, SIGMA_RANGE,
                                  auto_constants, auto_problem, auto_python_path, auto_settings,
                                  bench_auto, parse_fort7, parse_total_time, run_auto)
from autocable.methods.continuation import ContinuationSettings, System

x, y, U, eta, sigma = sp.symbols("x y U eta sigma")
# "U" as a parameter name (as in the AME) collides with AUTO's array U in case-insensitive Fortran;
# the long float needs 17 digits to survive printing.
TINY = System("tiny", ("x", "y"),
              (sigma * x - x ** 3 + U * y / (2 + sigma) + sp.Float(0.12345678901234567) * eta,
               -y + eta * x * y - sp.Rational(1, 3) * y ** 3 + sp.sqrt(1 + x ** 2) * sigma),
              (("sigma", 0.0), ("U", 0.0), ("eta", 0.0)))
XSCALE, SPAN, LAM = 0.3, 0.1, 0.37
BASE = {"sigma": -0.05, "U": 0.7, "eta": 1.4e-3}
STATE = np.array([0.8, -1.3])                  # scaled: x = XSCALE * STATE


def _pars(problem):
    pars = problem.start_pars(BASE, XSCALE, SPAN)
    pars[PAR_LAM] = LAM
    return pars


def _expected():
    p = TINY.parameter_vector({**BASE, "sigma": BASE["sigma"] + SPAN * LAM})
    xs = XSCALE * STATE
    return TINY.f(xs, p) / XSCALE, TINY.jac(xs, p), TINY.jac_p(xs, p)[:, 0] * SPAN / XSCALE


def _func_statements(source: str) -> list[str]:
    body = source[source.index("SUBROUTINE FUNC"):source.index("END SUBROUTINE FUNC")]
    text = re.sub(r"&\s*\n\s*", "", body)                      # join free-form continuations
    out = []
    for line in text.splitlines()[1:]:
        line = line.split("!")[0].strip()
        if not line or line.upper().startswith(("IMPLICIT", "INTEGER", "DOUBLE PRECISION")):
            continue
        out.append(line)
    return out


def _run_func(source: str, u, par: dict, ijac: int) -> dict:
    """Execute FUNC's assignments in Python: U(i) -> U[i], 1.5d-3 -> 1.5e-3, RETURN on IJAC."""
    env = {"U": {i + 1: float(v) for i, v in enumerate(u)}, "PAR": dict(par), "IJAC": ijac,
           "sqrt": math.sqrt, "exp": math.exp, "log": math.log, "sin": math.sin, "cos": math.cos}
    out = {}
    for st in _func_statements(source):
        m = re.fullmatch(r"IF \(IJAC \.EQ\. (\d)\) RETURN", st)
        if m:
            if ijac == int(m.group(1)):
                break
            continue
        target, expr = (s.strip() for s in st.split("=", 1))
        expr = re.sub(r"(\d)[dD]([+-]?\d+)", r"\1e\2", expr)
        expr = re.sub(r"\b(U|PAR)\((\d+)\)", r"\1[\2]", expr)
        value = eval(expr, {"__builtins__": {}}, env)            # noqa: S307 - our own generated text
        if "(" in target:
            out[target.replace(" ", "")] = value
        else:
            env[target] = value
    return out


def test_equation_file_evaluates_to_the_system_in_the_chart():
    prob = auto_problem(TINY, "sigma")
    f, J, Jl = _expected()
    got = _run_func(prob.source, STATE, _pars(prob), ijac=2)
    np.testing.assert_allclose([got[f"F({i})"] for i in (1, 2)], f, rtol=1e-14, atol=1e-15)
    np.testing.assert_allclose([[got[f"DFDU({i},{j})"] for j in (1, 2)] for i in (1, 2)], J, rtol=1e-14)
    np.testing.assert_allclose([got[f"DFDP({i},1)"] for i in (1, 2)], Jl, rtol=1e-14)
    # AUTO's IJAC contract: IJAC = 0 residual only, IJAC = 1 no parameter derivatives.
    assert not any(k.startswith("DFD") for k in _run_func(prob.source, STATE, _pars(prob), ijac=0))
    assert not any(k.startswith("DFDP") for k in _run_func(prob.source, STATE, _pars(prob), ijac=1))


def test_equation_file_text():
    prob = auto_problem(TINY, "sigma")
    src = prob.source
    for sub in ("FUNC", "STPNT", "BCND", "ICND", "FOPT", "PVLS"):
        assert f"SUBROUTINE {sub}" in src and f"END SUBROUTINE {sub}" in src
    lit = re.search(r"(0\.1234567890123456\d*)d0", src)    # 17 digits, a Fortran double ...
    assert lit and float(lit.group(1)) == 0.12345678901234567  # ... that reads back exactly
    assert not re.search(r"(?<![\w.])\d+/\d+(?![\w.])", src)  # no integer division
    assert "P2 = PAR(5)  ! U" in src                         # the parameter U is not the array U
    assert prob.npar == 6 and prob.par_index("eta") == 6
    with pytest.raises(ValueError, match="not a parameter"):
        auto_problem(TINY, "mu")


@pytest.mark.skipif(shutil.which("gfortran") is None, reason="gfortran not on PATH")
def test_equation_file_compiles_and_computes(tmp_path):
    prob = auto_problem(TINY, "sigma")
    pars = _pars(prob)
    main = "\n".join([
        "PROGRAM T", "IMPLICIT NONE",
        "DOUBLE PRECISION :: U(2), PAR(6), F(2), DFDU(2,2), DFDP(2,6)", "INTEGER :: ICP(1)",
        f"U = (/ {STATE[0]!r}D0, {STATE[1]!r}D0 /)",
        "PAR = (/ " + ", ".join(f"{pars[i]!r}".replace("e", "D") + ("" if "e" in f"{pars[i]!r}" else "D0")
                                for i in range(1, 7)) + " /)",
        "ICP(1) = 1", "DFDP = 0D0",
        "CALL FUNC(2, U, ICP, PAR, 2, F, DFDU, DFDP)",
        "WRITE(*,'(8ES25.16E3)') F, DFDU(1,1), DFDU(2,1), DFDU(1,2), DFDU(2,2), DFDP(1,1), DFDP(2,1)",
        "END PROGRAM T", ""])
    (tmp_path / "model.f90").write_text(prob.source)
    (tmp_path / "main.f90").write_text(main)
    subprocess.run(["gfortran", "-o", "t", "main.f90", "model.f90"], cwd=tmp_path, check=True,
                   capture_output=True)
    vals = [float(v) for v in subprocess.run([str(tmp_path / "t")], capture_output=True, text=True,
                                             check=True).stdout.split()]
    f, J, Jl = _expected()
    np.testing.assert_allclose(vals, [*f, *J.T.ravel(), *Jl], rtol=1e-13, atol=1e-15)


def test_constants_file():
    prob = auto_problem(TINY, "sigma")
    s = auto_settings(prob, (0.0, 1.0), ds=5e-3, dsmin=1e-7, dsmax=2e-2, nmx=2000, itnw=6,
                      epsl=1e-10, epsu=1e-10, epss=1e-8)
    text = auto_constants(prob, s, [0.1, 1 / 3], prob.start_pars(BASE, XSCALE, SPAN), uzr=[0.25])
    lines = dict(ln.split(" = ", 1) for ln in text.splitlines())
    assert lines["IPS"] == "1" and lines["ICP"] == "[1]" and lines["NDIM"] == "2" and lines["NPAR"] == "6"
    assert float(lines["DSMAX"]) == 2e-2 and float(lines["EPSS"]) == 1e-8 and lines["JAC"] == "1"
    assert lines["UZR"] == "{1: [0.25]}"
    u = eval(lines["U"])                                                 # noqa: S307
    assert u == {1: 0.1, 2: 1 / 3}                                       # exact round trip
    par = eval(lines["PAR"])                                             # noqa: S307
    assert par[PAR_LAM] == 0.0 and par[PAR_XSCALE] == XSCALE and par[PAR_SPAN] == SPAN
    assert par[prob.par_index("U")] == 0.7 and par[prob.par_index("sigma")] == -0.05
    with pytest.raises(ValueError):
        auto_constants(prob, s, [0.1], {})


FORT7 = """\
   0    PT  TY  LAB    PAR(1)           L2-NORM            U(1)               U(2)
   1    -1   9    1   0.0000000000E+000  1.0000000000E+000  6.0000000000E-001  8.0000000000E-001
   1    -2   4    0   1.0000000000E-002  1.1000000000E+000  7.0000000000E-001  8.5000000000E-001
   1     3   1    2   2.0000000000E-002  1.2000000000E+000  8.0000000000E-001  9.0000000000E-001
   1     4   2    3   3.0000000000E-002  1.3000000000E+000  9.0000000000E-001  9.5000000000E-001
   1     5  -4    4   4.0000000000E-002  1.4000000000E+000  1.0000000000E+000  1.0000000000E+000
   1     6   9    5   5.0000000000E-002  1.5000000000E+000  1.1000000000E+000  1.0500000000E+000
"""


def test_fort7_and_total_time():
    rows = parse_fort7(FORT7, 2)
    assert [r.type for r in rows] == ["EP", "RG", "BP", "LP", "UZ", "EP"]
    assert [r.stable for r in rows] == [True, True, False, False, False, False]
    assert rows[2].lam == 0.02 and rows[2].u == (0.8, 0.9) and rows[3].label == 3
    assert parse_total_time("\n Total Time    0.112E-02\n") == pytest.approx(1.12e-3)
    assert parse_total_time("no timing") is None


def test_missing_auto_environment_is_one_clear_line(monkeypatch, tmp_path):
    import autocable.bench.auto as ba
    monkeypatch.delenv(AUTO_PYTHON_ENV, raising=False)
    monkeypatch.setattr(ba, "_bifpy_here", lambda: False)
    r = bench_auto("models/luongo_zulli_2012.toml")
    assert set(r) == {"skipped"} and "\n" not in r["skipped"] and AUTO_PYTHON_ENV in r["skipped"]
    r = bench_auto("models/luongo_zulli_2012.toml", auto_python=str(tmp_path / "no-python"))
    assert set(r) == {"skipped"} and "\n" not in r["skipped"] and "not an executable" in r["skipped"]
    monkeypatch.setenv(AUTO_PYTHON_ENV, str(tmp_path / "no-python"))
    assert auto_python_path()[0] is None
    monkeypatch.delenv(AUTO_PYTHON_ENV)
    monkeypatch.setattr(ba, "_bifpy_here", lambda: True)               # bifpy in this Python
    assert auto_python_path() == (sys.executable, "")


@pytest.mark.skipif(importlib.util.find_spec("bifpy") is not None, reason="bifpy is installed here")
def test_python_without_bifpy_is_reported():
    r = run_auto(sys.executable, "", [])
    assert set(r) == {"error"} and "bifpy is not importable" in r["error"] and "\n" not in r["error"]


# ------------------------------------------------------------------------------------------------
# the cross-check against AUTO-07p itself (runs in CI: .ci/run builds AUTO-07p in its own venv)
SAMPLE = Path(__file__).resolve().parents[1] / "models" / "luongo_zulli_2012.toml"


def _in_ci() -> bool:
    return os.environ.get("CI", "").strip().lower() not in ("", "0", "false", "no")


def _auto_python_or_skip() -> str:
    """The AUTO Python (`auto_python_path`); outside CI its absence skips with the reason, in CI
    (CI=true) it fails, so the comparison can never be skipped silently there."""
    python, why = auto_python_path()
    if python is None:
        if _in_ci():
            pytest.fail(f"CI must run the AUTO-07p cross-check: {why}")
        pytest.skip(why)
    return python


@pytest.fixture(scope="module")
def against_auto():
    python = _auto_python_or_skip()
    r = bench_auto(str(SAMPLE), auto_python=python, repeats=1, interpreted=False)
    if "skipped" in r:
        if _in_ci():
            pytest.fail(f"CI must run the AUTO-07p cross-check: {r['skipped']}")
        pytest.skip(r["skipped"])
    return {c["case"]: c for c in r["cases"]}


# AUTO locates a special point to EPSS = test_tol in lam = (sigma - sigma0) / span (the same chart
# autocable uses), so the two sigma values of one point agree to test_tol * span.
SPECIAL_TOL = ContinuationSettings().test_tol * (SIGMA_RANGE[1] - SIGMA_RANGE[0])
# Both solve the same equations by Newton to tol = 1e-10 in the scaled coordinates (a1 is of the
# order of the scale): a1 at a fixed sigma agrees to 10 tol.
BRANCH_RTOL = 10 * ContinuationSettings().tol


@pytest.mark.parametrize("engine", ["autocable", "compiled"])
def test_fig6_special_points_match_auto_07p(against_auto, engine):
    """Fig. 6 (U = 0, eta = 1.4e-3): the 2-dof AME branch from sigma = -0.05 has two branch points
    (the pitchforks where the out-of-plane motion sets in and dies). AUTO-07p, PyCont (with
    autocable's analysis) and the compiled engine find the same ones: same types, sigma within
    AUTO's location tolerance, a1 within what that sigma error allows (|da1/dsigma| ~ a1 / 0.01
    near them: 1e-9 in sigma is ~1e-7 of a1)."""
    case = against_auto["fig6"]
    pairs = case["special_points"] if engine == "autocable" else case["compiled"]["special_points_vs_auto"]
    assert [p["type"] for p in pairs] == ["BP", "BP"], pairs          # none missing on either side
    for p in pairs:
        assert p["auto"] is not None and p["autocable"] is not None, p
        assert abs(p["difference"]) <= SPECIAL_TOL, p
        assert p["a1_relative_difference"] <= 1e-7, p
    assert pairs[0]["auto"] == pytest.approx(-0.02614, abs=1e-5)      # the branch's two pitchforks,
    assert pairs[1]["auto"] == pytest.approx(0.02294, abs=1e-5)       # AUTO's numbers (regression pin)


@pytest.mark.parametrize("label", ["fig6", "fig5a"])
def test_branch_values_match_auto_07p(against_auto, label):
    """a1 on the branch at sigma = -0.04, -0.02, 0, 0.02, 0.04 (AUTO's UZ points; autocable's by
    Newton at the same sigma from its branch): the same equilibria to the Newton tolerance, for
    PyCont and the compiled engine. Fig. 5a (eta = 8.2e-5) has no special point: its branch values
    are the comparison there."""
    case = against_auto[label]
    for checks in (case["a1_check"], case["compiled"]["a1_check"]):
        assert [round(c["sigma"], 6) for c in checks] == [-0.04, -0.02, 0.0, 0.02, 0.04]
        for c in checks:
            assert c["relative_difference"] is not None and c["relative_difference"] <= BRANCH_RTOL, c
    if label == "fig5a":
        assert case["special_points"] == [] and case["compiled"]["special_points_vs_auto"] == []
    # Both reach the end of the range.
    assert case["auto"]["end_sigma"] >= SIGMA_RANGE[1] - 1e-9
    assert case["autocable"]["end_sigma"] == pytest.approx(SIGMA_RANGE[1], abs=1e-12)
