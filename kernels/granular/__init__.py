"""Granular MPM on the device ("Granular MPM" §3.3–3.4): domains of interaction, the interaction
graph, its connected components, and the per-node grid layers that keep components apart.

Every kernel runs without a host sync and can be captured in a CUDA graph; on a step that keeps
its labels the rebuild kernels sit in a conditional graph node and are not launched at all. One
concept per module:

- ``flags``: the named slots of ``Interaction.flags`` and the sizes and thresholds they go with;
- ``interaction``: the ``Interaction`` struct of every array below;
- ``domains``: the domain of interaction of a point and the node range of its stencil;
- ``cells``, ``pairs``, ``unionfind``: the cell binning, single pair tests and the lock-free
  union–find the kernels share;
- ``search``: a rebuild's ``reset_search``, ``prepare``, ``place`` and ``link``;
- ``labels``: ``settle``, ``relink`` and ``label``, the components;
- ``layers``: the grid copies (task 2–3) and ``assign``, which gives them out for the tent;
- ``reuse``: ``check`` and ``judge``, whether the next step rebuilds, relabels or keeps its labels;
- ``graph``: ``make_granular_kernels``, the kernels of one variant in launch order.

Non-granular materials (no critical density) are continua: their points interact with every point
they share a node with, so they are never split.
"""

from . import flags
from .domains import DEFORMING_DOMAINS, domains_overlap, make_domain_of_interaction, make_node_ranges, make_node_reach
from .flags import *  # noqa: F403 (every named slot, size and threshold: ``flags.__all__``)
from .graph import GranularKernels, make_granular_kernels
from .interaction import make_interaction_struct
from .layers import (
    ASSIGN_CACHE,
    COPY_RUN,
    NO_LAYER,
    make_granular_statistics,
    make_layer_row,
    slot_words,
)
from .reuse import make_rebuild_decision
from .search import make_reset_search

__all__ = [
    *flags.__all__,
    "ASSIGN_CACHE",
    "COPY_RUN",
    "DEFORMING_DOMAINS",
    "GranularKernels",
    "NO_LAYER",
    "domains_overlap",
    "make_domain_of_interaction",
    "make_granular_kernels",
    "make_granular_statistics",
    "make_interaction_struct",
    "make_layer_row",
    "make_node_ranges",
    "make_node_reach",
    "make_rebuild_decision",
    "make_reset_search",
    "slot_words",
]
