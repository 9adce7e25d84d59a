"""The model layer must not import VTK, PyVista, trame or ipywidgets (DESIGN.md).

Two checks: importing every model module loads none of them, and no model source file has an
import statement for them anywhere (a function-level import would escape the first check).
"""

import ast
import subprocess
import sys
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "ffd_notebook"
MODEL_FILES = sorted(
    [PACKAGE / "__init__.py", PACKAGE / "errors.py"]
    + list((PACKAGE / "ffd").glob("*.py"))
    + list((PACKAGE / "_util").glob("*.py"))
    + list((PACKAGE / "gp").glob("*.py"))
    + list((PACKAGE / "solidtex").glob("*.py"))
    + list((PACKAGE / "images").glob("*.py"))
    # batch: drawing and deforming (the engine, output and file loading write and read meshes through io)
    + [PACKAGE / "batch" / f"{name}.py" for name in ("models", "gp_model", "folding", "seeds", "evaluate")]
    # face: everything but the mesh builder (face_from_photo returns PolyData: it imports PyVista when called)
    + [PACKAGE / "face" / f"{name}.py" for name in ("crop", "detection", "landmarks", "models", "photo", "topology")]
)
FORBIDDEN = ("vtk", "vtkmodules", "pyvista", "trame", "ipywidgets")


def _module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODEL_MODULES = [_module_name(p) for p in MODEL_FILES]


def test_every_model_module_is_listed():
    assert {"ffd_notebook.ffd.deform", "ffd_notebook.gp.kernels", "ffd_notebook.gp.lowrank"} <= set(MODEL_MODULES)
    assert {"ffd_notebook.solidtex.synthesis", "ffd_notebook.solidtex.sampling"} <= set(MODEL_MODULES)
    assert {"ffd_notebook.face.detection", "ffd_notebook.face.landmarks"} <= set(MODEL_MODULES)


def test_model_imports_no_view_libraries():
    code = (
        "import sys, importlib\n"
        f"for m in {MODEL_MODULES!r}: importlib.import_module(m)\n"
        f"bad = sorted(m for m in sys.modules if m.split('.')[0] in {FORBIDDEN!r})\n"
        "print(','.join(bad))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
    assert out == "", f"model layer imported: {out}"


@pytest.mark.parametrize("path", MODEL_FILES, ids=MODEL_MODULES)
def test_model_source_has_no_view_imports(path):
    imported = []
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            imported += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            imported.append((node.lineno, node.module))
    bad = [f"line {line}: {name}" for line, name in imported if name.split(".")[0] in FORBIDDEN]
    assert not bad, f"{path.name} imports view libraries: {bad}"


def test_reading_a_ffd_file_loads_no_vtk():
    """``load_ffd`` reads a text file: ``ffd_notebook.io`` imports the mesh formats (PyVista) only on first use."""
    code = (
        "import sys, ffd_notebook, ffd_notebook.io\n"
        "from ffd_notebook import load_ffd, save_ffd\n"
        f"bad = sorted(m for m in sys.modules if m.split('.')[0] in {FORBIDDEN!r})\n"
        "print(','.join(bad))\n"
        "from ffd_notebook.io import read_obj\n"
        "print('pyvista' in sys.modules)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert out == ["True"], f"load_ffd imported: {out[0]}"


@pytest.mark.parametrize("path", sorted((PACKAGE / "meshing").glob("*.py")) + sorted((PACKAGE / "io").glob("*.py")),
                         ids=lambda p: f"{p.parent.name}/{p.stem}")  # fmt: skip
def test_meshing_and_io_import_no_ui_library(path):
    """Below the views: PyVista (VTK) may be used, trame and ipywidgets never."""
    modules = []
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            modules += [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            modules.append(node.module)
    assert not [m for m in modules if m.split(".")[0] in ("trame", "ipywidgets")], path.name


def test_the_face_package_loads_pyvista_only_to_build_the_mesh():
    """``import ffd_notebook.face`` and finding landmarks load no VTK; ``face_from_photo`` returns PolyData."""
    code = (
        "import sys\n"
        "from skimage import data\n"
        "import ffd_notebook.face as face\n"
        "face.face_landmarks(data.astronaut())\n"
        f"print(','.join(sorted(m for m in sys.modules if m.split('.')[0] in {FORBIDDEN!r})) or '-')\n"
        "face.face_from_photo(data.astronaut(), subdivisions=0)\n"
        "print('pyvista' in sys.modules)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert out == ["-", "True"], out


# names every command-line module or module with a logger defines for itself, by convention
PER_MODULE_NAMES = {"main", "build_parser", "log"}


def _top_level_names(path: Path) -> list[tuple[str, int]]:
    """The public names a module defines at its top level (functions, classes, assignments), with their lines."""
    found = []
    for node in ast.parse(path.read_text(), filename=str(path)).body:
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
            found.append((node.name, node.lineno))
        elif isinstance(node, ast.Assign):
            found += [(t.id, node.lineno) for t in node.targets if isinstance(t, ast.Name)]
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            found.append((node.target.id, node.lineno))
    return [(name, line) for name, line in found if not name.startswith("_") and name not in PER_MODULE_NAMES]


def test_one_name_per_meaning():
    """No public name is defined in two modules of the package: where two things differ their names say which,
    where they are the same thing it is defined once and imported (DESIGN.md: one definition per idea)."""
    where: dict[str, list[str]] = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        for name, line in _top_level_names(path):
            where.setdefault(name, []).append(f"{path.relative_to(PACKAGE.parent)}:{line}")
    twice = {name: places for name, places in where.items() if len(places) > 1}
    assert not twice, f"names defined in more than one module: {twice}"


def test_the_view_folder_shows_products_and_plumbing_apart():
    """``view/`` holds the products (editor, GP explorer, cut viewer) and two folders of shared plumbing
    (serving a plotter to a browser; rendering): no loose modules beside them."""
    view = PACKAGE / "view"
    loose = sorted(p.name for p in view.glob("*.py") if p.name != "__init__.py")
    folders = sorted(p.name for p in view.iterdir() if p.is_dir() and p.name != "__pycache__")
    assert loose == [], loose
    assert folders == ["editor", "gp", "rendering", "serving", "solidtex"], folders
