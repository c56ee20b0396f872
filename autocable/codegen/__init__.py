"""The one place that turns sympy into PyDSTool specs and builds them (see `pydstool`).

`compat` holds the only PyDSTool compatibility code (imports on Python 3.11, the build folder,
silencing, error translation); `cache` the content-hashed cache folder. Importing this package does
not import PyDSTool: that happens on first use.
"""
