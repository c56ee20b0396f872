"""`autocable onset`: its output folder is safe (a user's files are never overwritten, a second onset
is locked out, a killed onset's temporaries are cleared) and a wind speed past the model's premises
is said (U* beyond 2, above 100 m/s, Mach > 0.3) for the onset, --max-wind, --design-wind and the
rows of damping.csv. Run time: about 25 s on two busy cores (about 6 s of CPU)."""
import csv
import fcntl
import json
import os
from pathlib import Path

import pytest

ROOT = Path(__file__).parent.parent
SAMPLE = ROOT / "models" / "luongo_zulli_2012.toml"     # U_c = 36 m/s: 5 U_c reaches Mach 0.5


def _cli(capsys, *args):
    from autocable.cli import main
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


# -- premises ----------------------------------------------------------------------------------------
def test_wind_premises_closed_form():
    """Each premise at its bound: U* = 2 (simulate's warning), 100 m/s (the model files' bound),
    Mach 0.3 = 102.9 m/s in air at 20 deg C."""
    from autocable.model.premises import wind_premises, wind_warning
    assert wind_premises(50.0, 2.0) == [] and wind_warning("x", 50.0, 2.0) is None
    assert len(wind_premises(50.0, 2.0001)) == 1
    assert len(wind_premises(100.5, 1.0)) == 1                  # > 100 m/s, Mach 0.293
    assert len(wind_premises(103.0, 1.0)) == 2                  # Mach 0.3003 too
    assert "Mach 1.07" in wind_warning("the onset at", 367.7, 3.7)


def test_onset_past_the_premises_warns(capsys):
    """Damping 1 % with the fitted angle held moves the sample's onset to 90 m/s, U* = 2.5: warned on
    stderr and in JSON 'warnings'; at 0.5 % (45 m/s, U* = 1.25) no such warning."""
    code, out, err = _cli(capsys, "onset", SAMPLE, "--set", "cable.damping_ratio=0.01", "--json")
    assert code == 0
    rep = json.loads(out)
    assert rep["onsets"][0]["U_m_s"] == pytest.approx(90.0, rel=1e-6)
    w = [x for x in rep["warnings"] if "past the model's premises" in x]
    assert len(w) == 1 and "U* = U/U_c = 2.5 > 2" in w[0] and w[0] in err
    code, out, err = _cli(capsys, "onset", SAMPLE, "--set", "cable.damping_ratio=0.005", "--json")
    assert not [x for x in json.loads(out)["warnings"] if "premises" in x] and "premises" not in err


@pytest.mark.parametrize("option, value, words", [("--max-wind", 150.0, ["Mach 0.437", "above 100 m/s"]),
                                                  ("--design-wind", 80.0, ["U* = U/U_c = 2.22"])])
def test_wind_options_past_the_premises_warn(capsys, option, value, words):
    code, out, err = _cli(capsys, "onset", SAMPLE, option, value, "--json")
    assert code == 0
    w = [x for x in json.loads(out)["warnings"] if x.startswith(option)]
    assert len(w) == 1 and all(word in w[0] for word in words) and w[0] in err


def test_damping_rows_past_the_premises(tmp_path, capsys):
    """damping.csv: a row whose U_cr lies past the premises says why (column past_premises), the
    others leave it empty, and one warning counts them."""
    code, out, err = _cli(capsys, "onset", SAMPLE, "--damping", "0.002:0.008:4", "--checks", "0",
                          "--out", tmp_path / "o", "--json")
    assert code == 0, err
    rows = list(csv.DictReader(open(tmp_path / "o" / "damping.csv")))
    for r in rows:
        U = float(r["U_cr_m_s"])
        assert bool(r["past_premises"]) == (U / 36.0 > 2 or U > 100)
    n = sum(bool(r["past_premises"]) for r in rows)
    assert 0 < n < len(rows)
    assert any(x.startswith(f"damping.csv: {n} of {len(rows)} rows") for x in json.loads(out)["warnings"])


# -- the output folder -------------------------------------------------------------------------------
def _run(capsys, out, *extra):
    return _cli(capsys, "onset", SAMPLE, "--checks", "0", "--out", out, *extra)


