"""Property-based tests of the NIfTI header reading (what a header says a file holds): any header, any byte
changed in one, gives a deformation or a clear refusal (FileFormatError or ValueError naming the file), never
another exception, a crash or a hang; and what is read is what the header says."""

from __future__ import annotations

import nibabel as nib
import numpy as np
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from ffd_notebook import FFD, Lattice
from ffd_notebook.errors import FileFormatError
from ffd_notebook.io import DisplacementField, load_deformation, save_niftyreg
from ffd_notebook.io.nifti_files import nifti_meaning

GRID = {"size": (6, 6, 6), "spacing": 2.0}
INTENTS = st.sampled_from([0, 1006, 1007, 2006, 2007, 2008, 2009, 2016, 2017, 2018, 5, 1011])
NAMES = st.sampled_from(["", "NREG_TRANS", "Mapping", "ITK", "nreg_trans"]) | st.text(
    st.characters(min_codepoint=32, max_codepoint=126), max_size=15
)
SHAPES = st.sampled_from([(5, 5, 5, 1, 3), (5, 5, 5, 3), (5, 5, 1, 1, 2), (4, 4, 4), (5, 5, 5, 1, 2), (6, 5, 4, 1, 3)])


def _accepted(path):
    try:
        return load_deformation(path, reference=GRID, source=GRID)
    except (FileFormatError, ValueError) as exc:
        assert str(path) in str(exc) or "reference" in str(exc) or "source" in str(exc), str(exc)
        return None


@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(intent=INTENTS, name=NAMES, p1=st.sampled_from([0.0, 1.0, 2.0, 3.0, 5.0, 6.0, 7.0, -1.0, 2.5, np.nan]),
       shape=SHAPES, dtype=st.sampled_from([np.float32, np.float64, np.int16]),
       sform=st.sampled_from([0, 1, 2]), qform=st.sampled_from([0, 1]),
       descrip=st.sampled_from(["", "Deformation", "a field"]), seed=st.integers(0, 2**16))  # fmt: skip
def test_any_header_gives_a_deformation_or_a_clear_refusal(tmp_path_factory, intent, name, p1, shape, dtype, sform,
                                                            qform, descrip, seed):  # fmt: skip
    values = np.random.default_rng(seed).normal(0.0, 1.0, shape).astype(dtype)
    affine = np.diag([2.0, 2.0, 2.0, 1.0])
    image = nib.Nifti1Image(values, affine)
    header = image.header
    header["intent_code"] = intent
    header["intent_name"] = name.encode("ascii")[:15]
    header["intent_p1"] = p1
    header["descrip"] = descrip.encode()
    image.set_sform(affine, sform)
    image.set_qform(affine, qform)
    path = tmp_path_factory.mktemp("hdr") / "t.nii.gz"
    nib.save(image, path)
    kind, what = nifti_meaning(nib.load(path).header)
    result = _accepted(path)
    if result is None:
        return
    # what is read is what the header says
    if kind == "niftyreg":
        assert what in (0, 1, 2, 5) and (isinstance(result, FFD) == (what == 2))  # 5: exponentiated on GRID
    elif kind == "fsl":
        assert what in (2006, 2007, 2016)
    else:
        assert kind == "itk" and isinstance(result, DisplacementField) and result.outside == "zero"
    assert np.all(np.isfinite(result.deform(np.zeros((1, 3)))))


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(at=st.integers(0, 347), value=st.integers(0, 255))
def test_any_byte_of_a_grid_header_changed_gives_a_deformation_or_a_clear_refusal(tmp_path_factory, at, value):
    folder = tmp_path_factory.mktemp("byte")
    lattice = Lattice((5, 5, 5), 4.0, origin=(-8.0, -8.0, -8.0), border="clamp")
    lattice.offsets[2, 2, 2] = (1.0, 0.0, 0.0)
    save_niftyreg(folder / "cpp.nii", FFD(lattice))
    data = bytearray((folder / "cpp.nii").read_bytes())
    assume(data[at] != value)
    data[at] = value
    (folder / "cpp.nii").write_bytes(bytes(data))
    result = _accepted(folder / "cpp.nii")
    if result is not None:
        assert np.all(np.isfinite(result.deform(np.zeros((1, 3)))))
