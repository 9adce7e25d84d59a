"""Organ models with solid textures: tetrahedra, surface, dense colours, cutting, deformation."""

import sys
import warnings

import numpy as np
import pytest
import pyvista as pv
import skimage.data

import ffd_notebook.view  # noqa: F401  (headless settings before any plotter)
from ffd_notebook import FFD, Lattice
from ffd_notebook.datasets import frog_liver
from ffd_notebook.meshing import organ as organ_module
from ffd_notebook.meshing.organ import organ_surface, tetrahedralize, texture_surface
from ffd_notebook.solidtex import LazySolidTexture, SolidTexture, sliding_crops, volume_from_slices
from ffd_notebook.view.solidtex import CutViewer, TexturedOrgan, add_cut
from ffd_notebook.view.solidtex.cut_viewer import _rim


@pytest.fixture(scope="module")
def liver():
    return frog_liver(1200)


@pytest.fixture(scope="module")
def texture(liver):
    # a real exemplar stack straight from an image: enough to see colours move (no synthesis needed)
    vol = volume_from_slices(sliding_crops(skimage.data.immunohistochemistry(), 32, 48, step=(1, 1), start=(90, 90)))
    return SolidTexture.fit(vol, liver.bounds)


@pytest.fixture(scope="module")
def grid(liver):
    return tetrahedralize(liver, method="delaunay")


@pytest.fixture
def without_tetgen(monkeypatch):
    monkeypatch.setitem(sys.modules, "tetgen", None)  # "import tetgen" now raises ImportError


def _check_tet_model(grid, surface):
    assert grid.n_cells == len(grid.cells_dict[pv.CellType.TETRA])
    assert np.all(grid.compute_cell_sizes()["Volume"] >= 0)
    outer = organ_surface(grid)
    assert outer.n_open_edges == 0 and outer.is_manifold
    # the boundary faces enclose exactly the tetrahedra, and about the organ's volume
    assert outer.volume == pytest.approx(grid.volume, rel=1e-6)
    assert outer.volume == pytest.approx(surface.volume, rel=0.03)
    np.testing.assert_array_equal(outer.point_data["rest"], grid.points[outer.point_data["grid_point"]])
    return outer


def test_fallback_tetrahedralisation_without_tetgen(liver, without_tetgen):
    grid = tetrahedralize(liver)  # "auto" falls back
    assert grid.field_data["tetrahedralizer"][0] == "delaunay"
    _check_tet_model(grid, liver)
    with pytest.raises(ImportError, match=r"ffd_notebook\[tetgen\]"):
        tetrahedralize(liver, method="tetgen")


def test_tetgen_when_installed(liver):
    grid = tetrahedralize(liver)
    assert grid.field_data["tetrahedralizer"][0] == "tetgen"
    outer = _check_tet_model(grid, liver)
    assert outer.n_points >= liver.n_points  # TetGen keeps every surface point (and may add some)


def test_open_surface_is_refused():
    with pytest.raises(ValueError, match="open edges"):
        tetrahedralize(pv.Plane())
    with pytest.raises(ValueError, match="method"):
        tetrahedralize(pv.Sphere(), method="voxels")


def test_dense_colours_are_the_texture_at_rest_positions(grid, texture):
    outer = organ_surface(grid)
    dense = texture_surface(outer, texture, subdivisions=2)
    assert dense.n_cells == 16 * outer.n_cells
    np.testing.assert_allclose(dense.points, dense.point_data["rest"], atol=1e-3)  # VTK keeps float32 points
    np.testing.assert_array_equal(dense.point_data["RGB"], texture.sample(dense.point_data["rest"]))
    # subdividing shows texture detail the coarse vertices miss: more distinct colours per triangle
    coarse = texture_surface(outer, texture, subdivisions=0)
    assert len(np.unique(dense.point_data["RGB"], axis=0)) > 4 * len(np.unique(coarse.point_data["RGB"], axis=0))
    assert organ_module.auto_subdivisions(outer, texture) >= 1


