"""Software in the loop (``coopsat sil``, :func:`coopsat.sil`; docs/sil.md).

One simulator process (this one: plant, environment, sensors, actuators, network model,
recording) and one flight-software process per spacecraft, which runs exactly that
spacecraft's part of the controller. They speak the versioned message format of
:mod:`~coopsat.workflows.sil.protocol` over ZeroMQ.

* :mod:`~coopsat.workflows.sil.protocol`: the messages, their version, their encoding;
* :mod:`~coopsat.workflows.sil.schema`: the schema of a flight software's replies, and the
  check every message from it passes (and :class:`SILError`, the one error of a SIL run);
* :mod:`~coopsat.workflows.sil.fsw`: coopsat's own flight-software host
  (``python -m coopsat.workflows.sil.fsw``);
* :mod:`~coopsat.workflows.sil.processes`: starting, pausing, killing and reaping the
  flight-software processes (one process group; none outlives the simulator);
* :mod:`~coopsat.workflows.sil.loop`: the simulator's period loop, the engine's own period
  functions jitted one period at a time;
* :mod:`~coopsat.workflows.sil.run`: the workflow (faults, the run's :class:`Result`).

A package under ``workflows`` rather than ``coopsat.sil``: importing a ``coopsat.sil``
subpackage would replace the public function ``coopsat.sil`` by the module
(docs/architecture.md, "The public surface"). Nothing here imports ZeroMQ until a run starts.
"""
