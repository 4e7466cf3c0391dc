"""Topology metrics (SPEC §2 Table 1) against hand-computed values and networkx."""

import math
import time

import networkx as nx
import numpy as np
import pytest

from coopsat.network import metrics, topology

P = 0.8


def test_star_table1_values():
    a = topology.star_adjacency(4)
    # Hub pairs: 1 hop (6 ordered pairs); leaf pairs: 2 hops via the hub (6 ordered pairs).
    assert metrics.average_shortest_path(a) == pytest.approx(1.5, abs=1e-15)
    rel = metrics.mean_pairwise_reliability(a, P)
    assert rel.method == "exact" and rel.samples == 2**3
    assert rel.ci_low == rel.ci_high == rel.value
    # Hub pairs need one link (0.8), leaf pairs two (0.64): mean (0.8 + 0.64) / 2.
    assert rel.value == pytest.approx(0.72, abs=1e-12)
    assert rel.per_pair[0, 1] == pytest.approx(0.8, abs=1e-12)
    assert rel.per_pair[1, 2] == pytest.approx(0.64, abs=1e-12)
    assert np.all(np.isnan(np.diag(rel.per_pair)))


def test_ring_table1_values():
    a = topology.ring_adjacency(4)
    # Each node: 2 neighbours at 1 hop, the opposite node at 2 hops.
    assert metrics.average_shortest_path(a) == pytest.approx(4 / 3, abs=1e-15)
    rel = metrics.mean_pairwise_reliability(a, P)
    adjacent = 1 - (1 - P) * (1 - P**3)  # direct link, else the 3-link way round: 0.9024
    opposite = 1 - (1 - P**2) ** 2  # two disjoint 2-link paths: 0.8704
    assert adjacent == pytest.approx(0.9024, abs=1e-12) and opposite == pytest.approx(0.8704, abs=1e-12)
    assert rel.value == pytest.approx((4 * adjacent + 2 * opposite) / 6, abs=1e-12)
    assert rel.value == pytest.approx(0.8917333333333333, abs=1e-12)
    assert rel.per_pair[0, 2] == pytest.approx(opposite, abs=1e-12)
    assert metrics.two_terminal_reliability(a, P, source=3, target=0) == pytest.approx(adjacent, abs=1e-12)


def test_mesh_table1_value_differs_from_published_0892():
    a = topology.complete_adjacency(4)
    assert metrics.average_shortest_path(a) == 1.0
    # K4, terminals s, t, others u, v. Condition on the direct link s–t: up → connected;
    # down → the other 5 links form a bridge network (s–u, s–v, u–t, v–t, bridge u–v).
    # Condition on the bridge: up → s reaches {u, v} and {u, v} reaches t: (1 − q²)²;
    # down → one of the two disjoint 2-link paths: 1 − (1 − p²)². With q = 1 − p:
    #   R = p + q·[p(1 − q²)² + q(1 − (1 − p²)²)]
    #     = 0.8 + 0.2·[0.8·0.9216 + 0.2·0.8704] = 0.8 + 0.2·0.91136 = 0.982272.
    # All pairs alike, so the mean is 0.982272 (SPEC: ≈ 0.9823; paper prints 0.892).
    q = 1 - P
    k4 = P + q * (P * (1 - q**2) ** 2 + q * (1 - (1 - P**2) ** 2))
    assert k4 == pytest.approx(0.982272, abs=1e-12)
    # The bridge polynomial 2p⁵ − 5p⁴ + 2p³ + 2p² cross-checks the bracket.
    assert P * (1 - q**2) ** 2 + q * (1 - (1 - P**2) ** 2) == pytest.approx(
        2 * P**5 - 5 * P**4 + 2 * P**3 + 2 * P**2, abs=1e-14
    )
    rel = metrics.mean_pairwise_reliability(a, P)
    assert rel.value == pytest.approx(0.982272, abs=1e-12)
    assert rel.samples == 2**6  # 6 two-way links


def test_monte_carlo_ring_ci_covers_exact_with_expected_width():
    a = topology.ring_adjacency(4)
    exact = metrics.mean_pairwise_reliability(a, P).value
    n_samples = 200_000
    mc = metrics.mean_pairwise_reliability(a, P, method="monte-carlo", samples=n_samples, seed=1)
    assert mc.method == "monte-carlo" and mc.samples == n_samples
    assert mc.ci_low <= exact <= mc.ci_high
    half = (mc.ci_high - mc.ci_low) / 2
    bernoulli_half = 1.96 * math.sqrt(mc.value * (1 - mc.value) / n_samples)
    # Pairs within one state are correlated: the sample spread is below √(v(1 − v)).
    assert bernoulli_half / 1.5 < half < bernoulli_half * 1.5
    assert np.nanmax(np.abs(mc.per_pair - metrics.mean_pairwise_reliability(a, P).per_pair)) < 0.01
    again = metrics.mean_pairwise_reliability(a, P, method="monte-carlo", samples=n_samples, seed=1)
    assert again.value == mc.value


def test_directed_chain_follows_information_flow():
    a = topology.chain_adjacency(3, directed=True)  # 0 → 1 → 2
    assert metrics.average_shortest_path(a) == math.inf
    assert metrics.count_links(a) == 2
    assert metrics.two_terminal_reliability(a, P, source=0, target=2) == pytest.approx(P**2, abs=1e-15)
    assert metrics.two_terminal_reliability(a, P, source=2, target=0) == 0.0
    rel = metrics.mean_pairwise_reliability(a, P)
    # Reachable ordered pairs: 0→1, 1→2 (p each), 0→2 (p²); the other 3 never.
    assert rel.value == pytest.approx((2 * P + P**2) / 6, abs=1e-15)
    assert rel.per_pair[2, 0] == pytest.approx(P**2) and rel.per_pair[0, 2] == 0.0


