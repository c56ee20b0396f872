"""Scenes: ``runs/*.toml`` files that say what to continue or integrate for one figure.

`schema` reads and validates a scene (light: no PyDSTool, no sympy); `runner` executes it
(continuation runs, overlays of eq. (21)); `time_scene` runs the time-history scenes (Fig. 11).
"""
