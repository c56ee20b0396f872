"""Plots of autocable results (paper style). Reads `autocable.results` records only; matplotlib is
imported lazily inside the functions, with the Agg canvas (no display, no pyplot state)."""
