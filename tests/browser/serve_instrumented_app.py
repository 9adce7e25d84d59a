"""``python -m ffd_notebook`` with the tests' instrumentation (tests/editor_instrument.py) installed by code.

Usage: ``python tests/browser/serve_instrumented_app.py TRACE_FILE [ffd_notebook arguments...]``. The product
has no setting that installs test hooks; this script passes ``setup=`` to :func:`ffd_notebook.__main__.main`.
With the environment variable ``FFD_FRAME_TRACE=PATH`` it also logs frame timings there (tests/frame_timing.py).
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # tests/: editor_instrument

from editor_instrument import Instrument

from ffd_notebook.__main__ import main


def instrument(trace: str):
    def setup(app) -> None:
        Instrument(app.editor, trace=trace).register_triggers(app.server)
        if os.environ.get("FFD_FRAME_TRACE"):
            from frame_timing import FrameTimer

            FrameTimer(app.editor, os.environ["FFD_FRAME_TRACE"]).register_triggers(app.server)

    return setup


if __name__ == "__main__":
    if os.environ.get("FFD_FRAME_TRACE"):  # patch the protocols and views before the app makes its view
        import frame_timing

        frame_timing.install(os.environ["FFD_FRAME_TRACE"])
    sys.exit(main(sys.argv[2:], setup=instrument(sys.argv[1])))
