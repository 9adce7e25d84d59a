"""One sample, start to finish: seed, fold-free draw, deformation, files. Runs on a Dask worker.

A :class:`Job` is small (paths, the model's parameters, the seed, the fold rule), so it travels
with every task; each worker process reads the mesh and binds the model once and keeps them
(:func:`context`). Sample ``i``'s generator is ``default_rng(SeedSequence(seed, spawn_key=(i,)))``
(the ``i``-th child of ``SeedSequence(seed).spawn``), so what sample ``i`` is depends neither on
the number of workers nor on the order they run in.

With images (``generate(..., image=, label_image=)``) each sample also warps them, and the
direction matters: a sample's transform ``T`` is applied to the images as ITK applies a
transform, a pull-back (the output voxel at ``x`` takes the input's value at ``T(x)``), so what
the input showed at ``q`` appears at ``T^-1(q)``; the mesh, drawn on the input image, is moved by
``T^-1`` too (:func:`~ffd_notebook.images.invert_points`, Newton's method at the vertices) and so
stays on the warped image. The parameters file holds ``T`` itself: the transform that
``warp_image`` or ``sitk.Resample`` takes to warp the image again. A run without images moves
the mesh by ``T``, as before.
"""

from __future__ import annotations

import json
import os
import threading
import time
from dataclasses import asdict, dataclass, replace
from typing import Any

import numpy as np

from .._util.blas import one_blas_thread
from ..images import image_suffix, invert_points, read_image, warp_image, write_image
from ..io import load_ffd, read_mesh, save_ffd, write_mesh
from ..io._atomic import folder_syncs_deferred
from .evaluate import PointEvaluator
from .files import BoundFiles, LatticeFiles
from .folding import FoldFree, accept, volume_grid
from .gp_model import GPSample, RandomGP
from .models import BoundLattice, LatticeSample, RandomLattice
from .output import IMAGE_COLUMNS, Layout, read_parameters_txt, write_parameters_txt
from .ply import TrianglePly
from .seeds import sample_rng

__all__ = [
    "MODELS",
    "Context",
    "Job",
    "context",
    "deformed_mesh",
    "job_layout",
    "model_from_spec",
    "run_sample",
    "run_samples",
    "sample_points",
    "warped_image",
]

MODELS = {cls.name: cls for cls in (RandomLattice, RandomGP, LatticeFiles)}


def model_from_spec(spec: dict[str, Any]):
    """Rebuild a model from its ``to_spec()`` (validated again).

    Examples
    --------
    >>> model_from_spec(RandomLattice(5, 2.0).to_spec()) == RandomLattice(5, 2.0)
    True
    """
    params = dict(spec)
    name = params.pop("model", None)
    if name not in MODELS:
        raise ValueError(f"unknown model {name!r}; known: {sorted(MODELS)}")
    return MODELS[name](**params)


@dataclass(frozen=True)
class Job:
    """What every sample of a run shares."""

    mesh: str
    spec: dict[str, Any]
    seed: int
    rule: FoldFree | None
    out: str
    format: str
    image: str | None = None
    label_image: str | None = None
    interpolation: str = "linear"  # of the image; the label map is always "nearest"
    #: SHA-256 of the model's deformation files (:class:`LatticeFiles`), in its order: what their samples
    #: are made of, so part of the run's identity, and of the key of a process's cached context
    files_sha256: tuple[str, ...] = ()

    @property
    def images(self) -> dict[str, str]:
        """``{"image": path, "label": path}`` for the images given (none: an empty dict)."""
        return {kind: path for kind, path in (("image", self.image), ("label", self.label_image)) if path}

    @property
    def model_files(self) -> list[str]:
        """The deformation files the model reads (:class:`LatticeFiles`), else an empty list."""
        return list(self.spec.get("files", [])) if self.spec.get("model") == LatticeFiles.name else []

    def with_file_digests(self) -> Job:
        """This job with :attr:`files_sha256` read from its model's files now."""
        return replace(self, files_sha256=tuple(file_sha256(path) for path in self.model_files))

    def settings(self, mesh_digest: str) -> dict[str, Any]:
        """The run's identity, stored in ``run.json`` (the sample count is not part of it)."""
        rule = None if self.rule is None else asdict(self.rule)
        settings = {"mesh": self.mesh, "mesh_sha256": mesh_digest, "model": self.spec, "seed": self.seed,
                    "fold_free": rule, "format": self.format}  # fmt: skip
        if self.files_sha256:  # only then: other runs keep the run.json they always had
            settings["files_sha256"] = list(self.files_sha256)
        if self.images:  # only then: a run without images keeps the run.json it always had
            settings["images"] = {
                kind: {"path": path, "sha256": file_sha256(path)} for kind, path in self.images.items()
            }
            settings["image_interpolation"] = self.interpolation
        return settings

    @classmethod
    def from_settings(cls, out: str | os.PathLike[str], settings: dict[str, Any]) -> Job:
        rule = None if settings["fold_free"] is None else FoldFree(**settings["fold_free"])
        images = settings.get("images", {})
        image, label = (images[kind]["path"] if kind in images else None for kind in ("image", "label"))
        interpolation = settings.get("image_interpolation", "linear")
        return cls(settings["mesh"], settings["model"], settings["seed"], rule, str(out), settings["format"], image,
                   label, interpolation, tuple(settings.get("files_sha256", ())))  # fmt: skip


