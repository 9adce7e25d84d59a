"""Names a package exports but imports only on first use (PEP 562), so importing it stays light.

The top-level package, ``io`` (mesh formats load VTK), ``batch`` and the view packages each keep a
table ``{public name: module that defines it}`` and get their module ``__getattr__`` from
:func:`lazy_getattr`.
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable, Mapping
from typing import Any

__all__ = ["lazy_getattr"]


def lazy_getattr(module_name: str, table: Mapping[str, str]) -> Callable[[str], Any]:
    """A module-level ``__getattr__`` for ``module_name`` that imports ``table[name]`` on first access.

    The value is then stored in the module's namespace, so the import happens once.

    Examples
    --------
    >>> import types, sys
    >>> demo = types.ModuleType("demo_lazy")
    >>> sys.modules["demo_lazy"] = demo
    >>> demo.__getattr__ = lazy_getattr("demo_lazy", {"sqrt": "math"})
    >>> demo.sqrt(9.0), "sqrt" in vars(demo)
    (3.0, True)
    >>> demo.cbrt
    Traceback (most recent call last):
    ...
    AttributeError: module 'demo_lazy' has no attribute 'cbrt'
    """
    namespace = vars(sys.modules[module_name])

    def __getattr__(name: str) -> Any:
        if name in table:
            value = getattr(importlib.import_module(table[name]), name)
            namespace[name] = value
            return value
        raise AttributeError(f"module {module_name!r} has no attribute {name!r}")

    return __getattr__
