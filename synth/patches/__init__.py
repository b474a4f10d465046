"""Example patches: a district copied from the town as mapped — by default one whole neighbourhood, fitted to
the free land (:mod:`synth.patches.transplant`, :attr:`PatchOptions.transplant`); where none fills the site to
the town's density, a quilt of pieces of it, its seams walked (below).

The growth pattern of Aliaga et al. 2008 and Nishida et al. 2016, which keep
the look of an example by copying *fragments of the real network* — their
streets, real shapes, dead ends, junction angles and blocks — and fixing the
seams between fragments procedurally; here the seams are walked with 004's
transition probability (§3.1). Seed 004 §6.2 says what its junction-cloud
walk loses (shapes, dead ends, the town's density); patches keep all three.

1. **Cells.** Cell centres are laid over the region's free land (not water,
   blocks, unbuildable land, nor within ``clearance`` of the town's streets),
   starting next to the town and growing outward ``cell_size`` junction
   spacings apart; each centre owns its Voronoi cell of the free land.
2. **How much.** A real district of the town holds open land too (fields,
   parks, water): its street density, measured on discs of the district's
   area centred on the town's streets, is the target. Cells are filled from
   the town outward until the district reaches the median of those densities;
   the rest stays open, as the town's own edges do.
3. **Patches.** Each filled cell takes the streets of a patch of the town
   around one of its neighbourhoods' junctions (drawn as the fidelity
   yardstick draws them; patches within ``density_band`` of their median
   density only),
   translated — never rotated, so the district keeps the town's orientations
   — by an offset of up to half a spacing chosen so that its streets continue
   those of the cells already filled, and clipped to the cell. Motorways,
   trunk roads, bridges and tunnels are not copied.
4. **Seams.** A street cut by a seam continues into a cut street of the
   neighbouring cell with probability
   ``exp(-½ (gap / σ_L)²) · exp(-½ (turn / σ_θ)²)``, most probable first,
   crossing nothing; one left over runs on to meet the first street ahead
   (of the district or the town) in a tee, at a fair angle; every other cut
   end meets its neighbour along the district's edge by a street that follows
   the edge a few metres inside it (a perimeter street, as real estates
   have, when the two are within ``seam_gap`` spacings along it); every
   other cut end is trimmed back to its last junction, so no street ends
   where a seam or the site's edge cut it.
5. **Pieces.** Fragments shorter than ``min_fragment`` spacings go, and so
   do pieces that can be joined neither to the rest nor to the town; each
   piece left is joined to the largest by the shortest straight street
   between their junctions and ends that crosses nothing (a district is one
   network, not a scatter); a piece still apart stays only when it holds a
   district's worth of street (``min_land`` spacings), and parts of the free
   land smaller than that are left open, but for the largest.
6. **Topology.** The district aims at its town's neighbourhoods' median
   dead-end share and 2-core share (:class:`_Aim`, measured on an even
   spread of the neighbourhoods) and at the town's median cul-de-sac
   length: cut streets stay as cul-de-sacs within that budget, too many
   dead ends run on to tees or go, too few reopen tees onto the district's
   own streets, and too little length on loops closes or prunes the longest
   cul-de-sacs. Dead ends are counted as the fidelity yardstick counts
   them: a road out on the site's outer edge runs on and is none.

The seams leave corners at nodes of degree two that no street of the town
has (jogs of a seam link, spikes, Ls of trimmed tees, steps of perimeter
streets round building margins): they are counted
(:mod:`~synth.patches.corners`: corners over 45° per km beside the town's
neighbourhoods' rate), not straightened (session 39's ``corner_reach``,
measured and removed, is in docs/tried.md).

Nine modules, one idea each: :mod:`~synth.patches.options` (the tunables),
:mod:`~synth.patches.source` (the town's copyable streets and typical patches),
:mod:`~synth.patches.quilt` (the district being quilted), :mod:`~synth.patches.placing` (cells and the
patch each takes), :mod:`~synth.patches.seams`, :mod:`~synth.patches.edges` (perimeter streets),
:mod:`~synth.patches.topology` (trimming, pieces, dead ends and loops), :mod:`~synth.patches.corners`
(the corner count) and
:mod:`~synth.patches.pattern` (:class:`ExamplePatches`, which runs the steps above). Every public name is
importable from here, as it was when they were one module.
"""
from synth.patches.corners import SHARP, corner_turns, neighbourhood_corner_rates, sharp_corners
from synth.patches.edges import EDGE_INSET
from synth.patches.options import NOT_COPIED, PatchOptions
from synth.patches.pattern import ATTEMPTS, DEAD_END_DISCS, MAX_FILLS, ExamplePatches
from synth.patches.seams import CONNECTOR_STEP
from synth.patches.source import TYPICAL
from synth.patches.topology import JOIN_REACH, ON_EDGE, STUB_LENGTH

__all__ = [
    "ATTEMPTS", "CONNECTOR_STEP", "DEAD_END_DISCS", "EDGE_INSET", "ExamplePatches", "JOIN_REACH",
    "MAX_FILLS", "NOT_COPIED", "ON_EDGE", "PatchOptions", "SHARP", "STUB_LENGTH", "TYPICAL", "corner_turns",
    "neighbourhood_corner_rates", "sharp_corners",
]