def job_layout(job: Job) -> Layout:
    """The output folder's layout for ``job`` (its mesh format, and its images' extensions)."""
    return Layout(job.out, job.format, {kind: image_suffix(path) for kind, path in job.images.items()})


@dataclass(frozen=True)
class Context:
    """A job's mesh and bound model in one process, with evaluators for its vertices and check points."""

    mesh: Any
    points: np.ndarray
    bound: Any
    vertices: PointEvaluator
    check: PointEvaluator  # vertices, then the volume grid
    ply: TrianglePly | None  # the fast writer, for triangle meshes
    images: dict[str, Any]  # "image" / "label" -> the SimpleITK image read once

    def min_det_j(self, sample: Any) -> float:
        """Smallest Jacobian determinant over the vertices and the volume grid."""
        return float(self.check.jacobian_determinant(sample).min())


def _template(bound: Any):
    """An FFD with the placement every sample of ``bound`` shares (for the cached evaluators)."""
    if isinstance(bound, BoundLattice):
        return bound.sample_ffd(bound.lattice.offsets)
    if isinstance(bound, BoundFiles):
        return bound.deformations[0]
    return None


_CONTEXTS: dict[str, Context] = {}
_KEEP = 4
_LOCK = threading.Lock()


def context(job: Job) -> Context:
    """The mesh and bound model of ``job``, built once per process (and per file version)."""
    files = [job.mesh, *job.images.values()]
    versions = [(path, os.stat(path).st_mtime_ns, os.stat(path).st_size) for path in files]
    # the model's files by their contents (a file edited within the clock's tick keeps its time and size)
    key = json.dumps([versions, job.spec, job.files_sha256, job.rule and job.rule.grid], sort_keys=True)
    with _LOCK:  # threads of one worker share it; building it twice would only waste time
        if key not in _CONTEXTS:
            mesh = read_mesh(job.mesh)
            points = np.asarray(mesh.points, dtype=np.float64)
            grid = 12 if job.rule is None else job.rule.grid
            check = np.vstack([points, volume_grid(points, grid)]) if grid else points
            bound = model_from_spec(job.spec).bind(points)
            template = _template(bound)
            evaluators = PointEvaluator(points, template), PointEvaluator(check, template)
            while len(_CONTEXTS) >= _KEEP:  # a notebook trying many settings: keep the newest few
                del _CONTEXTS[next(iter(_CONTEXTS))]
            images = {kind: read_image(path) for kind, path in job.images.items()}
            _CONTEXTS[key] = Context(mesh, points, bound, *evaluators, TrianglePly.for_mesh(mesh), images)
        return _CONTEXTS[key]


def sample_points(ctx: Context, sample: Any) -> np.ndarray:
    """The sample's mesh vertices: moved by ``T``, or by ``T^-1`` in a run with images (see the module)."""
    if ctx.images:
        return invert_points(sample, ctx.points)
    return ctx.vertices.deform(sample)


