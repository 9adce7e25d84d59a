"""elastix parameter files against itk-elastix: real registrations read back, written files applied by transformix.

The registrations are small (18x22x20 volumes, 20 iterations) and run once per session; itk's
import (~25 s here) is the main cost. Points are compared with transformix's ``OutputPoint``
(6 decimals) to 1e-6 of the grid spacing, and are kept off the border of the B-spline's valid
region, where elastix and ITK differ (elastix #509).
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
from elastix_reference import TRANSFORMIX_ROUNDING, register, transformix_points

from ffd_notebook import FFD, Lattice
from ffd_notebook.errors import FileFormatError
from ffd_notebook.io import load_deformation, load_ffd, save_deformation
from ffd_notebook.io.elastix import MAX_CHAIN, BSplineStep, load_elastix, save_elastix
from ffd_notebook.io.elastix_text import read_parameter_file, write_parameter_file

ROTATED = np.array([[0.8, -0.6, 0.0], [0.6, 0.8, 0.0], [0.0, 0.0, 1.0]])
COMMON = [
    ("FixedImageDimension", [3]),
    ("MovingImageDimension", [3]),
    ("FixedInternalImagePixelType", ["float"]),
    ("MovingInternalImagePixelType", ["float"]),
    ("Size", [8, 8, 8]),
    ("Index", [0, 0, 0]),
    ("Spacing", [1, 1, 1]),
    ("Origin", [0, 0, 0]),
    ("Direction", [1, 0, 0, 0, 1, 0, 0, 0, 1]),
    ("UseDirectionCosines", [True]),
    ("ResampleInterpolator", ["FinalBSplineInterpolator"]),
    ("FinalBSplineInterpolationOrder", [3]),
    ("Resampler", ["DefaultResampler"]),
    ("DefaultPixelValue", [0]),
    ("ResultImageFormat", ["nii"]),
    ("ResultImagePixelType", ["float"]),
    ("CompressResultImage", [False]),
]


@pytest.fixture(scope="session")
def registrations(tmp_path_factory) -> dict[str, Path]:
    """Two real registrations: affine then B-spline (rotated, anisotropic, off-origin), and a B-spline alone."""
    root = tmp_path_factory.mktemp("elastix")
    return {
        "affine+bspline": register(
            root / "ab",
            affine=True,
            spacing=(1.5, 1.0, 2.0),
            origin=(10.0, -5.0, 3.0),
            direction=ROTATED,
            grid_spacing=8.0,
        ),
        "bspline": register(
            root / "b",
            affine=False,
            spacing=(1.2, 0.9, 1.6),
            origin=(-20.0, 4.0, 7.5),
            direction=np.eye(3),
            grid_spacing=6.0,
        ),
    }


def _image_points(n: int, spacing, origin, direction, seed: int = 0) -> np.ndarray:
    """Random points inside the 18x22x20 image domain of a registration."""
    index = np.random.default_rng(seed).random((n, 3)) * (np.array([17, 21, 19]) - 2) + 1
    return (index * spacing) @ np.asarray(direction).T + origin


def _off_border(chain, points: np.ndarray, margin: float = 1e-3) -> np.ndarray:
    """Points whose continuous grid index is at least ``margin`` from every B-spline valid-region face."""
    keep = np.ones(len(points), bool)
    for step in chain.steps:
        if isinstance(step, BSplineStep):
            rows = step.grid_index(points)  # the B-spline sees the chain's earlier steps' output in Compose
            dims = np.array(step.coefficients.shape[:3])[:, None]
            keep &= np.all((np.abs(rows - 1.0) > margin) & (np.abs(rows - (dims - 2.0)) > margin), axis=0)
    return points[keep]


def _tolerance(chain) -> float:
    spacing = min(np.linalg.norm(s.placement, axis=0).min() for s in chain.steps if isinstance(s, BSplineStep))
    return max(1e-6 * spacing, TRANSFORMIX_ROUNDING * 1.01)


def _file(path: Path, transform: str, parameters, *, initial="NoInitialTransform", how="Compose", **extra) -> Path:
    entries = [
        ("Transform", [transform]),
        ("NumberOfParameters", [len(parameters)]),
        ("TransformParameters", list(parameters)),
        ("InitialTransformParameterFileName", [initial]),
        ("HowToCombineTransforms", [how]),
        *((k, v) for k, v in extra.items()),
        *COMMON,
    ]
    write_parameter_file(path, entries)
    return path


# ---------------------------------------------------------------------------------------- real registrations
@pytest.mark.parametrize("case", ["affine+bspline", "bspline"])
def test_registration_chain_moves_points_as_transformix(registrations, case, tmp_path):
    path = registrations[case]
    chain = load_elastix(path)
    assert [s.kind for s in chain.steps] == (
        ["AffineTransform", "BSplineTransform"] if "affine" in case else ["BSplineTransform"]
    )
    params = read_parameter_file(path)
    spacing, origin = params.numbers("Spacing"), params.numbers("Origin")
    direction = params.numbers("Direction").reshape(3, 3).T
    points = _off_border(chain, _image_points(400, spacing, origin, direction))
    assert len(points) > 300
    reference = transformix_points(path, points, tmp_path)
    assert np.abs(reference - points).max() > 0.05  # the registration moved them
    assert np.abs(chain.deform(points) - reference).max() <= _tolerance(chain)


def test_bspline_registration_loads_as_an_ffd_equal_to_transformix(registrations, tmp_path):
    path = registrations["bspline"]
    ffd = load_deformation(path)
    assert ffd.only_inside and ffd.lattice.shape == tuple(
        read_parameter_file(path).integers("GridSize", 3, low=4, high=99)
    )
    chain = load_elastix(path)
    points = _off_border(chain, _image_points(300, (1.2, 0.9, 1.6), (-20.0, 4.0, 7.5), np.eye(3), seed=3))
    reference = transformix_points(path, points, tmp_path)
    assert np.abs(ffd.deform(points) - reference).max() <= _tolerance(chain)


@pytest.mark.parametrize(
    ("change", "value"),
    [("Transform", "RecursiveBSplineTransform"), ("GridIndex", "1 0 2"), ("GridDirection", "0 1 0 -1 0 0 0 0 1")],
)
def test_bspline_variants_match_transformix(registrations, tmp_path, change, value):
    """The recursive B-spline, a grid index other than 0 (elastix moves the grid by it), a rotated grid."""
    text = registrations["bspline"].read_text()
    start = text.index(f"({change} ")
    edited = text[:start] + f"({change} {value if value[0].isdigit() else chr(34) + value + chr(34)})"
    edited += text[text.index(")", start) + 1 :]
    path = tmp_path / "TransformParameters.0.txt"
    path.write_text(edited)
    chain = load_elastix(path)
    params = read_parameter_file(path)
    grid = chain.steps[0]
    points = (
        grid.origin
        + (np.random.default_rng(8).random((300, 3)) * (np.array(grid.coefficients.shape[:3]) + 1) - 1)
        @ grid.placement.T
    )
    points = _off_border(chain, points)
    reference = transformix_points(path, points, tmp_path / "out")
    assert np.abs(reference - points).max() > 0.05
    assert np.abs(chain.deform(points) - reference).max() <= _tolerance(chain)
    assert np.abs(load_deformation(path).deform(points) - reference).max() <= _tolerance(chain)
    assert params.values(change) == tuple(value.split())


def test_affine_then_bspline_compose_chain_is_an_ffd_on_a_sheared_lattice(registrations, tmp_path):
    """elastix's usual run: the affine part shears the B-spline's grid; the FFD holds it, elastix files too."""
    path = registrations["affine+bspline"]
    ffd = load_deformation(path)
    assert ffd.lattice.sheared and ffd.only_inside and not np.array_equal(ffd.affine, np.eye(4))
    chain = load_elastix(path)
    points = _off_border(chain, _image_points(400, (1.5, 1.0, 2.0), (10.0, -5.0, 3.0), ROTATED, seed=6))
    reference = transformix_points(path, points, tmp_path / "a")
    assert np.abs(ffd.deform(points) - reference).max() <= _tolerance(chain)
    out = tmp_path / "saved" / "TransformParameters.0.txt"
    out.parent.mkdir()
    save_deformation(out, ffd, format="elastix")  # the sheared grid as GridDirection, the affine part by "Add"
    assert np.abs(transformix_points(out, points, tmp_path / "b") - reference).max() <= 2 * TRANSFORMIX_ROUNDING
    back = load_deformation(out)
    assert back.lattice.sheared and np.array_equal(back.lattice.offsets, ffd.lattice.offsets)
    for name, why in (("x.tfm", "sheared"), ("x.ffd", "sheared"), ("x.h5", "sheared")):
        with pytest.raises(ValueError, match=why):
            save_deformation(tmp_path / name, ffd)
        assert not (tmp_path / name).exists()


def test_registration_saves_back_exactly(registrations, tmp_path):
    """B-spline alone: load, save as elastix, transformix applies the new file as it did the original."""
    ffd = load_deformation(registrations["bspline"])
    out = tmp_path / "again" / "TransformParameters.0.txt"
    out.parent.mkdir()
    save_deformation(out, ffd, format="elastix")
    chain = load_elastix(registrations["bspline"])
    points = _off_border(chain, _image_points(200, (1.2, 0.9, 1.6), (-20.0, 4.0, 7.5), np.eye(3), seed=5))
    a = transformix_points(registrations["bspline"], points, tmp_path / "a")
    b = transformix_points(out, points, tmp_path / "b")
    assert np.array_equal(a, b)
    again = load_deformation(out)
    assert again.lattice == ffd.lattice and again.only_inside
    assert read_parameter_file(out).values("Size") == read_parameter_file(registrations["bspline"]).values("Size")


# ---------------------------------------------------------------------------------------- linear transforms, chains
def test_linear_transforms_and_both_combinations_match_transformix(tmp_path):
    rng = np.random.default_rng(7)
    euler = _file(
        tmp_path / "euler.txt",
        "EulerTransform",
        [0.3, -0.2, 0.5, 1.0, 2.0, -1.0],
        CenterOfRotationPoint=[1.5, -2.0, 0.5],
        ComputeZYX=[True],
    )
    similarity = _file(
        tmp_path / "sim.txt",
        "SimilarityTransform",
        [0.1, 0.2, -0.15, -1.0, 0.5, 2.0, 1.1],
        initial=str(euler),
        how="Add",
        CenterOfRotationPoint=[0.0, 1.0, 2.0],
    )
    affine = _file(
        tmp_path / "affine.txt",
        "AffineTransform",
        [1.1, 0.2, 0.0, -0.1, 0.9, 0.05, 0.0, 0.1, 1.2, 3.0, -2.0, 1.0],
        initial=str(similarity),
        CenterOfRotationPoint=[2.0, 2.0, 2.0],
    )
    last = _file(tmp_path / "shift.txt", "TranslationTransform", [0.25, -0.5, 4.0], initial=str(affine), how="Add")
    xyz = _file(
        tmp_path / "euler_xyz.txt",
        "EulerTransform",
        [0.3, -0.2, 0.5, 0.0, 0.0, 0.0],
        CenterOfRotationPoint=[0.0, 0.0, 0.0],
    )
    points = rng.normal(0.0, 5.0, (50, 3))
    for path in (euler, similarity, affine, last, xyz):
        reference = transformix_points(path, points, tmp_path / f"out-{path.stem}")
        assert np.abs(load_elastix(path).deform(points) - reference).max() <= TRANSFORMIX_ROUNDING * 1.01, path.name
    assert [s.kind for s in load_elastix(last).steps] == [
        "EulerTransform",
        "SimilarityTransform",
        "AffineTransform",
        "TranslationTransform",
    ]


def test_rigid_then_bspline_compose_chain_is_an_ffd(registrations, tmp_path):
    """An Euler transform composed before a B-spline keeps the grid orthogonal: the FFD's lattice is pulled back."""
    shutil.copy(registrations["bspline"], tmp_path / "bspline.txt")
    params = read_parameter_file(tmp_path / "bspline.txt")
    euler = _file(
        tmp_path / "euler.txt",
        "EulerTransform",
        [0.05, -0.1, 0.2, 1.0, -0.5, 0.3],
        CenterOfRotationPoint=[-10.0, 14.0, 22.0],
    )
    keep = [
        (name, list(entry.values))
        for name, entry in params.entries.items()
        if name not in ("InitialTransformParameterFileName", "HowToCombineTransforms")
    ]
    keep = [(k, [float(v) if v[0] in "-0123456789" else v for v in vals]) for k, vals in keep]
    write_parameter_file(
        tmp_path / "chain.txt",
        [*keep, ("InitialTransformParameterFileName", [euler.name]), ("HowToCombineTransforms", ["Compose"])],
    )
    chain = load_elastix(tmp_path / "chain.txt")
    ffd = load_deformation(tmp_path / "chain.txt")
    assert not np.array_equal(ffd.affine, np.eye(4)) and not np.array_equal(ffd.lattice.rotation, np.eye(3))
    points = _off_border(chain, _image_points(300, (1.2, 0.9, 1.6), (-20.0, 4.0, 7.5), np.eye(3), seed=9))
    reference = transformix_points(tmp_path / "chain.txt", points, tmp_path / "out")
    assert np.abs(reference - chain.steps[0].apply(points)).max() > 0.05  # the B-spline part moved them too
    assert np.abs(ffd.deform(points) - reference).max() <= _tolerance(chain)


