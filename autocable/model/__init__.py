"""The physics: statics, modes, aerodynamics, Galerkin projection (eq. 21), Multiple Scales (eqs. 22-24).

Nothing in this package knows of PyDSTool or matplotlib."""
