"""The parts of the face path: the shipped topology and its reader, the detector's anchors and decoding, crops."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from skimage import data

from ffd_notebook.errors import FileFormatError
from ffd_notebook.face import detection, topology
from ffd_notebook.face.crop import Square, bilinear
from ffd_notebook.face.landmarks import crop_from_detection, crop_from_landmarks, face_landmarks


def test_the_shipped_triangles_are_mediapipes_face_mesh():
    tri = topology.face_triangles()
    assert tri.shape == (852, 3) and sorted(np.unique(tri)) == list(range(468))
    edges = {frozenset((int(t[i]), int(t[(i + 1) % 3]))) for t in tri for i in range(3)}
    assert len(edges) == 1322 and 468 - len(edges) + len(tri) == -2  # a disc with three holes
    topology.triangles_from_edges([(int(t[i]), int(t[(i + 1) % 3])) for t in tri for i in range(3)])  # oriented
    loops = topology.boundary_loops(tri)
    assert sorted(len(loop) for loop in loops) == [16, 16, 20, 36]  # two eyes, the lips, the outline
    for corners in topology.HOLE_CORNERS:
        assert any(set(corners) <= set(loop) for loop in loops)


def test_closing_the_eyes_and_mouth_keeps_one_consistent_disc():
    closed = topology.closed_face_triangles()
    assert len(closed) == 898 and np.array_equal(closed[:852], topology.face_triangles())
    (outline,) = topology.boundary_loops(closed)
    assert {234, 454, 10, 152} <= set(outline)
    edges = {frozenset((int(t[i]), int(t[(i + 1) % 3]))) for t in closed for i in range(3)}
    assert 468 - len(edges) + len(closed) == 1


def _write_connections(path, edges, name="FACEMESH_TESSELATION"):
    path.write_text(
        f'"""MediaPipe FaceMesh connections."""\n\nFACEMESH_LIPS = frozenset([(0, 1)])\n{name} = frozenset([\n'
    )
    with path.open("a") as f:
        for a, b in edges:
            f.write(f"    ({a}, {b}),\n")
        f.write("])\n")


def _strip_of_468() -> list[tuple[int, int, int]]:
    """A consistently oriented strip of triangles over the points 0..467."""
    return [(i, i + 1, i + 2) if i % 2 == 0 else (i + 1, i, i + 2) for i in range(466)]


@settings(max_examples=30, deadline=None)
@given(st.permutations(range(468)), st.randoms(use_true_random=False))
def test_reading_a_tessellation_gives_its_triangles(tmp_path_factory, relabel, rnd):
    triangles = [tuple(relabel[v] for v in t) for t in _strip_of_468()]
    rnd.shuffle(triangles)
    turned = [t[k:] + t[:k] for t in triangles for k in [rnd.randrange(3)]]  # any corner first
    path = tmp_path_factory.mktemp("mp") / "face_mesh_connections.py"
    _write_connections(path, [e for a, b, c in turned for e in ((a, b), (b, c), (c, a))])
    assert topology.read_tessellation(path).tolist() == [list(t) for t in turned]


def test_a_broken_tessellation_is_refused_with_its_line(tmp_path):
    path = tmp_path / "face_mesh_connections.py"
    edges = [e for a, b, c in _strip_of_468() for e in ((a, b), (b, c), (c, a))]
    _write_connections(path, edges[:-1] + [(5, 7)])
    with pytest.raises(FileFormatError, match=r"line 4: FACEMESH_TESSELATION: edges .* do not close a triangle"):
        topology.read_tessellation(path)
    _write_connections(path, edges, name="OTHER")
    with pytest.raises(FileFormatError, match="no FACEMESH_TESSELATION"):
        topology.read_tessellation(path)
    _write_connections(path, edges[:-3])  # point 467 unused
    with pytest.raises(FileFormatError, match=r"do not use the points 0\.\.467"):
        topology.read_tessellation(path)
    flipped = [(0, 1), (1, 2), (2, 0), (1, 2), (2, 3), (3, 1)]
    with pytest.raises(ValueError, match="not consistently oriented"):
        topology.triangles_from_edges(flipped)


def test_anchors_follow_ssd_anchors_calculator():
    a = detection.anchors()
    assert a.shape == (896, 2)
    # stride 8: a 16x16 grid, two anchors a cell, row by row; stride 16 (three layers merged): 8x8, six a cell
    first = a[:512].reshape(16, 16, 2, 2)
    assert np.allclose(first[..., 0, :], first[..., 1, :])
    assert np.allclose(first[0, :, 0, 0], (np.arange(16) + 0.5) / 16) and np.allclose(first[0, :, 0, 1], 1 / 32)
    second = a[512:].reshape(8, 8, 6, 2)
    assert np.allclose(second[3, 5, :, :], [(5.5 / 8, 3.5 / 8)] * 6)


def test_decoding_puts_a_box_where_the_raw_numbers_say():
    regressors = np.zeros((1, 896, 16), np.float32)
    logits = np.full((1, 896, 1), -10.0, np.float32)
    k = 512 + 6 * (8 * 3 + 5) + 2  # stride 16, cell (row 3, column 5), centre (0.6875, 0.4375)
    regressors[0, k, :4] = (12.8, -6.4, 25.6, 38.4)  # x, y offsets and width, height, in 128-pixel units
    regressors[0, k, 4:6] = (-12.8, 0.0)  # key point 0, 0.1 left of the anchor
    logits[0, k] = 3.0
    ((values, score),) = detection._decode(regressors, logits, 0.5)
    assert score == pytest.approx(1 / (1 + np.exp(-3.0)))
    centre = np.array([0.6875 + 0.1, 0.4375 - 0.05])
    assert np.allclose(values[:4], np.r_[centre - (0.1, 0.15), centre + (0.1, 0.15)])
    assert np.allclose(values[4:6], (0.5875, 0.4375))


def test_the_crop_is_turned_with_the_head():
    marks = face_landmarks(data.astronaut())
    first = crop_from_detection(marks.detection)
    again = crop_from_landmarks(marks.points)
    # the detector's eye key points give the roll roughly, the landmarks' eye corners finely (her head: ~3 degrees)
    assert abs(first.rotation - again.rotation) < np.deg2rad(15) and abs(again.rotation) < np.deg2rad(6)
    assert 1.2 < again.size / (marks.detection.box[2] - marks.detection.box[0]) < 2.0
    # a square turned by r maps its right edge's middle to centre + size/2 (cos r, sin r)
    sq = Square((100.0, 50.0), 40.0, np.deg2rad(30))
    assert np.allclose(sq.to_photo(np.array([[1.0, 0.5]])), [[100 + 20 * np.cos(np.pi / 6), 50 + 10]])


def test_sampling_a_crop_reads_the_photo():
    rgb = np.zeros((40, 60, 3), np.uint8)
    rgb[10:20, 30:40] = (255, 128, 0)
    patch = Square((35.0, 15.0), 10.0).sample(rgb, 10)
    assert np.allclose(patch, (255, 128, 0))
    turned = Square((35.0, 15.0), 10.0, np.pi / 2).sample(rgb, 10)
    assert np.allclose(turned, patch)
    assert np.allclose(bilinear(rgb, np.array([[30.0, 15.0]])), [(127.5, 64, 0)])


def test_the_triangle_file_is_made_by_the_topology_command(tmp_path, capsys):
    connections = tmp_path / "face_mesh_connections.py"
    triangles = topology.face_triangles()
    _write_connections(connections, [(int(t[i]), int(t[(i + 1) % 3])) for t in triangles for i in range(3)])
    out = tmp_path / "triangles.npy"
    assert topology.main([str(connections), str(out)]) == 0
    assert "852 triangles" in capsys.readouterr().out
    made = np.load(out)
    assert made.dtype == np.uint16 and np.array_equal(made, triangles)
    assert topology.main([]) == 2
