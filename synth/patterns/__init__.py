"""Beneš street patterns: minor streets grown from crossings (seed 000 §4.2.6).

A new street starts at an existing crossing (or at a point on a segment,
which becomes one) and is defined by its orientation and length. The
orientation is drawn from ``angle_pdf`` and measured in *world space*, in
*crossing space* — from the time-wise first incident street of the crossing
— or, for Weber's radial pattern (seed 002 §3.1), in *centre space*: from the
ray pointing away from a pattern centre. The length comes from a length PDF
or is a function of the orientation (``length_from_orientation``).

From that Default street four proposals are made (000 §4.2.6):

1. **Default** — the drawn street itself.
2. **Extend** — if lengthening the Default street by the look-ahead factor
   (×1.5, seed 002's "enlargement") meets a street that does not already
   share a crossing with the proposal, a street to that intersection point.
3. **Shorten** — if the Default street intersects other streets, a street to
   the first of these intersections.
4. **Snap** — a street to the nearest crossing within ``snap_radius_m``
   (25 m, seed 002) of the Default street's end.

They are evaluated Snap, Shorten, Extend, Default; the first valid one is
built. Each can be switched off. A proposal is valid when (000 §4.2.6, a–g)

a. it does not intersect any non-incident street or crossing;
b. it makes an angle of at least ``min_angle_deg`` with every street it
   shares a crossing with (at both ends);
c. its length lies in [``min_length_m``, ``max_length_m``];
d. it keeps at least ``min_cs_distance_m`` from every non-incident street;
e. a new end crossing is at least ``min_cc_distance_m`` from every existing
   crossing (also applied to a start point that splits a segment);
f. it closes no triangle of three streets and three crossings;
g. both its crossings have degree ≤ ``max_degree`` afterwards;

and, with water and forbidden areas given: it does not end in water nor
touch a forbidden area. A proposal that crosses water is a **bridge**: each
crossing makes one bridge attempt (000 §4.2.6), a bridge may be at most
``max_bridge_length_m`` long and no closer than ``min_bridge_spacing_m`` to
another bridge. Besides bridges that arise from ordinary proposals, a
crossing near water first tries 000 §4.2.3's bridge: rays shot in
``bridge_rays`` directions, the one that crosses water in the shortest span
becomes the proposal.

Weber's organic, grid and radial patterns (002 §3.1) and the eras' patterns
(000 §4.2.9) are parameter sets of :class:`PatternOptions`: ``ORGANIC``,
``GRID``, ``RADIAL``, ``MEDIEVAL``, ``GRID_19TH_CENTURY``,
``GRID_NORTH_AMERICAN``, ``SUBURBAN``.

Five modules, one idea each: :mod:`~synth.patterns.options` (the tunables),
:mod:`~synth.patterns.sets` (the named parameter sets), :mod:`~synth.patterns.proposals` (starts and the
four proposals), :mod:`~synth.patterns.rules` (the rules a proposal must pass) and
:mod:`~synth.patterns.growing` (:func:`grow_streets`). Every public name is importable from here, as it
was when they were one module.
"""
from synth.patterns.growing import grow_streets
from synth.patterns.options import MAX_TRIES, AngleSpace, LengthMode, PatternOptions, PdfKind, Proposal, Rule
from synth.patterns.proposals import ON_TOLERANCE, GrowthStep, Start, StartPoints, StreetProposal, propose
from synth.patterns.rules import check_proposal
from synth.patterns.sets import (
    GRID,
    GRID_19TH_CENTURY,
    GRID_NORTH_AMERICAN,
    MEDIEVAL,
    ORGANIC,
    PATTERNS,
    RADIAL,
    SUBURBAN,
    pattern,
)

__all__ = [
    "AngleSpace", "GRID", "GRID_19TH_CENTURY", "GRID_NORTH_AMERICAN", "GrowthStep", "LengthMode", "MAX_TRIES",
    "MEDIEVAL", "ON_TOLERANCE", "ORGANIC", "PATTERNS", "PatternOptions", "PdfKind", "Proposal", "RADIAL", "Rule",
    "SUBURBAN", "Start", "StartPoints", "StreetProposal", "check_proposal", "grow_streets", "pattern", "propose",
]
