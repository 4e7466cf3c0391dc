"""`coopsat topology`: the cartwheel paper's Table 1 beside ours, and bad input."""

import numpy as np

from coopsat.cli import main


def test_table1_beside_ours(capsys):
    assert main(["topology", "star", "ring", "mesh"]) == 0
    out = capsys.readouterr().out
    lines = {tuple(line.split()[:2]): line for line in out.splitlines() if line.startswith("  ")}
    assert lines[("star", "reliability")].split()[2:5] == ["0.72", "0.72", "agrees"]
    assert lines[("ring", "reliability")].split()[2:5] == ["0.8917", "0.891733", "agrees"]
    mesh = lines[("mesh", "reliability")]
    assert mesh.split()[2:5] == ["0.892", "0.982272", "differs:"] and "transposed" in mesh


def test_adjacency_file_and_monte_carlo(tmp_path, capsys):
    path = tmp_path / "chain.csv"
    np.savetxt(path, [[0, 1, 0], [1, 0, 1], [0, 1, 0]], delimiter=",")
    assert main(["topology", str(path), "--monte-carlo", "5000", "--link-reliability", "0.9"]) == 0
    row = next(line for line in capsys.readouterr().out.splitlines() if line.startswith("chain"))
    # Path 0-1-2: pairs (0,1), (1,2) at 0.9, (0,2) at 0.81 (both ways): mean 0.87.
    assert abs(float(row.split()[4]) - 0.87) < 0.01 and "MC [" in row


def test_bad_graph_and_probability(capsys):
    assert main(["topology", "hexagon"]) == 2
    assert "not a named graph" in capsys.readouterr().err
    assert main(["topology", "ring", "--link-reliability", "1.5"]) == 2
    assert "must be a probability" in capsys.readouterr().err
