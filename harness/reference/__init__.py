"""Independent NumPy reference estimators, written from docs/methods.md, never importing casadi.

Each reference module offers the estimator shape of docs/architecture.md on NumPy vectors with the same
named layouts as the symbolic model: ``names(config) -> (inputs, states, outputs)``,
``init(config, u0) -> state`` and ``step(config, state, u) -> (state, output)``; the harness
checks the layout names agree.
"""

from __future__ import annotations

from types import ModuleType

from vsegen.harness.reference import arx_dual_kf, ekf_rls, fusion, kf2dof, particle, switching, unscented

REFERENCES: dict[str, ModuleType | unscented.Variant | particle.ParticleFilter] = {
    "kf2dof": kf2dof, "switching": switching, "fusion": fusion, "arx_dual_kf": arx_dual_kf,
    "ekf_rls": ekf_rls, "ukf": unscented.Variant("ukf", adaptive=False),
    "aukf": unscented.Variant("aukf", adaptive=True),
    "pf_adaptive": particle.ParticleFilter("pf_adaptive", improved=False),
    "pf_improved": particle.ParticleFilter("pf_improved", improved=True)}
LONG_DOUBLE = frozenset(name for name, ref in REFERENCES.items() if isinstance(ref, unscented.Variant))
"""References that compute in long double, the unscented filters' (``harness.verify.compare.for_estimator``)."""
