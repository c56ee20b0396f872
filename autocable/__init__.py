"""autocable: nonlinear dynamics of stay cables under wind and support motion."""
__version__ = "0.1.0"