# ---------------------------------------------------------------------------------------- writing
@pytest.mark.parametrize("only_inside", [False, True])
def test_written_ffd_is_applied_exactly_by_transformix(tmp_path, only_inside):
    rng = np.random.default_rng(11)
    lat = Lattice((6, 5, 7), (2.0, 3.0, 1.5), origin=(5.0, -3.0, 1.0), rotation=ROTATED.T)
    lat.offsets[...] = rng.normal(0.0, 0.8, lat.offsets.shape)
    affine = np.array([[1.05, 0.1, 0.0, 2.0], [-0.05, 0.95, 0.02, -1.0], [0.0, 0.1, 1.1, 0.5], [0, 0, 0, 1]])
    ffd = FFD(lat, affine=affine, only_inside=only_inside)
    path = tmp_path / "run" / "TransformParameters.1.txt"
    path.parent.mkdir()
    save_deformation(path, ffd, format="elastix")
    assert (path.parent / "TransformParameters.1.affine.txt").is_file()
    uvw = rng.random((400, 3)) * (np.array(lat.shape) + 1) - 1  # inside the lattice and around it
    points = lat.to_world(uvw)
    if only_inside:
        chain = load_elastix(path)
        points = _off_border(chain, points)
    reference = transformix_points(path, points, tmp_path / "out")
    assert np.abs(ffd.deform(points) - reference).max() <= max(1e-6 * 1.5, TRANSFORMIX_ROUNDING * 1.01)
    back = load_deformation(path)
    assert back.only_inside == ("half-open" if only_inside else False)  # elastix's valid region, open at its far faces
    assert np.array_equal(back.affine, ffd.affine)
    assert np.allclose(back.lattice.origin, lat.origin, rtol=0, atol=1e-12)
    assert np.array_equal(back.lattice.offsets, lat.offsets)