def _transform(sample: Any) -> Any:
    """What ``warp_image`` takes: a lattice sample's FFD itself (evaluated separably on the image grid)."""
    return sample.ffd if isinstance(sample, LatticeSample) else sample


def warped_image(job: Job, ctx: Context, kind: str, sample: Any) -> Any:
    """The sample's ``"image"`` (the run's interpolation) or ``"label"`` map (nearest), a SimpleITK image."""
    interpolation = job.interpolation if kind == "image" else "nearest"
    return warp_image(ctx.images[kind], _transform(sample), interpolation=interpolation)


def deformed_mesh(ctx: Context, sample: Any, points: np.ndarray | None = None):
    """A copy of the mesh (colours and all) with the sample's vertices (:func:`sample_points`), or the given ones."""
    mesh = ctx.mesh.copy(deep=True)
    mesh.points = sample_points(ctx, sample) if points is None else points
    if "Normals" in mesh.point_data:
        del mesh.point_data["Normals"]  # the rest shape's normals are wrong for the deformed one
    return mesh


def _save_parameters(layout: Layout, index: int, bound: Any, sample: Any) -> str:
    """Store what replays the sample; returns the path written into the manifest."""
    if isinstance(bound, BoundFiles):
        return bound.model.files[index]  # the given file itself, and the scale in the manifest
    if isinstance(sample, LatticeSample):
        path = layout.parameters(index, ".ffd")
        save_ffd(path, sample.ffd.lattice)
    elif isinstance(sample, GPSample):
        path = layout.parameters(index, ".txt")
        write_parameters_txt(path, sample.coefficients)
    else:
        raise TypeError(f"no parameter file for {type(sample).__name__}")
    return path.relative_to(layout.root).as_posix()


def load_sample(layout: Layout, row: dict[str, Any], ctx: Context, rule: FoldFree | None):
    """The sample a manifest row describes, rebuilt from its parameters file."""
    bound, index = ctx.bound, int(row["id"])
    if isinstance(bound, BoundFiles):
        sample = bound.draw(None, index)
        for _ in range(int(row["scale_downs"])):  # the same products, in the same order, as the run
            sample = sample.scaled(rule.shrink)  # type: ignore[union-attr]
        return sample
    path = layout.root / row["parameters_file"]
    if isinstance(ctx.bound.model, RandomLattice):
        loaded = load_ffd(path)
        if loaded.shape != bound.lattice.shape:
            raise ValueError(f"{path}: lattice shape {loaded.shape}, the run's is {bound.lattice.shape}")
        if loaded.border != bound.lattice.border:
            raise ValueError(f"{path}: border {loaded.border!r}, the run's is {bound.lattice.border!r}")
        return LatticeSample(bound.sample_ffd(loaded.offsets))
    return bound.sample_from(read_parameters_txt(path, bound.process.rank))


def run_sample(job: Job, index: int) -> dict[str, Any]:
    """Make sample ``index``: returns ``{"id", "row", "seconds", "cpu"}``, or ``{"id", "error"}`` naming the sample.

    Errors are returned, not raised, so that one bad sample never stops a Dask computation.
    """
    return run_samples(job, [index])[0]