def test_a_cut_face_is_sampled_along_its_long_edges(grid):
    # a texture finer than the tetrahedra: subdivisions chosen by the mean edge left a section's long
    # thin triangles sampled too sparsely (their corners' colours fanned out as streaks); "auto" brings
    # the long edges (99th percentile) down to two voxels, with uniform subdivisions: no T-junctions
    fine = SolidTexture.fit(np.zeros((256, 256, 256, 3), np.uint8), grid.bounds)
    organ = TexturedOrgan(grid, fine, subdivisions=0)
    origin, normal = np.array(grid.center), np.array([0.3, 1.0, 0.0])
    section = grid.slice(normal=normal, origin=origin, generate_triangles=True)
    face = organ.cut_face(origin, normal)

    def lengths(mesh):
        return mesh.extract_all_edges().compute_cell_sizes(length=True, area=False, volume=False)["Length"]

    n = organ_module.auto_subdivisions(section, fine, samples_per_voxel=0.5, quantile=0.99)
    assert n > organ_module.auto_subdivisions(section, fine, samples_per_voxel=0.5)  # the mean would miss them
    assert face.n_cells == 4**n * section.n_cells
    assert n == 4 or np.quantile(lengths(face), 0.99) <= 2 * fine.spacing * (1 + 1e-9)
    np.testing.assert_allclose(face.point_data["rest"], face.points, atol=1e-3)  # rest interpolated on the plane
    # conforming: the rim is the section's outline, no inner edge drawn
    assert sum(lengths(_rim(face))) == pytest.approx(sum(lengths(_rim(section))), rel=1e-6)  # float32 points


def test_cut_faces_sample_the_interior_and_follow_a_deformation(grid, texture):
    organ = TexturedOrgan(grid, texture, subdivisions=1)
    origin, normal = np.array(grid.center), np.array([0.6, 0.8, 0.0])
    outside, face = organ.cut(origin, normal)
    assert face.n_cells > 0 and outside.n_cells > 0
    np.testing.assert_allclose((face.points - origin) @ normal, 0, atol=1e-3)
    assert np.all((outside.points - origin) @ normal <= 1e-3)
    colours = face.point_data["RGB"].copy()
    np.testing.assert_array_equal(colours, texture.sample(face.points))
    # move the organ by an FFD translation: the same material is cut by the moved plane
    lattice = Lattice.around(grid.points, shape=(5, 5, 5))
    lattice.offsets[...] = (7.0, -3.0, 2.0)
    organ.deform(FFD(lattice).deform)
    shift = organ.surface.points - organ.surface.point_data["rest"]
    np.testing.assert_allclose(shift, np.broadcast_to([7.0, -3.0, 2.0], shift.shape), atol=1e-3)
    _, moved = organ.cut(origin + (7.0, -3.0, 2.0), normal)
    np.testing.assert_allclose(moved.point_data["rest"], moved.points - (7.0, -3.0, 2.0), atol=1e-3)
    assert np.abs(moved.point_data["RGB"].astype(int).mean(0) - colours.astype(int).mean(0)).max() < 2
    assert not np.array_equal(moved.point_data["RGB"], texture.sample(moved.points))  # not world-frame colours
    organ.deform(None)
    np.testing.assert_allclose(organ.grid.points, organ.grid.point_data["rest"])


