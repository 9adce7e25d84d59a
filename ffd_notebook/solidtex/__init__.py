"""Solid (volume) textures: exemplars from slice stacks or one image, block synthesis (whole or lazy), sampling.

Plain NumPy/SciPy (and tqdm); the meshes, tetrahedra and the cutting-plane viewer are in
:mod:`ffd_notebook.meshing.organ`.
"""

from __future__ import annotations

from .blending import axis_ramp, block_weights
from .blocks import box_mean, choose_block_size, classify_blocks, feature_inclusiveness
from .kopf import exemplar_from_image
from .lazy import LazySolidTexture
from .lazy_blocks import LazyBlockTexture
from .neighbourhoods import neighbourhood_distance, seam_error
from .optimisation import synthesize_by_optimisation
from .quality import color_histogram, colour_histogram, gradient_energy, histogram_distance, seam_energy
from .sampling import SolidTexture, TextureSampler
from .similarity import block_grid, likeness, self_similarity, self_similarity_figure, volume_slices
from .slices import as_rgb8, sliding_crops, volume_from_slices
from .synthesis import Stage, plan_stages, synthesize, synthesize_by_blocks
from .tetra import boundary_faces
from .transport import exemplar_by_transport

__all__ = [
    "LazyBlockTexture",
    "LazySolidTexture",
    "SolidTexture",
    "Stage",
    "TextureSampler",
    "as_rgb8",
    "axis_ramp",
    "block_grid",
    "block_weights",
    "boundary_faces",
    "box_mean",
    "choose_block_size",
    "classify_blocks",
    "color_histogram",
    "colour_histogram",
    "exemplar_by_transport",
    "exemplar_from_image",
    "feature_inclusiveness",
    "gradient_energy",
    "histogram_distance",
    "likeness",
    "neighbourhood_distance",
    "plan_stages",
    "seam_energy",
    "seam_error",
    "self_similarity",
    "self_similarity_figure",
    "sliding_crops",
    "synthesize",
    "synthesize_by_blocks",
    "synthesize_by_optimisation",
    "volume_from_slices",
    "volume_slices",
]
