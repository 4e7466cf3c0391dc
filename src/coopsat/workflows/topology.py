"""``coopsat topology``: communication graphs compared by average path length, reliability
and algebraic connectivity, with the cartwheel paper's Table 1 beside ours when the
comparison is the paper's (SPEC §2)."""

from pathlib import Path

import numpy as np

from coopsat.network import topology
from coopsat.network.graphs import NAMED_GRAPH_NAMES, named_graph
from coopsat.scenarios.load import ScenarioError, bundled_names, load_scenario


def resolve_graphs(refs, nodes):
    """name -> adjacency ``(n, n)`` for each reference: a named graph of ``nodes`` nodes
    (:func:`coopsat.network.graphs.named_graph`), a scenario's network (its first graph), or an adjacency file
    (whitespace- or comma-separated).

    Raises
    ------
    ScenarioError
        A reference that is none of these, or a file that is not an adjacency matrix.
    """
    from coopsat.scenarios.build import build_graph

    graphs = {}
    for ref in refs:
        if ref in NAMED_GRAPH_NAMES:
            graphs[ref] = named_graph(ref, nodes)
        elif ref in bundled_names() or ref.endswith(".toml"):
            scenario = load_scenario(ref)
            graphs[scenario.name] = build_graph(scenario.network, [sc.name for sc in scenario.spacecraft]).toarray()
        elif Path(ref).is_file():
            try:
                a = np.loadtxt(ref, delimiter="," if ref.endswith(".csv") else None, ndmin=2)
                graphs[Path(ref).stem] = topology.validate_adjacency(a)
            except ValueError as err:
                raise ScenarioError(f"{ref}: not an adjacency matrix ({err})") from None
        else:
            raise ScenarioError(f"topology: '{ref}' is not a named graph ({', '.join(NAMED_GRAPH_NAMES)}), a scenario, or an adjacency file")
    return graphs


def compare_topologies(refs, nodes=4, link_reliability=0.8, monte_carlo=None):
    """One row of :func:`coopsat.network.metrics.topology_table` per graph reference
    (:func:`resolve_graphs`); reliability exact where it can be, else from ``monte_carlo``
    random link states (100 000 when not given and exact is out of reach)."""
    from coopsat.network.metrics import topology_table

    if not 0.0 <= link_reliability <= 1.0:
        raise ScenarioError(f"--link-reliability {link_reliability:g}: must be a probability in [0, 1]")
    method, samples = ("monte-carlo", monte_carlo) if monte_carlo else ("auto", 100_000)
    return topology_table(resolve_graphs(refs, nodes), link_reliability, method=method, samples=samples)


def table_lines(rows, nodes, link_reliability):
    """The printed table of :func:`compare_topologies`'s rows, and Table 1 of the cartwheel
    paper beside ours when the nodes and link reliability are the paper's."""
    from coopsat.analysis.papers.cartwheel_keeping import TABLE_1_LINK_RELIABILITY, TABLE_1_NODES, table1_rows

    lines = [f"link reliability {link_reliability:g}; reliability = mean two-terminal reliability over ordered pairs",
             f"{'graph':<24}{'n':>5}{'links':>7}{'avg path':>10}{'reliability':>13}{'  method (95% CI)':<34}{'λ2':>8}  tree"]
    for r in rows:
        how = r["reliability_method"] if r["reliability_method"] == "exact" else (
            f"MC [{r['reliability_ci_low']:.4f}, {r['reliability_ci_high']:.4f}]")
        lines.append(f"{r['name'][:23]:<24}{r['n']:>5}{r['links']:>7}{r['average_shortest_path']:>10.4g}"
                     f"{r['reliability']:>13.6f}  {how:<32}{r['algebraic_connectivity']:>8.4g}  {'yes' if r['spanning_tree'] else 'no'}")
    compared = table1_rows(rows) if (nodes, link_reliability) == (TABLE_1_NODES, TABLE_1_LINK_RELIABILITY) else []
    if compared:
        lines += ["", "Table 1 of the cartwheel paper (SPEC §2), published beside ours:"]
        lines += [f"  {c['name']:<9}{c['quantity']:<23}{c['published']:>8g}{c['ours']:>11.6g}  {c['verdict']}"
                  + (f": {c['reason']}" if c["reason"] else "") for c in compared]
    return lines