def run_samples(job: Job, indices: list[int]) -> list[dict[str, Any]]:
    """Make several samples (one Dask task): :func:`run_sample`'s result for each, in order.

    One task for several samples spreads Dask's fixed cost per task (the scheduler's
    bookkeeping, messages, the worker's task state: ~8 ms of CPU per task measured on a
    ``LocalCluster``, a third of a 53k-vertex sample's work) over all of them. Their meshes and
    parameters are written first, then their folders are fsync-ed once, then their records:
    a record that survives a crash names files that survive it too, so a resumed run
    (:meth:`Layout.done`) never skips a sample whose files were lost; a lost record only means
    the sample is made again (with the same bytes).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> import pyvista as pv
    >>> from ffd_notebook.batch.output import Layout
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> pv.Sphere(theta_resolution=10, phi_resolution=10).save(folder / "ball.ply")
    >>> job = Job(str(folder / "ball.ply"), RandomLattice(5, 0.05).to_spec(), 0, FoldFree(), str(folder / "out"), "ply")
    >>> Layout(job.out).make()
    >>> [out["id"] for out in run_samples(job, [3, 4])], Layout(job.out).done(4)
    ([3, 4], True)
    """
    # one BLAS thread: samples run in parallel already, and a sample's numbers must not depend on how
    # many BLAS threads a worker has (bit-for-bit equal outputs on any cluster, and in replay)
    with one_blas_thread():
        layout = job_layout(job)
        with folder_syncs_deferred():
            outs = [_make_sample(job, layout, i) for i in indices]
            tic, cpu = time.perf_counter(), time.thread_time()  # to the block's end: the folders' fsyncs
        synced, synced_cpu = time.perf_counter() - tic, time.thread_time() - cpu
        with folder_syncs_deferred():
            for out in outs:
                if "row" in out:
                    _write_record(layout, out)
            tic, cpu = time.perf_counter(), time.thread_time()  # and the records' folder fsync
        synced, synced_cpu = synced + time.perf_counter() - tic, synced_cpu + time.thread_time() - cpu
    made = [out for out in outs if "row" in out]
    for out in made:  # each sample's write time includes its share of the folder fsyncs
        seconds = out["seconds"]
        seconds["write"] += seconds.pop("record") + synced / len(made)
        out["cpu"] += synced_cpu / len(made)
    return outs


def _write_record(layout: Layout, out: dict[str, Any]) -> None:
    """Write the sample's manifest row (last: it marks the sample as done); a failure becomes its error."""
    tic, cpu = time.perf_counter(), time.thread_time()
    try:
        layout.write_record(out["row"])
    except Exception as exc:
        index = out["id"]
        out.clear()
        out.update(id=index, error=f"sample {index}: {type(exc).__name__}: {exc}")
        return
    out["seconds"]["record"] = time.perf_counter() - tic
    out["cpu"] += time.thread_time() - cpu


def _make_sample(job: Job, layout: Layout, index: int) -> dict[str, Any]:
    """Draw, check, deform and write one sample's mesh and parameters (its record comes later).

    ``cpu`` is the CPU time of the thread that made it (wall time minus waits for the disk and
    for a core: a busy machine stretches ``seconds``, not ``cpu``).
    """
    cpu = time.thread_time()
    try:
        ctx = context(job)
        got = accept(ctx.bound, index, sample_rng(job.seed, index), ctx.min_det_j, job.rule)
        seconds = dict(got.seconds)
        tic = time.perf_counter()
        points = sample_points(ctx, got.sample)
        seconds["deform"] = time.perf_counter() - tic
        tic = time.perf_counter()
        image_files = {}
        for kind in ctx.images:
            path = layout.image(kind, index)
            write_image(path, warped_image(job, ctx, kind, got.sample), compress=True)
            image_files[IMAGE_COLUMNS[kind]] = path.relative_to(layout.root).as_posix()
        if ctx.images:
            seconds["images"] = time.perf_counter() - tic
        tic = time.perf_counter()
        parameters = _save_parameters(layout, index, ctx.bound, got.sample)
        mesh_path = layout.mesh(index)
        if job.format == "ply" and ctx.ply is not None:
            ctx.ply.write(mesh_path, points)
        else:
            write_mesh(mesh_path, deformed_mesh(ctx, got.sample, points))
        row = {
            "id": index,
            "seed": job.seed,
            "source_mesh": job.mesh,
            "mesh_file": mesh_path.relative_to(layout.root).as_posix(),
            "parameters_file": parameters,
            "min_det_j": got.min_det_j,
            "max_displacement": float(np.linalg.norm(points - ctx.points, axis=1).max()),
            "redraws": got.redraws,
            "scale_downs": got.scale_downs,
            "scale": float(got.sample.scale),
            **image_files,
        }
        seconds["write"] = time.perf_counter() - tic
        return {"id": index, "row": row, "seconds": seconds, "cpu": time.thread_time() - cpu}
    except Exception as exc:  # reported per sample; the run goes on with the others
        return {"id": index, "error": f"sample {index}: {type(exc).__name__}: {exc}"}


def file_sha256(path: str | os.PathLike[str]) -> str:
    """SHA-256 of a file: the source mesh, an input image or a deformation file (ties a run folder to them)."""
    import hashlib

    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()
