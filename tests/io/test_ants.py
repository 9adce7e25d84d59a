"""ANTs' files against ANTs itself: a real SyN registration's warp, affine (ITK's MATLAB .mat) and composite .h5,
applied by ants.apply_transforms, and our files applied by ANTs (see ``tests/registration_reference.py``)."""

from __future__ import annotations

import struct
import time

import numpy as np
import pytest
import registration_reference as rr
import SimpleITK as sitk
from hypothesis import given, settings
from hypothesis import strategies as st

from ffd_notebook import FFD, warp_image
from ffd_notebook.errors import FileFormatError
from ffd_notebook.io import (
    AffineTransform,
    DisplacementField,
    TransformChain,
    fit_lattice,
    load_deformation,
    save_deformation,
)
from ffd_notebook.io.itk_matlab import read_itk_matlab

GREY = 0.05  # grey levels of an MRI spanning 0..19009: ANTs resamples in float32


def _against_ants(deformation, image, reference, ants_result, what: str) -> float:
    """warp_image of ``image`` onto ``reference`` through ``deformation`` against ANTs' resampling: the largest
    difference where both sample inside the image (printed with the median and the count)."""
    ours = warp_image(str(image), deformation, reference=str(reference), interpolation="linear")
    theirs = sitk.ReadImage(str(ants_result), sitk.sitkFloat64)
    worst, median, count = rr.compare_inside(ours, theirs, rr.inside_mask(deformation, reference, image))
    print(f"\nants.apply_transforms({what}) vs warp_image: max {worst:.3g}, median {median:.2g} grey levels over "
          f"{count} voxels")  # fmt: skip
    assert count > 20000
    return worst


def _timed_load(paths):
    start = time.perf_counter()
    loaded = load_deformation(paths)
    return loaded, 1000 * (time.perf_counter() - start)


def test_generic_affine_mat_is_read_as_itk_reads_it(ants_run):
    affine, ms = _timed_load(ants_run["affine"])
    print(f"\nload {ants_run['affine'].name}: {ms:.1f} ms")
    assert isinstance(affine, AffineTransform)
    itk = sitk.ReadTransform(str(ants_run["affine"]))  # SimpleITK reads ITK's MATLAB files too
    points = np.random.default_rng(0).normal(0.0, 60.0, (200, 3))
    theirs = np.array([itk.TransformPoint(p) for p in points.tolist()])
    assert np.abs(affine.deform(points) - theirs).max() < 1e-9
    assert read_itk_matlab(ants_run["affine"])[0].kind == "AffineTransform_float_3_3"  # as ANTs writes it


def test_the_syn_list_deforms_as_ants_apply_transforms(ants_run):
    chain, ms = _timed_load([ants_run["warp"], ants_run["affine"]])  # antsApplyTransforms -t order
    print(f"\nload [{ants_run['warp'].name}, {ants_run['affine'].name}]: {ms:.1f} ms")
    assert isinstance(chain, TransformChain) and isinstance(chain.steps[0], DisplacementField)
    fixed, moving = ants_run["fixed"], ants_run["moving"]
    assert _against_ants(chain, moving, fixed, ants_run["ants_list"], "[warp, affine]") < GREY
    # the other order is another deformation: the list's order is what it means
    backwards = load_deformation([ants_run["affine"], ants_run["warp"]])
    assert _against_ants(backwards, moving, fixed, ants_run["ants_list"], "[warp, affine], our list reversed") > 1.0


def test_the_inverse_list_with_the_affine_inverted_deforms_as_ants(ants_run):
    inverse = load_deformation([(ants_run["affine"], True), ants_run["inverse_warp"]])  # invtransforms order
    worst = _against_ants(inverse, ants_run["fixed"], ants_run["moving"], ants_run["ants_inverse"],
                          "invtransforms, whichtoinvert=[True, False]")  # fmt: skip
    assert worst < GREY
    with pytest.raises(ValueError, match="only an affine transform is inverted"):
        load_deformation([(ants_run["warp"], True)])


def test_the_composite_h5_is_the_same_chain(ants_run):
    composite, ms = _timed_load(ants_run["composite"])
    print(f"\nload {ants_run['composite'].name}: {ms:.1f} ms")
    assert isinstance(composite, TransformChain)
    assert [type(s) for s in composite.steps] == [DisplacementField, AffineTransform]
    worst = _against_ants(composite, ants_run["moving"], ants_run["fixed"], ants_run["ants_composite"], "composite")
    assert worst < GREY