def test_viewer_recuts_in_place_when_the_plane_widget_moves(grid, texture):
    organ = TexturedOrgan(grid, texture, subdivisions=1)
    viewer = CutViewer(organ, normal=(1, 0, 0), window_size=(300, 200))
    outside, face = viewer.outside, viewer.face
    before = face.n_points
    viewer.widget.SetOrigin(*(np.array(grid.center) + (25.0, 0.0, 0.0)))
    viewer.widget.InvokeEvent("InteractionEvent")  # what a drag does, as the widget sees it
    assert viewer.outside is outside and viewer.face is face
    actors = viewer.plotter.actors
    assert actors["organ-outside"].mapper.dataset is outside and actors["organ-cut"].mapper.dataset is face
    assert viewer.origin[0] == pytest.approx(grid.center[0] + 25.0)
    assert face.n_points != before and np.allclose(face.points[:, 0], viewer.origin[0], atol=1e-3)
    viewer.look_at_cut()
    image = viewer.plotter.screenshot(return_img=True)
    assert image.std() > 10  # a textured organ, not an empty frame
    viewer.plotter.close()


def _widget_outline(widget):
    import vtk

    poly = vtk.vtkPolyData()
    widget.GetPolyData(poly)  # the plane clipped to the widget's box
    return poly


def test_viewer_widget_follows_the_plane_and_the_camera_frames_the_organ(grid, texture):
    organ = TexturedOrgan(grid.copy(), texture, subdivisions=1)  # deformed below: not the shared fixture
    viewer = CutViewer(organ, normal=(0, 1, 0), window_size=(300, 200))
    # the widget box is faint and grey, its plane trace not coloured by scalars (VTK's default red)
    assert viewer.widget.GetOutlineProperty().GetOpacity() < 0.5
    assert not viewer.widget.GetScaleEnabled() and not viewer.widget.GetOutlineTranslation()
    # the camera is fitted to the organ, not the widget's box: the cut organ spans the picture
    image = viewer.plotter.screenshot(return_img=True)
    organ_pixels = np.argwhere(np.abs(image.astype(int) - 255).sum(axis=2) > 120)
    assert np.ptp(organ_pixels[:, 1]) > 0.85 * image.shape[1]
    # a plane set in code moves the widget too, and the widget follows a deformed organ's bounds
    target = np.array(grid.center) + (0.0, 10.0, 0.0)
    viewer.update(origin=target, normal=(0.0, 0.6, 0.8))
    np.testing.assert_allclose(viewer.widget.GetOrigin(), target, atol=1e-6)
    np.testing.assert_allclose(viewer.widget.GetNormal(), [0, 0.6, 0.8], atol=1e-6)
    lattice = Lattice.around(grid.points, shape=(4, 4, 4))
    lattice.offsets[...] = (30.0, 0.0, 0.0)
    organ.deform(FFD(lattice).deform)
    viewer.update()
    outline = pv.wrap(_widget_outline(viewer.widget))
    # the plane has no x tilt: its patch spans the widget's box along x, now around the moved organ
    assert outline.center[0] == pytest.approx(organ.grid.center[0], abs=0.5)
    assert outline.center[0] == pytest.approx(grid.center[0] + 30.0, abs=0.5)
    np.testing.assert_allclose(viewer.widget.GetOrigin(), target, atol=1e-6)  # the plane stays put
    # a plane beyond the organ leaves nothing to cut: empty meshes, no error, a picture still renders
    viewer.update(origin=np.array(grid.center) + (0.0, -500.0, 0.0))
    assert viewer.outside.n_cells == 0 and viewer.face.n_cells == 0
    viewer.look_at_cut()
    viewer.plotter.screenshot(return_img=True)
    viewer.plotter.close()


