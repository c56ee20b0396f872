"""`autocable onset --band` with the curves' band and blend: the galloping amplitude at the design
wind over the band (`autocable.studies.band.amplitude_band`).

The 190 m stay with its cubic fits held over phi0 +- 15 deg and blended to the dry cylinder beyond
(models/stay_190m.blended.toml). The band's amplitude ends are checked against an independent
`gallop_study(..., with_sensitivity=True)` (what `autocable gallop --load exact` computes) on an
equation derived here from the model file, not through the band's loop: the ends equal the minimum
and maximum over its nominal curves and four curve variants to 1e-9, and the nominal case equals
gallop's amplitude. A model whose curves have no band or blend (models/stay_190m.toml) gives the
one-line reason and no amplitude band. The global least damping over the band (nominal curves) equals
an independent `least_damping_global`. Run time: about 40 s on two busy cores (the slow test, two
calibrated combinations over U_c = 9-10 m/s, about 55 s more).
"""
import json
import warnings
from dataclasses import replace
from pathlib import Path

import pytest

MODELS = Path(__file__).parent.parent / "models"
BLENDED = MODELS / "stay_190m.blended.toml"
PLAIN = MODELS / "stay_190m.toml"
DESIGN = 25.0
TOL = 1e-9


def _derive_exact(spec):
    from autocable.model.derive import derive
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return derive(replace(spec, aero=replace(spec.aero, load="exact")))


def _gallop(spec, d=None):
    """`autocable gallop --load exact` on ``spec`` (its primary damping): the independent route."""
    from autocable.studies.gallop import gallop_study
    return gallop_study(_derive_exact(spec) if d is None else d, DESIGN, checks=False, with_sensitivity=True)


def _all_amplitudes(study) -> list:
    """Per curve case, the largest peak of each plane over the stable cycles found at the design wind
    (``envelope_at_design_wind_m``, which the band spans), the nominal case first."""
    s = study["sensitivity"]
    rows = [study] + list(s["cases"])
    return [r.get("envelope_at_design_wind_m") or r["amplitude_at_design_wind_m"] for r in rows
            if r.get("amplitude_at_design_wind_m")]


@pytest.fixture(scope="module")
def cli_band():
    """`autocable onset stay_190m.blended.toml --band --design-wind 25 --json`: (band, stderr)."""
    import contextlib
    import io

    from autocable.cli import main
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        code = main(["onset", str(BLENDED), "--band", "--design-wind", str(DESIGN), "--json"])
    assert code == 0
    return json.loads(out.getvalue())["band"], err.getvalue()


@pytest.fixture(scope="module")
def derived_given():
    from autocable.spec import load_model
    return _derive_exact(load_model(BLENDED))


@pytest.fixture(scope="module")
def gallop_given(derived_given):
    return _gallop(None, derived_given)


def test_amplitude_ends_are_the_extremes_of_gallop_sensitivity(cli_band, gallop_given):
    """One calibrated combination at the model's U_c (the other three have no admissible calibration):
    the model as given, which sets both ends of the least damping band. Its five curve cases (nominal,
    range -+5 deg, blend x0.5, x2) are those of `gallop --sensitivity`; the band's ends are their
    extremes, to 1e-9 (the cases must differ by more than that: the exact load sees the blend)."""
    band, _ = cli_band
    amp = band["amplitude_at_design_wind_m"]
    assert amp["load"] == "exact"
    assert [c["roles"] for c in amp["cases"]] == [["the model as given", "sets the least damping's low end",
                                                   "sets the least damping's high end"]]
    amps = _all_amplitudes(gallop_given)
    assert len(amps) == 5
    for i, key in enumerate(("in_plane", "out_of_plane")):
        vals = [a[i] for a in amps]
        assert max(vals) - min(vals) > 0.05            # the band and blend move the amplitude (m)
        assert amp[key] == pytest.approx([min(vals), max(vals)], rel=TOL, abs=0)
        # and agree with gallop's own range of the sensitivity
        assert amp[key] == pytest.approx(gallop_given["sensitivity"]["envelope_at_design_wind_m"]["range"][i],
                                         rel=TOL, abs=0)


def test_nominal_case_is_gallops_amplitude(cli_band, gallop_given):
    band, _ = cli_band
    case = band["amplitude_at_design_wind_m"]["cases"][0]
    nominal = case["variants"][0]
    assert nominal["curves"] == "nominal"
    assert nominal["amplitude_at_design_wind_m"] == pytest.approx(gallop_given["amplitude_at_design_wind_m"],
                                                                  rel=TOL, abs=0)
    assert nominal["beyond_valid_range"] == gallop_given["beyond_valid_range"]


