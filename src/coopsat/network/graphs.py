"""The graph kinds of a scenario's ``[network]`` and its switches, and the named graphs of
``coopsat topology``.

:data:`GRAPH_KINDS` maps every ``kind`` of a graph table to its builder
``(graph, names, where) -> EdgeList``: ``graph`` is the table (the fields of
:class:`coopsat.scenarios.schema.Graph`: ``kind``, ``directed``, ``weight``, ``hub``, ``edges``,
``adjacency``), ``names`` the spacecraft in state order and ``where`` the table's place in the
scenario (``network``, ``network.switches[0]``), which every message names. The graph is a
:class:`~coopsat.network.edge_list.EdgeList` (memory linear in the links, whatever the number of
spacecraft): a link j → i with weight ``a_ij`` means i hears j (:mod:`coopsat.network.topology`).
A graph that cannot be built raises :class:`~coopsat.network.topology.GraphError` with one line.

:func:`named_graph` gives the graphs that ``coopsat topology`` knows by name
(:data:`NAMED_GRAPH_NAMES`, ``mesh`` being the complete graph) for a number of nodes.

Importing this module imports neither networkx nor SciPy (the scenario schema reads
:data:`GRAPH_KINDS`): the builders load :mod:`coopsat.network.topology` when they run.
"""

from coopsat.network import edge_list


def _none(graph, names, where):
    """No links: nobody hears anybody."""
    return edge_list.empty(len(names))


def _named(kind):
    """The builder of a named graph of unit links (ring, chain, complete), times ``weight``."""

    make = {"ring": edge_list.ring, "chain": edge_list.chain, "complete": lambda n, directed: edge_list.complete(n)}[kind]

    def build(graph, names, where):
        return make(len(names), directed=graph.directed).scaled(graph.weight)

    build.__name__ = build.__qualname__ = f"_{kind}"
    build.__doc__ = f"The {kind} of the spacecraft in state order, every link of weight ``weight``."
    return build


def _star(graph, names, where):
    """A star around ``hub`` (default the first spacecraft), every link of weight ``weight``."""
    from coopsat.network import topology

    index = {name: k for k, name in enumerate(names)}
    hub = graph.hub or names[0]
    if hub not in index:
        raise topology.GraphError(f"{where}.hub: unknown spacecraft '{hub}' (known: {', '.join(names)})")
    return edge_list.star(len(names), graph.directed, hub=index[hub]).scaled(graph.weight)


def _edges(graph, names, where):
    """The links of ``edges``: [transmitter, receiver, weight] by spacecraft name."""
    from coopsat.network import topology

    index = {name: k for k, name in enumerate(names)}
    src, dst, weight = [], [], []
    for k, (j, i, w) in enumerate(graph.edges):
        for end in (j, i):
            if end not in index:
                raise topology.GraphError(f"{where}.edges[{k}]: unknown spacecraft '{end}' (known: {', '.join(names)})")
        src.append(index[j])
        dst.append(index[i])
        weight.append(w)
    return edge_list.edge_list(len(names), src, dst, weight, graph.directed, where=f"{where}.edges")


def _adjacency(graph, names, where):
    """The matrix ``adjacency`` as given, checked, one row and column per spacecraft."""
    from coopsat.network import topology

    n = len(names)
    try:
        a = topology.validate_adjacency(graph.adjacency)
    except topology.GraphError as err:
        raise topology.GraphError(str(err).replace("network", where, 1)) from None
    if a.shape[0] != n:
        raise topology.GraphError(f"{where}.adjacency: is {a.shape[0]}×{a.shape[0]} but there are {n} spacecraft")
    return edge_list.from_adjacency(a)


GRAPH_KINDS = {
    "none": _none,
    "ring": _named("ring"),
    "chain": _named("chain"),
    "star": _star,
    "complete": _named("complete"),
    "edges": _edges,
    "adjacency": _adjacency,
}
"""Builder ``(graph, names, where) -> EdgeList`` of every graph ``kind``, in the order the
scenario schema and docs/scenarios.md list them."""


def graph_edges(graph, names, where="network"):
    """The links of one graph table of a scenario (``.toarray()`` gives ``A[i, j]``, i hears j).

    Parameters
    ----------
    graph : coopsat.scenarios.schema.Graph
    names : sequence of str
        Spacecraft names, in state order.
    where : str
        The graph's place in the scenario, for error messages.

    Returns
    -------
    coopsat.network.edge_list.EdgeList
        Memory linear in the links (a ring of 1e6 spacecraft is 2e6 links, not 1e12 entries).

    Raises
    ------
    coopsat.network.topology.GraphError
        A graph that names an unknown spacecraft or is malformed (one line, naming ``where``).
    """
    builder = GRAPH_KINDS.get(graph.kind)
    if builder is None:
        from coopsat.network.topology import GraphError

        raise GraphError(f"{where}.kind: unknown graph kind '{graph.kind}' (known: {', '.join(GRAPH_KINDS)})")
    return builder(graph, names, where)


NAMED_GRAPH_NAMES = ("star", "ring", "chain", "mesh", "complete")
"""The graphs ``coopsat topology`` knows by name, in the order its messages list them."""

_ALIASES = {"mesh": "complete"}


def named_graph(name, n):
    """The unit-weight, undirected graph ``name`` (:data:`NAMED_GRAPH_NAMES`; a star's hub is
    node 0) of ``n`` nodes, as an adjacency of shape (n, n).

    Raises
    ------
    coopsat.network.topology.GraphError
        An unknown name, or fewer than one node.
    """
    from coopsat.network import topology

    if name not in NAMED_GRAPH_NAMES:
        raise topology.GraphError(f"'{name}' is not a named graph ({', '.join(NAMED_GRAPH_NAMES)})")
    return topology.NAMED_GRAPHS[_ALIASES.get(name, name)](n)
