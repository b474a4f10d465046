"""The maturation engine: a City lives through the years of a history.

One module per concern of the year loop (seed 003 Algorithm 1; seed 002 §2.2):
the history (eras, time functions), nuclei of growth, traffic (trade routes
and trips), the pathfinding lattice and routing, major roads, land use, lots
and buildings.
"""
