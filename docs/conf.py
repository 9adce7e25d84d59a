"""Sphinx configuration of the ffd_notebook site.

Build (from the repository root)::

    python -m sphinx -W --keep-going -n -b html docs docs/_build/html

then open ``docs/_build/html/index.html``. The gallery renders its pictures off-screen through
PyVista's scraper (EGL on a headless machine); the tutorial notebooks are shown with the outputs
saved in them (``tests/test_notebooks.py`` executes them).
"""

from __future__ import annotations

import os
import shutil
import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
REPO = DOCS.parent
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(DOCS))

# off-screen rendering before VTK makes its first window: EGL needs no X server
os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
os.environ.setdefault("PYVISTA_OFF_SCREEN", "true")

import pyvista  # noqa: E402
from api_modules import PUBLIC  # noqa: E402

import ffd_notebook  # noqa: E402

pyvista.OFF_SCREEN = True
pyvista.BUILDING_GALLERY = True
pyvista.set_plot_theme("document")
pyvista.global_theme.window_size = [800, 500]
pyvista.global_theme.multi_samples = 0  # software rendering: anti-aliasing costs ~3.5x a frame

project = "ffd_notebook"
author = "the ffd_notebook developers"
copyright = "the ffd_notebook developers"
release = version = ffd_notebook.__version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.intersphinx",
    "sphinx.ext.mathjax",
    "numpydoc",
    "sphinx_gallery.gen_gallery",
    "myst_nb",
]

exclude_patterns = [
    "_build",
    "**.ipynb_checkpoints",
    "gallery/README.txt",
    "auto_examples/*.ipynb",
    "sg_execution_times.rst",
]
templates_path = ["_templates"]
source_suffix = {".rst": "restructuredtext", ".ipynb": "myst-nb"}
root_doc = "index"

# --- API reference: one page per public module (generated below), one page per name (autosummary)
autosummary_generate = True
autosummary_imported_members = True
autodoc_typehints = "none"  # numpydoc's Parameters section says the types
autodoc_default_options = {"members": False}
numpydoc_show_class_members = False  # the class template documents the members
numpydoc_show_inherited_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False
numpydoc_attributes_as_param_list = True
add_module_names = False

# references that are types written in prose, not objects of this package
nitpick_ignore_regex = [
    (r"py:.*", r"(numpy|np|pv|pyvista|vtk|scipy|distributed|dask|PIL|h5py)\..*"),
]

intersphinx_mapping = {}  # offline build: no inventories fetched

# --- the tutorial notebooks: shown with their saved outputs (executing them takes minutes and
# tests/test_notebooks.py already runs each one; the outputs in the repository are from such a run)
nb_execution_mode = "off"
myst_enable_extensions = ["dollarmath"]
suppress_warnings = ["mystnb.unknown_mime_type"]

# --- the gallery: short scripts, each renders a picture (or an animation: PyVista's scraper moves a plotter's GIF,
# which ffd_notebook.animate leaves registered on its plotter)
sphinx_gallery_conf = {
    "examples_dirs": ["gallery"],
    "gallery_dirs": ["auto_examples"],
    "filename_pattern": r"/plot_",
    "image_scrapers": (pyvista.Scraper(), "matplotlib"),
    "download_all_examples": False,
    "remove_config_comments": True,
    "within_subsection_order": "FileNameSortKey",
    "reset_modules": ("matplotlib",),
    "doc_module": ("ffd_notebook",),
    "backreferences_dir": None,
    "show_memory": False,
    "write_computation_times": False,
    "plot_gallery": "True",
}

html_theme = "pydata_sphinx_theme"
html_title = "ffd_notebook"
html_static_path: list[str] = []
html_theme_options = {
    "navigation_with_keys": False,
    "show_toc_level": 2,
    "header_links_before_dropdown": 7,
}
html_context = {"default_mode": "light"}


def _write_if_changed(path: Path, text: str) -> None:
    if not path.exists() or path.read_text(encoding="utf-8") != text:
        path.write_text(text, encoding="utf-8")