def test_add_cut_draws_a_snapshot_that_later_deformations_do_not_change(grid, texture):
    organ = TexturedOrgan(grid.copy(), texture, subdivisions=1)
    pl = pv.Plotter(off_screen=True, shape=(1, 2), window_size=(400, 200))
    pl.subplot(0, 0)
    whole, empty = add_cut(pl, organ)
    pl.subplot(0, 1)
    outside, face = add_cut(pl, organ, normal=(1, 0, 0))
    assert np.all(outside.points[:, 0] <= grid.center[0] + 1e-3)
    assert empty.n_cells == 0 and whole.n_cells == organ.surface.n_cells
    assert face.n_cells > 0 and {"organ-outside", "organ-cut", "organ-rim"} <= set(pl.renderer.actors)
    rim = pl.renderer.actors["organ-rim"].mapper.dataset
    # the face's edge, lifted a thousandth of the face's size towards the side cut away (where the
    # camera looks from), so that the face does not hide parts of it
    lift = 1e-3 * float(np.ptp(face.points, axis=0).max())
    assert rim.n_lines > 0 and np.allclose(rim.points[:, 0], grid.center[0] + lift, atol=1e-3)
    before = whole.points.copy()
    lattice = Lattice.around(grid.points, shape=(4, 4, 4))
    lattice.offsets[...] = (0.0, 0.0, 12.0)
    organ.deform(FFD(lattice).deform)
    np.testing.assert_array_equal(whole.points, before)
    pl.close()


def test_a_lazy_texture_is_cut_viewed_and_deformed_like_a_whole_one(grid):
    exemplar = volume_from_slices(sliding_crops(skimage.data.immunohistochemistry(), 32, 32, start=(90, 90)))
    lazy = LazySolidTexture.fit(exemplar, grid.bounds, resolution=128)
    organ = TexturedOrgan(grid.copy(), lazy, subdivisions=1)
    after_surface = lazy.tiles_synthesised
    # the surface needs a shell of voxels, far fewer than the box holds
    assert 0 < lazy.voxels_synthesised < 0.5 * np.prod(lazy.shape)
    np.testing.assert_array_equal(organ.surface.point_data["RGB"], lazy.sample(organ.surface.point_data["rest"]))
    viewer = CutViewer(organ, normal=(1, 0, 0), window_size=(300, 200))
    after_cut = lazy.tiles_synthesised
    assert after_cut > after_surface  # the cut face reaches inside: its tiles are made now
    face = viewer.face
    np.testing.assert_array_equal(face.point_data["RGB"], lazy.sample(face.point_data["rest"]))
    # deforming and recutting the same tissue makes nothing new: the colours follow the rest frame
    lattice = Lattice.around(grid.points, shape=(4, 4, 4))
    lattice.offsets[...] = (5.0, 0.0, 0.0)
    organ.deform(FFD(lattice).deform)
    viewer.update(origin=np.array(grid.center) + (5.0, 0.0, 0.0))
    assert lazy.tiles_synthesised == after_cut
    np.testing.assert_allclose(viewer.face.point_data["rest"][:, 0], grid.center[0], atol=1e-3)
    assert viewer.plotter.screenshot(return_img=True).std() > 10
    viewer.plotter.close()


def test_the_rim_of_a_cut_through_slivers_is_the_outline():
    # Delaunay tetrahedra of a coarse sphere are slivers, and a plane through its points cuts them into
    # degenerate triangles: VTK's adaptive subdivision tore such a face (a "rim" of 732 units on a
    # sphere of circumference 63); the rim is where the plane meets the organ's surface
    grid = tetrahedralize(pv.Sphere(radius=10, theta_resolution=16, phi_resolution=12), method="delaunay")
    texture = SolidTexture.fit(np.random.default_rng(0).integers(0, 255, (8, 8, 8, 3), dtype=np.uint8), grid.bounds)
    organ = TexturedOrgan(grid, texture, subdivisions=0)
    for origin, normal in (((0.0, 0.0, 0.0), (1.0, 0.0, 0.0)), ((0.3, 0.2, 0.1), (1.0, 0.2, 0.1))):
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            rim = _rim(organ.cut_face(origin, normal))
        outline = organ_surface(grid).slice(normal=normal, origin=origin)
        size = {"length": True, "area": False, "volume": False}
        assert rim.compute_cell_sizes(**size)["Length"].sum() == pytest.approx(
            outline.compute_cell_sizes(**size)["Length"].sum(), rel=1e-6
        )
