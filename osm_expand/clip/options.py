"""The clip's options (:class:`ClipStrategy`, :class:`ClipOptions`, the command line's ``--clip-index``) and
what a clip wrote (:class:`ClipResult`)."""
from __future__ import annotations

from dataclasses import dataclass, field
from enum import StrEnum
from pathlib import Path

import osmium

from osm_expand.errors import OptionError

__all__ = ["ClipOptions", "ClipResult", "ClipStrategy", "options_for_index"]


class ClipStrategy(StrEnum):
    """How :func:`clip_extracts` finds the objects of the boxes (see :mod:`osm_expand.clip`)."""

    TWO_PASS = "two-pass"
    ONE_PASS = "one-pass"


@dataclass(frozen=True)
class ClipOptions:
    """Tunables of the clip."""

    #: ``two-pass`` or ``one-pass`` (:class:`ClipStrategy`); two-pass by default: on Krems' copy in
    #: the 3 M-node benchmark file 4.4 s and 289 MB peak against 11.2 s and 229 MB, and the only one
    #: whose Python work grows with the clip, not the file.
    strategy: str = ClipStrategy.TWO_PASS.value
    #: the node-location index of ``one-pass``: a name from ``osmium.index.map_types()``, file-backed
    #: ones with ``,PATH`` (libosmium's default for in-memory reading is ``flex_mem``).
    index: str = "flex_mem"
    #: complete ``type=multipolygon`` relations with a member in the box (all member ways and
    #: their nodes), so areas crossing the box edge are assembled whole.
    complete_multipolygons: bool = True
    #: MB, the most the id sets of ``two-pass`` hold at once (4 MB per block of 2**25 ids touched);
    #: more blocks are tracked group by group, one read of ways and one of nodes each, in ascending
    #: ids (the extract is the same). A town touches nearly every block of the ids of its time:
    #: Krems (2013, ids to 2.6e9) 74 blocks, a town today up to ~390 (ids to 1.3e10), 1.55 GB
    #: uncapped. 512 MB: at most four groups for any town today, one for Krems. On Krems' copy in
    #: the 3 M-node file (benchmarks/large_inputs.py): 64 MB 7.8 s / 224 MB peak, 128 MB 4.4 s / 289 MB,
    #: 256 MB 4.6 s / 429 MB, 512 MB 3.4 s / 442 MB.
    max_id_set_mb: int = 512


@dataclass
class ClipResult:
    """What :func:`clip_extracts` wrote: the extract of each box that holds data, and counts."""

    #: name → the extract written
    paths: dict[str, Path] = field(default_factory=dict)
    #: name → {"nodes", "ways", "relations"} written
    counts: dict[str, dict[str, int]] = field(default_factory=dict)
    #: names of boxes with no node of the file inside (nothing written for them), in input order
    empty: list[str] = field(default_factory=list)
    #: name → why it is empty, one line (outside the file's declared bounds, or no node inside)
    why_empty: dict[str, str] = field(default_factory=dict)
    #: how many times the input file was read
    reads: int = 0


def options_for_index(index: str | None) -> ClipOptions:
    """The clip's options for the command line's ``--clip-index``.

    None: the default two-pass clip (node locations in a temporary file
    store). A name from ``osmium.index.map_types()`` (``flex_mem``,
    ``sparse_mem_array``, ``dense_file_array,PATH``, ...): the one-pass clip
    with that location index of every node.
    """
    if index is None:
        return ClipOptions()
    kinds = osmium.index.map_types()
    if index.split(",")[0] not in kinds:
        raise OptionError(f"--clip-index {index!r} is not one of {', '.join(kinds)} "
                          "(file-backed ones take ,PATH: sparse_file_array,/big/disk/nodes.idx)")
    return ClipOptions(strategy=ClipStrategy.ONE_PASS.value, index=index)
