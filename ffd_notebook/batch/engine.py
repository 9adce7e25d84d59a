"""``generate`` and ``replay``: many deformed meshes on Dask, and one of them again.

Samples go to Dask a few per task (:func:`task_groups`,
:func:`~ffd_notebook.batch.sample.run_samples`). Without a cluster the local threaded scheduler
runs them by default: measured on the 53k-vertex face with 2 cores, 60 samples took 2.3 s on
threads, 3.5 s in one thread and 6.5 s on the process pool (whose start-up, imports and
per-process binding of the model outweigh the GIL time a sample holds, now that its NumPy work is
mostly large array operations); a GP model is bound once and shared, too. ``scheduler="processes"``
is there for long runs of GIL-bound models. With ``client=`` or an address, the tasks go to that
``distributed`` cluster (:func:`~ffd_notebook.batch.local_cluster` starts a local one set up for
this); its workers must see the mesh and the output folder at the same paths (a shared file
system).
"""

from __future__ import annotations

import os
import time
import uuid
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .._util.blas import one_blas_thread
from ..errors import BatchError
from ..images import IMAGE_INTERPOLATIONS
from .files import LatticeFiles
from .folding import FoldFree
from .output import MESH_OUTPUT_FORMATS, Layout
from .sample import Job, context, deformed_mesh, file_sha256, job_layout, load_sample, run_samples, warped_image

__all__ = ["BatchResult", "generate", "replay"]

LOCAL = ("threads", "processes", "sync")
MAX_PER_TASK = 8  # samples per Dask task (see task_groups())
TASKS_PER_WORKER = 4


@dataclass
class BatchResult:
    """What :func:`generate` did.

    Parameters
    ----------
    out : pathlib.Path
        The output folder.
    rows : list of dict
        The manifest: every finished sample of the folder (this run's and earlier ones), by id.
    made, skipped : list of int
        Samples made by this call; samples already in the folder (not redone).
    failed : dict
        Sample id -> error message (the sample is named in it).
    seconds : dict of ndarray
        Per made sample, seconds spent in ``draw``, ``fold_check``, ``deform`` and ``write``.
    cpu : ndarray
        Per made sample, CPU seconds of the thread that made it (``seconds`` minus the waits for
        the disk and for a free core).
    wall : float
        Seconds from the first task submitted to the last result.
    scheduler : str
        Which scheduler ran the tasks.

    Examples
    --------
    >>> import pathlib
    >>> result = BatchResult(pathlib.Path("out"), made=[0, 1], failed={2: "sample 2: folds"})
    >>> len(result.made), sorted(result.failed)
    (2, [2])
    """

    out: Path
    rows: list[dict[str, Any]] = field(default_factory=list)
    made: list[int] = field(default_factory=list)
    skipped: list[int] = field(default_factory=list)
    failed: dict[int, str] = field(default_factory=dict)
    seconds: dict[str, np.ndarray] = field(default_factory=dict)
    cpu: np.ndarray = field(default_factory=lambda: np.zeros(0))
    wall: float = 0.0
    scheduler: str = ""


def _check_model(model: Any, n: int | None) -> int:
    if not all(hasattr(model, a) for a in ("to_spec", "bind", "name")):
        raise TypeError(f"model must be a RandomLattice, RandomGP or LatticeFiles, got {type(model).__name__}")
    if isinstance(model, LatticeFiles):
        n = len(model.files) if n is None else n
        if n > len(model.files):
            raise ValueError(f"n={n} samples but only {len(model.files)} files were given")
    if n is None or isinstance(n, bool) or not isinstance(n, int | np.integer) or n < 0:
        raise ValueError(f"n must be a non-negative integer, got {n!r}")
    return int(n)


def _rule(fold_free: FoldFree | bool | None) -> FoldFree | None:
    if fold_free is True:
        return FoldFree()
    if fold_free is False or fold_free is None:
        return None
    if not isinstance(fold_free, FoldFree):
        raise TypeError(f"fold_free must be a FoldFree, True or False, got {type(fold_free).__name__}")
    return fold_free


def _progress(total: int, enabled: bool):
    from tqdm.auto import tqdm  # a widget in a notebook, text in a terminal

    return tqdm(total=total, desc="samples", unit="mesh", disable=not enabled or total == 0)


