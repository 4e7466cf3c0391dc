"""Example coopsat plug-ins (docs/plugins.md).

* :mod:`coopsat_example.plugin` — the scenario tables, builders and design checks, registered
  with :func:`coopsat.plugins.register` when coopsat loads the entry point;
* :mod:`coopsat_example.saturated_consensus` — the controller part (JAX);
* :mod:`coopsat_example.cold_gas` — the actuator part (JAX);
* :mod:`coopsat_example.analysis` — the metrics a run of the law adds to metrics.json.

Importing this package registers nothing; only :mod:`coopsat_example.plugin` does.
"""
