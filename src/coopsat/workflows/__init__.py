"""Workflows: what the command line and the public API do with scenarios — one run end to end
(:mod:`~coopsat.workflows.pipeline`), batches and sweeps, paired runs, gradient tuning, the
deep-space trade-off, Monte Carlo campaigns on Dask, and the engine benchmark.

The public entry points are at the package root (``coopsat.run``, ``coopsat.workflows.sweep``, …,
docs/api.md); these modules are their implementation.
"""
