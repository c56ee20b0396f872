"""From a model spec (or its eq. (21) `Derivation`) to the N-mode equations, cached by content.

The N-mode model reuses everything the two-mode derivation fixed: the statics, the nondimensional
groups, the calibrated (beta, Theta0), the load scale K and velocity ratio nu, and the damping ratio;
only the trial functions change (`modes_n.mode_set`).
"""
from __future__ import annotations

from autocable._store import (cache_dir, code_fingerprint, content_hash, load_checked_json,
                              store_checked_json_for_code)
from autocable.model.aero import expand_load_jet
from autocable.model.curves import eq21_fits
from autocable.model.derive import DERIVATION_VERSION, Derivation, derive
from autocable.model.galerkin_n import ExactZeroIntegrator, project_n
from autocable.model.modes_n import mode_set
from autocable.model.multimode import NModeODE
from autocable.model.shapes import QuadratureIntegrator
from autocable.spec import ModelSpec

#: Bump when a change in the N-mode projection changes the numbers.
NMODE_VERSION = "nmode-v2"


def derive_nmode(source: Derivation | ModelSpec, n_in: int, n_out: int,
                 use_cache: bool = True, integrator: str = "closed-form") -> NModeODE:
    """The equations with the lowest ``n_in`` in-plane and ``n_out`` out-of-plane modes.

    ``integrator="quadrature"`` takes every integral by Gauss-Legendre quadrature instead of the
    closed form: the independent second path that tests compare with.
    """
    d = source if isinstance(source, Derivation) else derive(source)
    if not (isinstance(n_in, int) and isinstance(n_out, int) and n_in >= 1 and n_out >= 1):
        raise ValueError(f"the number of modes must be integers >= 1, got n_in = {n_in!r}, n_out = {n_out!r}")
    spec = d.spec
    # keyed by the code (`code_fingerprint`): a change to the projection without a bump of
    # NMODE_VERSION never serves the old equations
    code = code_fingerprint("derivation")
    key = content_hash({"spec": spec.content_hash(), "eq21": DERIVATION_VERSION, "version": NMODE_VERSION,
                        "code": code, "n_in": n_in, "n_out": n_out, "integrator": integrator})
    if integrator not in ("closed-form", "quadrature"):
        raise ValueError(f"unknown integrator {integrator!r}; use 'closed-form' or 'quadrature'")
    path = cache_dir("derivations") / f"nmode{n_in}x{n_out}-{key}.json"
    data = load_checked_json(path, f"derivation {path.name}") if use_cache else None
    if data is not None:
        return NModeODE.from_dict(data)
    st = d.statics
    ms = mode_set(st, n_in, n_out, spec.cable.twist_ends)
    lift, drag = eq21_fits(spec.aero, st.alpha, d.beta, d.theta0)     # a table or a blend: its cubic at phi0
    aero = expand_load_jet(lift, drag, st.alpha, d.beta, d.theta0, spec.aero.angle_convention, spec.aero.load_axes)
    ode = project_n(st, ms, aero, d.aero_scale, d.velocity_ratio, spec.cable.damping_ratio,
                    ExactZeroIntegrator(ms.shapes) if integrator == "closed-form"
                    else QuadratureIntegrator(ms.shapes, nodes=128),
                    provenance={"model": spec.name, "model_hash": spec.content_hash(),
                                "derivation": NMODE_VERSION, "n_in": n_in, "n_out": n_out})
    store_checked_json_for_code("derivation", code, path, ode.to_dict(), f"derivation {path.name}")
    return ode
