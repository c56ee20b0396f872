"""The file references of the documentation site are generated from the schemas (autocable.scene.
reference): every key a model spec, a scene, a chart table or a sweep file accepts has a text, and
no text names a key the schema dropped; a key added to a schema without a text is caught."""
import pytest

from autocable.scene import reference, schema
from autocable import spec


@pytest.mark.parametrize("kind", list(reference.KINDS))
def test_every_schema_field_is_documented(kind):
    assert reference.undocumented(kind) == []
    assert reference.stale(kind) == []
    page = reference.reference_page(kind)
    for key in reference.schema_keys(kind):
        assert f"| `{key}` |" in page


def test_a_field_added_to_a_schema_without_documentation_is_caught(monkeypatch):
    monkeypatch.setattr(schema, "_PLOT_KEYS", schema._PLOT_KEYS + ("colour",))
    assert reference.undocumented("scene") == ["plot.colour"]
    monkeypatch.setitem(spec._CABLE_RULES, "sag_m", ("pos", None, "a positive length in m"))
    assert reference.undocumented("model") == ["cable.sag_m"]


def test_a_documented_field_the_schema_dropped_is_caught(monkeypatch):
    monkeypatch.setattr(schema, "_OVERLAY_KEYS", tuple(k for k in schema._OVERLAY_KEYS if k != "max_time"))
    assert reference.stale("scene") == ["overlay.max_time"]


def test_the_scene_keys_are_the_ones_the_parser_enforces(tmp_path):
    """The list the reference is generated from is the parser's: a key outside it is refused, one
    inside it is accepted (plot.units)."""
    from conftest import scene_error, two_run_scene
    text = two_run_scene("\"trivial\"")
    err = scene_error(tmp_path / "a.toml", text + '[plot]\ncolour = "red"\n')
    assert "plot.colour" in str(err)
    (tmp_path / "b.toml").write_text(text + '[plot]\nunits = "si"\n')
    assert schema.load_scene(tmp_path / "b.toml").plot.units == "si"
    err = scene_error(tmp_path / "c.toml", text + '[plot]\nunits = "imperial"\n')
    assert "plot.units" in str(err) and "'si'" in str(err)
