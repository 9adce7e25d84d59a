#!/usr/bin/env bash
# Set up a fresh Debian machine for the test suite and run every test (the README's test command).
# - Debian's chromium for the real-browser tests (Playwright drives it; never `playwright install`),
#   and the Mesa/EGL libraries VTK renders with off-screen;
# - the package with its test extra;
# - the reference tools' virtual environments (Blender, NiftyReg built from source, ANTs and fslpy; see
#   tests/reference_env.py), built in the background from the start so that they overlap the steps below; the
#   tests that use one wait for its build (a file lock), and a build that failed is retried there and reported;
# - pytest over tests/ and the package's doctests. Extra arguments go to pytest.
set -euo pipefail
cd "$(dirname "$0")/.."
export DEBIAN_FRONTEND=noninteractive PIP_DISABLE_PIP_VERSION_CHECK=1 PIP_ROOT_USER_ACTION=ignore
mkdir -p "${FFD_NOTEBOOK_CACHE:-$HOME/.cache/ffd_notebook}"
setsid python3 tests/reference_env.py build >"${FFD_NOTEBOOK_CACHE:-$HOME/.cache/ffd_notebook}/background-build.log" 2>&1 &
builds=$!
trap 'kill -- "-$builds" 2>/dev/null || true' EXIT  # its own process group: pip and the compiler with it
as_root() { if [ "$(id -u)" = 0 ]; then "$@"; else sudo "$@"; fi; }
if command -v apt-get >/dev/null; then
  as_root apt-get update -q
  as_root apt-get install -y -q --no-install-recommends chromium libegl1 libegl-mesa0 libgl1-mesa-dri libgbm1
  # Node's npm, for JupyterHub's proxy below (an image whose nodejs already ships npm keeps its own)
  command -v npm >/dev/null || as_root apt-get install -y -q --no-install-recommends nodejs npm
fi
# JupyterHub's configurable-http-proxy (npm), for the hub browser test (tests/browser/test_jupyterhub_browser.py)
command -v configurable-http-proxy >/dev/null || as_root npm install -g --no-fund --no-audit configurable-http-proxy@5
python3 -m pip install -q -e ".[test]"
status=0
python3 -m pytest "$@" || status=$?
wait "$builds" 2>/dev/null || true  # done long before when the tests used them; never left running
exit "$status"
