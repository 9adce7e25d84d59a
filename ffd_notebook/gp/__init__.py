"""Gaussian-process deformation models ("Gaussian Process Morphable Models", Luthi et al.).

A Gaussian process over displacement fields ``u: R^3 -> R^3`` with a matrix-valued kernel:
draw smooth random deformations, see how the kernel width sets their smoothness, and condition
on a few observed landmark displacements to get the posterior deformation and its uncertainty.
NumPy/SciPy only (the pictures live in :mod:`ffd_notebook.view.gp`).

- :mod:`~ffd_notebook.gp.kernels`: Gaussian, exponential and cubic B-spline kernels, anisotropic
  and per-component versions; :mod:`~ffd_notebook.gp.combine`: sums, products, scalings, a
  kernel per axis and the mirrored (left-right symmetric) kernel.
- :mod:`~ffd_notebook.gp.process`: :class:`GaussianProcess` with exact Cholesky inference, noise
  per landmark (variances or 3x3 covariances) and the log marginal likelihood.
- :mod:`~ffd_notebook.gp.lowrank`: :class:`LowRankGP`, Nystrom or pivoted-Cholesky eigenbases on
  a mesh's vertices, statistical shape models from examples (PCA) and augmented models, with
  ``logpdf``; :mod:`~ffd_notebook.gp.metrics`: compactness, generalization, specificity.
- :mod:`~ffd_notebook.gp.statismo`: Statismo/Scalismo HDF5 files (:func:`load_model`,
  :func:`save_model`).
- :mod:`~ffd_notebook.gp.fields`: displacement fields on regular grids for arrow display.

Examples
--------
>>> import numpy as np
>>> from ffd_notebook.gp import GaussianKernel, GaussianProcess
>>> gp = GaussianProcess(GaussianKernel(sigma=50.0, scale=5.0))
>>> landmarks = np.array([[0.0, 0.0, 0.0], [100.0, 0.0, 0.0], [0.0, 100.0, 0.0]])
>>> moves = np.array([[0.0, 0.0, 10.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
>>> post = gp.posterior(landmarks, moves, noise=0.01)
>>> post.mean([[0.0, 0.0, 0.0], [10.0, 0.0, 0.0]]).round(2).tolist()
[[0.0, 0.0, 10.0], [0.0, 0.0, 9.6]]
>>> post.variance([[0.0, 0.0, 0.0]]).round(3).tolist()     # pinned down by the landmark
[[0.01, 0.01, 0.01]]
"""

from __future__ import annotations

from .combine import DiagonalKernel, MirroredKernel, ProductKernel, ScaledKernel, SumKernel
from .fields import ArrowField, arrow_field, grid_points, sample_jointly
from .kernels import BSplineKernel, ExponentialKernel, GaussianKernel, Kernel, bspline_weights
from .linalg import cholesky
from .lowrank import LowRankGP
from .metrics import compactness, generalization, specificity
from .process import GaussianProcess, PosteriorKernel
from .statismo import load_model, save_model

__all__ = [
    "ArrowField",
    "BSplineKernel",
    "DiagonalKernel",
    "ExponentialKernel",
    "GaussianKernel",
    "GaussianProcess",
    "Kernel",
    "LowRankGP",
    "MirroredKernel",
    "PosteriorKernel",
    "ProductKernel",
    "ScaledKernel",
    "SumKernel",
    "arrow_field",
    "bspline_weights",
    "cholesky",
    "compactness",
    "generalization",
    "grid_points",
    "load_model",
    "sample_jointly",
    "save_model",
    "specificity",
]
