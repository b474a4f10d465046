"""Growing minor streets each year (003 Algorithm 1, GROWMINORROADS; 002 §3).

Where: the candidate set Z (crossings that have not spawned streets, and
temporary points on long segments) ranked by the nuclei of growth
(:mod:`osm_expand.engine.growth.nuclei`, 003 §3.3.2). How: the era's pattern.

- **Street patterns** (000 §4.2.6: ``organic``, ``grid``, ``radial``,
  ``medieval``, ...; :mod:`synth.patterns`) grow this year's number of new
  streets from the best ⌈count / streets_per_start⌉ candidates, on a
  :class:`synth.street_graph.StreetGraph` of the whole city, so every rule
  (no crossing, angles, spacing, bridges) holds against the town too.
- **District patterns** (``example``, ``walk``, ``colonisation``; behind
  :class:`synth.growth.GrowthPattern`) grow districts: the year's street
  length is owed until it makes a district of at least
  :attr:`GrowthOptions.district_neighbourhoods` of the town's neighbourhoods
  (and :attr:`GrowthOptions.min_district` junction spacings; an era's or the
  run's last year grows what is owed), which then
  grows in a disc around the best-ranked candidate (holding the owed length
  at the town's own street density) and joins the town by the shared joining
  step.

New streets are ``planned`` (002 §2: they become built when traffic uses
them), with the year and era they were built in and origin ``engine``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
import shapely
from scipy.spatial import cKDTree

from osm_expand.district import place_district
from osm_expand.engine.growth.nuclei import Nucleus, candidate_points, rank_candidates
from osm_expand.engine.growth.stubs import StubReport, close_stubs
from osm_expand.engine.growth.yardstick import DistrictYardstick, growth_lines
from osm_expand.errors import OptionError
from osm_expand.joins import add_streets
from osm_expand.model import City, Origin, Status, match_points, polyline_length
from osm_expand.model.memo import EachMemo, IdentityMemo
from osm_expand.model.options import is_real_number
from osm_expand.model.segments import SegmentTable
from osm_expand.sites import (
    SETTLEMENT_GAP,
    DistanceMaps,
    SiteOptions,
    choose_sites,
    default_district_area,
    distance_maps,
    raster_at,
    settlement,
    settlement_distance,
    settlement_maps,
)
from synth.growth import GrowthPattern
from synth.patches.topology import STUB_LENGTH
from synth.patterns import PatternOptions, grow_streets
from synth.street_graph import StreetGraph

#: Rounds of candidates a street pattern tries in a year, the batch doubling each round: starts where
#: nothing fits are spent (002 §3.1 marks a node finished "if the expansion fails multiple times") and
#: the next-ranked get their turn, so a year grows its G(t) streets where the town has room for them
#: (one round grew 0 of 11 grid streets a year in Krems' dense centre).
CANDIDATE_ROUNDS = 4
#: A street-pattern stub runs on this many junction spacings to the street ahead, and a shorter one that
#: cannot goes: a block's side. (0.6, the example patches' tee reach, left Krems' suburban eras at 53–61 %
#: dead ends against its neighbourhoods' 7–22 %.)
STUB_REACH = 1.0
#: ℓ, the pathfinding lattice spacing (m): temporary candidate points are ⌊length / 1.25ℓ⌋ per segment (003).
ELL = 20.0


@dataclass(frozen=True)
class GrowthOptions:
    #: A district pattern grows once the owed street length reaches this many junction spacings:
    #: a district of about twenty blocks (the towns hold 1.3–1.8/s metres of street per m² of built-up
    #: land at junction spacing s: :func:`built_up_density`), not a street at a time (the patterns work
    #: at the district scale, and a district is a few blocks).
    min_district: float = 30.0
    #: Sites tried per district, best first (as the pipeline's first district).
    sites_tried: int = 5
    #: A district joined to the town at fewer places is not built (as the pipeline's first district).
    min_joins: int = 2
    #: The site raster has at least this many cells across a district's radius (its cell is
    #: ``radius / site_cells_per_radius``, never under :attr:`SiteOptions.cell`): disc and ring shares
    #: average hundreds of cells either way, and on Campo Grande the whole town's rasters cost 4 s a
    #: district at 10 m against 0.9 s at 20 m, for sites within a cell or two of each other.
    site_cells_per_radius: float = 10.0
    #: The district floor, in neighbourhoods (0: off, :attr:`min_district` alone): a district pattern waits until
    #: the owed length reaches this many times the street length of one of the town's neighbourhoods — a disc of
    #: the pipeline's district area (:attr:`SiteOptions.area_share` of the town's built-up land, at most
    #: :attr:`SiteOptions.neighbourhood_area`: the area of the discs the district verdict judges against) at the
    #: town's built-up street density (:func:`built_up_density`; :func:`neighbourhood_length`). An era (or the run:
    #: ``EngineContext.last_year``) that ends with length owed grows it in its last year (from
    #: :attr:`min_district` spacings on; without the run's end Andorra's seed 1 grew 17 km instead of main's 47, its
    #: ``consolidation`` era's owed length lost when the run ended), and a district due but
    #: refused is tried again every year (at :attr:`min_district`, as without the floor) until one is placed, so a
    #: town whose whole growth is smaller than the floor (Krems: 0.6 km a year against a 6.4 km neighbourhood)
    #: still grows (with one try at each era's end Krems' seed 1 grew no engine street: that try was refused). Why:
    #: one year of a large town's growth exceeds :attr:`min_district` (Campo Grande: 12 km a year at a 99 m
    #: spacing, one neighbourhood 10 km), so its ``contemporary`` era grew 16 small districts (median 15 km,
    #: 0.8 km²) with more rim and seams per km² than the town's neighbourhoods (note30: off 6 6 6; 600 spacings,
    #: 59 km, gave 3 2 3 but grew nothing on Krems). **5 by default** (session 31): judged with the town's window
    #: margin (the default yardstick), run seeds 0, 1, 2 × reference seeds 0, 1, 2, the mean off of 14 per town,
    #: 0 → 5: Krems 1.6 → 3.6, Andorra 6.8 → 1.1, north-bayreuth 3.0 → 3.8, Monaco 4.1 → 3.4, Campo Grande
    #: 6.9 → 3.5 (summed over the towns per run seed 20.7, 23.0, 23.3 → 14.7, 13.7, 17.6; the worst single
    #: reference 7, 8, 11 → 5, 5, 6); Campo Grande's run about 30 % less CPU (7 districts placed instead of 21).
    #: Every town within 4 on the mean over the seeds, none with 0; Krems and north-bayreuth are worse than with 0
    #: (larger districts than their own growth owed in a year). 5 itself is fitted to Campo Grande's need (about 600
    #: junction spacings, note30), only the unit comes from the yardstick. Measured first with the 50 m
    #: margin (``benchmarks/engine_growth.py --fixed-margin --neighbourhoods 5 [--seed 1]``), seed 0: Campo Grande
    #: 6 6 6 → 3 5 5 (21 → 7 districts, 356 → 334 km, its run 148 → 107 s CPU), Andorra 6 8 7 → 0 1 1, Monaco
    #: 7 8 6 → 4 4 5, north-bayreuth 2 1 2 → 5 4 5, Krems 1 2 1 → 2 2 3; seed 1: Andorra 6 5 6 → 1 0 0, Monaco
    #: 6 7 8 → 6 5 6, north-bayreuth 6 6 6 → 3 3 2, Krems 1 2 3 → 3 3 5, Campo Grande 8 8 8 → 4 4 4. Better
    #: overall, not on every town, and beyond 4 on three. At 3 Campo Grande stays 6 5 6 (11 districts); with the
    #: verdict band (PatchOptions ``density_from_verdict``, removed in session 42) at 5 it is 8 7 7
    #: (docs/growth-log.md, "The engine's district floor").
    #: 0 turns the floor off (main before session 31).
    district_neighbourhoods: float = 5.0
    #: Built-up land less than this far apart (m) is one settlement (:func:`osm_expand.sites.settlement`; the
    #: town is the piece with the most built-up land), and a site on land that water cuts off from the *town's*
    #: settlement loses its closeness to the town (:func:`osm_expand.sites.settlement_maps`,
    #: :func:`osm_expand.sites.far_bank`: a river the town lies on both sides of is no divide; the pipeline's
    #: site still reads the straight way to its nearest built-up land). Why: a site's nearest built-up land was
    #: any piece of it, and the way from Krems' engine quarter of 2029 (seed 0) to Mautern, the village on the
    #: far bank of the Danube, crosses no water: it grew there, a separate piece beside the village, not at Krems' edge.
    #: :data:`~osm_expand.sites.SETTLEMENT_GAP` (200 m, the EEA's urban morphological zones) by default;
    #: 0 reads every piece of built-up land as the town (main before session 32). Measured
    #: (``benchmarks/engine_growth.py --seed S``, off of 14 per reference seed, main → 200 m): seed 0 Krems
    #: 2 2 4 → 1 1 1 (15.7 → 10.4 km, both quarters at Krems' eastern edge), north-bayreuth 5 5 5 → 2 3 2 (its
    #: quarter in the fields 4 km east of the town now at the town's southern edge; 1 → 2 pieces, 27.4 → 19.5 km),
    #: Andorra and Monaco the same bytes; seed 1 Krems 4 3 4 → 0 0 1 but 12.6 → 4.3 km (the run's last district,
    #: due, refused at all five sites at Krems' filled eastern edge), north-bayreuth 3 3 3 → 2 3 2. Those were
    #: with the straight way to the settlement crossing water as the far bank; with the land water cuts off
    #: (:func:`~osm_expand.sites.far_bank`, session 32 h32w), straight line → land: seed 0 Krems 1 1 1 → 1 1 1
    #: (10.2 km, both quarters still at Krems' eastern edge), north-bayreuth 2 3 2 → 5 5 5 (main's: the stream
    #: its quarter in the fields was across runs through the town), Andorra 0 0 0 and Monaco 2 3 3 unchanged;
    #: seed 1 Andorra 5 5 4 → 0 0 1 (main's), Krems 0 0 1 → 3 3 4 (4.3 → 9.1 km: its last district grows at the
    #: eastern edge by the harbour basin, curvier and with smaller blocks than the town), north-bayreuth
    #: 2 3 2 → 3 3 3, Monaco 3 3 2 unchanged.
    settlement_gap: float = SETTLEMENT_GAP
    #: The district floor (:attr:`district_neighbourhoods`) is at most this share of the town's own settlement's
    #: street length (:func:`settlement_length`: the largest piece of built-up land, :attr:`settlement_gap` gaps
    #: bridged, at the town's built-up street density); ``inf``: the floor alone; 0.5 (the default): a district is at
    #: most half the town. Why: the
    #: neighbourhood the floor counts in is Perry's unit (0.65 km²) wherever the whole extract holds 2.6 km² of
    #: built-up land, and an extract of villages holds that though its town is small, so 5 neighbourhoods make
    #: one district of 3.25 km², larger than north-bayreuth's town without its buildings (2.87 km²): its
    #: district's region (a disc of free land up to twice its radius, cut by the country roads) reached 1.2 km
    #: from its centre, and the patches grew three clusters in the fields, 1-2 km apart. A town grows by its
    #: edge, a part at a time: 0.25, the pipeline's own district share (:attr:`SiteOptions.area_share`), put
    #: Andorra out of range (below); 0.5, at most half the town, is the default.
    #: A district smaller than the floor is due sooner and the next grows beside it (its blocks are built-up
    #: land then, which a site's closeness and contact count). Off: measured at 0.25 (session 36, h36g; off of 14 per
    #: reference seed, main 78bb88f -> on), seed 0: Andorra 0 0 0 -> 8 8 10, north-bayreuth 5 5 5 -> 4 5 5 (4
    #: quarters of 6-9 km, a median 120-664 m from its settlement, against 2 of 12-14 km at 1126-1698 m), Krems
    #: 1 1 1 and Monaco 2 3 3 the same; seed 1 Andorra 0 0 1 -> 5 6 7 (14 % outlying). With
    #: :attr:`district_town_reach` 1.5 as well: seed 0 Andorra 6 4 5, north-bayreuth 5 6 6, Krems and Monaco and
    #: Campo Grande (3 5 4: its settlement holds far more than 5 neighbourhoods) the same; seed 1 Andorra 9 9 8,
    #: north-bayreuth 2 3 3, Krems 3 3 4 and Monaco 6 5 5 the same; seed 2 Andorra 10 9 10, north-bayreuth 2 3 2
    #: (2-core 0.744 below its range), Krems 1 2 3 and Monaco 4 5 5 the same. Without its buildings (seed 0)
    #: north-bayreuth's quarters, 2 a median 863 and 180 m from its settlement, became 6 at 108-515 m around it
    #: (one piece each; off 4 3 2 -> 2 5 3 alone). At 0.5 with :attr:`district_town_reach` 1.5 (a district at most
    #: half the town; the floor binds on north-bayreuth, Krems and Monaco, not Andorra's 42 km against 33): seeds
    #: 0-2 on Krems, Andorra, north-bayreuth and Monaco off of 14 exactly as with the reach alone (their eras end
    #: before the lower floor is owed, or its districts grow where the reach's did); without its buildings (seed 0)
    #: north-bayreuth's 2 quarters (a median 863 and 180 m from its settlement, off 4 3 2) become 4 at 114-305 m
    #: round the town, north, north-west, west and south (off 2 3 2, 2 pieces; 19.6 -> 32.3 km grown, why not
    #: looked into).
    #: On since session 36 at 0.5, with :attr:`district_town_reach` 1.5: the same off counts as the reach alone on the
    #: five towns (seeds 0-2), and the picture of a town without its buildings reads as the town growing.
    district_town_share: float = 0.5
    #: An engine district's site is tried only when its centre lies within this many district radii of the town's
    #: settlement (:func:`osm_expand.sites.settlement_distance`: the largest piece of built-up land, the engine's
    #: earlier quarters in it once their blocks stand within :attr:`settlement_gap` of it); the best
    #: :attr:`sites_tried` of twice as many sites so near are tried, and none when none is (the district stays due
    #: and is tried next year). ``inf``: every site. Why: a site's closeness and contact count any
    #: built-up land, so when the sites by the town were refused (too few joins) the fifth, by a hamlet 7 km away,
    #: took the district (north-bayreuth without its buildings, seed 0, with :attr:`district_town_share` 0.25:
    #: its 2023 quarter). 1.5 (the default): a site's disc (one radius) within half a radius of the town's edge. On
    #: since session 36: the issue's promise is a new quarter at the town's edge, and no town leaves issue 20's engine
    #: target (at most 4 of 14 off, shares in range) on any seed where it was in. Measured at 1.5
    #: (``benchmarks/engine_growth.py --seed S --measures --where --option district_town_reach=1.5``, off of 14 per
    #: reference seed, main 78bb88f -> on; session 36, h36g), seed 0: north-bayreuth 5 5 5 -> 2 3 2 (its two quarters
    #: a median 1698 and 1126 m from the town's settlement, in the fields by the motorway, -> 305 and 132 m, at its
    #: edge), Andorra 0 0 0 -> 1 1 1 (its second quarter, by a valley town 3.3 km from Andorra la Vella, -> at the
    #: largest settlement, 254 m), Krems 1 1 1, Monaco 2 3 3 and Campo Grande 3 5 4 the same; seed 1: Andorra
    #: 0 0 1 -> 2 2 2, Krems 3 3 4, north-bayreuth 3 3 3, Monaco 6 5 5 and Campo Grande 4 5 5 the same; seed 2:
    #: Andorra 2 4 3 -> 3 3 4, north-bayreuth 4 4 2 -> 3 4 2 (2-core 0.723 -> 0.729, below its range either way),
    #: Krems 1 2 3, Monaco 4 5 5 and Campo Grande 3 4 4 the same. Withheld buildings
    #: (``benchmarks/withheld_buildings.py --option district_town_reach=1.5``): north-bayreuth 0.5 % on a real
    #: building and 0 crossed, Krems 0 % and 0, as off. It bounds a site's centre, not its district: the region
    #: (a disc up to twice the radius, :func:`osm_expand.sites.district_region`) and the patches' cells reach
    #: further (north-bayreuth with its buildings dropped in memory, seed 0, with :attr:`district_town_share` 0.5
    #: too: its 2037 quarter a median 1153 m from the town's settlement, 900 m from it or the earlier quarters).
    #: Summed over the four small towns and three seeds 101 -> 101: north-bayreuth's gain (mean
    #: 3.78 -> 2.78, its seed 0 within 4) is Andorra's loss (1.11 -> 2.11, within 4 on every seed); Andorra's valley
    #: towns (1.1-1.85 km² each beside its 8.4 km² largest settlement) are where the verdict likes its growth, and
    #: they are as large as north-bayreuth's villages (1.1-1.8 km² beside its 2.1 km² town), so no size tells them
    #: apart (as a settlement-size threshold, measured and not adopted, found: ``docs/tried.md``). Without its
    #: buildings north-bayreuth is unchanged
    #: (its sites' centres lie near the town; the quarter in the fields is its region's, :attr:`district_town_share`).
    district_town_reach: float = 1.5
    #: Whether a street pattern's era (``grid``, ``organic``, ``suburban``, ...) aims its connectedness at its
    #: town's neighbourhoods, as the district's topology does (:mod:`synth.patches.topology`): each year, while the
    #: era's streets (measured as the growth verdict measures an era, on their streets' land, against the town's
    #: neighbourhood discs pooled per piece: :meth:`~osm_expand.engine.growth.yardstick.DistrictYardstick.aim`) have
    #: fewer dead ends than the neighbourhoods' median share and more of their length on the 2-core than its
    #: median, the year's stubs that ran on to the street ahead (:func:`~osm_expand.engine.growth.stubs.close_stubs`)
    #: are taken back, the longest first, until the estimate reaches either median; a stub taken back stays a
    #: cul-de-sac (or goes, when shorter than the stub reach). Why: issue 20, "eras with a named pattern may differ
    #: from the town in orientation and angles, but not in connectedness"; the run-ons close every stub they can, so
    #: Krems' gründerzeit grid (13.1 km) had a 2-core share of 0.973 against its neighbourhoods' 0.885-0.959.
    #: District patterns are not touched (their topology aims already), so the default history is the same bytes.
    #: A kept stub's own nodes are spent as growth starts (:func:`_kept_nodes`): it stays a cul-de-sac for good and
    #: does not seed next year's streets (kept stubs that grew on made north-bayreuth's grid 14.8 -> 38 km).
    #: On: measured (session 37, h37e/h37e2; ``cd fixtures && python ../benchmarks/engine_growth.py --seed S
    #: --history european [--eras] --measures --option pattern_aim=true TOWN``; mean off of 14, dead-end / 2-core
    #: share, off -> on): Krems seed 0 12.0 -> 11.0, 0.085 / 0.9684 above [0.885-0.9674] -> 0.130 / 0.942, both in
    #: (the grid era 0.060 / 0.973 -> both in); seed 1 10.7 -> 11.3, both in either way; seed 2 the same bytes
    #: (dead-end 0.154 just above [0.027-0.151]); north-bayreuth seed 0 11.3 -> 12.0 (dead-end below -> in, 2-core
    #: above either way), seed 1 10.0 -> 10.0 (dead-end below -> 0.302 just above [0.185-0.300], 2-core above -> in),
    #: seed 2 12.3 -> 12.0 (dead-end 0.186 in -> 0.193 just below [0.201-0.285], 2-core above either way); Monaco seed
    #: 0 14.0 -> 12.7 (dead-end below -> in), Andorra seed 0 14.0 -> 13.0 (dead-end below -> in; 69 -> 78 km). Shares
    #: in range over these 8 runs 5 -> 9 of 16, mean off summed 96.0 -> 93.7: on, for the reason above, although
    #: north-bayreuth seed 2's dead-end share slips out by 0.008. Acting only while a share is outside the range was
    #: worse (north-bayreuth seeds 1, 2 both shares out); keeping no stubs left Krems' 2-core out (0.972).
    pattern_aim: bool = True

    def __post_init__(self) -> None:
        # a negative or NaN floor would silently turn the floor off (or never let a district grow)
        if not (np.isfinite(self.district_neighbourhoods) and self.district_neighbourhoods >= 0):
            raise OptionError(f"growth option district_neighbourhoods must be a finite number of neighbourhoods "
                              f">= 0, got {self.district_neighbourhoods!r}")
        if not (np.isfinite(self.settlement_gap) and self.settlement_gap >= 0):
            raise OptionError(f"growth option settlement_gap must be a finite number of metres >= 0, "
                              f"got {self.settlement_gap!r}")
        if not isinstance(self.pattern_aim, (bool, np.bool_)):  # a string "false" would read as on
            raise OptionError(f"growth option pattern_aim must be a bool, got {self.pattern_aim!r}")
        if not (is_real_number(self.district_town_reach) and self.district_town_reach > 0):  # NaN, 0 or negative
            raise OptionError(f"growth option district_town_reach must be a number of district radii > 0 "
                              f"(inf: every site), got {self.district_town_reach!r}")
        if not (is_real_number(self.district_town_share) and self.district_town_share > 0):  # NaN, 0 or negative
            raise OptionError(f"growth option district_town_share must be a share > 0 of the town's settlement "
                              f"(inf: the floor alone), got {self.district_town_share!r}")


@dataclass
class GrowthMemory:
    """What street growth remembers from year to year (not part of the city)."""

    spawned: set[int] = field(default_factory=set)  #: city nodes that spawned streets (or never will)
    #: (F, 2) points where growth failed (003: finished)
    failed: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    owed: float = 0.0  #: street length a district pattern owes (m)
    #: street length of one of the town's neighbourhoods (m; :func:`neighbourhood_length`), measured once, on
    #: the town as it was when the first district was owed; None: not yet
    neighbourhood: float | None = None
    #: street length of the town's settlement (m; :func:`settlement_length`), measured with :attr:`neighbourhood`
    #: when :attr:`GrowthOptions.district_town_share` is finite; None: not measured
    settlement: float | None = None
    #: a district is due (:attr:`GrowthOptions.district_neighbourhoods`: the floor was reached or an era ended
    #: with length owed): tried every year, at what is owed, until one is placed
    due: bool = False
    #: the town's neighbourhoods a named pattern's era aims at (:attr:`GrowthOptions.pattern_aim`; measured once a
    #: run, the first time an era is aimed); None: not yet
    yardstick: DistrictYardstick | None = None


@dataclass(frozen=True)
class GrowthYear:
    """What one year of street growth did."""

    streets: int = 0  #: new streets
    length_m: float = 0.0
    bridges: int = 0
    districts: int = 0  #: districts grown by a district pattern

    def __add__(self, other: GrowthYear) -> GrowthYear:
        return GrowthYear(self.streets + other.streets, self.length_m + other.length_m,
                          self.bridges + other.bridges, self.districts + other.districts)

    def to_dict(self) -> dict:
        return {"streets": self.streets, "length_km": round(self.length_m / 1000, 3), "bridges": self.bridges,
                "districts": self.districts}


def grow_street_pattern(city: City, count: int, options: PatternOptions, nuclei: list[Nucleus],
                        memory: GrowthMemory, rng: np.random.Generator, *, year: int, era: str,
                        centre: np.ndarray, reach: float | None = None,
                        aim: DistrictYardstick | None = None) -> tuple[City, GrowthYear]:
    """Grow ``count`` new streets with a street pattern from the best candidates (003 §3.3.2, 000 §4.2.6).

    With ``reach`` (m), the year's stubs run on to the street ahead or go
    (:func:`osm_expand.engine.growth.stubs.close_stubs`): connectedness is the
    town's whatever the pattern. With ``aim`` too, run-ons are taken back while
    the era is more connected than the town's neighbourhoods
    (:attr:`GrowthOptions.pattern_aim`, :func:`_withheld`)."""
    if count <= 0:
        return city, GrowthYear()
    table = SegmentTable.from_city(city)
    graph = StreetGraph.from_segments(table.xy, table.uv, created=np.maximum(table.year, 0), bridge=table.bridge,
                                      major=table.major)
    n_nodes, n_segments = graph.n_nodes, graph.n_segments
    degree = graph.degree
    graph.spawned[:] = degree == 2  # shape points never start a street
    spawned = np.fromiter(memory.spawned, dtype=np.int64, count=len(memory.spawned))
    graph.spawned[spawned[spawned < n_nodes]] = True
    failed = memory.failed
    water, forbidden = city.water_geometry(), _forbidden(city)
    splits: list[tuple[np.ndarray, np.ndarray]] = []
    made, batch = 0, math.ceil(count / options.streets_per_start)
    for _ in range(CANDIDATE_ROUNDS):  # failed starts are spent; the next-ranked ones get their turn
        z = candidate_points(graph, spawned_mask=graph.spawned, ell=ELL, max_degree=options.max_degree,
                             temporary_points=options.segment_starts, segment_mask=_not_bridges(graph),
                             exclude_points=failed if len(failed) else None)
        if reach is not None and len(z):
            z = z.take(np.flatnonzero(_at_the_edge(city, z.xy, reach)))
        if not len(z):
            break
        starts = z.take(rank_candidates(z.xy, nuclei, take=batch))
        step = grow_streets(graph, starts, options=options, rng=rng, water=water, forbidden=forbidden,
                            centre=centre, time=float(year))
        splits.append((step.split_segment, step.split_new_segment))
        failed = np.vstack([failed, np.asarray(step.failed_xy, dtype=float).reshape(-1, 2)])
        made += len(step.new_segments)
        if made >= count:
            break
        batch *= 2
    memory.spawned |= set(np.flatnonzero(graph.spawned[:n_nodes]).tolist())
    memory.failed = failed
    if not splits:
        return city, GrowthYear()
    lines, bridges = _new_lines(graph, splits, n_segments)
    report = StubReport()
    if reach is not None and lines:
        town = city.network
        stub_args = (town.street_lines(), town.xy[town.used_nodes()], shapely.GeometryCollection([water, forbidden]))
        grown_lines, grown_bridges, report = close_stubs(lines, bridges, *stub_args, reach=reach,
                                                         loops=_never_closes(options))
    else:
        grown_lines, grown_bridges = lines, bridges
    if not grown_lines:
        return city, GrowthYear()

    def added(new_lines: list[np.ndarray], flags: list[bool]) -> City:
        attrs = [{"highway": "residential", "hierarchy": 9, "origin": Origin.ENGINE, "status": Status.PLANNED,
                  "year": year, "era": era, "bridge": b, "layer": 1 if b else 0} for b in flags]
        return add_streets(city, new_lines, attrs)

    before = len(city.network.streets)
    grown = added(grown_lines, grown_bridges)
    if aim is not None and reach is not None and (report.ran or report.short or report.stubs):
        withhold, keep, drop = _withheld(grown, era, aim, lines, report, reach, closes=not _never_closes(options))
        if withhold or keep or drop:
            again, again_bridges, _ = close_stubs(lines, bridges, *stub_args, reach=reach,
                                                  loops=_never_closes(options), withhold=withhold, keep=keep,
                                                  drop=drop)
            if again:
                grown, grown_lines, grown_bridges = added(again, again_bridges), again, again_bridges
                memory.spawned |= _kept_nodes(city, grown, [lines[k] for k in keep])  # culs-de-sac for good
    lines, bridges = grown_lines, grown_bridges
    new_nodes = match_points(graph.xy[n_nodes:], grown.network.xy)  # crossings made this year spawned
    memory.spawned |= {int(n) for n, s in zip(new_nodes, graph.spawned[n_nodes:]) if n >= 0 and s}
    length = sum(float(np.hypot(*np.diff(ln, axis=0).T).sum()) for ln in lines)
    return grown, GrowthYear(streets=len(grown.network.streets) - before, length_m=length, bridges=int(sum(bridges)))


def _kept_nodes(city: City, grown: City, kept: list[np.ndarray]) -> set[int]:
    """The nodes of ``grown`` on the stubs :func:`_withheld` kept (``kept``) that were not nodes of ``city``: spent
    as growth starts (:attr:`GrowthMemory.spawned`), so that a kept stub stays a cul-de-sac and seeds no street
    in a later year."""
    if not kept:
        return set()
    at = match_points(np.vstack(kept), grown.network.xy)
    old = match_points(np.vstack(kept), city.network.xy)
    return {int(n) for n, o in zip(at.tolist(), old.tolist()) if n >= 0 and o < 0}


def _withheld(grown: City, era: str, aim: DistrictYardstick, lines: list[np.ndarray], report: StubReport,
              reach: float, *, closes: bool = True
              ) -> tuple[frozenset[tuple[int, int]], frozenset[int], frozenset[int]]:
    """The stub ends whose run-on is taken back, the short stubs kept and the culs-de-sac dropped (of ``lines``,
    the year's new streets before :func:`~osm_expand.engine.growth.stubs.close_stubs` made ``report``) so that the
    era's streets in ``grown`` come nearer its town's neighbourhoods' median dead-end and 2-core shares
    (:attr:`GrowthOptions.pattern_aim`), as the district's topology brings its own to them
    (:mod:`synth.patches.topology`).

    More connected than the town (fewer dead ends and more of the length on the 2-core than the medians): run-ons
    are taken back and short stubs kept. A run-on taken back: its tee was a junction and its stub becomes a dead end
    (the count of dead ends and junctions stays), and the stub's street leaves the 2-core; only stubs at least
    ``reach`` long (a shorter one would go instead of staying). A short stub kept (at least
    :data:`synth.patches.topology.STUB_LENGTH` spacings, as the district keeps a cut street as a cul-de-sac): a dead
    end and the tee it hangs from, and its length off the 2-core. The longest first: the fewest dead ends for the
    2-core share the era is above.

    Less connected (more dead ends and less on the 2-core), for a pattern that never ``closes`` its trees
    (:func:`_never_closes`: its dead ends stay dead ends): culs-de-sac go, the shortest first, each a dead end, its
    tee and its length. A pattern that closes its trees in later years keeps them (a young grid is all trees).

    Acting also on a share out of the neighbourhoods' range while the other stays in it was measured and not
    adopted (``docs/tried.md``).

    Each step is estimated, not measured again."""
    none: tuple[frozenset[tuple[int, int]], frozenset[int], frozenset[int]] = (frozenset(), frozenset(), frozenset())
    got = aim.aim(*growth_lines(grown, era=era))
    if got is None:
        return none
    (length, _, dead, counted, core), medians = got
    dead_aim, core_aim = float(medians[1]), float(medians[2])
    if not (counted > 0 and length > 0 and np.isfinite(dead_aim) and np.isfinite(core_aim)):
        return none

    def looser() -> bool:
        """Whether the era should lose connectedness: both shares on the connected side of their medians."""
        return core / length > core_aim and dead / counted < dead_aim

    def tighter() -> bool:
        """Whether the era, of a pattern that never closes its trees, should lose dead ends: both shares on the
        tree side of their medians."""
        return not closes and dead / counted > dead_aim and core / length < core_aim

    withhold: set[tuple[int, int]] = set()
    keep: set[int] = set()
    drop: set[int] = set()
    if looser():
        least = STUB_LENGTH * reach / STUB_REACH
        candidates = [(polyline_length(lines[k]), False, k, side) for k, side in report.ran
                      if polyline_length(lines[k]) >= reach]
        candidates += [(polyline_length(lines[k]), True, k, -1) for k in report.short
                       if polyline_length(lines[k]) >= least]
        for stub, kept, k, side in sorted(candidates, reverse=True):
            if not looser():
                break
            if k in keep or any(j == k for j, _ in withhold):  # one end of a street at most
                continue
            dead += 1
            if kept:
                keep.add(k)
                counted, length = counted + 2, length + stub
            else:
                withhold.add((k, side))
                core -= stub
    elif tighter():
        for stub, k in sorted((polyline_length(lines[k]), k) for k in report.stubs):
            if stub >= length or not tighter():
                break
            drop.add(k)
            dead, counted, length = dead - 1, counted - 2, length - stub
            if counted <= 0:  # no dead end or junction left to count
                break
    return frozenset(withhold), frozenset(keep), frozenset(drop)


def _never_closes(options: PatternOptions) -> bool:
    """Whether a pattern's later streets never close a tree it grew: without Snap and Extend (000 §4.2.6;
    ``suburban``) no street ever runs on to another's end, so a tree hung on the town at one point stays a
    comb's tooth for good (Krems' european history: its two suburban eras made 22 of the engine's 26 dead
    ends on 8 of its 25 km), and it goes (:func:`osm_expand.engine.growth.stubs.close_stubs`' ``loops``). A pattern
    that snaps or extends closes its trees in later years: dropping them each year starved the grid of
    Krems' Gründerzeit from 15.4 km to 2.9."""
    return not (options.snap_enabled or options.extend_enabled)


#: a KD-tree of the vertices of the town's land (:attr:`~osm_expand.model.land.Land.town`, the very array;
#: :func:`_at_the_edge`): a run's land does not change, its years ask again and again
_TOWN_VERTICES = IdentityMemo(kept=2)


def _at_the_edge(city: City, xy: np.ndarray, reach: float) -> np.ndarray:
    """Per point, whether it lies within ``reach`` of the built-up land: the town's land
    (:attr:`~osm_expand.model.land.Land.town`) or a street the tool made. Towns grow at the edge of
    what is built and along its roads, not out of a country road in the fields (Liu et al. 2010's
    outlying growth)."""
    near = np.zeros(len(xy), dtype=bool)
    points = shapely.points(xy)
    if city.land is not None and len(city.land.town):
        # a point within reach of a vertex of the town's land is within reach of the land (the vertex lies on
        # it; a micrometre short, for the rounding of the two distances): found in a KD-tree of the vertices,
        # and only the other points are measured against the polygons (all of them were: 0.66 s a call, 0.11 s
        # now, on Campo Grande's european years, 189 calls; 46,090 of 50,837 points near, the same ones)
        town = city.land.town
        vertices = _TOWN_VERTICES.get((town,), "vertices", lambda: cKDTree(shapely.get_coordinates(town)))
        dist, _ = vertices.query(xy, k=1, distance_upper_bound=reach)
        near = dist <= reach - 1e-6
        rest = np.flatnonzero(~near)
        near[rest[city.land.town_tree.query(points[rest], predicate="dwithin", distance=reach)[0]]] = True
    lines = city.network.street_lines()
    made = np.array([s.is_new for s in city.network.streets], dtype=bool)
    if made.any():
        near[shapely.STRtree(lines[made]).query(points, predicate="dwithin", distance=reach)[0]] = True
    if city.land is None:
        near[:] = True
    return near


#: each town block's polygon shrunk 1 m (:func:`_forbidden`), made once for the very same polygon: the blocks a
#: street did not change are last year's polygons (Krems' 150 north-american years: 1,008 blocks a year at the end)
_SHRUNK = EachMemo()


def _forbidden(city: City) -> shapely.Geometry:
    """Where no street may go: the blocks that are town (shrunk 1 m), unbuildable land and the land the
    town is presumed to take where no building is mapped near (:attr:`~osm_expand.model.land.Land.presumed`:
    its frontage and settlement); water is handled by the pattern's bridges. A collection, not a union:
    the patterns only ask whether a segment touches it
    (GEOS ≥ 3.13 answers that for overlapping parts), and the union of Campo Grande's blocks cost a
    second a year."""
    blocks = city.town_block_polygons()
    parts = _SHRUNK.get([(b,) for b in blocks.tolist()], lambda missing: shapely.buffer(blocks[missing], -1.0).tolist())
    if city.unbuildable is not None:
        parts.append(city.unbuildable)
    if city.land is not None:  # where buildings are mapped, they (unbuildable, with a margin) are what stops a street
        parts.extend(city.land.presumed.tolist())
    return shapely.GeometryCollection([p for p in parts if not p.is_empty])


def _not_bridges(graph: StreetGraph) -> np.ndarray:
    return ~np.asarray(graph.bridge[:graph.n_segments], dtype=bool)


def _new_lines(graph: StreetGraph, splits: list[tuple[np.ndarray, np.ndarray]], n_old: int
               ) -> tuple[list[np.ndarray], list[bool]]:
    """The segments this step made, chained into polylines at their own degree-2 nodes.

    The far half of a split *old* segment is part of an old street (the tee
    node is inserted into that street by :func:`osm_expand.joins.add_streets`),
    so it is not a new street; halves of split new segments are.
    """
    old = set(range(n_old))
    for segments, fars in splits:  # in the order the steps made them: a half of a half is old too
        for seg, far in zip(np.asarray(segments).tolist(), np.asarray(fars).tolist()):
            if seg in old:
                old.add(far)
    new = [k for k in range(n_old, graph.n_segments) if k not in old]
    if not new:
        return [], []
    edges, bridge = graph.edges[new], graph.bridge[new]
    xy = graph.xy
    lines, flags = [], []
    used = np.zeros(len(new), dtype=bool)
    ends: dict[int, list[int]] = {}
    for i, (u, v) in enumerate(edges.tolist()):
        ends.setdefault(u, []).append(i)
        ends.setdefault(v, []).append(i)
    degree = graph.degree
    for i in range(len(new)):
        if used[i]:
            continue
        chain = [i]
        used[i] = True
        path = list(edges[i])
        for side in (0, 1):  # extend through nodes where exactly two new segments of one kind meet
            while True:
                node = path[-1] if side else path[0]
                nxt = [j for j in ends[node] if not used[j] and bridge[j] == bridge[i]]
                if degree[node] != 2 or len(nxt) != 1:
                    break
                j = nxt[0]
                used[j] = True
                chain.append(j)
                other = edges[j][1] if edges[j][0] == node else edges[j][0]
                path = path + [other] if side else [other] + path
        lines.append(xy[path])
        flags.append(bool(bridge[i]))
    return lines, flags


def grow_district(city: City, pattern: GrowthPattern, length: float, density: float, nuclei: list[Nucleus],
                  rng: np.random.Generator, *, spacing: float, year: int, era: str,
                  options: GrowthOptions = GrowthOptions()) -> tuple[City, GrowthYear]:
    """A district of about ``length`` metres of street on the best free site.

    The site holds ``length`` at the town's own street density on its
    built-up land (:func:`built_up_density`), or at ``density`` (m per m²;
    the loop passes a grid's 2/s) where the town has no built-up land.

    The sites are the pipeline's (:mod:`osm_expand.sites`: free land next to
    the town, near water, with room), re-ranked by the nuclei of growth
    (003 §3.3.2: distance to the nearest nucleus × (1 − strength)); the
    first whose district joins the town at :attr:`GrowthOptions.min_joins`
    places within a junction spacing of its built-up land (the sites'
    raster, which the LEI reads too: joined to a country road in the
    fields, Monaco's second district grew as outlying growth) is built.
    The far bank of a river is seen from the town's own settlement
    (:attr:`GrowthOptions.settlement_gap`), not from a village on it
    (Krems' quarter beside Mautern). Rules measured and not adopted (the
    nuclei of the settlement alone, a score tolerance, candidates judged by
    the yardstick, ...) are in ``docs/tried.md``.
    Its stubs are the pattern's: closing them as a street pattern's are
    (:mod:`osm_expand.engine.growth.stubs`) left north-bayreuth's engine streets
    with 7 % dead ends against its neighbourhoods' 17–41 %.
    """
    pts = city.network.xy[city.network.used_nodes()]
    margin = 0.5 * float(np.hypot(*(pts.max(axis=0) - pts.min(axis=0)))) if len(pts) else 0.0
    # the rasters at the cell of a district at ``density`` (the finer one: the town's density is lower)
    radius = math.sqrt(max(length / max(density, 1e-9), 9.0 * spacing ** 2) / math.pi)
    site_options = SiteOptions(cell=max(SiteOptions.cell, radius / options.site_cells_per_radius))
    maps = distance_maps(city, site_options, margin=margin)
    town = built_up_density(city, maps)
    area = max(length / (town if town > 0 else max(density, 1e-9)), 9.0 * spacing ** 2)
    if options.settlement_gap > 0:  # the far bank seen from the town, not from a village on the far bank
        maps = settlement_maps(maps, options.settlement_gap)
    district_radius = math.sqrt(area / math.pi)
    if math.isfinite(options.district_town_reach) and maps.city.any():  # the town's edge, not a hamlet's
        sites = choose_sites(maps, area, site_options, most=2 * options.sites_tried)
        near = _from_the_town(maps, np.array([s.centre for s in sites]).reshape(-1, 2), options)
        sites = [s for s, d in zip(sites, near) if d <= options.district_town_reach * district_radius]
        sites = sites[:options.sites_tried]
    else:
        sites = choose_sites(maps, area, site_options, most=options.sites_tried)
    if not sites:
        return city, GrowthYear()
    order = rank_candidates(np.array([s.centre for s in sites]), nuclei, take=len(sites))
    before = len(city.network.streets)
    reach = STUB_REACH * spacing
    placement = place_district(
        city, sites, pattern, spacing=spacing, order=order.tolist(), rng=lambda attempt: rng,
        accept=lambda joins: (_built_up_distance(maps, joins.at) <= reach).sum() >= options.min_joins,
        bounds=city.bounds_polygon, origin=Origin.ENGINE, year=year, era=era)
    if placement.placed is None:
        return city, GrowthYear()
    grown = placement.placed.city
    new = grown.network.streets[before:]
    made = sum(polyline_length(grown.network.street_xy(s)) for s in new)
    return grown, GrowthYear(streets=len(new), length_m=made, bridges=sum(s.bridge for s in new), districts=1)


def _from_the_town(maps: DistanceMaps, xy: np.ndarray, options: GrowthOptions) -> np.ndarray:
    """Per point (``(K, 2)`` m), metres to the land :attr:`GrowthOptions.district_town_reach` measures from: the
    town's settlement (:func:`osm_expand.sites.settlement_distance`); every piece of built-up land with a
    :attr:`GrowthOptions.settlement_gap` of 0, which reads them all as the town's."""
    if options.settlement_gap == 0:
        return _built_up_distance(maps, xy)
    return settlement_distance(maps, xy, options.settlement_gap)

def neighbourhood_length(city: City, site: SiteOptions | None = None, growth: GrowthOptions | None = None) -> float:
    """The street length (m) of one of the town's neighbourhoods: the pipeline's district area (``area_share`` of
    the town's built-up land, at most ``neighbourhood_area``: Perry's unit) at the town's built-up street density.

    What :attr:`GrowthOptions.district_neighbourhoods` counts in: the district verdict judges a district against
    discs of that area around the town's denser junctions, so a district of about that length is a
    neighbourhood's worth of streets. The rasters cut the unit's radius into ``growth``'s
    :attr:`GrowthOptions.site_cells_per_radius` cells, as a district's site does (45 m by default; the density
    falls on coarse cells: Krems 0.0101 m/m² at 20 m, 0.0099 at 45 m, 0.0079 at 200 m). Measured once a run, at
    45 m: Krems 6.4 km (0.65 km² × 0.0099 m/m²), Campo Grande 10.1 km (0.65 km² × 0.0156 m/m²), one year of its
    growth.
    """
    site = site or SiteOptions()
    maps = _town_maps(city, site, growth or GrowthOptions())
    return default_district_area(site, maps.built_area) * built_up_density(city, maps)


def settlement_length(city: City, site: SiteOptions | None = None, growth: GrowthOptions | None = None) -> float:
    """The street length (m) of the town's own settlement: its built-up area (:func:`osm_expand.sites.settlement`,
    the largest piece of built-up land with ``growth``'s :attr:`GrowthOptions.settlement_gap` gaps bridged; all of
    it with a gap of 0) at the town's built-up street density, on :func:`neighbourhood_length`'s rasters.

    What :attr:`GrowthOptions.district_town_share` caps the district floor with: the floor's neighbourhood is
    the whole extract's (Perry's unit on any extract of 2.6 km² of built-up land), the town may be far smaller.
    Measured at 45 m cells: north-bayreuth 5.38 km², without its buildings 2.87 km², Krems 5.08, Monaco 2.84,
    Andorra 8.36 (the whole extract's built-up land 15.4, 14.9, 5.67, 2.84, 20.4).
    """
    growth = growth or GrowthOptions()
    maps = _town_maps(city, site or SiteOptions(), growth)
    # settlement_gap 0 reads every piece of built-up land as the town's (:attr:`GrowthOptions.settlement_gap`)
    town = settlement(maps, growth.settlement_gap) if growth.settlement_gap > 0 else maps.city
    return float(town.sum()) * maps.cell ** 2 * built_up_density(city, maps)


def _town_maps(city: City, site: SiteOptions, growth: GrowthOptions) -> DistanceMaps:
    """The rasters the town's neighbourhood and settlement are measured on: Perry's unit's radius cut into
    ``growth``'s :attr:`GrowthOptions.site_cells_per_radius` cells, as a district's site is."""
    cell = max(site.cell, math.sqrt(site.neighbourhood_area / math.pi) / growth.site_cells_per_radius)
    return distance_maps(city, replace(site, cell=cell))


def built_up_density(city: City, maps: DistanceMaps) -> float:
    """The city's street length on its built-up land per m² of that land (m/m²; 0 without built-up land).

    What a district of the town holds: an engine district's site is its owed street length over this,
    so it is as large as the town's own streets would need. A grid of spacing s has 2/s; the towns as
    mapped have 1.3–1.8/s (Andorra 1.33, Krems 1.47, north-bayreuth 1.70, Monaco 1.77 at their junction
    spacings), since blocks are not squares and not every block side is a street. Sites at 2/s were
    smaller than one patch cell (5 × 5 spacings), so an engine district was one piece of dense fabric cut
    to a disc: 2-core shares above the town's range on Andorra (0.94) and Monaco (0.97).
    Segments count by their midpoints' raster cells.
    """
    table = SegmentTable.from_city(city)
    on = _built_up_distance(maps, (table.a + table.b) / 2) <= 0.0
    area = maps.built_area
    return float(table.length[on].sum() / area) if area > 0 else 0.0


def _built_up_distance(maps: DistanceMaps, xy: np.ndarray) -> np.ndarray:
    """Per point, metres to the built-up land of the site rasters (infinite off the rasters)."""
    return raster_at(maps, maps.city_distance, xy)
