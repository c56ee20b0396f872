"""What `autocable simulate` writes besides its result: progress that reads line by line in a log or
a pipe (a bar only on a terminal), a --csv history thinned by --every / --samples to a row count
and a time step that follow from the forcing period, a hint to raise --max-time when a response
near the threshold has not settled, and --plot's files."""
import io
import math

import pytest

from autocable.cli import main
from conftest import SAMPLE


def run_cli(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def test_progress_off_a_terminal_is_whole_lines(capsys):
    """stderr captured (not a terminal): no carriage return, one line per tenth of --max-time at
    most and a last one, each naming the command."""
    code, out, err = run_cli(capsys, "simulate", SAMPLE, "--U", "0.95", "--eta", "8.2e-5", "--sigma", "0.02",
                             "--max-time", "3000")
    assert code == 0
    assert "\r" not in err
    lines = [ln for ln in err.splitlines() if ln.startswith("simulate:")]
    assert 2 <= len(lines) <= 11
    assert lines[-1].startswith("simulate: done")
    assert [ln.split()[1] for ln in lines[:-1]] == sorted({ln.split()[1] for ln in lines[:-1]}, key=lambda p: int(p))


def test_progress_on_a_terminal_is_a_bar():
    from autocable.progress import BarProgress, LineProgress, progress_for

    class Tty(io.StringIO):
        def isatty(self):
            return True

    tty, log = Tty(), io.StringIO()
    bar = progress_for("simulate", 100.0, stream=tty)
    assert isinstance(bar, BarProgress)
    bar.update(50.0, "t* = 50")
    bar.close("done")
    assert "simulate" in tty.getvalue()
    lines = progress_for("simulate", 100.0, stream=log)
    assert isinstance(lines, LineProgress)
    for t in range(0, 101, 5):
        lines.update(float(t))
    lines.close()
    assert log.getvalue().count("\n") == 11 and "\r" not in log.getvalue()
    assert type(progress_for("x", 1.0, quiet=True, stream=tty)).__name__ == "_Silent"


def _rows(path):
    lines = path.read_text().splitlines()
    assert lines[0] == "t,q1,q2,q1dot,q2dot"
    return [[float(v) for v in ln.split(",")] for ln in lines[1:]]


def test_csv_every_and_samples_thin_the_history(capsys, tmp_path):
    """64 samples per forcing period: --every 7 keeps ceil(n / 7) rows of the n that --every 1
    writes, 7 forcing-period sixty-fourths apart (Omega = omega1 + sigma, from the JSON); --samples
    N at most N rows."""
    base = ("simulate", SAMPLE, "--eta", "8.2e-5", "--sigma", "0.02", "--max-time", "1500", "--quiet")
    code, out, _ = run_cli(capsys, *base, "--csv", tmp_path / "all.csv", "--every", "1", "--json")
    assert code == 0
    import json
    Omega = json.loads(out)["Omega"]
    full = _rows(tmp_path / "all.csv")
    n = len(full)
    assert n > 1000
    assert run_cli(capsys, *base, "--csv", tmp_path / "e7.csv", "--every", "7")[0] == 0
    thin = _rows(tmp_path / "e7.csv")
    assert len(thin) == math.ceil(n / 7)
    step = 7 * 2 * math.pi / Omega / 64
    assert thin[1][0] - thin[0][0] == pytest.approx(step, rel=1e-6)
    assert thin[3] == full[21]
    assert run_cli(capsys, *base, "--csv", tmp_path / "s.csv", "--samples", "100")[0] == 0
    assert 50 <= len(_rows(tmp_path / "s.csv")) <= 100
    # the default caps the rows at 50,000 (this history is shorter: every row kept)
    assert run_cli(capsys, *base, "--csv", tmp_path / "d.csv")[0] == 0
    assert len(_rows(tmp_path / "d.csv")) == n


@pytest.mark.parametrize("argv, option", [
    (["--csv", "x.csv", "--every", "0"], "--every"),
    (["--csv", "x.csv", "--every", "2", "--samples", "10"], "--every"),
    (["--every", "2"], "--every"),
    (["--plot", "p", "--method", "ame"], "--plot"),
])
def test_thinning_and_plot_options_are_checked(capsys, tmp_path, monkeypatch, argv, option):
    monkeypatch.chdir(tmp_path)
    code, _, err = run_cli(capsys, "simulate", SAMPLE, *argv)
    assert code == 2 and option in err and len(err.strip().splitlines()) == 1


def test_unsettled_response_near_the_threshold_gets_the_max_time_hint(capsys):
    code, out, err = run_cli(capsys, "simulate", SAMPLE, "--U", "0.95", "--eta", "8.2e-5", "--sigma", "0.02",
                             "--max-time", "600", "--quiet")
    assert code == 0 and "not steady" in out
    assert "raise --max-time" in err and "near the galloping threshold" in err and "--max-time 2400" in err
    # a settled response gets none
    code, out, err = run_cli(capsys, "simulate", SAMPLE, "--eta", "8.2e-5", "--sigma", "0.02", "--quiet")
    assert "steady" in out and "hint" not in err


def test_simulate_plot_writes_png_and_pdf(capsys, tmp_path):
    code, _, err = run_cli(capsys, "simulate", SAMPLE, "--eta", "8.2e-5", "--sigma", "0.02", "--max-time", "1500",
                           "--plot", tmp_path / "fh_U0_eta8.2e-5", "--units", "si")
    assert code == 0
    assert (tmp_path / "fh_U0_eta8.2e-5.png").stat().st_size > 0
    assert (tmp_path / "fh_U0_eta8.2e-5.pdf").read_bytes()[:5] == b"%PDF-"