def test_real_ffd_file_converts_to_elastix_and_back_losslessly(shared_data, tmp_path):
    from ffd_notebook.__main__ import main

    real = shared_data / "seed-lineage" / "registration_11x12x11.FFD"
    lattice = load_ffd(real)
    assert main(["convert", str(real), str(tmp_path / "reg.txt"), "--to", "elastix"]) == 0
    back = load_deformation(tmp_path / "reg.txt")
    assert back.lattice == lattice and not back.only_inside and np.array_equal(back.affine, np.eye(4))
    assert main(["convert", str(tmp_path / "reg.txt"), str(tmp_path / "back.ffd")]) == 0
    assert load_ffd(tmp_path / "back.ffd") == lattice
    points = lattice.control_points().reshape(-1, 3)
    reference = transformix_points(tmp_path / "reg.txt", points, tmp_path / "out")
    assert np.abs(FFD(lattice).deform(points) - reference).max() <= TRANSFORMIX_ROUNDING * 1.01


def test_writer_refuses_what_elastix_cannot_hold(tmp_path):
    with pytest.raises(ValueError, match="'bernstein' basis"):
        save_elastix(tmp_path / "a.txt", FFD(Lattice((4, 4, 4), 1.0), "bernstein"))
    with pytest.raises(ValueError, match="border='clamp'"):
        save_elastix(tmp_path / "a.txt", FFD(Lattice((4, 4, 4), 1.0), border="clamp"))
    assert not list(tmp_path.iterdir())