@pytest.mark.parametrize("name", ["damping.csv", "onset.png", "notes.txt"])
def test_a_users_file_is_never_overwritten(tmp_path, capsys, name):
    out = tmp_path / "o"
    out.mkdir()
    (out / name).write_bytes(b"the user's own")
    code, _, err = _run(capsys, out)
    assert code == 2 and "--out" in err and name in err and "did not write" in err
    assert len(err.strip().splitlines()) == 1
    assert (out / name).read_bytes() == b"the user's own"
    assert sorted(p.name for p in out.iterdir()) == [name]          # nothing written beside it


def test_a_rerun_replaces_its_own_files_and_only_those(tmp_path, capsys):
    out = tmp_path / "o"
    code, _, err = _run(capsys, out, "--damping", "0.002:0.004:3")
    assert code == 0, err
    meta = json.loads((out / "run.json").read_text())
    assert meta["name"] == "onset" and meta["status"] == "complete"
    assert set(meta["files"]) == {"onset.json", "damping.csv", "amplitude.csv", "onset.png", "onset.pdf"}
    code, _, err = _run(capsys, out)                     # the same folder again: its own files
    assert code == 0, err
    (out / "mine.txt").write_text("x")                   # a user's file added since: refused
    code, _, err = _run(capsys, out)
    assert code == 2 and "mine.txt" in err
    assert (out / "mine.txt").read_text() == "x"


def test_a_second_onset_is_locked_out(tmp_path, capsys):
    """While a process holds the folder's lock (as a running onset does), another onset is refused
    naming --out; once it is released the run goes through."""
    out = tmp_path / "o"
    out.mkdir()
    fd = os.open(out, os.O_RDONLY | os.O_DIRECTORY)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        code, _, err = _run(capsys, out)
        assert code == 2 and "another autocable onset is writing into" in err
        assert list(out.iterdir()) == []
    finally:
        os.close(fd)
    code, _, err = _run(capsys, out)
    assert code == 0, err


def test_temporaries_of_a_dead_writer_are_cleared_a_live_runs_are_not(tmp_path, capsys):
    """A killed onset's half-written file is removed (the lock proves its writer dead); the staging
    folder of a live process (this one) is another run's: refused, and left as it is."""
    out = tmp_path / "o"
    out.mkdir()
    (out / ".onset.json.ab12cd34.tmp").write_text("{half")
    code, _, err = _run(capsys, out)
    assert code == 0, err
    assert not (out / ".onset.json.ab12cd34.tmp").exists()
    other = tmp_path / "p"
    live = other / f".autocable-staging-{os.getppid()}"
    live.mkdir(parents=True)
    code, _, err = _run(capsys, other)
    assert code == 2 and "another autocable run" in err and live.is_dir()


def test_mode_pairs_past_the_premises_warn(capsys):
    """--modes-below: the sample's pairs gallop at 36, 71.7, 107.6 and 143.4 m/s (U* = k, about): the
    onsets of pairs 3 and 4 lie past the premises (U* > 2, above 100 m/s, Mach > 0.3), those of pairs
    1 and 2 do not."""
    code, out, err = _cli(capsys, "onset", SAMPLE, "--modes-below", 5, "--json")
    assert code == 0
    rep = json.loads(out)
    w = [x for x in rep["warnings"] if "past the model's premises" in x]
    assert [x.split(")")[0] for x in w] == ["the onset (mode pair 3", "the onset (mode pair 4"]
    assert all(x in err for x in w) and "Mach 0.314" in w[0]


def test_a_typing_error_leaves_the_folder_as_it_was(tmp_path, capsys):
    """The options and the model are read before the folder is taken: a bad --damping makes no new
    folder, and leaves an earlier onset's files and its complete run.json untouched."""
    code, _, err = _run(capsys, tmp_path / "new", "--damping", "0.1:0.01")
    assert code == 2 and not (tmp_path / "new").exists()
    out = tmp_path / "o"
    assert _run(capsys, out)[0] == 0
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    code, _, err = _run(capsys, out, "--damping", "0.1:0.01")
    assert code == 2 and "--damping" in err
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before
