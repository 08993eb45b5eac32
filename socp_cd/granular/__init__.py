"""Granular mechanics on contact-dynamics snapshots (J.J. Moreau).

Moreau's average stress from the internal moment and its decomposition into
an external-action term plus the Love–Weber tensor (:mod:`.stress`), tractions
across cuts compared with the continuum ``σ n`` (:mod:`.cuts`), contact
statistics (:mod:`.stats`), all on a plain :class:`GranularState`
(:mod:`.state`) built from generic frames (:func:`from_frame`) or, by
:mod:`.adapters`, from simulator objects (:func:`from_simulation`,
:func:`from_trajectory`, :func:`from_hdf5`).  Scene builders for the experiments (biaxial box,
talus poured in batches) are in :mod:`.samples`, drawing helpers in
:mod:`.plot`; both import the simulator / matplotlib lazily.
"""
from .cuts import (CutSweep, cauchy_deviation, continuum_traction, cut_sweep, cut_traction,
                   region_balance)
from .adapters import from_hdf5, from_simulation, from_trajectory
from .state import GranularState, from_frame
from .stats import (ForceDistribution, contact_counts, coordination_number, fabric_tensor,
                    force_distribution, rattlers)
from .stress import (StressReport, asymmetry, external_stress, internal_moment, moreau_stress,
                     principal, relative_difference, sample_mask, stress_report, weber_stress)

__all__ = [
    "GranularState", "from_frame", "from_hdf5", "from_simulation", "from_trajectory",
    "internal_moment", "moreau_stress", "weber_stress", "external_stress", "stress_report",
    "StressReport", "principal", "asymmetry", "relative_difference", "sample_mask",
    "cut_traction", "cut_sweep", "CutSweep", "region_balance", "continuum_traction", "cauchy_deviation",
    "contact_counts", "rattlers", "coordination_number", "force_distribution",
    "ForceDistribution", "fabric_tensor",
]