def task_groups(todo: list[int], workers: int) -> list[list[int]]:
    """The samples grouped into Dask tasks: up to ``MAX_PER_TASK`` each, at least ``TASKS_PER_WORKER`` per worker.

    A task costs Dask ~8 ms of CPU on a ``LocalCluster`` (scheduler and worker together, measured;
    a 53k-vertex sample is ~25 ms of work), so several samples share one; enough tasks remain
    for the workers to balance the load and for the progress bar to move.

    Examples
    --------
    >>> [len(t) for t in task_groups(list(range(500)), 2)][:3], len(task_groups(list(range(500)), 2))
    ([8, 8, 8], 63)
    >>> task_groups([0, 1, 2, 5], 2)
    [[0], [1], [2], [5]]
    """
    size = max(1, min(MAX_PER_TASK, len(todo) // (TASKS_PER_WORKER * max(1, workers))))
    return [todo[k : k + size] for k in range(0, len(todo), size)]


def _run_local(job: Job, todo: list[int], scheduler: str, workers: int | None, bar) -> Iterable[dict[str, Any]]:
    import dask
    from dask.callbacks import Callback

    groups = task_groups(todo, 1 if scheduler == "sync" else workers or os.cpu_count() or 1)
    sizes = {f"ffd-samples-{g[0]}-{g[-1]}": len(g) for g in groups}

    class _Ticks(Callback):
        def _posttask(self, key, result, dsk, state, worker_id):
            bar.update(sizes.get(key, 0))

    delayed = [
        dask.delayed(run_samples, pure=True)(job, g, dask_key_name=k) for k, g in zip(sizes, groups, strict=True)
    ]
    kwargs: dict[str, Any] = {"scheduler": "sync" if scheduler == "sync" else scheduler}
    if scheduler != "sync" and workers:
        kwargs["num_workers"] = workers
    with _Ticks():
        return [out for outs in dask.compute(*delayed, **kwargs) for out in outs]


def _run_distributed(job: Job, todo: list[int], client, bar) -> Iterable[dict[str, Any]]:
    from distributed import as_completed

    token = uuid.uuid4().hex[:8]  # fresh keys: a rerun in the same client must not reuse results
    threads = sum(w.get("nthreads", 1) for w in client.scheduler_info()["workers"].values())
    groups = task_groups(todo, threads)
    futures = [
        client.submit(run_samples, job, g, key=f"ffd-samples-{token}-{g[0]}-{g[-1]}", pure=False) for g in groups
    ]
    index = {f.key: g for f, g in zip(futures, groups, strict=True)}
    for future in as_completed(futures):
        try:
            outs = future.result()
        except Exception as exc:  # the task itself never raises: the cluster lost it (KilledWorker, ...)
            outs = [{"id": i, "error": f"sample {i}: {type(exc).__name__}: {exc}"} for i in index[future.key]]
        future.release()
        bar.update(len(outs))
        yield from outs


def _execute(job, todo, client, scheduler, workers, bar) -> tuple[list[dict[str, Any]], str]:
    if client is not None:
        return list(_run_distributed(job, todo, client, bar)), f"distributed {client.scheduler.address}"
    if scheduler is None:
        scheduler = "threads"  # the fastest local one (see the module docstring)
    if scheduler in LOCAL:
        return list(_run_local(job, todo, scheduler, workers, bar)), scheduler
    from distributed import Client

    with Client(scheduler) as remote:  # an address: tcp://host:8786
        return list(_run_distributed(job, todo, remote, bar)), f"distributed {scheduler}"


def generate(
    mesh: str | os.PathLike[str],
    model: Any,
    n: int | None,
    out: str | os.PathLike[str],
    *,
    seed: int = 0,
    fold_free: FoldFree | bool | None = True,
    format: str = "ply",
    client: Any = None,
    scheduler: str | None = None,
    workers: int | None = None,
    progress: bool = True,
    image: str | os.PathLike[str] | None = None,
    label_image: str | os.PathLike[str] | None = None,
    image_interpolation: str = "linear",
) -> BatchResult:
    """Write ``n`` deformed copies of a mesh, their parameters and a manifest into ``out``.

    With ``image`` and/or ``label_image``, every sample also writes them warped by the same
    transform, so that image and mesh stay together: ``meshes/image_NNNNNN.EXT`` and
    ``meshes/label_NNNNNN.EXT`` in the input's format, named in the manifest (``image_file``,
    ``label_file``). The direction: the images are resampled through the sample's transform
    ``T`` as ITK does (the output at ``x`` is the input at ``T(x)``, a pull-back), so the mesh is
    moved by ``T^-1`` (see :mod:`ffd_notebook.batch.sample`); the parameters file holds ``T``.

    Parameters
    ----------
    mesh : path
        The source mesh (anything :func:`~ffd_notebook.io.read_mesh` reads); colours are kept.
    model : RandomLattice, RandomGP or LatticeFiles
        The random deformation model.
    n : int
        Samples ``0 .. n-1`` (``None`` with :class:`LatticeFiles`: one per file).
    out : path
        Output folder. Samples already in it are skipped, so an interrupted run resumes and a
        larger ``n`` extends a run; a folder holding a run with other settings is refused.
    seed : int
        Root seed; sample ``i`` draws from the ``i``-th spawned ``SeedSequence``.
    fold_free : FoldFree or bool
        The fold rule (default ``FoldFree()``: det J > 0.1, redraw); ``False``: no check (min
        det J is still measured and recorded).
    format : {"ply", "vtp", "obj"}
        Mesh file format.
    client : distributed.Client, optional
        Run on this cluster.
    scheduler : str, optional
        ``"threads"``, ``"processes"`` or ``"sync"`` (local), or a scheduler address such as
        ``"tcp://10.0.0.5:8786"``; by default the fastest local one for the model.
    workers : int, optional
        Local workers (default: one per core).
    progress : bool
        Show a progress bar (a widget in a notebook).
    image : path, optional
        An image in the mesh's physical space (anything SimpleITK reads: NIfTI, NRRD,
        MetaImage...), warped with ``image_interpolation``.
    label_image : path, optional
        A label map (segmentation) in the same space, warped with nearest-neighbour
        interpolation: no new label values.
    image_interpolation : {"linear", "bspline", "nearest"}
        Interpolation of ``image``.

    Returns
    -------
    BatchResult

    Raises
    ------
    BatchError
        After the run, if some samples failed (the others are written and in the manifest).
    FileFormatError, FileNotFoundError, ValueError
        Before any work, for an unreadable mesh or bad settings.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> import pyvista as pv
    >>> from ffd_notebook.batch import RandomLattice
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> pv.Sphere(theta_resolution=10, phi_resolution=10).save(folder / "ball.ply")
    >>> model = RandomLattice(num_control_points=5, max_displacement=0.05, locked_borders=1)
    >>> result = generate(folder / "ball.ply", model, 3, folder / "out", scheduler="sync", progress=False)
    >>> [row["id"] for row in result.rows], (folder / "out" / "manifest.csv").is_file()
    ([0, 1, 2], True)
    >>> again = generate(folder / "ball.ply", model, 4, folder / "out", scheduler="sync", progress=False)
    >>> again.skipped, again.made
    ([0, 1, 2], [3])
    """
    n = _check_model(model, n)
    rule = _rule(fold_free)
    if format not in MESH_OUTPUT_FORMATS:
        raise ValueError(f"format must be one of {MESH_OUTPUT_FORMATS}, got {format!r}")
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise ValueError(f"seed must be a non-negative integer, got {seed!r}")
    if scheduler is not None and client is not None:
        raise ValueError("give client= or scheduler=, not both")
    if image_interpolation not in IMAGE_INTERPOLATIONS:
        raise ValueError(
            f"image_interpolation must be one of {tuple(IMAGE_INTERPOLATIONS)}, got {image_interpolation!r}"
        )
    mesh_path = Path(mesh).resolve()
    image_path, label_path = (None if path is None else str(Path(path).resolve()) for path in (image, label_image))
    job = Job(str(mesh_path), model.to_spec(), int(seed), rule, str(Path(out).resolve()), format, image_path,
              label_path, image_interpolation).with_file_digests()  # fmt: skip
    with one_blas_thread():
        context(job)  # an unreadable mesh or image, a model that does not fit: fails here, before any work
    layout = job_layout(job)
    layout.claim(job.settings(file_sha256(mesh_path)))
    result = BatchResult(layout.root)
    todo: list[int] = []
    for i in range(n):
        (result.skipped if layout.done(i) else todo).append(i)
    tic = time.perf_counter()
    with _progress(len(todo), progress) as bar:
        outputs, result.scheduler = _execute(job, todo, client, scheduler, workers, bar)
    result.wall = time.perf_counter() - tic
    _collect(result, outputs)
    result.rows = layout.write_manifest()
    if result.failed:
        raise BatchError(result)
    return result


def _collect(result: BatchResult, outputs: Iterable[dict[str, Any]]) -> None:
    timings: dict[str, list[float]] = {}
    cpu = []
    for out in sorted(outputs, key=lambda o: o["id"]):
        if "error" in out:
            result.failed[out["id"]] = out["error"]
            continue
        result.made.append(out["id"])
        cpu.append(out["cpu"])
        for name, value in out["seconds"].items():
            timings.setdefault(name, []).append(value)
    result.seconds = {k: np.array(v) for k, v in timings.items()}
    result.cpu = np.array(cpu)


def replay(out: str | os.PathLike[str], index: int, *, part: str = "mesh"):
    """The deformed mesh (or warped image) of sample ``index`` of a run, rebuilt from its saved parameters.

    Reads ``run.json`` and the manifest row, binds the model to the source mesh again, loads
    the parameters file and deforms: the same code path as the run, so the points are the
    ones that were written (bit for bit, before the file format's own rounding).

    ``part="image"`` or ``"label"``: the sample's warped image or label map (a SimpleITK
    image) of a run made with images, voxel for voxel what was written.

    Parameters
    ----------
    out : str or os.PathLike
        The output folder of a :func:`generate` run.
    index : int
        The sample's id.
    part : str
        ``"mesh"``, or the name of one of the run's images (``"image"``, ``"label"``).

    Returns
    -------
    pyvista.PolyData or SimpleITK.Image
        The deformed mesh, or the warped image, as the run made it.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> import numpy as np, pyvista as pv
    >>> from ffd_notebook.batch import RandomLattice
    >>> from ffd_notebook.io import read_mesh
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> pv.Sphere(theta_resolution=10, phi_resolution=10).save(folder / "ball.vtp")
    >>> model = RandomLattice(5, max_displacement=0.05, locked_borders=1)
    >>> _ = generate(folder / "ball.vtp", model, 2, folder / "out", format="vtp", scheduler="sync", progress=False)
    >>> again = replay(folder / "out", 1)
    >>> bool(np.array_equal(again.points, read_mesh(folder / "out" / "meshes" / "sample_000001.vtp").points))
    True
    """
    settings = Layout(out).settings()
    job = Job.from_settings(out, settings)
    layout = job_layout(job)
    if part != "mesh" and part not in job.images:
        raise ValueError(f"part must be 'mesh' or one of the run's images {sorted(job.images)}, got {part!r}")
    rows = [r for r in layout.records() if int(r["id"]) == int(index)]
    if not rows:
        raise KeyError(f"{layout.root} has no finished sample {index}")
    if job.model_files and not job.files_sha256:
        raise ValueError(f"{layout.run_file} records no SHA-256 of the model's deformation files (a run made before "
                         "they were recorded): its samples cannot be checked against them; run it again")  # fmt: skip
    recorded = [(job.mesh, settings["mesh_sha256"]), *zip(job.model_files, job.files_sha256, strict=True)]
    recorded += [(path, settings["images"][kind]["sha256"]) for kind, path in job.images.items()]
    for path, digest in recorded:
        if file_sha256(path) != digest:
            raise ValueError(f"{path} changed since the run: its samples cannot be replayed from it")
    with one_blas_thread():
        ctx = context(job)
        sample = load_sample(layout, rows[0], ctx, job.rule)
        return deformed_mesh(ctx, sample) if part == "mesh" else warped_image(job, ctx, part, sample)
