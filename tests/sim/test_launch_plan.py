"""How a step's plan is cut for the branches of a CUDA graph (``launch_plan.split_after_conditionals``).

The coupled step records its start plan (list rebuilds, the Granular MPM relabel) up to its last
conditional node before it opens a branch, and the rest beside the contact forces. The cut must
launch what the plan launches, in its order (so the CPU, which runs every block in line, keeps its
bits), and leave no conditional node after the cut (a CUDA capture cannot record one while a
branch is open). Reference: the plan's own order, as ``run_plan`` walks it.
"""

from mpmdem.sim.launch_plan import IfAny, IfFlag, Launch, split_after_conditionals


def launches(items, inline_all=True):
    """The kernels' names in the order run_plan launches them outside a graph (every block in line)."""
    out = []
    for item in items:
        if isinstance(item, Launch):
            out.append(item.kernel)
        elif isinstance(item, (IfFlag, IfAny)):
            out += launches(item.body)
    return out


def relabel_plan(relabel_inline: bool, rebuild_inline: bool):
    """The Granular MPM relabel as ``granular_state.make_granular_plan`` lays it out: the rebuild block
    nested first in the relabel block, then the relabel's own kernels; the list rebuilds before it."""
    rebuild = IfFlag(None, [Launch("reset_search", 1, []), Launch("link", 1, [])], inline=rebuild_inline)
    relabel = IfFlag(None, [rebuild, Launch("relink", 1, []), Launch("label", 1, [])], inline=relabel_inline)
    lists = IfAny([None], None, [Launch("build_lists", 1, [])])
    return [lists, relabel]


def test_the_cut_keeps_the_launch_order_and_leaves_no_conditional_node_after_it():
    """Verify head + tail launch the plan's kernels in its order, and the tail holds no block."""
    for relabel_inline in (False, True):
        for rebuild_inline in (False, True):
            plan = relabel_plan(relabel_inline, rebuild_inline)
            head, tail = split_after_conditionals(plan)
            assert launches(head) + launches(tail) == launches(plan)
            assert not any(isinstance(item, (IfFlag, IfAny)) for item in tail)


def test_a_relabel_in_line_leaves_its_own_kernels_after_the_cut():
    """Verify the kernels of an in-line relabel come after the cut (the part that runs beside the
    contact forces), whether its nested rebuild is a conditional node or in line too, and that a
    relabel in its conditional node leaves nothing after it."""
    _, tail = split_after_conditionals(relabel_plan(True, False))
    assert launches(tail) == ["relink", "label"]
    _, tail = split_after_conditionals(relabel_plan(True, True))
    assert launches(tail) == ["reset_search", "link", "relink", "label"]
    head, tail = split_after_conditionals(relabel_plan(False, False))
    assert tail == [] and len(head) == 2
    assert split_after_conditionals([]) == ([], [])


def test_grouped_conditional_blocks_keep_the_launch_order():
    """Verify the first run of conditional blocks goes under one IfAny of their flags, in-line
    blocks and launches stay outside it, and the launches keep their order."""
    from mpmdem.sim.launch_plan import group_conditionals

    lists = IfFlag("lists", [Launch("build_lists", 1, [])])
    plan = relabel_plan(True, False)[1:]  # the relabel in line, its rebuild a conditional node
    head, tail = split_after_conditionals([lists, *plan])
    grouped = group_conditionals(head, "any")
    assert len(grouped) == 1 and isinstance(grouped[0], IfAny)
    assert grouped[0].flags == ["lists", None] and grouped[0].any_flag == "any"
    assert launches(grouped) + launches(tail) == launches([lists, *plan])
    # a lone conditional block, or blocks apart, stay as they are
    assert group_conditionals([lists], "any") == [lists]
    apart = [lists, Launch("k", 1, []), IfFlag("x", [])]
    assert group_conditionals(apart, "any") == apart