def test_our_affine_and_composite_files_are_applied_by_ants_as_we_apply_them(ants_run, tmp_path):
    chain = load_deformation([ants_run["warp"], ants_run["affine"]])
    save_deformation(tmp_path / "affine.mat", chain.steps[1])
    save_deformation(tmp_path / "chain.h5", chain)
    itk = sitk.ReadTransform(str(tmp_path / "affine.mat"))
    points = np.random.default_rng(1).normal(0.0, 40.0, (100, 3))
    by_itk = np.array([itk.TransformPoint(p) for p in points.tolist()])
    assert np.abs(by_itk - chain.steps[1].deform(points)).max() < 1e-9
    back = load_deformation(tmp_path / "chain.h5")
    assert np.abs(back.deform(points) - chain.deform(points)).max() < 1e-9
    fixed, moving = ants_run["fixed"], ants_run["moving"]
    ours = warp_image(str(moving), chain, reference=str(fixed))
    mask = rr.inside_mask(chain, fixed, moving)
    jobs = {tmp_path / "list.nii.gz": [ants_run["warp"], tmp_path / "affine.mat"],
            tmp_path / "composite.nii.gz": [tmp_path / "chain.h5"]}  # fmt: skip
    rr.ants_apply(fixed, moving, jobs, tmp_path / "work")
    for result, files in jobs.items():
        worst, median, _ = rr.compare_inside(ours, sitk.ReadImage(str(result), sitk.sitkFloat64), mask)
        print(f"\nants.apply_transforms of our {[f.name for f in files]}: max {worst:.3g}, median {median:.2g}")
        assert worst < GREY


def test_fit_lattice_makes_the_syn_warp_an_editable_lattice_with_its_residual(ants_run):
    chain = load_deformation([ants_run["warp"], ants_run["affine"]])
    start = time.perf_counter()
    ffd = fit_lattice(chain, (10, 12, 9), region=str(ants_run["fixed"]), affine=True)
    seconds = time.perf_counter() - start
    fit = ffd.lattice.metadata["fit"]
    warp = chain.steps[0]
    size = float(np.linalg.norm(warp.vectors, axis=-1).max())
    print(f"\nfit_lattice(SyN chain, 10x12x9, affine=True): residual RMS {fit['rms']:.3f} mm, max {fit['max']:.3f} mm "
          f"over {fit['samples']} voxels (the warp moves points up to {size:.2f} mm), {seconds:.2f} s")  # fmt: skip
    assert isinstance(ffd, FFD) and fit["samples"] == 33 * 41 * 25
    assert fit["rms"] < 0.25 * size
    from ffd_notebook.images import reference_grid

    points = reference_grid(str(ants_run["fixed"])).physical_points()
    residual = np.linalg.norm(ffd.deform(points) - chain.deform(points), axis=1)
    assert np.sqrt(np.mean(residual**2)) == pytest.approx(fit["rms"], rel=1e-6)
    before = ffd.deform(points)
    ffd.lattice.offsets[4, 5, 4] += (3.0, 0.0, 0.0)  # editable: a hand correction moves the points near it
    moved = np.linalg.norm(ffd.deform(points) - before, axis=1)
    apart = np.abs(ffd.lattice.to_lattice(points) - (4, 5, 4))  # in control-point spacings
    near, beyond = apart.max(axis=1) < 0.5, apart.max(axis=1) >= 2.0  # a cubic B-spline reaches 2 spacings
    assert near.any() and moved[near].min() > 0.3 and moved.max() <= 3.0 and not moved[beyond].any()  # 3 (23/48)^3