def test_two_way_pair_is_one_link_and_one_way_pairs_are_separate():
    # 0 ↔ 1 (one link), 1 → 2 and 2 → 0 one way each: 3 links.
    a = topology.adjacency_from_edges(3, [(0, 1, 1.0), (1, 0, 2.0), (1, 2, 1.0), (2, 0, 1.0)], directed=True)
    assert metrics.count_links(a) == 3
    # 0 transmits only over 0↔1, so P(1 hears 0) = p.
    assert metrics.two_terminal_reliability(a, P, source=0, target=1) == pytest.approx(P, abs=1e-15)
    # 0 hears 1: directly (0↔1) or 1 → 2 → 0: 1 − (1 − p)(1 − p²).
    assert metrics.two_terminal_reliability(a, P, source=1, target=0) == pytest.approx(
        1 - (1 - P) * (1 - P**2), abs=1e-15
    )
    # Monte Carlo agrees with the enumeration within its interval.
    exact = metrics.mean_pairwise_reliability(a, P)
    mc = metrics.mean_pairwise_reliability(a, P, method="monte-carlo", samples=50_000, seed=3)
    assert mc.ci_low <= exact.value <= mc.ci_high


@pytest.mark.parametrize(
    "a, g",
    [
        (topology.ring_adjacency(6), nx.cycle_graph(6)),
        (topology.star_adjacency(6), nx.star_graph(5)),
        (topology.chain_adjacency(6), nx.path_graph(6)),
    ],
    ids=["ring", "star", "path"],
)
def test_algebraic_connectivity_matches_networkx(a, g):
    expected = nx.algebraic_connectivity(g, method="tracemin_lu", tol=1e-12)
    assert metrics.algebraic_connectivity(a) == pytest.approx(expected, rel=1e-8)


def test_algebraic_connectivity_disconnected_and_directed():
    two_islands = topology.adjacency_from_edges(4, [(0, 1, 1.0), (2, 3, 1.0)], directed=False)
    assert metrics.algebraic_connectivity(two_islands) == 0.0
    assert metrics.algebraic_connectivity(topology.star_adjacency(4, directed=True)) == pytest.approx(1.0)
    # Directed 4-ring: L = I − shift, eigenvalues 1 − e^{2πik/4}; nonzero modes 1 ± i, 2: min Re = 1.
    assert metrics.algebraic_connectivity(topology.ring_adjacency(4, directed=True)) == pytest.approx(1.0)
    # Two roots (0 and 1 both only transmit to 2): no spanning tree.
    two_roots = topology.adjacency_from_edges(3, [(0, 2, 1.0), (1, 2, 1.0)], directed=True)
    assert metrics.algebraic_connectivity(two_roots) == 0.0


def test_auto_picks_monte_carlo_beyond_twenty_links():
    for directed, m in ((False, 30), (True, 30)):
        a = topology.ring_adjacency(30, directed=directed)
        assert metrics.count_links(a) == m
        rel = metrics.mean_pairwise_reliability(a, P, samples=2_000)
        assert rel.method == "monte-carlo" and rel.samples == 2_000
    with pytest.raises(ValueError, match="exact"):
        metrics.mean_pairwise_reliability(topology.ring_adjacency(30), P, method="exact")


def test_exact_enumeration_of_16_links_is_fast():
    # Circulant graph on 8 nodes, links to ±1 and ±2: 16 two-way links, 65 536 states.
    a = topology.adjacency_from_edges(
        8, [(i, (i + s) % 8, 1.0) for i in range(8) for s in (1, 2)], directed=False
    )
    assert metrics.count_links(a) == 16
    start = time.perf_counter()
    rel = metrics.mean_pairwise_reliability(a, P)
    elapsed = time.perf_counter() - start
    assert rel.method == "exact" and rel.samples == 2**16
    assert elapsed < 2.0
    # Every link up with probability p, down with 1 − p: p = 1 connects all, p = 0 none.
    assert metrics.mean_pairwise_reliability(a, 1.0).value == 1.0
    assert metrics.mean_pairwise_reliability(a, 0.0).value == 0.0
    # Bounded by the ring's (a subgraph) and by the all-links-up value.
    assert metrics.mean_pairwise_reliability(topology.ring_adjacency(8), P).value < rel.value < 1.0


def test_topology_table_rows():
    graphs = {
        "star": topology.star_adjacency(4),
        "ring": topology.ring_adjacency(4),
        "mesh": topology.complete_adjacency(4),
        "chain>": topology.chain_adjacency(3, directed=True),
    }
    rows = metrics.topology_table(graphs, P)
    assert [r["name"] for r in rows] == list(graphs)
    star, ring, mesh, chain = rows
    assert (star["n"], star["links"], ring["links"], mesh["links"], chain["links"]) == (4, 3, 4, 6, 2)
    assert star["average_shortest_path"] == pytest.approx(1.5)
    assert ring["reliability"] == pytest.approx(0.8917333333333333, abs=1e-12)
    assert mesh["reliability"] == pytest.approx(0.982272, abs=1e-12)
    assert mesh["reliability_method"] == "exact" and mesh["reliability_ci_low"] == mesh["reliability"]
    assert mesh["algebraic_connectivity"] == pytest.approx(4.0)
    assert star["spanning_tree"] and chain["spanning_tree"] is True
    assert chain["average_shortest_path"] == math.inf
    assert chain["algebraic_connectivity"] == pytest.approx(1.0)
