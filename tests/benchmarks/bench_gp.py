"""Gaussian-process deformation models on the 53k-vertex face (issue: Gaussian-process deformation models).

Run from the repository root (needs ../shared/data):

    python tests/benchmarks/bench_gp.py           # everything
    python tests/benchmarks/bench_gp.py models    # only the shape-model part (issue 13)

Prints, in one run and as medians of several repeats (the machine is shared): building a
rank-200 low-rank model (Nystrom, and pivoted Cholesky for comparison), drawing a sample, the
posterior mean at every vertex from 20 landmarks, each with its target; then the dense exact
posterior on a 2,000-vertex subset (the accuracy reference and the time baseline) and the
low-rank model's error against it; and the blog post's point-by-point kernel loop against the
vectorised kernel as a second baseline. The posterior is timed twice: with OpenBLAS's default
threads and with one (through threadpoolctl) because on a busy shared machine the threads of small
products wait for each other; the load average is printed at the start and the end.

Shape models (issue 13): a model built from 50 random deformations of the face (target <= 3 s; baseline
NumPy's SVD of the 50 x 160k data matrix), the log density of an instance, the posterior from 20 landmarks
each with its own 3x3 noise covariance (target <= 50 ms, with the mean at every vertex), and loading and
saving Scalismo's model file (targets <= 200 ms; baseline reading its datasets with h5py alone).
"""

from __future__ import annotations

import math
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

import h5py
import numpy as np
from threadpoolctl import threadpool_limits  # installed with scikit-learn (the test extra)

from ffd_notebook import read_mesh
from ffd_notebook.gp import GaussianKernel, GaussianProcess, LowRankGP, load_model, save_model

HERE = Path(__file__).resolve().parent
FACE = HERE.parents[2] / "shared" / "data" / "face" / "template.ply"
SCALISMO = HERE.parents[2] / "shared" / "data" / "statismo" / "scalismo_asm_model.h5"


def median_s(fn, repeat):
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def row(name, seconds, target_s=None, extra=""):
    ms = 1000 * seconds
    verdict = "" if target_s is None else ("  ok" if seconds <= target_s else "  MISSED")
    tgt = "" if target_s is None else f"(target <= {1000 * target_s:g} ms)"
    print(f"{name:<52} {ms:10.1f} ms {tgt:<22}{verdict} {extra}")


def blog_loop_kernel(x, y, sigma, scale):
    """The blog post's way: one Python call per pair of points, a 3x3 block each."""
    out = np.zeros((3 * len(x), 3 * len(y)))
    for i in range(len(x)):
        for j in range(len(y)):
            d2 = sum((x[i][a] - y[j][a]) ** 2 for a in range(3))
            out[3 * i : 3 * i + 3, 3 * j : 3 * j + 3] = scale**2 * math.exp(-d2 / sigma**2) * np.eye(3)
    return out