def test_each_end_names_its_case_and_validity(cli_band, gallop_given):
    """``set_by`` names the combination and the curve variant of each end, with that cycle's validity;
    the named variant's peak is the end's value."""
    band, err = cli_band
    amp = band["amplitude_at_design_wind_m"]
    names = {c["curves"] for c in amp["cases"][0]["variants"]}
    assert names == {"nominal", "band narrowed by 5 deg", "band widened by 5 deg", "blend x0.5", "blend x2"}
    for i, key in enumerate(("in_plane", "out_of_plane")):
        for k, end in enumerate(("lo", "hi")):
            b = amp["set_by"][key][end]
            assert b["curves"] in names and b["combination"] == amp["cases"][0]["label"]
            assert b["peak_m"][i] == amp[key][k]
            assert isinstance(b["beyond_valid_range"], bool) and b["phi_swept_deg"] > 0
            # the validity is that of the cycle whose peak the end is: the design cycle's, or the other
            # stable cycle's that reaches further in that plane (the widened band's 2.12 m out of plane)
            variant = next(r for r in amp["cases"][0]["variants"] if r["curves"] == b["curves"])
            if b["another_cycle"]:
                o = next(o for o in variant["other_stable_cycles"] if o["peak_m"][i] == b["peak_m"][i])
                assert (b["phi_swept_deg"], b["beyond_valid_range"]) == (o["phi_swept_deg"], o["beyond_valid_range"])
            else:
                assert b["peak_m"][i] == variant["amplitude_at_design_wind_m"][i]
                assert b["phi_swept_deg"] == variant["phi_swept_deg"]
    assert any(amp["set_by"][key][end]["another_cycle"] for key in ("in_plane", "out_of_plane") for end in ("lo", "hi"))
    # progress on stderr while it runs
    assert "autocable onset --band: galloping at 25 m/s on the exact load" in err


def test_global_least_damping_is_that_of_the_combination(cli_band, derived_given):
    """``least_damping_global`` over the one combination (nominal curves, exact load) equals an
    independent `least_damping_global` on the model file's equation, to 1e-9; it lies above the
    linear least damping (the onset is sub-critical: cycles exist below it)."""
    from autocable.studies.gallop import least_damping_global
    band, _ = cli_band
    g = least_damping_global(derived_given, DESIGN)["least_damping_ratio_global"]
    assert band["least_damping_global"] == pytest.approx([g, g], rel=TOL, abs=0)
    assert g > band["least_damping"][1]
    by = band["set_by"]["least_damping_global"]["hi"]
    assert by["combination"] == band["amplitude_at_design_wind_m"]["cases"][0]["label"]
    assert by["beyond_valid_range"] in (True, False)


def test_model_without_a_blend_says_why_in_one_line(capsys):
    """The paper's cubic fits with no stated range: no amplitude band, one line saying why (gallop's
    reason), in the study and in the text report."""
    from autocable.spec import load_model
    from autocable.studies.band import amplitude_band, amplitude_text
    out = amplitude_band(load_model(PLAIN), {}, DESIGN)
    assert out["amplitude_at_design_wind_m"] is None
    assert "\n" not in out["amplitude_note"] and "the curves are not varied" in out["amplitude_note"]
    assert "sensitivity to the curves' band is undefined" in out["amplitude_note"]
    lines = amplitude_text(dict(out, design_wind_m_s=DESIGN))
    assert len(lines) == 1 and out["amplitude_note"] in lines[0]


@pytest.mark.slow
def test_two_combinations_over_a_range_of_onset_speeds():
    """U_c = 9-10 m/s: the least damping's high end is set at U_c = 9 (a second combination, derived
    here by calibrating the model file at U_c = 9), the model as given (U_c = 10) sets the low end.
    The band's ends are the extremes over both combinations' five curve cases, to 1e-9."""
    from autocable.spec import load_model
    from autocable.studies.band import amplitude_band, band_study
    spec = load_model(BLENDED)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        band = band_study(spec, (9.0, 10.0), DESIGN)
    assert band["set_by"]["least_damping"]["hi"]["critical_wind_speed_m_s"] == 9.0
    amp = amplitude_band(spec, band, DESIGN)["amplitude_at_design_wind_m"]
    assert len(amp["cases"]) == 2
    amps = _all_amplitudes(_gallop(spec)) + _all_amplitudes(
        _gallop(replace(spec, aero=replace(spec.aero, critical_wind_speed_m_s=9.0))))
    for i, key in enumerate(("in_plane", "out_of_plane")):
        vals = [a[i] for a in amps]
        assert amp[key] == pytest.approx([min(vals), max(vals)], rel=TOL, abs=0)
