"""``face_from_photo`` on photos made offline from scikit-image's ``astronaut()``, checked against an independent
face detector (scikit-image's LBP cascade) and against the photo itself.

The checks (:func:`check_face`) are written to fail on the three mistakes a face-from-photo path
makes: a wrong crop (landmarks off the face), a mirrored mesh, a flipped v coordinate; the last
tests show that they do.
"""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from skimage import color, data, transform
from skimage.feature import Cascade

import ffd_notebook as fn
from ffd_notebook.errors import FileFormatError, NoFaceError
from ffd_notebook.face import face_landmarks, landmarks

RIGHT_EYE, LEFT_EYE, NOSE_TIP, FOREHEAD, CHIN = 33, 263, 4, 10, 152
MIDLINE = [4, 1, 10, 152, 0, 17, 13, 14, 168, 6]  # landmarks on the face's plane of symmetry
PAIRS = [(33, 263), (133, 362), (61, 291), (234, 454)]  # (the subject's right, left): eye corners, mouth, cheeks


@pytest.fixture(scope="module")
def astronaut() -> np.ndarray:
    return data.astronaut()


@pytest.fixture(scope="module")
def astronaut_mesh(astronaut):
    return fn.face_from_photo(astronaut)


def lbp_face_box(rgb: np.ndarray) -> np.ndarray:
    """The largest face scikit-image's LBP cascade finds, ``(xmin, ymin, xmax, ymax)`` in the photo's pixels.

    Run on a copy of at most 512 pixels a side (the cascade's time grows with the photo).
    """
    grey = color.rgb2gray(rgb)
    factor = min(1.0, 512 / max(grey.shape))
    if factor < 1:
        grey = transform.rescale(grey, factor, anti_aliasing=True)
    n = min(grey.shape)
    cascade = Cascade(data.lbp_frontal_face_cascade_filename())
    found = cascade.detect_multi_scale(
        img=grey, scale_factor=1.2, step_ratio=1, min_size=(max(24, n // 8),) * 2, max_size=(n, n)
    )
    assert found, "the LBP cascade finds no face: the test photo is wrong"
    best = max(found, key=lambda f: f["width"] * f["height"])
    return np.array([best["c"], best["r"], best["c"] + best["width"], best["r"] + best["height"]]) / factor


def photo_positions(mesh, rgb: np.ndarray) -> np.ndarray:
    """Where each vertex is in the photo (pixels, x right, y down), from the mesh's texture coordinates."""
    uv = np.asarray(mesh.active_texture_coordinates, dtype=np.float64)
    height, width = rgb.shape[:2]
    return np.column_stack([uv[:, 0] * width, (1.0 - uv[:, 1]) * height])


def photo_colours(rgb: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """Bilinear colours of the photo at continuous pixel positions (pixel (i, j) centred at (j + 0.5, i + 0.5))."""
    x = np.clip(xy[:, 0] - 0.5, 0, rgb.shape[1] - 1)
    y = np.clip(xy[:, 1] - 0.5, 0, rgb.shape[0] - 1)
    x0 = np.minimum(np.floor(x).astype(int), rgb.shape[1] - 2)
    y0 = np.minimum(np.floor(y).astype(int), rgb.shape[0] - 2)
    fx, fy = (x - x0)[:, None], (y - y0)[:, None]
    img = rgb.astype(np.float64)
    top = img[y0, x0] * (1 - fx) + img[y0, x0 + 1] * fx
    bottom = img[y0 + 1, x0] * (1 - fx) + img[y0 + 1, x0 + 1] * fx
    return top * (1 - fy) + bottom * fy


def check_face(mesh, rgb: np.ndarray, box: np.ndarray | None = None) -> None:
    """The mesh is the face of ``rgb``: on the face found by the LBP cascade, coloured from the photo, seen from
    the front (not mirrored, v up), nose nearest the viewer, eyes on their sides, of a face's size in mm."""
    box = lbp_face_box(rgb) if box is None else box
    assert mesh.n_points >= 10_000 and mesh.is_all_triangles
    xy = photo_positions(mesh, rgb)
    uv = np.asarray(mesh.active_texture_coordinates)
    assert uv.min() >= 0 and uv.max() <= 1

    # the landmarks landed on the face: most vertices inside the independent detector's box (grown by 15%)
    size = box[2:] - box[:2]
    lo, hi = box[:2] - 0.15 * size, box[2:] + 0.15 * size
    inside = np.all((xy >= lo) & (xy <= hi), axis=1).mean()
    assert inside >= 0.85, f"only {inside:.0%} of the vertices are on the face box {box.round()}"
    centre = (xy[:468].min(axis=0) + xy[:468].max(axis=0)) / 2
    off = np.abs(centre - (box[:2] + box[2:]) / 2) / size
    assert np.all(off < 0.15), f"the vertices are off the face box: their centre is {off.round(2)} box sizes away"
    spread = (xy.max(axis=0) - xy.min(axis=0)) / size
    assert np.all(spread > 0.6), f"the mesh covers only {spread.round(2)} of the face box"

    # coloured from the photo where the texture coordinates say (a flipped v takes other pixels' colours)
    expected = photo_colours(rgb, xy)
    wrong = np.abs(mesh.point_data["RGB"].astype(float) - expected).max(axis=1) > 1.01
    assert wrong.mean() < 0.001, f"{wrong.mean():.1%} of the colours are not the photo's at the vertex"

    # seen from the front: the mesh's (x, y) is a rotation and scale of the photo's (x right, y up), no reflection
    up = np.column_stack([xy[:, 0], -xy[:, 1], np.ones(len(xy))])
    fit, *_ = np.linalg.lstsq(up, mesh.points[:, :2], rcond=None)
    assert np.linalg.det(fit[:2]) > 0, "the mesh is the photo's mirror image"
    assert np.abs(up @ fit - mesh.points[:, :2]).max() < 1e-3 * np.ptp(mesh.points[:, 0])

    # the subject's eyes on their sides (the right eye on the photo's left, both in the box's upper half),
    # in the mesh the left eye at +x, both above the nose tip; the forehead up, the chin down
    p = mesh.points
    middle = (box[:2] + box[2:]) / 2
    assert xy[RIGHT_EYE, 0] < middle[0] < xy[LEFT_EYE, 0], (xy[[RIGHT_EYE, LEFT_EYE]], box)
    assert xy[RIGHT_EYE, 1] < middle[1] and xy[LEFT_EYE, 1] < middle[1], "the eyes are not in the face's upper half"
    assert p[RIGHT_EYE, 0] < p[NOSE_TIP, 0] < p[LEFT_EYE, 0]
    assert min(p[RIGHT_EYE, 1], p[LEFT_EYE, 1]) > p[NOSE_TIP, 1] > p[CHIN, 1] and p[FOREHEAD, 1] > p[NOSE_TIP, 1]
    assert abs(p[RIGHT_EYE, 1] - p[LEFT_EYE, 1]) < 5, "the head's roll is not undone"

    # the nose tip is the vertex nearest the viewer (+z), in the middle of the face box
    nearest = int(np.argmax(p[:, 2]))
    assert np.linalg.norm(p[nearest] - p[NOSE_TIP]) < 8.0
    assert np.all(np.abs(xy[nearest] - middle) < 0.25 * size), (xy[nearest], box)
    # looking towards +z: the triangles face the viewer
    normals = mesh.compute_normals(cell_normals=True, point_normals=False, auto_orient_normals=False)
    facing = (normals.cell_data["Normals"] * normals.compute_cell_sizes()["Area"][:, None]).sum(axis=0)
    assert facing[2] > 0.8 * np.linalg.norm(facing)

    # millimetres: an adult face's size
    extent = np.ptp(p, axis=0)
    assert 110 < extent[0] < 190 and 120 < extent[1] < 230 and 40 < extent[2] < 140, extent


def rotated(rgb: np.ndarray, degrees: float) -> tuple[np.ndarray, np.ndarray]:
    """The photo turned counter-clockwise on the screen (whole, on a larger canvas), and the 3x3 matrix taking
    the original's continuous pixel positions to the new photo's."""
    h, w = rgb.shape[:2]
    a = np.deg2rad(degrees)
    turn = np.array([[np.cos(a), np.sin(a)], [-np.sin(a), np.cos(a)]])  # counter-clockwise with y down
    corners = (np.array([[0, 0], [w, 0], [0, h], [w, h]]) - (w / 2, h / 2)) @ turn.T
    lo = corners.min(axis=0)
    out = np.ceil(corners.max(axis=0) - lo).astype(int)
    matrix = np.eye(3)
    matrix[:2, :2] = turn
    matrix[:2, 2] = -np.array([w / 2, h / 2]) @ turn.T - lo
    half = np.eye(3)
    half[:2, 2] = 0.5  # scikit-image puts pixel centres at integers
    tform = transform.AffineTransform(matrix=np.linalg.inv(half) @ matrix @ half)
    turned = transform.warp(rgb, tform.inverse, output_shape=(out[1], out[0]), order=1, preserve_range=True)
    return turned.round().astype(np.uint8), matrix


def test_astronaut(astronaut, astronaut_mesh):
    check_face(astronaut_mesh, astronaut)
    box = lbp_face_box(astronaut)
    detected = fn.face.detect_faces(astronaut)[0].box
    lo, hi = np.maximum(box[:2], detected[:2]), np.minimum(box[2:], detected[2:])
    iou = np.prod(hi - lo) / (np.prod(box[2:] - box[:2]) + np.prod(detected[2:] - detected[:2]) - np.prod(hi - lo))
    assert iou > 0.6, (box, detected)  # the bundled detector and the LBP cascade agree on the face


def test_mirrored_photo_gives_the_mirrored_face(astronaut, astronaut_mesh):
    mirrored = np.ascontiguousarray(astronaut[:, ::-1])
    mesh = fn.face_from_photo(mirrored)
    check_face(mesh, mirrored)
    width = astronaut.shape[1]
    xy, xy_ref = photo_positions(mesh, mirrored), photo_positions(astronaut_mesh, astronaut)
    xy[:, 0] = width - xy[:, 0]
    face_width = np.linalg.norm(xy_ref[454] - xy_ref[234])
    # the midline maps to itself, the subject's right eye of the mirror image is the original's left eye, ...
    assert np.median(np.linalg.norm(xy[MIDLINE] - xy_ref[MIDLINE], axis=1)) < 0.03 * face_width
    right, left = np.array(PAIRS).T
    assert np.median(np.linalg.norm(xy[right] - xy_ref[left], axis=1)) < 0.03 * face_width
    # ... and the mesh is the original mesh mirrored (x -> -x), up to the model's noise
    mirrored_points = astronaut_mesh.points[:468] * (-1, 1, 1)
    partner = np.arange(468)
    partner[right], partner[left] = left, right
    ids = np.r_[MIDLINE, right, left]
    assert np.median(np.linalg.norm(mesh.points[ids] - mirrored_points[partner[ids]], axis=1)) < 4.0


def test_photo_rotated_20_degrees(astronaut, astronaut_mesh):
    turned, matrix = rotated(astronaut, 20)
    mesh = fn.face_from_photo(turned)
    # the cascade's box on the upright photo, turned with it (the cascade finds faces upright only)
    x0, y0, x1, y1 = lbp_face_box(astronaut)
    corners = np.array([[x0, y0], [x1, y0], [x0, y1], [x1, y1]]) @ matrix[:2, :2].T + matrix[:2, 2]
    check_face(mesh, turned, box=np.r_[corners.min(axis=0), corners.max(axis=0)])
    # the landmarks are where the turn took the original's, and the roll is undone: the same mesh (mm)
    ref = photo_positions(astronaut_mesh, astronaut)[:468] @ matrix[:2, :2].T + matrix[:2, 2]
    face_width = np.linalg.norm(ref[454] - ref[234])
    error = np.linalg.norm(photo_positions(mesh, turned)[:468] - ref, axis=1)
    assert np.median(error) < 0.02 * face_width and np.percentile(error, 95) < 0.04 * face_width
    assert np.median(np.linalg.norm(mesh.points[:468] - astronaut_mesh.points[:468], axis=1)) < 3.0


@pytest.mark.parametrize("factor", [1 / 3, 3], ids=["third", "triple"])
def test_photo_scaled(astronaut, astronaut_mesh, factor):
    scaled = transform.rescale(astronaut, factor, channel_axis=-1, anti_aliasing=factor < 1, preserve_range=True)
    scaled = scaled.round().astype(np.uint8)
    mesh = fn.face_from_photo(scaled)
    check_face(mesh, scaled)
    # the same texture coordinates and the same mesh in millimetres, whatever the photo's size
    uv, uv_ref = mesh.active_texture_coordinates[:468], astronaut_mesh.active_texture_coordinates[:468]
    assert np.median(np.linalg.norm(uv - uv_ref, axis=1)) < 0.005  # 2.5 pixels of the 512-pixel photo
    assert np.median(np.linalg.norm(mesh.points[:468] - astronaut_mesh.points[:468], axis=1)) < 3.0


def test_darkened_photo(astronaut, astronaut_mesh):
    dark = (astronaut * 0.4).astype(np.uint8)
    mesh = fn.face_from_photo(dark)
    check_face(mesh, dark)
    assert np.median(np.linalg.norm(mesh.points[:468] - astronaut_mesh.points[:468], axis=1)) < 3.0
    ratio = mesh.point_data["RGB"].astype(float).mean() / astronaut_mesh.point_data["RGB"].astype(float).mean()
    assert 0.35 < ratio < 0.42


def test_colours_come_from_the_full_resolution_photo(astronaut):
    big = transform.rescale(astronaut, 3, channel_axis=-1, order=0).astype(np.uint8)  # 3x3 blocks, sharp edges
    rng = np.random.default_rng(0)
    big = np.clip(big.astype(int) + rng.integers(-40, 41, big.shape), 0, 255).astype(np.uint8)  # pixel-level noise
    mesh = fn.face_from_photo(big)
    xy = photo_positions(mesh, big)
    assert np.abs(mesh.point_data["RGB"].astype(float) - photo_colours(big, xy)).max() <= 1.01


def test_grey_and_rgba_photos_work(astronaut, astronaut_mesh):
    grey = (color.rgb2gray(astronaut) * 255).round().astype(np.uint8)
    mesh = fn.face_from_photo(grey)
    assert np.array_equal(mesh.point_data["RGB"][:, 0], mesh.point_data["RGB"][:, 2])
    check_face(mesh, np.dstack([grey] * 3))
    rgba = np.dstack([astronaut, np.full(astronaut.shape[:2], 128, np.uint8)])
    mesh = fn.face_from_photo(rgba)
    assert np.array_equal(mesh.point_data["RGB"], astronaut_mesh.point_data["RGB"])


def test_files(tmp_path, astronaut, astronaut_mesh):
    from PIL import Image

    Image.fromarray(astronaut).save(tmp_path / "astronaut.png")
    Image.fromarray(astronaut).convert("LA").save(tmp_path / "grey_alpha.png")
    Image.fromarray((color.rgb2gray(astronaut) * 60000).astype(np.uint16)).save(tmp_path / "grey16.png")
    mesh = fn.face_from_photo(tmp_path / "astronaut.png")
    assert np.array_equal(mesh.points, astronaut_mesh.points)
    assert np.array_equal(mesh.point_data["RGB"], astronaut_mesh.point_data["RGB"])
    for name in ("grey_alpha.png", "grey16.png"):
        check_face(fn.face_from_photo(tmp_path / name), fn.face.read_photo(tmp_path / name))
    # a phone's JPEG stored sideways with an EXIF orientation comes out upright
    exif = Image.Exif()
    exif[0x0112] = 6  # orientation: turn 90 degrees clockwise to show
    Image.fromarray(np.rot90(astronaut, 1)).save(tmp_path / "phone.jpg", exif=exif, quality=95)
    mesh = fn.face_from_photo(tmp_path / "phone.jpg")
    assert tuple(mesh.field_data["photo_size"]) == (512, 512)
    assert np.median(np.linalg.norm(mesh.points[:468] - astronaut_mesh.points[:468], axis=1)) < 3.0


def test_a_huge_photo_is_shrunk_for_the_models_not_refused(astronaut, astronaut_mesh):
    from PIL import Image

    huge = np.asarray(Image.fromarray(astronaut).resize((5000, 5000), Image.Resampling.BILINEAR))
    mesh = fn.face_from_photo(huge)
    uv, uv_ref = mesh.active_texture_coordinates[:468], astronaut_mesh.active_texture_coordinates[:468]
    assert np.median(np.linalg.norm(uv - uv_ref, axis=1)) < 0.005


def test_no_face(tmp_path):
    from PIL import Image

    path = tmp_path / "coins.png"
    Image.fromarray(data.coins()).save(path)
    with pytest.raises(NoFaceError, match=r"coins\.png: no face found in the photo"):
        fn.face_from_photo(path)
    with pytest.raises(NoFaceError, match=r"the photo \(a 384x303 array\): no face found"):
        fn.face_from_photo(data.coins())
    assert isinstance(NoFaceError("x", "y"), ValueError)


def test_not_an_image(tmp_path):
    path = tmp_path / "face.jpg"
    path.write_bytes(b"GIF89a but not really" + bytes(100))
    with pytest.raises(FileFormatError, match=r"face\.jpg: (not an image|damaged)"):
        fn.face_from_photo(path)
    half = tmp_path / "half.png"
    from PIL import Image

    Image.fromarray(data.astronaut()).save(tmp_path / "whole.png")
    half.write_bytes((tmp_path / "whole.png").read_bytes()[:5000])  # a truncated download
    with pytest.raises(FileFormatError, match=r"half\.png: damaged"):
        fn.face_from_photo(half)
    with pytest.raises(FileNotFoundError, match=r"missing\.png"):
        fn.face_from_photo(tmp_path / "missing.png")
    # the package's dtype policy (issue 35 item 8): floats are 0 to 1, so 0-255 levels in a float array are refused
    # rather than clipped to white (a float photo in [0, 1], uint16 one, is read: tests/test_colours.py)
    with pytest.raises(ValueError, match=r"floating-point colours must be in \[0, 1\].*from 0 to 255"):
        fn.face_from_photo(data.astronaut().astype(float))


def test_several_faces_largest_first_or_by_index(astronaut):
    head = astronaut[:320, 60:380]
    small = transform.rescale(head, 0.8, channel_axis=-1, anti_aliasing=True, preserve_range=True)
    canvas = np.full((320, 320 + small.shape[1], 3), 255, np.uint8)
    canvas[:, :320] = head
    canvas[: small.shape[0], 320:] = small.round().astype(np.uint8)
    faces = fn.face.detect_faces(canvas)
    assert len(faces) == 2 and faces[0].box[2] < 320 < faces[1].box[0]
    assert face_landmarks(canvas).points[:, 0].max() < 320
    assert face_landmarks(canvas, index=1).points[:, 0].min() > 320
    u = fn.face_from_photo(canvas, index=1, subdivisions=0).active_texture_coordinates[:, 0]
    assert u.min() > 320 / canvas.shape[1]
    with pytest.raises(NoFaceError, match="face index 2 asked for, but only 2 face"):
        fn.face_from_photo(canvas, index=2)


# -- the checks fail on the mistakes they are there to catch ---------------------------------------------------------


def test_the_checks_fail_on_a_wrong_crop(astronaut, monkeypatch):
    right = landmarks.landmarks_of_face

    def off_by_a_fifth(photo, face, **kwargs):  # landmarks projected back through a square 20% off the crop
        found = right(photo, face, **kwargs)
        points = found.points + (0.2 * found.crop.size, 0.0, 0.0)
        return landmarks.FaceLandmarks(points, found.presence, found.crop, found.detection)

    monkeypatch.setattr(fn.face.mesh, "landmarks_of_face", off_by_a_fifth)
    with pytest.raises(AssertionError, match="off the face box"):
        check_face(fn.face_from_photo(astronaut), astronaut)


def test_the_checks_fail_on_a_mirrored_mesh(astronaut, astronaut_mesh):
    mirrored = astronaut_mesh.copy()
    mirrored.points = mirrored.points * (-1, 1, 1)
    with pytest.raises(AssertionError, match="mirror image"):
        check_face(mirrored, astronaut)


def test_the_checks_fail_on_a_flipped_v(astronaut, astronaut_mesh):
    flipped = astronaut_mesh.copy()
    uv = np.array(flipped.active_texture_coordinates)
    uv[:, 1] = 1 - uv[:, 1]
    flipped.active_texture_coordinates = uv
    with pytest.raises(AssertionError):
        check_face(flipped, astronaut)


def test_without_litert_the_package_imports_and_face_from_photo_says_what_to_install():
    code = (
        "import sys\n"
        "sys.modules['ai_edge_litert'] = None  # as on a platform without its wheel\n"
        "import numpy as np, ffd_notebook as fn, ffd_notebook.face\n"
        "try:\n"
        "    fn.face_from_photo(np.zeros((64, 64, 3), np.uint8))\n"
        "except ImportError as exc:\n"
        "    print(type(exc).__name__, exc)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.startswith("LiteRTMissingError") and "install ai-edge-litert" in out, out


@pytest.mark.parametrize("crop", [(0, 512, 100, 350), (30, 230, 0, 512)], ids=["portrait", "landscape"])
def test_a_photo_that_is_not_square(astronaut, crop):
    """The letterbox and the crops are placed in pixels: a cut-out of the photo gives the same landmarks, shifted."""
    y0, y1, x0, x1 = crop
    part = np.ascontiguousarray(astronaut[y0:y1, x0:x1])
    points = face_landmarks(part).points[:, :2] + (x0, y0)
    reference = face_landmarks(astronaut).points[:, :2]
    assert np.median(np.linalg.norm(points - reference, axis=1)) < 1.0  # pixels
    check_face(fn.face_from_photo(part), part)


def test_threads_share_the_models(astronaut, astronaut_mesh):
    """The editor builds faces in worker threads: calls at once give the same meshes as one at a time."""
    from concurrent.futures import ThreadPoolExecutor

    photos = [astronaut, np.ascontiguousarray(astronaut[:, ::-1])] * 3
    with ThreadPoolExecutor(3) as pool:
        meshes = list(pool.map(fn.face_from_photo, photos))
    mirrored = fn.face_from_photo(photos[1])
    for k, mesh in enumerate(meshes):
        assert np.array_equal(mesh.points, (astronaut_mesh if k % 2 == 0 else mirrored).points)


def test_an_upload_s_bytes(tmp_path, astronaut_mesh):
    from PIL import Image

    Image.fromarray(data.astronaut()).save(tmp_path / "me.jpg", quality=98)
    mesh = fn.face_from_photo(fn.face.decode_photo((tmp_path / "me.jpg").read_bytes(), "me.jpg"))
    assert np.median(np.linalg.norm(mesh.points[:468] - astronaut_mesh.points[:468], axis=1)) < 2.0
    with pytest.raises(NoFaceError, match=r"^coins\.png: no face found"):
        Image.fromarray(data.coins()).save(tmp_path / "coins.png")
        fn.face_from_photo(fn.face.decode_photo((tmp_path / "coins.png").read_bytes(), "coins.png"))
    with pytest.raises(FileFormatError, match=r"^notes\.jpg: not an image"):
        fn.face.decode_photo(b"shopping list", "notes.jpg")
