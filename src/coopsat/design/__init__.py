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

The modules behind them (``coopsat.design.lqr``, ``.delay_margin``, ``.lmi``, ``.formation``,
``.sampled_data``, …) are internal. Two public functions share their name with the module
that defines them (``lqr``, ``delay_margin``): the attribute of the package is always the
function, even after the module has been imported (Python would otherwise replace it by the
module); reach a module itself by ``from coopsat.design.lqr import …`` or ``importlib``.
"""

from __future__ import annotations

import importlib
import sys
import types
from typing import TYPE_CHECKING

_PUBLIC = {
    "lqr": "coopsat.design.lqr",
    "LQRResult": "coopsat.design.lqr",
    "delay_margin": "coopsat.design.delay_margin",
    "DelayMargin": "coopsat.design.delay_margin",
    "certified_delay": "coopsat.design.lmi",
    "CertifiedBound": "coopsat.design.lmi",
    "design_delay_gain": "coopsat.design.lmi",
    "DelayGainDesign": "coopsat.design.lmi",
    "formation_lmi": "coopsat.design.formation",
    "LMIGain": "coopsat.design.formation",
    "sampled_data_check": "coopsat.design.sampled_data",
    "SampledDataStability": "coopsat.design.sampled_data",
}

__all__ = sorted(_PUBLIC)

if TYPE_CHECKING:  # for type checkers and IDEs; at run time the names load lazily (__getattr__)
    from coopsat.design.delay_margin import DelayMargin, delay_margin
    from coopsat.design.formation import LMIGain, formation_lmi
    from coopsat.design.lmi import CertifiedBound, DelayGainDesign, certified_delay, design_delay_gain
    from coopsat.design.lqr import LQRResult, lqr
    from coopsat.design.sampled_data import SampledDataStability, sampled_data_check

_loaded: dict[str, object] = {}


def _load(name: str) -> object:
    if name not in _loaded:
        _loaded[name] = getattr(importlib.import_module(_PUBLIC[name]), name)
    return _loaded[name]


def __getattr__(name: str) -> object:
    if name not in _PUBLIC:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = _load(name)
    globals()[name] = value  # the next lookup is a plain attribute
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))


class _Package(types.ModuleType):
    """This package's module type: a public name that is also a submodule's name is a property,
    so the import system's ``setattr(package, "lqr", <module coopsat.design.lqr>)`` does not
    replace the function."""


def _function_not_module(name: str) -> property:
    submodule = f"{__name__}.{name}"

    def get(_module: types.ModuleType) -> object:
        return _load(name)

    def set_(_module: types.ModuleType, value: object) -> None:
        if isinstance(value, types.ModuleType) and value.__name__ == submodule:
            return  # the import system recording the submodule: sys.modules has it
        _loaded[name] = value  # e.g. unittest.mock.patch

    def delete(_module: types.ModuleType) -> None:
        _loaded.pop(name, None)  # the next lookup loads the function again

    return property(get, set_, delete, doc=f"The public function {name!r} (not the module {submodule}).")


#: Public functions named like the module that defines them.
_SHADOWED = ("delay_margin", "lqr")

for _name in _SHADOWED:
    setattr(_Package, _name, _function_not_module(_name))
sys.modules[__name__].__class__ = _Package
