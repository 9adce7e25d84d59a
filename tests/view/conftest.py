"""Fixtures for the editor tests: small coloured meshes and editors that are closed afterwards."""

from __future__ import annotations

import pytest
from editor_testing import colored_sphere


@pytest.fixture
def sphere():
    return colored_sphere()


@pytest.fixture
def editor(sphere):
    from ffd_notebook.view.editor import Editor

    ed = Editor(sphere, shape=(5, 5, 5), window_size=(240, 180))
    yield ed
    ed.close()
