"""The build step that ships the repository's sample models and figure scenes inside the package.

All metadata, pins and tool settings live in setup.cfg. The top-level folders ``models/`` and
``runs/`` stay where they are (the scenes name their model as ``../models/...``); a build copies
them to ``autocable/_data/models`` and ``autocable/_data/runs`` in the wheel, so that an installed
autocable (``pip install .``, not editable) runs ``autocable figures``, ``run`` and ``onset`` from
any folder (`autocable._paths` finds them there). An editable install reads the folders in place.
"""
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

#: The repository's folders shipped as package data, and the files of each.
SHIPPED = {"models": ("*.toml",), "runs": ("*.toml", "README.md")}
HERE = Path(__file__).resolve().parent


def shipped_files() -> list[tuple[Path, str]]:
    """(source file, path inside the package) for every file `SHIPPED` names."""
    files = []
    for folder, patterns in SHIPPED.items():
        for pattern in patterns:
            files += [(p, f"_data/{folder}/{p.name}") for p in sorted((HERE / folder).glob(pattern))]
    return files


class BuildWithData(build_py):
    """`build_py` plus the copies of models/ and runs/ under autocable/_data."""

    def run(self):
        super().run()
        if getattr(self, "editable_mode", False):
            return          # an editable install reads the folders in place (autocable._paths)
        for src, rel in shipped_files():
            dst = Path(self.build_lib) / "autocable" / rel
            self.mkpath(str(dst.parent))
            self.copy_file(str(src), str(dst))

    def get_outputs(self, include_bytecode=True):
        return super().get_outputs(include_bytecode) + [
            str(Path(self.build_lib) / "autocable" / rel) for _, rel in shipped_files()]


setup(cmdclass={"build_py": BuildWithData})
