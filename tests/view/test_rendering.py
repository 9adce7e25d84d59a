"""No import side effects: importing every module of the package changes no environment variable and no
``pyvista.global_theme`` setting; the headless settings go to the plotters the package makes, on headless Linux."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from ffd_notebook.view.rendering.plotters import WINDOW_VARIABLE, headless_settings_apply, is_headless, new_plotter

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = ROOT / "ffd_notebook"


def _fresh_python(code: str, env: dict[str, str] | None = None) -> str:
    env = {**os.environ, **(env or {})}
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, env=env).stdout


def test_importing_every_module_changes_no_environment_variable_and_no_theme_setting():
    modules = sorted(
        ".".join(p.relative_to(ROOT).with_suffix("").parts[:-1] if p.name == "__init__.py" else
                 p.relative_to(ROOT).with_suffix("").parts)
        for p in PACKAGE.rglob("*.py") if p.name != "__main__.py"
    )  # fmt: skip
    code = (
        # threadpoolctl (the BLAS thread limits) sets KMP_DUPLICATE_LIB_OK on its own import: not ours
        "import importlib, json, os, pyvista as pv, threadpoolctl\n"
        "env, theme = dict(os.environ), pv.global_theme.to_dict()\n"
        f"for name in {modules!r}: importlib.import_module(name)\n"
        "changed_env = sorted(k for k in set(env) | set(os.environ) if env.get(k) != os.environ.get(k))\n"
        "now = pv.global_theme.to_dict()\n"
        "changed_theme = sorted(k for k in set(theme) | set(now) if theme.get(k) != now.get(k))\n"
        "print(json.dumps([changed_env, changed_theme]))\n"
    )
    # as on a headless Linux machine (no DISPLAY): where the settings used to be applied on import
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY", WINDOW_VARIABLE)}
    env.pop("FFD_NOTEBOOK_NO_HEADLESS", None)
    out = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        check=True,
        env={**env, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])},
    ).stdout
    changed_env, changed_theme = json.loads(out.strip().splitlines()[-1])
    assert len(modules) > 60 and "ffd_notebook.view.gp.explorer" in modules
    assert changed_env == [] and changed_theme == []


@pytest.mark.skipif(not is_headless(), reason="the headless settings apply on headless Linux only")
def test_plotters_the_package_makes_get_the_headless_settings():
    """The editor's, the GP explorer's and the cut viewer's plotters: EGL window, no multi-sampling; the
    environment and the global theme stay as they were."""
    import numpy as np
    import pyvista as pv

    from ffd_notebook.view import Editor, GPExplorer

    env, samples = dict(os.environ), pv.global_theme.multi_samples
    editor = Editor(pv.Sphere(), shape=(4, 4, 4), window_size=(64, 48))
    explorer = GPExplorer(pv.Sphere(theta_resolution=8, phi_resolution=8), widgets=False, off_screen=True)
    try:
        for plotter in (editor.plotter, explorer.plotter):
            assert plotter.render_window.GetClassName() == "vtkEGLRenderWindow"
            assert plotter.render_window.GetMultiSamples() == 0
        assert editor.screenshot().shape == (48, 64, 3) and np.asarray(editor.screenshot()).any()
        assert dict(os.environ) == env and pv.global_theme.multi_samples == samples
        user = pv.Plotter(off_screen=True)  # a user's own plotter keeps PyVista's settings
        assert user.render_window.GetMultiSamples() == samples
        user.close()
    finally:
        editor.close()
        explorer.plotter.close()


def test_the_settings_can_be_turned_off_and_a_users_window_choice_is_kept():
    assert headless_settings_apply(force=False) is False and headless_settings_apply(force=True) is True
    code = (
        "import os\nfrom ffd_notebook.view.rendering.plotters import headless_settings_apply\n"
        "print(headless_settings_apply())\n"
    )
    assert _fresh_python(code, {"FFD_NOTEBOOK_NO_HEADLESS": "1"}).strip() == "False"
    import pyvista as pv

    plain, reference = new_plotter(off_screen=True, headless=False), pv.Plotter(off_screen=True)
    assert plain.render_window.GetMultiSamples() == reference.render_window.GetMultiSamples()  # untouched
    plain.close(), reference.close()
    os.environ[WINDOW_VARIABLE] = "vtkEGLRenderWindow"
    try:
        plotter = new_plotter(off_screen=True, window_size=(32, 24), headless=True)
        assert os.environ[WINDOW_VARIABLE] == "vtkEGLRenderWindow"  # the user's value stays
        plotter.close()
    finally:
        del os.environ[WINDOW_VARIABLE]
