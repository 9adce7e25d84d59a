"""The model layer must not import VTK, PyVista, trame or ipywidgets (DESIGN.md)."""

import subprocess
import sys

MODEL_MODULES = ["ffd_notebook", "ffd_notebook.lattice", "ffd_notebook.basis", "ffd_notebook.deform"]
FORBIDDEN = ("vtk", "vtkmodules", "pyvista", "trame", "ipywidgets")


def test_model_imports_no_view_libraries():
    code = (
        "import sys, importlib\n"
        f"for m in {MODEL_MODULES!r}: importlib.import_module(m)\n"
        "for m in ('ffd_notebook.gp', 'ffd_notebook.solidtex'):\n"
        "    try: importlib.import_module(m)\n"
        "    except ImportError: pass\n"
        f"bad = sorted(m for m in sys.modules if m.split('.')[0] in {FORBIDDEN!r})\n"
        "print(','.join(bad))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
    assert out == "", f"model layer imported: {out}"
