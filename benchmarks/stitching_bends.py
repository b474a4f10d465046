"""Where do the engine's streets bend? The yardstick's curvature chords of each engine district, by what laid them.

Issue 20: the engine's streets read bendier than the town's neighbourhoods (north-bayreuth seed 0: curvature
median 2.3° per 20 m chord against the town's 1.0, KS 0.145 above its bound; Krems 5.2° against 0.0). This
runs the default command in-process (``osm-expand TOWN``, default options, ``--seed``; the history's 30 years)
and watches each example-patches district being quilted: the patch pieces as copied (:func:`_place`), the
links each stitching step lays (seam links, tees, perimeter streets) and the district as it leaves
(:func:`_planar`, the last step). For the districts the engine placed, every curvature chord (heading change
between consecutive 20 m chords along the yardstick's edges, :mod:`osm_expand.measures`, which run through
nodes of degree two) is put in one class by where its three points lie:

- ``one piece``: on one copied piece (a stretch of one of the town's streets, translated);
- ``piece joint``: on two copied pieces (where two of the town's ways meet, or a tee whose third arm was
  trimmed: an L);
- ``joint seam`` / ``joint edge`` / ``joint tee``: across the end of a seam link, a perimeter street or a
  tee and the street it continues;
- ``in seam`` / ``in edge`` / ``in tee``: along the link itself;
- ``other``: the rest (links the topology step laid).

Per class: chords, their median bend and the share bent over 20°; then the curvature KS against the whole
town (as the verdict reads it) with the chords of each class of joints left out, and the corners over 45° at
nodes of degree two per km beside the town's own rate. Session 34's reading (seed 0): the copied pieces bend
as the town does (north-bayreuth median 1.0-1.6°, Krems 0.3-3.7°); the joints carry most chords over 20°,
and without them north-bayreuth's KS falls from 0.15 to 0.08.

Session 35 (h35b), seed 0, curvature KS against the town (all chords), off -> on: ``--option
seam_link_turn=true`` Krems 0.372 -> 0.332, north-bayreuth 0.150 -> 0.194 (almost no seam link is made);
``--option stubs_at_bends=true`` Krems 0.306, north-bayreuth 0.150; ``--option edge_min_run=0.5`` Krems 0.353,
north-bayreuth 0.117 (joint-edge chords 46 -> 28). Each moves the engine's districts (all three options removed
in session 41: docs/tried.md).

Session 36 (h36c), seed 0: Krems' bends on one piece (median 2.3°) are its patches' own: the density band keeps
its denser half, the curving old town, and clipping to the cells adds 0.00-0.03 of KS. ``--option
bends_of_neighbourhoods=true`` (patches ranked by their bends' KS distance to all the neighbourhoods): Krems
one piece 2.3° -> 0.3°, curvature KS 0.372 -> 0.256, without every joint's chords 0.245 -> 0.124;
north-bayreuth 0.150 -> 0.137 (0.080 -> 0.073). Off, removed in session 42 (docs/tried.md).

Session 37 (h37c): ``--district`` classifies the pipeline's district instead (the README picture's circle; no
years run), and the piece joints are split by what the copy had there before the trimming. Seed 0: Krems'
district, 180 chords, KS 0.371 (bound 0.259): one piece 51 % (median 2.0°), piece joints 27 % (12.2°, 37 % over
20°), of which 47 of 49 are where two of the town's ways meet (degree two in the copy already: the old town's own
corners, 7.9°) and 2 are tees whose arm was trimmed (94°); joint edge 17 chords (64°), joint seam 9 (82°): the
kinks a viewer sees. Without the piece joints 0.206. north-bayreuth: 149 chords, KS 0.264, joint edge 22 (57°),
without them 0.181; its 24 piece joints are all the town's way joints (2.4°). ``--option
typical_of_neighbourhoods=true`` (engine districts, Krems): one piece 2.3° -> 1.0°, KS 0.372 -> 0.282 (off,
removed in session 42: docs/tried.md).

Session 37 (h37c, second helper), ``--district``, seed 0: the perimeter joints kink because each cut end is joined
to its neighbour along the edge whatever its street's heading (Krems' 14 perimeter joints turn 28-167°, 9 over
105°: Vs between cut streets splaying to the edge); the seam joints because the transition reads only the angle
between the two cut streets, so streets facing each other far apart sideways get an S or a hook (Krems' two longest
links turn 77-107° off their streets). ``--option seam_jog=90``: Krems' seam joints 82° -> 17°, KS 0.371 ->
0.316; ``--option edge_turn=135``: Krems' joint edge 64° -> 21°, north-bayreuth's 57° -> 38° (KS 0.264 -> 0.300,
its district moved). Both off, removed in session 41 (their measurements in docs/tried.md).

Session 38 (h38c): ``--seeds`` pools several seeds' districts per town (one seed's district is chaotic: an option that
changes one street's length can change which attempt of patches the quilting keeps). ``--district --seeds 0 1 2 3
4``, default: Krems 893 chords, KS 0.366, corners over 45° 7.20 per km, joint edge 103 (45.6°), joint seam 38
(47.1°); north-bayreuth 931, 0.233, 8.01, joint edge 128 (44.8°), joint seam 5. ``--option edge_tee=105`` (a V-joint
met square further back, a tee): Krems 0.358, joint edge 94 (43.1°); north-bayreuth 0.223, joint edge 90 (33.6°).
``--option seam_passing=true`` (no link between streets running past each other): Krems 0.357, joint seam 33
(26.3°). ``--option edge_square=105`` (a V cut back to a right angle): Krems 0.375, north-bayreuth 0.230. All off,
removed in session 41 (their measurements in docs/tried.md).

Usage: ``python benchmarks/stitching_bends.py [--seed N | --seeds N ...] [--option NAME=VALUE ...] [--district]
[TOWN ...]``
(default: Krems and north-bayreuth, seed 0; about 15 s CPU each, 4 s with ``--district``; several seeds pool their
districts' chords per town). ``--option`` (repeatable, a JSON value) sets a :class:`synth.patches.PatchOptions`
field in every PatchOptions the run makes that does not set it itself (the history's eras take theirs from the
defaults), e.g. ``--option cells=5``.
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import shapely

REPO = Path(__file__).resolve().parent.parent
JOINTS = ("joint edge", "joint seam", "piece joint")


class Watch:
    """Wraps the steps :mod:`synth.patches.pattern` calls to note, per quilting, the copied pieces, the
    links each stitching step adds and the district it returns (of the rounds filling one quilt, the last)."""

    def __init__(self) -> None:
        import synth.patches.pattern as pattern

        self.rounds: list[dict] = []
        self.current: dict = {}
        for name, kind in (("_walk_seams", "seam"), ("_tees", "tee"), ("_edge_streets", "edge")):
            setattr(pattern, name, self._adding(getattr(pattern, name), kind))
        place, planar = pattern._place, pattern._planar

        def placed(source, patches, centres, cells, quilt, *args, **kwargs):
            out = place(source, patches, centres, cells, quilt, *args, **kwargs)
            self.current = {"raw": [x.copy() for x in quilt.xy], "seam": [], "tee": [], "edge": [], "quilt": quilt}
            return out

        def last(net):
            out = planar(net)
            self.current["final"] = [out.street_xy(s) for s in out.streets]
            if self.rounds and self.rounds[-1]["quilt"] is self.current["quilt"]:
                self.rounds[-1] = self.current  # another round of filling the same quilt: the last one counts
            else:
                self.rounds.append(self.current)
            return out

        pattern._place, pattern._planar = placed, last

    def _adding(self, step, kind: str):
        def wrapped(quilt, *args, **kwargs):
            before = len(quilt.xy)
            out = step(quilt, *args, **kwargs)
            self.current[kind] = self.current.get(kind, []) + [x.copy() for x in quilt.xy[before:]]
            return out
        return wrapped


def _default_patch_options(values: dict) -> None:
    """Every :class:`~synth.patches.PatchOptions` made from now on takes ``values`` where its caller gives none:
    the engine's eras read theirs from the defaults, so this is how an option reaches the engine's districts."""
    from synth.patches import PatchOptions

    made = PatchOptions.__init__

    def init(self, *args, **kwargs) -> None:
        made(self, *args, **{**values, **kwargs})

    PatchOptions.__init__ = init  # type: ignore[method-assign]
    print(f"PatchOptions: {values}")


def chords(lines: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """The yardstick's curvature chords of ``lines`` (:func:`osm_expand.measures.shape._chords`, the same
    edges and rounding): bends (degrees) and the three points of each, ``(K, 3, 2)``."""
    from osm_expand.measures.graph import _build_graph
    from osm_expand.measures.kinds import MeasureOptions
    from osm_expand.measures.lines import LineSet
    from osm_expand.measures.shape import _chords, _rounded

    opts = MeasureOptions()
    ls = LineSet.from_lines(lines)
    g = _build_graph(ls.coords, ls.line_of, window=None, open_points=None, opts=opts)
    bends, points = _chords(g, opts.curvature_step)
    return _rounded(bends, opts.angle_resolution), points


def classify(watched: dict, points: np.ndarray) -> np.ndarray:
    """Each chord's class (module docstring) from its three points."""
    pieces = [shapely.LineString(x) for x in watched["raw"]]
    tree = shapely.STRtree(pieces)
    on = np.full(points.shape[:2], -1)
    for j in range(3):
        (which, idx), dist = tree.query_nearest(shapely.points(points[:, j]), return_distance=True,
                                                all_matches=False)
        on[which, j] = np.where(dist < 0.5, idx, -1)
    kind = np.where((on[:, 0] >= 0) & (on[:, 0] == on[:, 1]) & (on[:, 1] == on[:, 2]), "one piece",
                    np.where((on >= 0).all(axis=1), "piece joint", "other")).astype(object)
    for name in ("seam", "tee", "edge"):
        if not watched[name]:
            continue
        links = shapely.MultiLineString([shapely.LineString(x) for x in watched[name]])
        near = np.stack([shapely.distance(links, shapely.points(points[:, j])) < 0.5 for j in range(3)], axis=1)
        kind[(kind == "other") & near.all(axis=1)] = f"in {name}"
        kind[(kind == "other") & near.any(axis=1)] = f"joint {name}"
    return kind


