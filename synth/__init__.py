"""Street synthesis from a town's example: the random walk of seed 004 §3.1.

``grow`` draws a district in a region; ``random_walk`` connects a junction
cloud; ``reproduce`` re-walks a town's own junctions and scores the result.
"""
from synth.grow import GrowResult, grow
from synth.reproduce import reproduce
from synth.walk import NodeCloud, WalkOptions, random_walk

__all__ = ["GrowResult", "NodeCloud", "WalkOptions", "grow", "random_walk", "reproduce"]
