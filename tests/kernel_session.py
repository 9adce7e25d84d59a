"""A real IPython kernel driven as JupyterLab drives it, for tests of what a notebook session leaves behind.

:class:`Kernel` starts ``python3`` (ipykernel) with jupyter_client, with this checkout first on its
``PYTHONPATH`` and the tests folder importable, and runs cells the way JupyterLab sends them: an
``execute_request`` whose metadata carries the cell's id (``cellId``), so re-running "the same cell" is
sending the same id again. Outputs come back as the streams, display data and errors of that request.
"""

from __future__ import annotations

import json
import os
import uuid
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[1]
TESTS = Path(__file__).resolve().parent


class CellError(AssertionError):
    """A cell raised: its error name, value and the end of the traceback."""


class Kernel:
    """A python3 kernel; use as a context manager (shut down on exit, even after a failure).

    Parameters
    ----------
    env : dict, optional
        Extra environment variables of the kernel (e.g. ``PYVISTA_JUPYTER_BACKEND``).
    cwd : path, optional
        The kernel's working directory.
    """

    #: Jupyter's grace period: it sends SIGTERM after half of it, SIGKILL at its end (its default is 5 s)
    shutdown_wait_s = 5.0

    def __init__(self, env: dict[str, str] | None = None, cwd: str | os.PathLike[str] | None = None) -> None:
        self.env = {**os.environ, **(env or {})}
        path = [str(REPO), str(TESTS), *filter(None, [os.environ.get("PYTHONPATH")])]
        self.env["PYTHONPATH"] = os.pathsep.join(path)
        if "PYVISTA_JUPYTER_BACKEND" not in (env or {}):  # the default backend (trame), as a user has it
            self.env.pop("PYVISTA_JUPYTER_BACKEND", None)
        self.cwd = None if cwd is None else str(cwd)
        self.manager: Any = None
        self.client: Any = None

    def __enter__(self) -> Kernel:
        from jupyter_client.manager import KernelManager

        self.manager = KernelManager(kernel_name="python3", shutdown_wait_time=self.shutdown_wait_s)
        self.manager.start_kernel(env=self.env, cwd=self.cwd)
        self.client = self.manager.client()
        self.client.start_channels()
        self.client.wait_for_ready(timeout=120)
        return self

    def __exit__(self, *exc: Any) -> None:
        self.shutdown()

    @property
    def pid(self) -> int:
        """The kernel process's id."""
        return self.manager.provisioner.process.pid

    def shutdown(self, *, restart: bool = False) -> None:
        """Shut the kernel down as Jupyter does (a shutdown request, then a kill after a grace period)."""
        if self.manager is None:
            return
        if restart:
            self.manager.restart_kernel(now=False)
            self.client.wait_for_ready(timeout=120)
            return
        self.client.stop_channels()
        self.manager.shutdown_kernel(now=False)
        self.manager = self.client = None

    def run(self, code: str, *, cell_id: str | None = None, timeout: float = 300.0) -> dict[str, Any]:
        """Run ``code`` as notebook cell ``cell_id`` (a new id if omitted) and return its outputs:
        ``{"stdout": str, "stderr": str, "displays": [data dicts], "result": data dict or None}``.
        A cell that raises raises :class:`CellError`."""
        session = self.client.session
        content = {
            "code": code,
            "silent": False,
            "store_history": True,
            "user_expressions": {},
            "allow_stdin": False,
            "stop_on_error": True,
        }
        msg = session.msg("execute_request", content, metadata={"cellId": cell_id or uuid.uuid4().hex})
        self.client.shell_channel.send(msg)
        msg_id = msg["header"]["msg_id"]
        out: dict[str, Any] = {"stdout": "", "stderr": "", "displays": [], "result": None}
        error = None
        while True:
            reply = self.client.get_iopub_msg(timeout=timeout)
            if reply["parent_header"].get("msg_id") != msg_id:
                continue
            kind, body = reply["msg_type"], reply["content"]
            if kind == "stream":
                out[body["name"]] += body["text"]
            elif kind == "display_data":
                out["displays"].append(body["data"])
            elif kind == "execute_result":
                out["result"] = body["data"]
            elif kind == "error":
                error = f"{body['ename']}: {body['evalue']}\n" + "\n".join(body["traceback"][-4:])
            elif kind == "status" and body["execution_state"] == "idle":
                break
        if error is not None:
            raise CellError(f"cell failed:\n{code}\n{error}\nstderr: {out['stderr'][-2000:]}")
        return out

    def json(self, code: str, **kwargs: Any) -> Any:
        """Run ``code``, whose last printed line is JSON, and return that value."""
        out = self.run(code, **kwargs)["stdout"].strip().splitlines()
        if not out:
            raise CellError(f"the cell printed nothing:\n{code}")
        return json.loads(out[-1])
