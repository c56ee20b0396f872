"""Time integration: eq. (21) (`ode21`), the AME (`ame`), eq. (21) with N modes (`nmode`), sweeps in a
parameter (`sweeps`), Floquet multipliers (`floquet21`) and periodic orbits (`periodic21`) of eq. (21)."""
