"""Run VTK's reader on an untrusted file in a child process: ``python _vtk_child.py IN OUT SUFFIX``.

VTK's legacy reader walks the cell counts of a file without bounds (``POLYGONS 1 4`` followed by
``100000000 0 1 2`` kills the process with SIGSEGV), and VTK's other readers were never meant for
hostile input either. So the parent never lets VTK parse such a file: this child reads it and
writes what VTK understood as a VTK XML file of its own making (raw appended arrays: no parsing
ambiguity), which the parent reads and checks (:func:`~ffd_notebook.io.mesh_checks.check_cells`).
If the child crashes, only the child dies and the parent reports a :class:`FileFormatError`.

Only ``vtkmodules`` is imported here (no PyVista, no package import): the child starts in a
fraction of a second. Exit status: 0 written, 2 VTK reported an error (message on stderr).
"""

from __future__ import annotations

import sys

_READERS = {  # extension -> (module, class)
    ".stl": ("vtkmodules.vtkIOGeometry", "vtkSTLReader"),
    ".vtk": ("vtkmodules.vtkIOLegacy", "vtkDataSetReader"),
    ".vtp": ("vtkmodules.vtkIOXML", "vtkXMLPolyDataReader"),
    ".vtu": ("vtkmodules.vtkIOXML", "vtkXMLUnstructuredGridReader"),
}


def rewrite_as_vtk_xml(source: str, target: str, suffix: str) -> str | None:
    """Read ``source`` with VTK and write it to ``target`` + .vtp or .vtu; an error message or None."""
    import importlib

    from vtkmodules.vtkCommonCore import vtkCommand, vtkOutputWindow
    from vtkmodules.vtkIOXML import vtkXMLPolyDataWriter, vtkXMLUnstructuredGridWriter

    vtkOutputWindow.GetInstance().SetDisplayModeToNever()
    module, name = _READERS[suffix]
    reader = getattr(importlib.import_module(module), name)()
    errors: list[str] = []
    reader.AddObserver(vtkCommand.ErrorEvent, lambda obj, event: errors.append(f"{name} reported an error"))
    reader.SetFileName(source)
    if suffix == ".vtk":
        for flag in ("Scalars", "Vectors", "Normals", "Tensors", "ColorScalars", "TCoords", "Fields"):
            getattr(reader, f"ReadAll{flag}On")()
    reader.Update()
    output = reader.GetOutputDataObject(0)
    if errors or output is None or reader.GetErrorCode():
        return errors[0] if errors else f"{name} could not read it"
    kind = output.GetClassName()
    if kind == "vtkPolyData":
        writer, target = vtkXMLPolyDataWriter(), target + ".vtp"
    elif kind == "vtkUnstructuredGrid":
        writer, target = vtkXMLUnstructuredGridWriter(), target + ".vtu"
    else:
        return f"expected a surface or unstructured mesh, got a {kind}"
    writer.SetInputData(output)
    writer.SetFileName(target)
    writer.SetDataModeToAppended()
    writer.EncodeAppendedDataOff()
    writer.SetCompressorTypeToNone()
    if not writer.Write():
        return "could not write the converted mesh"
    return None


if __name__ == "__main__":
    source, target, suffix = sys.argv[1:4]
    problem = rewrite_as_vtk_xml(source, target, suffix)
    if problem is not None:
        sys.stderr.write(problem)
        sys.exit(2)
