"""What every scene's run.json records of how it was made: package versions, the engine of the direct
integrations of eq. (21)."""
from __future__ import annotations

import platform


def versions() -> dict[str, str]:
    from importlib import metadata

    from autocable._version import __version__
    out = {"autocable": __version__, "python": platform.python_version()}
    for pkg in ("numpy", "scipy", "sympy", "PyDSTool", "matplotlib"):
        try:
            out[pkg] = metadata.version(pkg)
        except metadata.PackageNotFoundError:
            out[pkg] = "not installed"
    return out


def ode21_engine() -> str:
    """The engine of the scenes' direct integrations of eq. (21) (provenance)."""
    from autocable.methods.integration.ode21 import SCENE_ENGINE
    return SCENE_ENGINE
