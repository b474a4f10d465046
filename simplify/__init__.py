"""Street-network simplification of seed 004 §4.2, one module per pass.

``simplify(network)`` runs every pass in order and returns the simplified
network, a per-pass report and the dead ends it removed.
"""
from simplify.options import SimplifyOptions
from simplify.pipeline import SimplifyResult, simplify

__all__ = ["SimplifyOptions", "SimplifyResult", "simplify"]
