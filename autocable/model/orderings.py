"""The names of the Multiple Scales orderings (Sect. 4), light on purpose: the scene schema and the
command line read them without loading sympy. `autocable.model.multiscale.ordering_named` gives
each its rules: "paper" (every aerodynamic term at third order, as Sect. 4 says) and "natural"
(aerodynamic terms at their natural order, quadratic ones second, like every other term)."""

ORDERINGS = ("paper", "natural")
