"""The file references of the documentation, generated from the schemas: every key a model spec,
a scene file (with its ``[chart]`` table) or a sweep file accepts, read from the parsers' own lists
of allowed keys, with its text from `autocable.scene.field_docs`. `undocumented` and `stale` are
what tests/test_reference.py checks; `reference_page` is what the documentation site shows
(``mkdocs build`` calls it through docs/hooks.py)."""
from __future__ import annotations

import textwrap

from autocable.scene import field_docs, schema, sweep_schema
from autocable.methods.continuation.settings import STEP_KEYS
from autocable.spec import model_fields

__all__ = ["KINDS", "schema_keys", "undocumented", "stale", "reference_page"]

#: The files with a generated reference page: kind -> its title.
KINDS = {"model": "Model spec files (models/*.toml)", "scene": "Scene files (runs/*.toml)",
         "chart": "Stability charts: the [chart] table of a scene", "sweep": "Sweep files"}


def schema_keys(kind: str) -> list[str]:
    """The dotted keys the schema of ``kind`` accepts, in the order the parser lists them."""
    if kind == "model":
        return list(model_fields())
    if kind == "sweep":
        return sorted(sweep_schema._TOP_KEYS, key=list(field_docs.SWEEP).index) \
            + [f"grid.{k}" for k in (*sweep_schema.AXES, "start")]
    tables = {"run": schema._RUN_KEYS, "run.steps": STEP_KEYS, "fixed": schema.PARAMETERS,
              "plot": schema._PLOT_KEYS, "compare": schema._COMPARE_KEYS, "overlay": schema._OVERLAY_KEYS,
              "time": schema._TIME_KEYS, "chart": schema._CHART_KEYS}
    if kind == "chart":
        return ["chart"] + [f"chart.{k}" for k in tables["chart"]]
    if kind != "scene":
        raise ValueError(f"unknown kind {kind!r}; one of {', '.join(KINDS)}")
    keys = list(schema._TOP_KEYS)
    for table, names in tables.items():
        keys += [f"{table}.{k}" for k in names]
    return keys


def _docs(kind: str) -> dict[str, str]:
    return {"model": field_docs.MODEL, "scene": field_docs.SCENE, "chart": field_docs.SCENE,
            "sweep": field_docs.SWEEP}[kind]


def undocumented(kind: str) -> list[str]:
    """Keys the schema of ``kind`` accepts that have no text in `field_docs`."""
    docs = _docs(kind)
    return [k for k in schema_keys(kind) if not docs.get(k, "").strip()]


def stale(kind: str) -> list[str]:
    """Texts in `field_docs` for keys the schema no longer accepts."""
    keys = set(schema_keys("scene")) | set(schema_keys("chart")) if kind in ("scene", "chart") else set(schema_keys(kind))
    return sorted(k for k in _docs(kind) if k not in keys)


def _cell(text: str) -> str:
    """A table cell: pipes escaped, and asterisks (U*, eta*), which Markdown would read as emphasis."""
    return text.replace("|", "\\|").replace("*", "\\*").replace("\n", " ")


def reference_page(kind: str) -> str:
    """The Markdown page of ``kind``: the schema module's own description, then one table row per key."""
    docs = _docs(kind)
    title = KINDS[kind]
    lines = [f"# {title}", "",
             "Generated from the schema (`autocable." + {"model": "spec", "scene": "scene.schema", "chart": "scene.schema",
                                                          "sweep": "scene.sweep_schema"}[kind]
             + "`): every key the file accepts. An unknown key, a bad value or a value outside its range is "
               "refused with one line naming the file, the field and what is expected.", ""]
    if kind == "model":
        fields = model_fields()
        lines += ["| field | required | meaning | accepted values |", "|---|---|---|---|"]
        for k in schema_keys(kind):
            expected, required = fields[k]
            lines.append(f"| `{k}` | {'yes' if required else 'no'} | {_cell(docs.get(k, ''))} | {_cell(expected)} |")
        lines += ["", "The repository's `models/luongo_zulli_2012.toml` is the sample cable of Sect. 5 with every "
                  "field commented (its symbol, unit and where its value comes from)."]
        return "\n".join(lines) + "\n"
    lines += ["| key | meaning |", "|---|---|"]
    lines += [f"| `{k}` | {_cell(docs.get(k, ''))} |" for k in schema_keys(kind)]
    if kind == "chart":
        from autocable.plotting import chart
        lines += ["", "## The brute-force map (`chart.map`, `--map`)", "", chart.__doc__.split("\n\n", 1)[1].strip()]
    if kind == "sweep":
        lines += ["", "## Example", "", "```toml", textwrap.dedent(sweep_schema.__doc__.split("\n\n")[1]).strip("\n"), "```"]
    if kind == "scene":
        lines += ["", "## Example", "", "```toml", _scene_example(), "```"]
    return "\n".join(lines) + "\n"


def _scene_example() -> str:
    """The annotated example of the schema's docstring (its first indented block)."""
    doc = schema.__doc__
    start = doc.index("    title = ")
    end = doc.index("\n\nA ``[time]``")
    return "\n".join(line[4:] for line in doc[start:end].splitlines())
