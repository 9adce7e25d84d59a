"""The public modules of ffd_notebook: the ones the API reference documents, one page each.

A module is public when a user imports from it. Its ``__all__`` is its public face; the modules
behind it (``ffd_notebook/gp/kernels.py``...) are its implementation and are documented through the
names the public module re-exports, as scikit-image does with its ``_private`` modules.

Every package of ``ffd_notebook`` is either in :data:`PUBLIC` or in :data:`INTERNAL`
(``tests/test_docs.py`` checks it), so a new package gets an API page by adding one line here.
"""

from __future__ import annotations

#: public module -> its title in the API reference
PUBLIC: dict[str, str] = {
    "ffd_notebook": "The top level: lattices, FFD and files",
    "ffd_notebook.ffd": "The FFD engine",
    "ffd_notebook.io": "Files: lattices, transforms, registration tools, meshes",
    "ffd_notebook.gp": "Gaussian-process deformation models",
    "ffd_notebook.batch": "Batch deformation on Dask",
    "ffd_notebook.solidtex": "Solid textures",
    "ffd_notebook.meshing": "Mesh processing",
    "ffd_notebook.face": "A face from a photo",
    "ffd_notebook.images": "Warping images",
    "ffd_notebook.blender": "Blender exchange",
    "ffd_notebook.datasets": "Sample meshes",
    "ffd_notebook.errors": "Errors",
    "ffd_notebook.view": "Views: the editor and the viewers",
    "ffd_notebook.view.editor": "The editor",
    "ffd_notebook.view.gp": "The GP explorer",
    "ffd_notebook.view.solidtex": "The organ cut viewer",
}

#: packages that are implementation only (underscore or documented through a public one) -> why
INTERNAL: dict[str, str] = {
    "ffd_notebook._util": "private helpers (lazy imports, BLAS threads, deprecations)",
    "ffd_notebook.view.editor.session": "the editor's layers: documented through ffd_notebook.view.editor",
    "ffd_notebook.view.editor.scene": "the editor's layers: documented through ffd_notebook.view.editor",
    "ffd_notebook.view.editor.notebook": "the editor's layers: documented through ffd_notebook.view.editor",
    "ffd_notebook.view.editor.app": "the editor's layers: documented through ffd_notebook.view.editor",
    "ffd_notebook.view.serving": "plumbing every view shares (Jupyter, the remote view, web security, the file root)",
    "ffd_notebook.view.rendering": "plumbing every view shares: documented through ffd_notebook.view (new_plotter...)",
}
