"""The Gaussian-process explorer: random and conditioned deformations of a mesh, shown live (PyVista)."""

from __future__ import annotations

from .explorer import GPExplorer

__all__ = ["GPExplorer"]
