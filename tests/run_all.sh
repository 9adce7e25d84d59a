#!/usr/bin/env bash
# Set up a fresh Debian machine for the test suite and run every test (the README's test command).
# - Debian's chromium for the real-browser tests (Playwright drives it; never `playwright install`),
#   and the Mesa/EGL libraries VTK renders with off-screen;
# - the package with its test extra;
# - pytest over tests/ and the package's doctests. Extra arguments go to pytest.
set -euo pipefail
cd "$(dirname "$0")/.."
export DEBIAN_FRONTEND=noninteractive PIP_DISABLE_PIP_VERSION_CHECK=1 PIP_ROOT_USER_ACTION=ignore
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
python3 -m pytest "$@"
