"""Registrations by the real tools, once per test session (see ``tests/registration_reference.py``)."""

from __future__ import annotations

import pytest
import registration_reference as rr


@pytest.fixture(scope="session")
def niftyreg_run(tmp_path_factory):
    """reg_aladin + reg_f3d -aff on the MRI pair, and what reg_resample and reg_transform make of the grid."""
    return rr.run_niftyreg(tmp_path_factory.mktemp("niftyreg"))


@pytest.fixture(scope="session")
def ants_run(tmp_path_factory):
    """ANTs SyN on the MRI pair (separate files and a composite .h5), applied by ants.apply_transforms."""
    return rr.run_ants(tmp_path_factory.mktemp("ants"), tmp_path_factory.mktemp("ants_script"))