# ---------------------------------------------------------------------------------------- finding the chain
def _translation(path: Path, shift, initial="NoInitialTransform") -> Path:
    return _file(path, "TranslationTransform", shift, initial=initial)


def test_initial_transform_is_found_as_written_beside_the_file_or_by_its_last_part(tmp_path, monkeypatch):
    run = tmp_path / "run"
    run.mkdir()
    _translation(run / "TransformParameters.0.txt", [1.0, 0.0, 0.0])
    _translation(run / "TransformParameters.1.txt", [0.0, 2.0, 0.0], initial="run/TransformParameters.0.txt")
    monkeypatch.chdir(tmp_path)  # as written: relative to the working directory elastix ran in
    assert load_elastix(run / "TransformParameters.1.txt").deform([[0.0, 0.0, 0.0]]).tolist() == [[1.0, 2.0, 0.0]]
    moved = tmp_path / "elsewhere" / "results"
    shutil.copytree(run, moved)
    monkeypatch.chdir(moved.parent)  # neither as written nor relative to the file: the last part, beside it
    assert load_elastix(moved / "TransformParameters.1.txt").steps[0].offset.tolist() == [1.0, 0.0, 0.0]
    _translation(run / "TransformParameters.2.txt", [0.0, 0.0, 3.0], initial="TransformParameters.1.txt")
    assert len(load_elastix(run / "TransformParameters.2.txt").steps) == 3  # relative to the file's folder


