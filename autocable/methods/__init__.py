"""Methods of the ladder: direct integration of eq. (21), continuation, periodic orbits."""
