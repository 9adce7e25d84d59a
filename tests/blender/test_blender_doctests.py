"""The examples of ffd_notebook.blender, run inside Blender's own Python (the ``bpy`` 4.5 environment).

Its Blender-side examples create lattice and mesh objects with ``bpy``, which this process cannot import:
pytest's doctest collection leaves them out here (tests/conftest.py) and this test runs every example of the
module, the NumPy-side ones too, with :mod:`doctest` in Blender.
"""

from __future__ import annotations

import numpy as np

SCRIPT = """
import doctest
import ffd_notebook.blender as module
result = doctest.testmod(module, optionflags=doctest.ELLIPSIS, verbose=False)
save(attempted=result.attempted, failed=result.failed)
if result.failed:
    raise SystemExit(1)  # doctest printed each failure: run_blender raises with that output
"""


def test_every_example_of_the_blender_module_runs_in_blender(blender):
    out = blender(SCRIPT)
    # 8 documented functions with examples; a module whose examples stopped being collected would count few
    assert int(out["attempted"]) >= 60, int(out["attempted"])
    assert int(np.asarray(out["failed"])) == 0