def main() -> None:
    import pyvista as pv

    points = np.asarray(pv.read(FACE).points, dtype=np.float64)
    n = len(points)
    size = float(np.linalg.norm(points.max(0) - points.min(0)))
    sigma, scale = 0.2 * size, 0.02 * size
    gp = GaussianProcess(GaussianKernel(sigma=sigma, scale=scale))
    print(f"face: {n} vertices, bounding-box diagonal {size:.4g}; GaussianKernel(sigma={sigma:.4g}, scale={scale:.4g})")
    print(f"2 shared cores, load average {os.getloadavg()[0]:.1f} at the start; medians of repeats\n")

    # ---------------------------------------------------------------- build
    print("building (first run with a progress bar):")
    LowRankGP.nystrom(gp, points, n_inducing=500, rank=200, rng=0, progress=True)
    build = median_s(lambda: LowRankGP.nystrom(gp, points, n_inducing=500, rank=200, rng=0), repeat=5)
    model = LowRankGP.nystrom(gp, points, n_inducing=500, rank=200, rng=0)
    row("Nystrom rank-200 model (m = 500)", build, 3.0, f"captured variance {model.captured_variance:.5f}")
    pivoted_s = median_s(lambda: LowRankGP.pivoted_cholesky(gp, points, tolerance=1e-4, rank=200), repeat=3)
    pivoted = LowRankGP.pivoted_cholesky(gp, points, tolerance=1e-4, rank=200, progress=True)
    row("pivoted Cholesky (tolerance 1e-4) -> rank 200", pivoted_s, None, f"captured {pivoted.captured_variance:.5f}")
    big_s = median_s(lambda: LowRankGP.nystrom(gp, points, n_inducing=500, rank=600, rng=0), repeat=3)
    big = LowRankGP.nystrom(gp, points, n_inducing=500, rank=600, rng=0)
    row("Nystrom rank-600 model (200 per component)", big_s, None, f"captured {big.captured_variance:.7f}")

    # ---------------------------------------------------------------- sample, posterior
    rng = np.random.default_rng(1)
    sample_s = median_s(lambda: model.sample(1, rng=rng), repeat=100)
    row("draw one sample at all vertices (rank 200)", sample_s, 0.020)
    row("draw one sample at all vertices (rank 600)", median_s(lambda: big.sample(1, rng=rng), repeat=100))

    subset = np.sort(rng.choice(n, 2000, replace=False))
    sub = points[subset]
    landmarks = sub[rng.choice(2000, 20, replace=False)]
    observed = gp.sample(landmarks, 1, rng=rng)[0]  # plausible observations: the prior at the landmarks
    noise = (0.01 * scale) ** 2
    post_s = median_s(lambda: model.posterior(landmarks, observed, noise).mean(), repeat=100)
    row("posterior mean at all vertices, 20 landmarks (rank 200)", post_s, 0.050)
    # On a shared machine OpenBLAS threads wait for each other on small products: one thread is steadier
    with threadpool_limits(1):
        one_thread_s = median_s(lambda: model.posterior(landmarks, observed, noise).mean(), repeat=100)
    row("  the same with one BLAS thread (threadpoolctl)", one_thread_s, 0.050)
    big_post_s = median_s(lambda: big.posterior(landmarks, observed, noise).mean(), repeat=100)
    row("posterior mean at all vertices, 20 landmarks (rank 600)", big_post_s)
    var_s = median_s(lambda: model.posterior(landmarks, observed, noise).variance(), repeat=10)
    row("posterior variance at all vertices (rank 200)", var_s)
    exact_mean_s = median_s(lambda: gp.posterior(landmarks, observed, noise).mean(points), repeat=10)
    row("baseline: exact posterior mean at all vertices", exact_mean_s, None, "(mean only: no samples, no covariance)")

    # ---------------------------------------------------------------- accuracy reference
    print("\naccuracy against the dense exact posterior on a 2,000-vertex subset")
    dense = gp.posterior(landmarks, observed, noise)
    dense_s = median_s(lambda: dense.covariance(sub), repeat=3)
    ref_mean, ref_cov = dense.mean(sub), dense.covariance(sub)
    row("dense posterior covariance, 2,000 points (6000 x 6000)", dense_s)
    ref = np.linalg.norm(ref_mean, axis=1)
    for name, m in (("rank 200", model), ("pivoted rank 200", pivoted), ("rank 600", big)):
        post = m.posterior(landmarks, observed, noise)
        err = np.linalg.norm(post.mean()[subset] - ref_mean, axis=1)
        cov_err = np.linalg.norm(post.covariance(sub) - ref_cov) / np.linalg.norm(ref_cov)
        print(
            f"  {name:<17} mean: max error {err.max() / ref.max():.1e} of the largest displacement, "
            f"RMS {np.sqrt(np.mean(err**2) / np.mean(ref**2)):.1e}; covariance: relative Frobenius error {cov_err:.1e}"
        )

    # ---------------------------------------------------------------- the blog's loop
    grid = rng.uniform(-1, 1, (125, 3)) * size
    loop_s = median_s(lambda: blog_loop_kernel(grid, grid, sigma, scale), repeat=3)
    vec_s = median_s(lambda: gp.kernel.matrix(grid), repeat=30)
    print(f"\nblog-style Python loop, 375 x 375 kernel matrix of 125 grid points: {1000 * loop_s:.1f} ms")
    row("vectorised Kernel.matrix, same matrix", vec_s, None, f"({loop_s / vec_s:.0f}x faster)")
    print(f"\nload average {os.getloadavg()[0]:.1f} at the end")
    assert np.allclose(blog_loop_kernel(grid[:10], grid[:10], sigma, scale), gp.kernel.matrix(grid[:10]))


