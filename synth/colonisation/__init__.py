"""Space colonisation street growth (seed 001 ch. 4, after Runions et al. 2007).

Six modules, one idea each: :mod:`~synth.colonisation.options` (the tunables),
:mod:`~synth.colonisation.rules` (the pure angle and force rules), :mod:`~synth.colonisation.network`
(the growing network and the attraction points), :mod:`~synth.colonisation.pruning` (extra pruning,
chaining into streets), :mod:`~synth.colonisation.result` (what a run returns) and
:mod:`~synth.colonisation.kernel` (the two phases, :func:`colonise`; its docstring gives the
algorithm step by step). Every public name is importable from here, as it was when they were one module.
"""
from synth.colonisation.kernel import colonise
from synth.colonisation.options import (
    MIN_ANGLE_FLOOR,
    PRIMARY,
    REFERENCE_AREA_SL2,
    SECONDARY,
    TERTIARY,
    ColonisationOptions,
    HierarchyBasis,
)
from synth.colonisation.pruning import chain_streets, extra_pruning
from synth.colonisation.result import ColonisationResult, GrownStreet, Join
from synth.colonisation.rules import connection_force, constrain_turn, ideal_directions

__all__ = [
    "ColonisationOptions", "ColonisationResult", "GrownStreet", "HierarchyBasis", "Join", "MIN_ANGLE_FLOOR",
    "PRIMARY", "REFERENCE_AREA_SL2", "SECONDARY", "TERTIARY", "chain_streets", "colonise", "connection_force",
    "constrain_turn", "extra_pruning", "ideal_directions",
]
