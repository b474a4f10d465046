"""The named parameter sets: Weber's organic, grid and radial patterns (002 §3.1) and the eras' (000 §4.2.9)."""
from __future__ import annotations

from dataclasses import fields, replace
from typing import Any

from osm_expand.errors import InputError
from synth.patterns.options import AngleSpace, LengthMode, PatternOptions, PdfKind

# --------------------------------------------------------------------------- parameter sets

#: Weber's organic pattern (002 §3.1): angle deviation from a truncated Gaussian around straight
#: on, left or right of the incoming street (crossing space); length likewise Gaussian.
ORGANIC = PatternOptions()

#: Weber's grid pattern (002 §3.1): angle deviation 0 (discrete straight/left/right in crossing
#: space), two length ranges: long blocks straight on (120 m), short ones across (60 m), ±10 %.
#: min_angle 60° keeps only right angles; min distances are half a short block. Grids grow from
#: crossings only, up to three streets each (000's queue grows a crossing to max_degree), so
#: that the blocks close.
GRID = PatternOptions(
    angle_space=AngleSpace.CROSSING, angle_pdf=((180.0, 2.0), (90.0, 1.0), (270.0, 1.0)),
    angle_pdf_kind=PdfKind.DISCRETE, angle_spread_deg=0.0, length_mode=LengthMode.ORIENTATION,
    length_from_orientation=((0.0, 120.0), (90.0, 60.0), (180.0, 120.0), (270.0, 60.0)),
    length_jitter=0.1, min_angle_deg=60.0, min_length_m=30.0, max_length_m=160.0,
    min_cs_distance_m=25.0, min_cc_distance_m=20.0, streets_per_start=3, segment_starts=False,
)

#: Weber's radial pattern (002 §3.1): the next node lies on a ray to or from the centre (0°, 180°
#: in centre space) or on the start's circle around it (90°/270°, bent into a chord). Ring
#: streets a little shorter than spokes (70 m vs 90 m): rings stay round near the centre.
RADIAL = PatternOptions(
    angle_space=AngleSpace.CENTRE, angle_pdf=((0.0, 2.0), (90.0, 1.0), (270.0, 1.0), (180.0, 0.5)),
    angle_pdf_kind=PdfKind.DISCRETE, angle_spread_deg=0.0, length_mode=LengthMode.ORIENTATION,
    length_from_orientation=((0.0, 90.0), (90.0, 70.0), (180.0, 90.0), (270.0, 70.0)),
    length_jitter=0.1, min_angle_deg=45.0, min_length_m=25.0, max_length_m=150.0,
    min_cs_distance_m=20.0, min_cc_distance_m=20.0,
)

#: 000 §4.2.9's medieval era ("mostly organic"): organic with short, strongly bent lanes
#: (40 ± 15 m, 25° spread), narrow spacing (10 m lanes between house rows) and sharp angles allowed.
MEDIEVAL = replace(
    ORGANIC, angle_spread_deg=25.0, length_mean_m=40.0, length_sd_m=15.0, min_length_m=15.0,
    max_length_m=90.0, min_angle_deg=25.0, min_cs_distance_m=10.0, min_cc_distance_m=12.0,
)

#: A 19th-century European block grid in world space (Hobrecht's Berlin, Cerdà's Barcelona: blocks
#: of about 110 × 70 m): 0°/180° long, 90°/270° short; the engine sets angle_offset_deg to the
#: town's dominant bearing.
GRID_19TH_CENTURY = PatternOptions(
    angle_space=AngleSpace.WORLD, angle_pdf=((0.0, 1.0), (90.0, 1.0), (180.0, 1.0), (270.0, 1.0)),
    angle_pdf_kind=PdfKind.DISCRETE, angle_spread_deg=0.0, length_mode=LengthMode.ORIENTATION,
    length_from_orientation=((0.0, 110.0), (90.0, 70.0), (180.0, 110.0), (270.0, 70.0)),
    length_jitter=0.05, min_angle_deg=60.0, min_length_m=30.0, max_length_m=150.0,
    min_cs_distance_m=30.0, min_cc_distance_m=20.0, streets_per_start=3, segment_starts=False,
)

#: A North-American grid in world space: the Chicago block, 1/8 × 1/16 mile ≈ 200 × 100 m.
GRID_NORTH_AMERICAN = replace(
    GRID_19TH_CENTURY,
    length_from_orientation=((0.0, 200.0), (90.0, 100.0), (180.0, 200.0), (270.0, 100.0)),
    min_length_m=40.0, max_length_m=260.0, min_cs_distance_m=40.0, min_cc_distance_m=25.0,
)

#: Modern suburban streets (000 §2: sprawl at the fringes): long gentle curves, T-junctions only
#: (max_degree 3), few connections — Snap and Extend off, so streets end in cul-de-sacs unless
#: they run into another street (Shorten).
SUBURBAN = replace(
    ORGANIC, angle_pdf=((180.0, 3.0), (90.0, 1.0), (270.0, 1.0)), angle_spread_deg=12.0,
    length_mean_m=70.0, length_sd_m=25.0, min_length_m=25.0, max_length_m=160.0, min_angle_deg=50.0,
    min_cs_distance_m=25.0, min_cc_distance_m=25.0, max_degree=3, snap_enabled=False, extend_enabled=False,
)

#: The named parameter sets, for a history file's ``pattern = "…"``.
PATTERNS: dict[str, PatternOptions] = {
    "organic": ORGANIC, "grid": GRID, "radial": RADIAL, "medieval": MEDIEVAL,
    "grid_19th_century": GRID_19TH_CENTURY, "grid_north_american": GRID_NORTH_AMERICAN,
    "suburban": SUBURBAN,
}


def pattern(name: str, **overrides: Any) -> PatternOptions:
    """A named parameter set (see :data:`PATTERNS`) with some fields replaced.

    Raises
    ------
    InputError
        For an unknown name or field.
    """
    if name not in PATTERNS:
        raise InputError(f"street pattern {name!r} is not one of {', '.join(PATTERNS)}")
    base = PATTERNS[name]
    return PatternOptions.from_mapping({**{f.name: getattr(base, f.name) for f in fields(base)}, **overrides})
