"""Tools of the repository that are not part of the shipped package (the hardening harness)."""
