"""Major roads: the pathfinding lattice searched implicitly, routes with the turn penalty, the four road types."""