def test_missing_looping_and_deep_chains_are_refused(tmp_path):
    _translation(tmp_path / "a.txt", [1.0, 0.0, 0.0], initial="/nowhere/gone.txt")
    with pytest.raises(FileFormatError, match=r"a\.txt, line 4: the initial transform '/nowhere/gone\.txt' is not"):
        load_elastix(tmp_path / "a.txt")
    _translation(tmp_path / "b.txt", [1.0, 0.0, 0.0], initial="c.txt")
    _translation(tmp_path / "c.txt", [1.0, 0.0, 0.0], initial="b.txt")
    with pytest.raises(FileFormatError, match="loops back"):
        load_elastix(tmp_path / "b.txt")
    _translation(tmp_path / "self.txt", [1.0, 0.0, 0.0], initial="self.txt")
    with pytest.raises(FileFormatError, match="loops back"):
        load_elastix(tmp_path / "self.txt")
    _translation(tmp_path / "d0.txt", [1.0, 0.0, 0.0])
    for i in range(1, MAX_CHAIN + 1):
        _translation(tmp_path / f"d{i}.txt", [1.0, 0.0, 0.0], initial=f"d{i - 1}.txt")
    assert len(load_elastix(tmp_path / f"d{MAX_CHAIN - 1}.txt").steps) == MAX_CHAIN
    with pytest.raises(FileFormatError, match=f"longer than {MAX_CHAIN}"):
        load_elastix(tmp_path / f"d{MAX_CHAIN}.txt")


# ---------------------------------------------------------------------------------------- refusals, syntax
@pytest.mark.parametrize(
    ("change", "message"),
    [
        (("BSplineTransformSplineOrder", [2]), "order 2"),
        (("UseCyclicTransform", [True]), "cyclic"),
        (("Transform", ["SplineKernelTransform"]), "unsupported transform 'SplineKernelTransform'"),
        (("GridSize", [4, 4]), "expected 3 numbers for GridSize"),
        (("GridSpacing", [1, 0, 1]), "positive grid spacing"),
        (("NumberOfParameters", [5]), "NumberOfParameters is 5"),
        (("HowToCombineTransforms", ["Multiply"]), None),
        (("FixedImageDimension", [2]), "only 3D"),
        (("GridDirection", [1, 0, 0, 1, 0, 0, 0, 0, 1]), "singular"),
    ],
)
def test_bad_bspline_files_are_refused_naming_the_line(tmp_path, change, message):
    entries = dict(
        [
            ("Transform", ["BSplineTransform"]),
            ("NumberOfParameters", [192]),
            ("TransformParameters", [0.0] * 192),
            ("InitialTransformParameterFileName", ["NoInitialTransform"]),
            ("HowToCombineTransforms", ["Compose"]),
            ("GridSize", [4, 4, 4]),
            ("GridIndex", [0, 0, 0]),
            ("GridSpacing", [1, 1, 1]),
            ("GridOrigin", [0, 0, 0]),
            ("GridDirection", [1, 0, 0, 0, 1, 0, 0, 0, 1]),
        ]
    )
    entries[change[0]] = change[1]
    path = tmp_path / "TransformParameters.0.txt"
    write_parameter_file(path, list(entries.items()))
    if message is None:  # the combination matters only with an initial transform
        _translation(tmp_path / "t.txt", [1.0, 0.0, 0.0])
        entries["InitialTransformParameterFileName"] = ["t.txt"]
        write_parameter_file(path, list(entries.items()))
        message = "expected HowToCombineTransforms"
    line = list(entries).index(change[0]) + 1
    with pytest.raises(FileFormatError, match=rf"TransformParameters\.0\.txt, line {line}: .*{message}"):
        load_deformation(path)


