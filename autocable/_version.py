"""The version of autocable (one place; the API and run.json provenance read it)."""
__version__ = "0.1.0"