def random_covariances(rng, n, std):
    """One random 3x3 noise covariance per landmark, standard deviations around ``std``."""
    a = rng.normal(size=(n, 3, 3))
    return std**2 * (a @ a.transpose(0, 2, 1) / 3 + 0.1 * np.eye(3))


def shape_models() -> None:
    mesh = read_mesh(FACE)
    points = np.asarray(mesh.points, dtype=np.float64)
    size = float(np.linalg.norm(points.max(0) - points.min(0)))
    gp = GaussianProcess(GaussianKernel(sigma=0.2 * size, scale=0.02 * size))
    print(f"\nshape models on the face ({len(points)} vertices), load average {os.getloadavg()[0]:.1f}")
    truth = LowRankGP.nystrom(gp, points, n_inducing=300, rank=200, rng=0)
    t0 = time.perf_counter()
    shapes = points + truth.sample(50, rng=2)  # the package's own random deformations of the face
    row("50 example shapes (samples of a rank-200 model)", time.perf_counter() - t0)

    build_s = median_s(lambda: LowRankGP.from_examples(mesh, shapes), repeat=3)
    model = LowRankGP.from_examples(mesh, shapes)
    row("build a model from 50 examples (PCA, rank 49)", build_s, 3.0, f"rank {model.rank}")
    data = (shapes - points).reshape(50, -1)
    svd_s = median_s(lambda: np.linalg.svd(data - data.mean(0), full_matrices=False), repeat=3)
    row("  baseline: NumPy SVD of the 50 x 160k data matrix", svd_s, None, f"(ratio {build_s / svd_s:.2f})")

    rng = np.random.default_rng(3)
    instance = model.instance(rng.normal(size=model.rank))
    row("logpdf_of(instance) (projection, 53k x 3 values)", median_s(lambda: model.logpdf_of(instance), 20))
    coef = model.coefficients(instance)
    row("logpdf(coefficients)", median_s(lambda: model.logpdf(coef), 200))

    ids = rng.choice(len(points), 20, replace=False)
    landmarks, observed = points[ids], instance[ids]
    covs = random_covariances(rng, 20, 0.001 * size)
    for name, m in (("PCA model, rank 49", model), ("kernel model, rank 200", truth)):
        s = median_s(lambda m=m: m.posterior(landmarks, observed, covs).mean(), repeat=50)
        row(f"posterior + mean, 20 landmarks with 3x3 noise ({name})", s, 0.050)
        with threadpool_limits(1):
            s1 = median_s(lambda m=m: m.posterior(landmarks, observed, covs).mean(), repeat=50)
        row("  the same with one BLAS thread", s1, 0.050)
    diag_s = median_s(lambda: truth.posterior(landmarks, observed, (0.001 * size) ** 2).mean(), repeat=50)
    row("  baseline: the same with a scalar noise variance (rank 200)", diag_s)

    def read_raw():
        with h5py.File(SCALISMO, "r") as f:
            return [f[k][()] for k in ("model/mean", "model/pcaBasis", "model/pcaVariance", "representer/points")]

    row("load Scalismo's model file (1,400 points, 50 modes)", median_s(lambda: load_model(SCALISMO), 20), 0.200)
    row("  baseline: read its datasets with h5py", median_s(read_raw, 20))
    scalismo = load_model(SCALISMO)
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "model.h5"
        row("save it (atomic: temporary file, then rename)", median_s(lambda: save_model(out, scalismo), 20), 0.200)
        row("save the 53k-vertex face model (rank 49)", median_s(lambda: save_model(out, model), 3))
        row("load it back", median_s(lambda: load_model(out), 3))
    print(f"load average {os.getloadavg()[0]:.1f} at the end")


if __name__ == "__main__":
    if sys.argv[1:] != ["models"]:
        main()
    shape_models()