def _api_pages() -> None:
    """One reference page per public module: its docstring's summary and an autosummary of ``__all__``."""
    import importlib

    folder = DOCS / "api"
    shutil.rmtree(folder / "generated", ignore_errors=True)  # autosummary writes them again: none stale
    folder.mkdir(exist_ok=True)
    entries = []
    documented: dict[int, str] = {}  # id(object) -> where its page is (the first public module exporting it)
    for name, title in PUBLIC.items():
        module = importlib.import_module(name)
        names, elsewhere = [], []
        for public in module.__all__:
            value = getattr(module, public)
            if callable(value) and id(value) in documented:
                elsewhere.append(f"* :obj:`{public} <{documented[id(value)]}>`")
            else:
                names.append(public)
                if callable(value):
                    documented[id(value)] = f"{name}.{public}"
        lines = [
            f"{name}",
            "=" * len(name),
            "",
            f"*{title}.*",
            "",
            f".. automodule:: {name}",
            "   :no-members:",
            "   :no-index:",
            "",
            f".. currentmodule:: {name}",
            "",
            ".. autosummary::",
            "   :toctree: generated",
            "",
            *[f"   {n}" for n in names],
            "",
        ]
        if elsewhere:
            lines += ["Also exported here (documented where first exported):", "", *elsewhere, ""]
        _write_if_changed(folder / f"{name}.rst", "\n".join(lines))
        entries.append(f"   {name}")
    index = [
        "API reference",
        "=============",
        "",
        "Every public name, by the module to import it from. A module's ``__all__`` is its public face; the",
        "modules behind it are implementation (:doc:`how this list is kept <../contributing>`).",
        "",
        ".. toctree::",
        "   :maxdepth: 1",
        "",
        *entries,
        "",
    ]
    _write_if_changed(folder / "index.rst", "\n".join(index))


def _tutorials() -> None:
    """Copy the notebooks into the source tree (Sphinx reads sources only below ``docs/``)."""
    target = DOCS / "tutorials"
    target.mkdir(exist_ok=True)
    for notebook in sorted((REPO / "notebooks").glob("*.ipynb")):
        copy = target / notebook.name
        if not copy.exists() or copy.read_bytes() != notebook.read_bytes():
            shutil.copyfile(notebook, copy)


# --- cross-references to implementation modules. A public module's ``__all__`` has the pages; the
# modules behind it (``ffd_notebook/gp/kernels.py``) have none. A reference such as
# :func:`~ffd_notebook.io.ffd_file.load_ffd` in a docstring still has to name something that exists:
# it links to the page of the same object where that is public, and is shown as code (no link) when the
# object exists but is implementation only. A reference to nothing stays a warning (an error with -W).
_DOCUMENTED: dict[int, str] = {}


def _documented() -> dict[int, str]:
    import importlib
    import inspect

    if not _DOCUMENTED:
        for name in PUBLIC:
            module = importlib.import_module(name)
            for public in module.__all__:
                value = getattr(module, public)
                if not isinstance(value, (str, int, float, bool, type(None))):  # not interned values
                    _DOCUMENTED.setdefault(id(value), f"{name}.{public}")
                if inspect.isclass(value):
                    for attr in vars(value):
                        if not attr.startswith("_"):
                            _DOCUMENTED.setdefault(id(vars(value)[attr]), f"{name}.{public}.{attr}")
    return _DOCUMENTED


def _import_target(dotted: str):
    import importlib

    parts = dotted.split(".")
    for cut in range(len(parts), 0, -1):
        try:
            value = importlib.import_module(".".join(parts[:cut]))
        except ImportError:
            continue
        try:
            for attr in parts[cut:]:
                value = value.__dict__[attr] if attr in getattr(value, "__dict__", {}) else getattr(value, attr)
        except AttributeError:
            return None
        return value
    return None


def _candidates(target: str, module: str | None, klass: str | None) -> list[str]:
    if target.startswith("."):
        stripped = target.lstrip(".")
        if not module:
            return [stripped]
        parts = module.split(".")
        return [".".join([*parts[:cut], stripped]) for cut in range(len(parts), 0, -1)]
    names = [target]
    if module:
        parts = module.split(".")
        if klass:
            names.insert(0, f"{module}.{klass}.{target}")
        names += [".".join([*parts[:cut], target]) for cut in range(len(parts), 0, -1)]
    return names


def _all_candidates(node) -> list[str]:
    target = node["reftarget"]
    names = _candidates(target, node.get("py:module"), node.get("py:class"))
    source = str(node.source or "")
    if "docstring of " in source:  # relative to the module that defines the documented object
        defined = source.split("docstring of ", 1)[1].split(":")[0]
        parts = defined.split(".")
        names += _candidates(target, ".".join(parts[:-1]), None) + _candidates(target, defined, None)
    # a summary line copied into a table has lost its module: any module of the package that has it
    names += [f"{module}.{target.lstrip('.')}" for module in sorted(sys.modules) if module.startswith("ffd_notebook")]
    return names


def _resolve_implementation(app, env, node, contnode):
    from docutils import nodes

    if node.get("refdomain") != "py":
        return None
    for dotted in _all_candidates(node):
        value = _import_target(dotted)
        if value is None:
            continue
        public = _documented().get(id(value))
        domain = env.get_domain("py")
        if public is not None and public != dotted:
            for role in ("obj", "mod"):
                found = domain.resolve_xref(env, node["refdoc"], app.builder, role, public, node, contnode)
                if found is not None:
                    return found
        return nodes.literal(contnode.astext(), contnode.astext())  # exists, has no page
    return None


def setup(app):
    app.connect("missing-reference", _resolve_implementation)


_api_pages()
_tutorials()
