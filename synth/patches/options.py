"""Example patches' tunables, and the road classes a patch never copies."""
from __future__ import annotations

from dataclasses import dataclass

from osm_expand.model import highways

#: Highway classes never copied into a district: a piece of motorway in a housing estate is no street.
NOT_COPIED = highways.CORRIDORS


@dataclass(frozen=True)
class PatchOptions:
    #: Cells are at least this many junction spacings across ...
    cell_size: float = 5.0
    #: ... and the district has about this many of them: large patches keep the town's structure.
    cells: int = 3
    #: Candidate patches drawn from the town (street points, by length) ...
    candidates: int = 48
    #: ... of which those whose street density is within this factor band of the median are used.
    density_band: tuple[float, float] = (1.0, 2.5)
    #: A patch turns to match its neighbours' grid only when both have a clear main direction:
    #: the fullest 5° bin of bearings (mod 90°) holds this many times its share.
    orientation_peak: float = 2.0
    #: Discs of the district's area measured on the town for the target density.
    density_discs: int = 64
    #: Copied streets keep this many spacings from the town's streets (they meet them only in tees).
    clearance: float = 0.15
    #: A seam's cut ends this many spacings apart may continue into each other (in a smooth curve) ...
    seam_gap: float = 1.2
    #: ... if the street turns by at most this much there (degrees).
    seam_turn: float = 75.0
    #: Spread of the seam's transition probability: gap (in spacings) and bend (degrees).
    seam_sigma: tuple[float, float] = (0.4, 30.0)
    #: When set, a seam link is judged by how the street bends through it, chord by chord
    #: (:data:`BEND_STEP`), and bends no more sharply than this share of the town's own chord bends
    #: do: a link between two cut streets that do not line up is a zig-zag across the seam (Krems seed
    #: 0: a third of the district's bends over 45° were seam links). Off by default: over seeds 0-4 of
    #: the five benchmark towns neither the 90th nor the 99th percentile brought the curvature into
    #: range, and the cut streets trimmed instead cost Monaco and Krems measures (README, issue 20) ...
    seam_bend_quantile: float | None = None
    #: ... or this many degrees where the town's bends are not measured (no ``measure``).
    seam_bend: float = 20.0
    #: When set, a cut street whose trimming would leave its junction a corner sharper than this
    #: (degrees) is the first kept as a cul-de-sac (within the dead-end budget): an L where the town
    #: had a T. Off by default, for the same reason.
    corner_bend: float | None = None
    #: With ``corner_bend`` set: a cut street whose trimming would leave such a corner is kept whatever the
    #: dead-end budget, and the dead-end steps (:func:`_fewer_dead_ends`, :func:`_shorter_trees`) never
    #: drop it: the tee stays a junction. Off by default: at 45°, seeds 0-4, each at the default run's
    #: site, the district's corners over 45° at degree-2 nodes per km (:func:`sharp_corners`) fall
    #: (Krems 7.1 -> 5.1, Andorra 5.6 -> 4.6, north-bayreuth 8.0 -> 6.9, Campo Grande 4.9 -> 4.3, Monaco
    #: 7.5 -> 6.3) but the kept arms are dead ends: Krems' dead-end share in range on 2 of 5 seeds, mean
    #: off Andorra 3.0 -> 3.6, Monaco 2.2 -> 4.0 (README, issue 20).
    keep_tees: bool = False
    #: When set (degrees), a seam link is made only where the street through it turns no more than this
    #: at any vertex, where it meets its two cut streets included (:func:`~synth.patches.seams._joint_turn`):
    #: most of the district's sharp turns at degree-2 nodes are those joints (Krems seed 0: 18 of 41,
    #: Monaco 31 of 95). Off by default: at 45°, seeds 0-4 at the default run's site, corners per km
    #: Krems 7.1 -> 5.2, Andorra 5.6 -> 4.7, Campo Grande 4.9 -> 3.1, north-bayreuth 8.0 -> 7.8, mean off
    #: 2.0, 2.4 (from 3.0), 2.6, 2.8 (from 2.6), but Monaco 2.2 -> 4.0 (its refused links trimmed).
    seam_joint: float | None = None
    #: When set, two cut ends closer than a connector step (:data:`CONNECTOR_STEP`) that a seam link would
    #: join meet halfway (:func:`~synth.patches.seams._meet_midway`): the straight link between them
    #: turned twice across the seam, a jog. Off by default: seeds 0-4 at the default run's site, corners
    #: per km Krems 7.1 -> 6.2, Campo Grande 4.9 -> 3.7, Monaco 7.5 -> 6.4, Andorra 5.6 -> 5.2,
    #: north-bayreuth 8.0 -> 8.0, mean off 1.8, 2.4, 2.4, 2.6 but Andorra 3.2 (issue 20 asks at most 3).
    #: And in the pipeline each of these three options moves Monaco's district: the site loop takes the
    #: first site whose district joins the town at two points, and the changed growth at the 2nd-ranked
    #: site now does (the default run's is the 3rd), 15 km of street where the town's neighbourhoods
    #: hold 12, off on 5-8.
    seam_meet: bool = False
    #: When set, perimeter streets run on past the cut streets they meet (which meet them in tees
    #: where they cross the edge's inset) and are pulled taut over the jagged edge of the free land
    #: (:func:`_perimeter_runs`), where by default one links each two cut ends along the edge, a U of
    #: two L-bends. Off by default: with ``seam_bend_quantile`` 0.9, over seeds 0-4 Campo Grande's
    #: curvature came into range on 5 of 5 seeds and Krems and north-bayreuth were off on fewer measures
    #: (0.8, 1.6 of 14), but Monaco's many short perimeter pieces put it off on 6.8 (edge and stroke
    #: length, circuity) and Andorra on 3.8; alone, Krems 0.4, north-bayreuth 2.2, Campo Grande 1.6,
    #: Andorra 5.4, Monaco 5.2, the curvature in range on 3, 0, 2 and 0 of 5 seeds for Krems,
    #: north-bayreuth, Campo Grande and Monaco (README, issue 20).
    perimeter_tees: bool = False
    #: A cut end left over runs on this many spacings to meet a street in a tee ...
    tee_reach: float = 0.6
    #: ... meeting it at this angle or more (degrees).
    tee_angle: float = 35.0
    #: Offsets tried per axis when fitting a patch to its placed neighbours (within half a spacing).
    offsets: int = 9
    #: A street cut by the site's edge stays (a road out of the district) when this many spacings long.
    keep_out: float = 1.0
    #: Connected pieces shorter than this many spacings are dropped.
    min_fragment: float = 2.0
    #: A piece is kept only if a street of the rest or of the town lies this many spacings from it.
    link_reach: float = 2.0
    #: Parts of the free land under this many squares of the junction spacing are left open, but for the
    #: largest: the pipeline's smallest district (``MIN_BLOCKS``); a sliver between the town's roads holds
    #: a scrap of streets, a second piece on the map, not a neighbourhood (Monaco: 0.01 km² beside 0.7).
    min_land: float = 9.0
    #: Dead ends closed for the 2-core share's sake leave at least this share of the dead ends the aimed
    #: dead-end share allows: the town's neighbourhoods' 10th percentile is about 0.3-0.5 of their
    #: median (Krems 0.03-0.05 of 0.10, Monaco 0.05-0.10 of 0.13; district_fidelity.py --table).
    dead_end_floor: float = 0.5