# ------------------------------------------------------------------------------- the .mat parser, refusals
def _matrix(name: bytes, values, *, mopt=0, rows=None, cols=1, imaginary=0, length=None, order="<") -> bytes:
    dtype = np.dtype(order + ("f4" if mopt // 10 % 10 else "f8"))
    data = np.asarray(values, dtype=dtype).tobytes()
    rows = len(values) if rows is None else rows
    length = len(name) + 1 if length is None else length
    return struct.pack(order + "5i", mopt, rows, cols, imaginary, length) + name + b"\0" + data


AFFINE = list(np.eye(3).ravel()) + [1.0, 2.0, 3.0]


@pytest.mark.parametrize(
    ("content", "message"),
    [
        (b"", "an empty file"),
        (b"\x00" * 7, "truncated header"),
        (_matrix(b"AffineTransform_double_3_3", AFFINE), "has no fixed parameters after it"),
        (_matrix(b"AffineTransform_double_3_3", AFFINE, cols=2), r"a 12x2 matrix"),
        (_matrix(b"AffineTransform_double_3_3", AFFINE, imaginary=1), "a complex matrix"),
        (_matrix(b"AffineTransform_double_3_3", AFFINE, mopt=2), "type 2 is not a MATLAB level-4 numeric matrix"),
        (_matrix(b"AffineTransform_double_3_3", AFFINE, rows=10**9), "at most"),
        (_matrix(b"AffineTransform_double_3_3", AFFINE, rows=13), "truncated"),
        (_matrix(b"AffineTransform_double_3_3", [np.nan] * 12), "NaN"),
        (_matrix(b"Affine", AFFINE) + _matrix(b"fixed", [0.0] * 3), "unsupported transform type 'Affine'"),
        (_matrix(b"AffineTransform_double_3_3", AFFINE[:9]) + _matrix(b"fixed", [0.0] * 3), "12 parameters"),
    ],
)
def test_bad_mat_files_are_refused_naming_the_file(tmp_path, content, message):
    path = tmp_path / "t.mat"
    path.write_bytes(content)
    with pytest.raises(FileFormatError, match=f"t.mat: .*{message}"):
        load_deformation(path)


def test_big_endian_and_float32_matrices_are_read_as_itk_reads_them(tmp_path):
    path = tmp_path / "t.mat"
    path.write_bytes(_matrix(b"AffineTransform_float_3_3", AFFINE, mopt=1010, order=">")
                     + _matrix(b"fixed", [1.0, 0.0, 0.0], mopt=1010, order=">"))  # fmt: skip
    itk = sitk.ReadTransform(str(path))
    ours = load_deformation(path)
    assert np.allclose(ours.deform([[5.0, 6.0, 7.0]]), [itk.TransformPoint((5.0, 6.0, 7.0))], atol=1e-12)


@settings(max_examples=150, deadline=None)
@given(st.binary(max_size=200), st.integers(0, 3))
def test_the_mat_parser_refuses_or_reads_any_bytes(tmp_path_factory, tail, cut):
    """Any bytes after a valid start: a deformation or FileFormatError, never another exception or a hang."""
    path = tmp_path_factory.mktemp("mat") / "t.mat"
    good = _matrix(b"AffineTransform_double_3_3", AFFINE) + _matrix(b"fixed", [0.0] * 3)
    path.write_bytes(good[: len(good) - cut] + tail)
    try:
        result = load_deformation(path)
    except FileFormatError:
        return
    assert isinstance(result, AffineTransform)


@pytest.mark.parametrize("name", ["a.ffd", "a.prm", "TransformParameters.0.txt", "cpp.nii.gz", "coef.nii.gz"])
@pytest.mark.parametrize("what", ["field", "affine", "chain"])
def test_what_is_not_a_lattice_is_refused_with_one_exception_type_on_every_route(tmp_path, name, what):
    """Issue 35 item 11: a field written as a lattice raised TypeError on the elastix route, ValueError elsewhere."""
    field = DisplacementField(np.zeros((3, 3, 3, 3)), spacing=2.0)
    affine = AffineTransform(np.diag([2.0, 1.0, 1.0, 1.0]))
    deformation = {"field": field, "affine": affine, "chain": TransformChain([field, affine])}[what]
    format = {"TransformParameters.0.txt": "elastix", "cpp.nii.gz": "niftyreg", "coef.nii.gz": "fnirt"}.get(name)
    if what == "field" and format == "niftyreg":  # an ITK field: NiftyReg would move points beyond its grid
        match = "leaves points there unmoved"
    else:
        match = "is not a lattice"
    with pytest.raises(ValueError, match=match):
        save_deformation(tmp_path / name, deformation, format=format, reference={"size": (4, 4, 4)},
                         source={"size": (4, 4, 4)})  # fmt: skip
    assert list(tmp_path.iterdir()) == []
