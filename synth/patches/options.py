"""Example patches' tunables, and the road classes a patch never copies."""
from __future__ import annotations

from dataclasses import dataclass

from osm_expand.errors import OptionError
from osm_expand.model import highways

#: Highway classes never copied into a district: a piece of motorway in a housing estate is no street.
NOT_COPIED = highways.CORRIDORS


@dataclass(frozen=True)
class PatchOptions:
    #: Cells are at least this many junction spacings across ...
    cell_size: float = 5.0
    #: ... and the district has about this many of them: large patches keep the town's structure.
    cells: int = 3
    #: Candidate patches drawn from the town's neighbourhoods (the denser half of junction discs, as the
    #: fidelity yardstick draws them) ...
    candidates: int = 48
    #: ... of which those whose street density is within this factor band of the median are used. 1-2.5
    #: dates from candidates drawn on any street, where the median was a country road; on the
    #: neighbourhoods it keeps their denser half, the town's densest quarter (Andorra: its straight valley
    #: floor, median curvature 0.25° against 2.0° over all its neighbourhoods at 514 m), and every engine
    #: district copies the top-ranked of those. 0.5-2 (a factor of two either way) in the default history's
    #: first two eras, seed 0, engine streets off of 14 per reference seed: Andorra 6 8 7 -> 0 0 0,
    #: north-bayreuth 2 1 2 -> 1 1 1, Monaco 7 8 6 -> 5 5 6, but Krems 1 2 1 -> 4 3 3, Campo Grande 6.0 ->
    #: 8.7 (its 2-core share below range) and, with Krems' buildings withheld, 5 real houses crossed
    #: (0 before): not the default (docs/growth-log.md, h29e).
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
    #: Whether the district's topology (its stub budget, :func:`~synth.patches.topology._fewer_dead_ends`,
    #: :func:`~synth.patches.topology._more_dead_ends`) reads a road out on the site's edge as a street running on
    #: (the pipeline's district, judged in its region: the yardstick opens it) or, False, as the dead end it is
    #: once the district stands in the fields (the engine's growth verdict judges its streets in their own
    #: buffer, where a road out ends). The streets are kept either way (:func:`~synth.patches.topology._trim`).
    #: Off (True), measured for the engine's eras (session 33, h33c; ``engine_growth.py --seed 0``, off of 14 per
    #: reference): north-bayreuth 5 5 5 -> 5 5 5 (2-core share 0.766 -> 0.801), Monaco 2 3 3 -> 4 4 4; seed 2
    #: north-bayreuth's 2-core 0.7233 -> 0.7382.
    roads_out_open: bool = True
    #: Grow the district as one whole neighbourhood of the town, fitted to the free land (turned and
    #: shifted to keep the most of its streets and junctions there), clipped, its cut streets run on to
    #: the town or trimmed back to their last junction: no cells, seams or perimeter streets
    #: (:mod:`synth.patches.transplant`). On by default since session 43: the quilt of patches it replaces
    #: read, in every picture, as a zig-zag knot of bent streets (corners over 45 degrees at degree-2 nodes,
    #: per km, 6.5-12.1 against the town's neighbourhoods' 1.2-1.6), the transplant as a piece of the town
    #: (2.1-7.9). Issue 20's tables, quilt -> transplant (with :attr:`transplant_fallback`; sessions 40-42,
    #: docs/growth-log.md): the district (``district_fidelity.py --table``, seeds 0-4, mean off of 14) Krems
    #: 2.0 -> 0.2, Andorra 3.0 -> 3.0, north-bayreuth 2.6 -> 1.2, Campo Grande 2.6 -> 1.6, Monaco 2.4 -> 2.4,
    #: one piece each, density and both shares in range on 4-5 of 5 seeds; the engine's 30 years
    #: (``engine_growth.py --seeds 0-5``, mean off; seeds with both shares in range) Andorra 2.4 (6/6) -> 3.1
    #: (6/6), Krems 2.2 (6/6) -> 1.2 (6/6), north-bayreuth 2.9 (6/6), Monaco over 18 seeds 4.9 (9/18) -> 2.8
    #: (11/18; the misses mostly a 2-core share just out of range). Krems' command costs the same (7.3-7.4 s
    #: CPU against 7.7), Campo Grande's less (59.6 s against 63-64). Its measurements and the variants tried
    #: are in docs/growth-log.md (sessions 40-43) and docs/tried.md.
    transplant: bool = True
    #: With :attr:`transplant` on: where the transplanted district's street length falls below the floor of
    #: the town's neighbourhood densities (:data:`synth.patches.pattern.DENSITY_FLOOR`, the verdict's) times
    #: the free land's area, the quilt grows on that site instead. The district must be a neighbourhood of
    #: the town's density; the whole neighbourhood is preferred where it reaches it (Monaco's narrow third
    #: site keeps about 10 km of any neighbourhood where the floor asks about 10.9). The fallback's quilt draws
    #: its patch ranking from the site's generator as it was before the transplant's draw, so it is the quilt
    #: the default grows there. Does nothing with :attr:`transplant` off (default outputs unchanged). Session 42
    #: (h42g), with transplant on, without -> with: ``district_fidelity.py --table`` Monaco off 2 2 2 1 3 ->
    #: 2 2 2 1 5 (mean 2.0 -> 2.4), density in range 3/5 (ynyyn) -> 4/5 (ynyyy: seed 4's first two sites fall back and
    #: its district is the default's, second site, density 20.81, off 5; seed 1's transplant on the third site, 10.0 km
    #: on 0.52 km², reaches this floor, 19.3 against grow's own 10th percentile of 17.7-19.2, but not the
    #: verdict's 21.09: the verdict's 32 parts are another sample), shares 5/5; Krems 0.2 (0 0 0 0 1) and
    #: Andorra 3.0 (2 1 3 5 4) as without. Without the generator's copy the fallback's quilt drew other
    #: patches: Monaco 6 2 2 1 3, density 3/5. The 25th percentile as the floor: Monaco 1 3 2 1 5, density
    #: 5/5 but 2-core share 4/5 and quilts on four seeds (corners > 45° per km 5.6-8.7 against 3.5-3.6).
    #: Engine (``engine_growth.py --seeds 0-5 --patch-option transplant=true``, Monaco): 3.0 1.0 4.7 4.0 2.0
    #: 7.0 (3.6, shares in range 3/6, re-run back to back) -> 2.0 3.0 4.7 8.3 3.7 2.3 (4.0, 4/6).
    #: A history's eras take it off (:func:`osm_expand.growth_patterns._example_era`: an era grows no district
    #: there rather than a quilt; Monaco over 18 seeds 3.5 -> 2.8 mean off with it on the district only).
    transplant_fallback: bool = True
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

    def __post_init__(self) -> None:
        if not isinstance(self.transplant, bool):
            raise OptionError(f"PatchOptions.transplant must be true or false, got {self.transplant!r}")
        if not isinstance(self.transplant_fallback, bool):
            raise OptionError("PatchOptions.transplant_fallback must be true or false, "
                              f"got {self.transplant_fallback!r}")
        if not isinstance(self.roads_out_open, bool):  # a history's "false" is a string, which Python reads as true
            raise OptionError(f"PatchOptions.roads_out_open must be true or false, got {self.roads_out_open!r}")
