"""Where each segment of last year's table went: the map traffic and trade routes follow.

Old segment ``i`` became the new segments ``flat[offsets[i]:offsets[i + 1]]``
(one when it was kept, several in path order when nodes were inserted into
it, none when its street was demolished). Kept as two arrays, not a list of
lists, because nearly every one of a large town's segments maps to exactly
one new id and the remaps gather them in one call.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray


@dataclass(frozen=True)
class Pieces:
    """New segment ids per old segment, compressed (see the module docstring)."""

    offsets: NDArray[np.int64]  #: (E_old + 1,)
    flat: NDArray[np.int64]  #: (offsets[-1],)

    @classmethod
    def of(cls, pieces: Pieces | Sequence[Sequence[int]]) -> Pieces:
        """``pieces`` as it is, or built from one sequence of new ids per old segment.

        >>> Pieces.of([[0], [1, 5], []]).sizes.tolist()
        [1, 2, 0]
        """
        if isinstance(pieces, Pieces):
            return pieces
        sizes = np.fromiter((len(p) for p in pieces), dtype=np.int64, count=len(pieces))
        flat = np.fromiter((int(s) for p in pieces for s in p), dtype=np.int64, count=int(sizes.sum()))
        return cls(np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64), flat)

    def __len__(self) -> int:
        return len(self.offsets) - 1

    @property
    def sizes(self) -> NDArray[np.int64]:
        return np.diff(self.offsets)

    def gather(self, old: NDArray[np.integer]) -> NDArray[np.int64]:
        """The new ids of the old segments ``old``, in order (a route through them).

        >>> Pieces.of([[0], [1, 5], [], [2]]).gather(np.array([3, 1, 2, 0])).tolist()
        [2, 1, 5, 0]
        """
        old = np.asarray(old, dtype=np.int64)
        start, size = self.offsets[old], self.sizes[old]
        within = np.arange(int(size.sum())) - np.repeat(np.cumsum(size) - size, size)
        return self.flat[np.repeat(start, size) + within]