@pytest.mark.parametrize(
    ("text", "line", "message"),
    [
        ('(Transform "BSplineTransform)\n', 1, "odd number of quotes"),
        ('// fine\n\nTransform "BSplineTransform"\n', 3, "expected a line '\\(Name value \\.\\.\\.\\)'"),
        ('(Transform "A")\n(Transform "B")\n', 2, "given twice \\(first on line 1\\)"),
        ("(Transform)\n", 1, "has no value"),
        ("(1abc 2)\n", 1, "expected a parameter name"),
        ('(Transform "TranslationTransform")\n(TransformParameters 1 nan 2)\n', 2, "got 'nan'"),
    ],
)
def test_syntax_errors_name_the_line(tmp_path, text, line, message):
    path = tmp_path / "p.txt"
    path.write_text(text)
    with pytest.raises(FileFormatError, match=rf"p\.txt, line {line}: .*{message}"):
        load_elastix(path)


def test_syntax_follows_elastix(tmp_path):
    path = tmp_path / "p.txt"
    path.write_text('\ufeff// header\n\t( Name\t"a b"  1 ) //comment "\n(Other ""  x)\r\n\n')
    params = read_parameter_file(path)
    assert params.values("Name") == ("a b", "1") and params.line("Name") == 2
    assert params.values("Other") == ("x",)


def test_txt_files_are_told_apart_by_content(tmp_path):
    ffd = FFD(Lattice((4, 4, 4), 1.0))
    save_deformation(tmp_path / "itk.txt", ffd)
    save_deformation(tmp_path / "elx.txt", ffd, format="elastix")
    assert (tmp_path / "itk.txt").read_text().startswith("#Insight")
    assert (tmp_path / "elx.txt").read_text().startswith("(Transform")
    assert load_deformation(tmp_path / "itk.txt").lattice == load_deformation(tmp_path / "elx.txt").lattice
    save_deformation(tmp_path / "again.txt", load_deformation(tmp_path / "elx.txt"))  # read from elastix: kept so
    assert (tmp_path / "again.txt").read_text().startswith("(Transform")
    save_deformation(tmp_path / "as-itk.txt", load_deformation(tmp_path / "elx.txt"), format="itk")
    assert (tmp_path / "as-itk.txt").read_text().startswith("#Insight")
    with pytest.raises(ValueError, match="format must be one of"):
        save_deformation(tmp_path / "x.txt", ffd, format="nifti")


# ---------------------------------------------------------------------------------------- convert
def test_sheared_chain_converts_to_a_field_and_to_a_fitted_lattice(registrations, tmp_path, capsys):
    from ffd_notebook.__main__ import main
    from ffd_notebook.io import load_displacement_field

    path = registrations["affine+bspline"]
    chain = load_elastix(path)
    assert main(["convert", str(path), str(tmp_path / "x.tfm")]) == 1
    assert "sheared" in capsys.readouterr().err and not (tmp_path / "x.tfm").exists()
    assert main(["convert", str(path), str(tmp_path / "field.nii.gz")]) == 0  # on the fixed image's grid
    field = load_displacement_field(tmp_path / "field.nii.gz")
    assert field.size == (18, 22, 20) and np.allclose(field.direction, ROTATED, atol=1e-6)
    centres = field.grid_points()
    assert np.abs(field.deform(centres) - chain.deform(centres)).max() < 1e-5  # NIfTI's float32 geometry
    assert main(["convert", str(path), str(tmp_path / "fitted.h5"), "--fit", "8", "--affine"]) == 0
    assert "fitted a 8x8x8 lattice to 7920 samples" in capsys.readouterr().err
    fitted = load_deformation(tmp_path / "fitted.h5")
    inside = _image_points(500, (1.5, 1.0, 2.0), (10.0, -5.0, 3.0), ROTATED, seed=4)
    assert np.abs(fitted.deform(inside) - chain.deform(inside)).max() < 0.5
