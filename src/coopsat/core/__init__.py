"""What every layer shares: the in-loop part protocol (:mod:`~coopsat.core.parts`) and JAX's
process settings (:mod:`~coopsat.core.runtime`)."""
