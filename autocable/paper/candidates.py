"""A candidate model of `autocable calibrate` and its files: the readings that name it, its model
file, the scene folders of its evaluation (shared by the full evaluation, `calibration`, and the
bound stage, `bound`, which import it; neither imports the other's helpers through a loop)."""
from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass
from pathlib import Path

from autocable.spec import load_model


@dataclass(frozen=True)
class Readings:
    """One choice of every reading the paper leaves open that changes eq. (21)."""

    twist_ends: str
    load_axes: str
    angle_convention: str
    load_length: str
    air_density_kg_m3: float

    @property
    def label(self) -> str:
        return (f"{self.twist_ends}-{self.load_axes}-{self.angle_convention}-{self.load_length}-"
                f"rho{self.air_density_kg_m3:g}")


def _finite(x):
    """JSON has no inf or nan: a non-finite number is written as null (a diverged a2 ratio, say)."""
    if isinstance(x, float) and not math.isfinite(x):
        return None
    if isinstance(x, dict):
        return {k: _finite(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_finite(v) for v in x]
    return x


def screen_score(c: dict) -> tuple:
    """Rank: screen and number targets met, then the smaller AME a2 ratio."""
    v = c["verdicts"]
    met = sum(x["shown"] == "yes" for x in v.values())
    ratio = v.get("a2_ratio_ame", {}).get("value")
    ratio = ratio if isinstance(ratio, (int, float)) and math.isfinite(ratio) else math.inf
    return (met, -ratio)


def candidate_name(c: dict) -> str:
    r = Readings(**c["readings"])
    return (f"{r.label}-beta{c['yaw_deg']:+.2f}-th{c['rivulet_angle_deg']:+.3f}-{c.get('theta0_rule', 'calibrate')}"
            f"-{c['ordering']}")


def write_candidate_model(spec_path: Path, c: dict, out: Path) -> Path:
    """The candidate's model file: the spec's text with the searched fields replaced."""
    text = spec_path.read_text()
    r = c["readings"]
    lines, out_lines = text.splitlines(), []
    repl = {"twist_ends": f'"{r["twist_ends"]}"', "load_axes": f'"{r["load_axes"]}"',
            "angle_convention": f'"{r["angle_convention"]}"', "load_length": f'"{r["load_length"]}"',
            "air_density_kg_m3": repr(float(r["air_density_kg_m3"])),
            "yaw_deg": f"{c['yaw_deg']!r}", "rivulet_angle_deg": f"{c['rivulet_angle_deg']!r}"}
    seen = set()
    for line in lines:
        key = line.split("=")[0].strip() if "=" in line and not line.lstrip().startswith("#") else ""
        if key in repl:
            out_lines.append(f"{key} = {repl[key]}   # set by autocable calibrate")
            seen.add(key)
        else:
            out_lines.append(line)
    text = "\n".join(out_lines) + "\n"
    for key in ("twist_ends",):
        if key not in seen:
            text = text.replace("[cable]\n", f"[cable]\n{key} = {repl[key]}\n", 1)
    for key in ("load_axes", "angle_convention", "load_length"):
        if key not in seen:
            text = text.replace("[aero]\n", f"[aero]\n{key} = {repl[key]}\n", 1)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text)
    load_model(out)    # the file must be a valid spec
    return out


#: The model line of the repository's figure scenes (runs/fig*.toml), which a candidate's copies replace.
SAMPLE_MODEL_LINE = 'model = "../models/luongo_zulli_2012.toml"'


def scene_on_model(text: str, model: Path, scene_dir: Path) -> str:
    """A figure scene's text with its model line naming ``model``, written relative to
    ``scene_dir``, the folder of the scene file (a scene resolves its model from there): a
    calibration whose ``--out`` is a relative path, or a folder moved after it ran, still finds it."""
    target = Path(model).resolve()
    try:
        rel = Path(os.path.relpath(target, Path(scene_dir).resolve())).as_posix()
    except ValueError:      # another drive (Windows): no relative path, the absolute one then
        rel = target.as_posix()
    return text.replace(SAMPLE_MODEL_LINE, f'model = "{rel}"')


def scene_complete(folder: Path, scene_file: Path) -> bool:
    """The scene's output folder holds a complete run of exactly this scene file (run.json's
    status and scene text): an evaluation that resumes reuses it instead of computing it again."""
    try:
        run = json.loads((folder / "run.json").read_text())
        return run.get("status") == "complete" and (run.get("provenance") or {}).get("scene_text") == scene_file.read_text()
    except (OSError, ValueError, AttributeError):
        return False


def _recorded_drops(folder: Path) -> list[str]:
    """The drops an earlier, interrupted evaluation of this candidate made (``dropped.json``)."""
    try:
        return list(json.loads((folder / "dropped.json").read_text()))
    except (OSError, ValueError, TypeError):
        return []


def _failed_start(error: str):
    """k of a scene error ``...: run[k].start: ...`` (the run whose start failed), else None."""
    import re
    m = re.search(r"run\[(\d+)\]\.start", error)
    return int(m.group(1)) if m else None


def table_span(lines: list[str], name: str) -> tuple[int, int, int] | None:
    """Where the ``[name]`` table of a scene file's lines is: (its header line, the end of its own
    keys, the end of the table with its ``[name.*]`` subtables); None if it has none."""
    i0 = next((i for i, line in enumerate(lines) if line.split("#", 1)[0].strip() == f"[{name}]"), None)
    if i0 is None:
        return None
    after = [j for j in range(i0 + 1, len(lines)) if lines[j].strip().startswith("[")]
    own = after[0] if after else len(lines)
    end = next((j for j in after if not lines[j].strip().startswith(f"[{name}.")), len(lines))
    return i0, own, end


def _drop_table(path: Path, name: str) -> bool:
    """Remove the ``[name]`` table (with its ``[name.*]`` subtables) from a scene file; False if it
    has none."""
    lines = path.read_text().splitlines()
    span = table_span(lines, name)
    if span is None:
        return False
    path.write_text("\n".join(lines[:span[0]] + lines[span[2]:]) + "\n")
    return True


def _switch_off(path: Path, table: str, key: str) -> bool:
    """Set ``key = false`` in the ``[table]`` table of a scene file where it is true (or absent,
    true by default: `autocable.scene.schema`); False if it was already false or there is no table."""
    lines = path.read_text().splitlines()
    span = table_span(lines, table)
    if span is None:
        return False
    for j in range(span[0] + 1, span[1]):
        head, _, rest = lines[j].partition("=")
        if head.strip() == key:
            if rest.split("#", 1)[0].strip() == "false":
                return False
            lines[j] = f"{key} = false"
            break
    else:
        lines.insert(span[0] + 1, f"{key} = false")
    path.write_text("\n".join(lines) + "\n")
    return True


def _drop_run(path: Path, k: int) -> bool:
    """Remove the k-th ``[[run]]`` table (with its ``[run.*]`` subtables) from a scene file."""
    lines = path.read_text().splitlines()
    starts = [i for i, line in enumerate(lines) if line.strip() == "[[run]]"]
    if k >= len(starts) or len(starts) < 2:
        return False
    i0 = starts[k]
    i1 = len(lines)
    for j in range(i0 + 1, len(lines)):
        t = lines[j].strip()
        if t.startswith("[") and not t.startswith("[run."):
            i1 = j
            break
    path.write_text("\n".join(lines[:i0] + lines[i1:]) + "\n")
    return True