def copied_degree(watched: dict, middle: np.ndarray) -> np.ndarray:
    """At each of ``middle`` (``(K, 2)``, a chord's middle point), how many arms the copied pieces had there as
    placed, before the stitching and trimming: a piece through the point gives two, one ending there one. A
    piece joint of degree 3 or more was a junction of the copy whose other arms the trimming took (an L left of
    a tee), one of degree 2 is where two of the town's ways meet, a bend the town has too."""
    pieces = [shapely.LineString(x) for x in watched["raw"]]
    ends = shapely.points(np.array([x[i] for x in watched["raw"] for i in (0, -1)]))
    lines = shapely.STRtree(pieces)
    out = np.zeros(len(middle), dtype=int)
    for k, xy in enumerate(middle):
        at = shapely.Point(xy)
        near = lines.query(at, predicate="dwithin", distance=0.5)
        at_end = int((shapely.distance(ends, at) < 0.5).sum())
        out[k] = 2 * len(near) - at_end
    return out


def _placed(watch: Watch, mapped: object, seed: int, district: bool
            ) -> tuple[list[np.ndarray], list[tuple[dict, np.ndarray, np.ndarray]], tuple[int, float], object] | None:
    """Grow ``mapped`` (a loaded city) with ``seed``: the town's streets, per quilting round that was placed
    (a round whose streets are those grown; a district refused, or an attempt another replaced, is not) the
    watched round with its chords' bends and points, the grown streets' corners over :data:`SHARP` and their
    km, and the pipeline's result (its district's area and example); None when nothing grew.

    The corners are counted on the grown city, as :func:`synth.patches.sharp_corners` counts them: at the
    grown streets' nodes of degree two in the whole network, so a tee onto the town is a junction (on the
    district's own lines before its joins it would read as a bend). The engine's: its streets but the major
    roads, as ``benchmarks/engine_growth.py`` counts them."""
    from osm_expand.engine.history import load_history
    from osm_expand.growth_fidelity import is_major_road
    from osm_expand.maturation import MatureOptions, mature_result
    from osm_expand.model import Origin, polyline_length
    from osm_expand.pipeline import ExpandOptions, expand
    from synth.patches import SHARP, corner_turns

    first = len(watch.rounds)
    city = expand(mapped, ExpandOptions(seed=seed, fidelity=False))  # type: ignore[arg-type]
    if district:  # the pipeline's district: its quilting rounds, its streets
        net, grew = city.city.network, Origin.GROWN
    else:
        first = len(watch.rounds)
        net = mature_result(city, load_history("example"), MatureOptions(fidelity=False), seed).city.network
        grew = Origin.ENGINE
    engine = [net.street_xy(s) for s in net.streets if s.origin == grew]
    town = [net.street_xy(s) for s in net.streets if s.origin == Origin.SOURCE]
    if not engine:
        return None
    mine = [s for s in net.streets if s.origin == grew and not (grew == Origin.ENGINE and is_major_road(s))]
    corners = int((corner_turns(net, np.unique(np.concatenate([np.asarray(s.nodes) for s in mine])))[1] > SHARP)
                  .sum()) if mine else 0
    km = sum(polyline_length(net.street_xy(s)) for s in mine) / 1000.0
    grown = shapely.MultiLineString([shapely.LineString(x) for x in engine])
    rounds = []
    for watched in watch.rounds[first:]:
        final = watched.get("final", [])
        if not final:
            continue
        middle = shapely.points([x[len(x) // 2] if len(x) > 2 else x.mean(axis=0) for x in final])
        if np.mean(shapely.distance(grown, middle) < 1.0) < 0.5:  # a district refused, not placed
            continue
        b, p = chords(final)
        rounds.append((watched, b, p))
    return town, rounds, (corners, km), city


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("towns", nargs="*", default=["krems.osm.gz", "north-bayreuth.osm.gz"])
    seeds = ap.add_mutually_exclusive_group()  # one seed, or several pooled
    seeds.add_argument("--seed", type=int, default=0)
    seeds.add_argument("--seeds", type=int, nargs="+", help="several seeds, their districts' chords pooled per town")
    ap.add_argument("--option", action="append", default=[], metavar="NAME=VALUE")
    ap.add_argument("--district", action="store_true",
                    help="the pipeline's district (the circle of the README's picture) instead of the engine's "
                         "districts; no years are run")
    args = ap.parse_args()
    if args.option:
        _default_patch_options({k: json.loads(v) for k, v in (o.split("=", 1) for o in args.option)})
    watch = Watch()
    from osm_expand.fidelity import ks_distance
    from osm_expand.ingest import load
    from osm_expand.measures import measure_network
    from osm_expand.model import Origin, network_from_lines
    from synth.patches import SHARP, corner_turns, neighbourhood_corner_rates

    for name in args.towns:
        bends, kinds, degrees, corners, km, radii, grown = [], [], [], 0, 0.0, [], None
        mapped_city = load(REPO / "fixtures" / name)
        for seed in args.seeds or [args.seed]:
            placed = _placed(watch, mapped_city, seed, args.district)
            if placed is None:
                continue
            town, rounds, (count, length), grown = placed
            corners, km = corners + count, km + length
            radii.append(float(np.sqrt(max(grown.report["district_area_m2"], 1.0) / np.pi)))
            for watched, b, p in rounds:
                bends.append(b)
                kinds.append(classify(watched, p))
                joint = kinds[-1] == "piece joint"
                degrees.append(np.where(joint, 0, -1))
                degrees[-1][joint] = copied_degree(watched, p[joint, 1])
        seeds = " ".join(map(str, args.seeds or [args.seed]))
        if not bends:
            print(f"{name} seed {seeds}: no {'district' if args.district else 'engine district'} placed")
            continue
        b, k = np.concatenate(bends), np.concatenate(kinds)
        whole = np.sort(measure_network(town, pieces=False).value("curvature"))
        mapped = network_from_lines(town, [{"highway": "residential", "origin": Origin.SOURCE}] * len(town))
        town_rate = (corner_turns(mapped)[1] > SHARP).sum() / (mapped.total_length() / 1000.0)
        # the same reading in the town's neighbourhoods at the district's size (the pipeline district's area, as
        # district_fidelity.py and engine_growth.py read it): the rate a district stands beside (session 39; the
        # whole extract's is mostly country roads)
        hoods = neighbourhood_corner_rates(grown.city, float(np.median(radii)))
        print(f"\n{name} seed {seeds}: {len(b)} chords in the placed districts, median {np.median(b):.1f}°, "
              f"corners over {SHARP:.0f}° {corners / km:.2f} per km (whole extract {town_rate:.2f}; its "
              f"neighbourhoods' median {np.nanmedian(hoods):.2f}, p90 {np.nanpercentile(hoods, 90):.2f})")
        print("| class | chords | share | median ° | over 20° |\n|---|---|---|---|---|")
        for kind in sorted(set(k), key=lambda c: -np.sum(k == c)):
            m = k == kind
            print(f"| {kind} | {m.sum()} | {m.mean():.2f} | {np.median(b[m]):.1f} | {np.mean(b[m] > 20):.2f} |")
        without = [f"without {', '.join(JOINTS[:i + 1])} {ks_distance(b[~np.isin(k, JOINTS[:i + 1])], whole):.3f}"
                   for i in range(len(JOINTS))]
        print(f"curvature KS against the town: all {ks_distance(b, whole):.3f}; " + "; ".join(without))
        d, joint = np.concatenate(degrees), k == "piece joint"
        trimmed = joint & (d >= 3)
        if joint.any():
            print(f"piece joints where the copy had a junction (an arm trimmed away): {trimmed.sum()} of "
                  f"{joint.sum()}, "
                  f"median {np.median(b[trimmed]) if trimmed.any() else float('nan'):.1f}°, over 20° "
                  f"{np.mean(b[trimmed] > 20) if trimmed.any() else float('nan'):.2f}; the town's own way joints: "
                  f"median {np.median(b[joint & (d < 3)]) if (joint & (d < 3)).any() else float('nan'):.1f}°; "
                  f"KS without the trimmed ones {ks_distance(b[~trimmed], whole):.3f}")


if __name__ == "__main__":
    main()
