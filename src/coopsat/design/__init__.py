"""Design tools on NumPy arrays: each returns a named, frozen result that carries its proof.

Public names (docs/api.md), loaded on first use, so ``import coopsat.design`` imports neither
SciPy nor cvxpy::

    from coopsat.design import lqr

    res = lqr([[0.0, 1.0], [0.0, 0.0]], [[0.0], [1.0]], [[1.0, 0.0], [0.0, 1.0]], [[1.0]])
    res.K, res.residual          # [[1, √3]], ~1e-16

=====================  ============================  ==============================================
name                   result                        what
=====================  ============================  ==============================================
``lqr``                :class:`LQRResult`            continuous or zero-order-hold LQR (CARE/DARE)
``delay_margin``       :class:`DelayMargin`          exact constant-delay margin of a retarded system
``certified_delay``    :class:`CertifiedBound`       largest delay bound certified by the LMI
``design_delay_gain``  :class:`DelayGainDesign`      gain with the best certified delay bound/decay
``formation_lmi``      :class:`LMIGain`              deep-space formation gain, guaranteed cost (LMI)
``sampled_data_check`` :class:`SampledDataStability` consensus attitude laws sampled and held
=====================  ============================  ==============================================

The modules behind them (``coopsat.design.riccati``, ``.delay_exact``, ``.delay_bounds``,
``.delay_gain``, ``.formation_synthesis``, ``.sampled_data``, …) are internal. No public name
is also a submodule's name: importing a submodule sets the package attribute of its name,
which would replace the function.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

_PUBLIC = {
    # public name: (module, name there)
    "lqr": ("coopsat.design.riccati", "lqr"),
    "LQRResult": ("coopsat.design.riccati", "LQRResult"),
    "delay_margin": ("coopsat.design.delay_exact", "delay_margin"),
    "DelayMargin": ("coopsat.design.delay_exact", "DelayMargin"),
    "certified_delay": ("coopsat.design.delay_bounds", "certified_delay"),
    "CertifiedBound": ("coopsat.design.delay_bounds", "CertifiedBound"),
    "design_delay_gain": ("coopsat.design.delay_gain", "design_delay_gain"),
    "DelayGainDesign": ("coopsat.design.delay_gain", "DelayGainDesign"),
    "formation_lmi": ("coopsat.design.formation_synthesis", "formation_lmi"),
    "LMIGain": ("coopsat.design.formation_synthesis", "LMIGain"),
    "sampled_data_check": ("coopsat.design.sampled_data", "sampled_data_check"),
    "SampledDataStability": ("coopsat.design.sampled_data", "SampledDataStability"),
}

__all__ = sorted(_PUBLIC)

if TYPE_CHECKING:  # for type checkers and IDEs; at run time the names load lazily (__getattr__)
    from coopsat.design.delay_bounds import CertifiedBound, certified_delay
    from coopsat.design.delay_exact import DelayMargin, delay_margin
    from coopsat.design.delay_gain import DelayGainDesign, design_delay_gain
    from coopsat.design.formation_synthesis import LMIGain, formation_lmi
    from coopsat.design.riccati import LQRResult, lqr
    from coopsat.design.sampled_data import SampledDataStability, sampled_data_check


def __getattr__(name: str) -> object:
    if name not in _PUBLIC:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    module, attribute = _PUBLIC[name]
    value = getattr(importlib.import_module(module), attribute)
    globals()[name] = value  # the next lookup is a plain attribute
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
