"""What every layer shares: the in-loop part protocol (:mod:`~coopsat.core.parts`), JAX's
process settings (:mod:`~coopsat.core.runtime`) and the error family
(:mod:`~coopsat.core.errors`)."""
