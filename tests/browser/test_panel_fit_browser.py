"""The standalone app's panel fits (issue 32 item 2): every label, value and button readable in full.

At 1280x800, 1440x900 and 1920x1080, the DOM is measured (``PANEL_FIT_JS`` in helpers.py): no visible text wider
than an element that holds it or past the panel's edge, no input value wider than its field, no two texts over
each other. Measured as the page opens (some sections folded), then with every section open and the widest texts
the controls can show: the longest choice of every select, displacements of twelve characters, messages. A new
control in ``CONTROLS`` is measured too; one that does not fit fails here.

Screenshots of each size (as it opens, and all open) go to test-artifacts/ (``FFD_PANEL_SCREENS`` names another
folder). Run: ``python -m pytest tests/browser/test_panel_fit_browser.py -m browser -s``.
"""

from __future__ import annotations

import json
import os
import time
from pathlib import Path

import pytest
from browser.helpers import (
    ARTIFACTS,
    app_server,
    cut_texts,
    free_port,
    launch_browser,
    open_app_page,
    open_panel_section,
    wait_for,
)
from playwright.sync_api import sync_playwright

from ffd_notebook.view.editor.app.layout import OPEN_SECTIONS
from ffd_notebook.view.editor.session.controls import CONTROLS

pytestmark = [pytest.mark.browser, pytest.mark.slow]

SIZES = ((1280, 800), (1440, 900), (1920, 1080))
PANEL, APP_BAR = "nav.ffd-panel", "header.v-app-bar"
#: the widest text each select can show, and values as wide as the number fields show
#: (the basis stays: a Bernstein lattice has no interpolation to show)
WIDEST = {
    **{control.state[0]: max(control.choices, key=lambda choice: len(choice[1]))[0]
       for control in CONTROLS if control.kind == "choice" and control.key != "basis"},
    **{key: "catmull-rom" for key in ("interp_x", "interp_y", "interp_z")},
    "dx": "-0.000123457", "dy": "-1.23457e-05", "dz": "-123457",  # 6 significant digits, as session_state gives
    "nx": "40", "ny": "40", "nz": "40",
}  # fmt: skip
SECTIONS = tuple(dict.fromkeys(c.section for c in CONTROLS if c.section != "toolbar" and c.kind != "messages"))


@pytest.fixture(scope="module")
def app_url(tmp_path_factory):
    # a root folder whose name is longer than the panel is wide: the panel shows it, wrapped
    folder = tmp_path_factory.mktemp("panel_fit") / ("a_folder_of_registration_results_" * 3 + "2024")
    folder.mkdir()
    with app_server(["-m", "ffd_notebook", "--port", str(free_port())], folder, timeout=120) as url:
        yield url


def section_open(page, section: str) -> bool:
    """Whether the app panel's ``section`` is unfolded."""
    title = page.locator(f"#ffd-section-{section.lower().replace(' ', '-')} .v-expansion-panel-title")
    return title.get_attribute("aria-expanded") == "true"


def open_every_section(page) -> None:
    for section in SECTIONS:
        open_panel_section(page, section)


def show_widest_texts(page) -> None:
    """Put the widest text every input can show in it (the server's commands run for those that have one)."""
    missing = "the_registration_result_of_subject_0042_to_the_atlas_at_level_3.ffd"
    page.fill("#ffd-mesh-path", missing)  # a message naming a file longer than the panel is wide
    page.click("#ffd-load-mesh")
    wait_for(lambda: missing in page.locator("#ffd-messages").inner_text(), 30, "the message about the missing file")
    put = "(values) => { for (const [k, v] of Object.entries(values)) window.trame.state.set(k, v); }"

    def shown() -> bool:
        # the server answers some of these (a new interpolation or size refreshes the point's fields), and
        # under load its answer can land after them: put again what it overwrote until everything shows
        now = page.evaluate("(keys) => keys.map((k) => window.trame.state.get(k))", list(WIDEST))
        values = dict(zip(WIDEST, now, strict=True))
        changed = {k: v for k, v in WIDEST.items() if values[k] != v}
        if changed:
            page.evaluate(put, changed)
            return False
        return page.locator("#ffd-dx").input_value() == WIDEST["dx"]

    page.evaluate(put, WIDEST)

    wait_for(shown, 30, "the widest values in the panel")
    time.sleep(0.5)  # the selects' menus close and the fields re-render


def problems_of(page) -> list:
    return cut_texts(page, PANEL) + cut_texts(page, APP_BAR)


def measure_size(pw, url: str, width: int, height: int, profile: Path, screens: Path) -> dict[str, list]:
    """What does not fit at ``width`` x ``height``: as the page opens, and with every section open and the widest
    texts; screenshots of both."""
    found = {}
    context = launch_browser(pw, profile, width=width, height=height)
    try:
        page, _, errors = open_app_page(context, url)
        wait_for(lambda: all(section_open(page, s) == (s in OPEN_SECTIONS) for s in SECTIONS), 20,
                 "the sections folded as the page opens")  # fmt: skip
        page.screenshot(path=screens / f"panel_{width}x{height}.png")
        found[f"{width}x{height} as it opens"] = problems_of(page)
        open_every_section(page)
        show_widest_texts(page)
        found[f"{width}x{height} all open, widest texts"] = problems_of(page)
        content = page.locator(PANEL).locator(".v-navigation-drawer__content")
        assert content.evaluate("(e) => e.scrollWidth <= e.clientWidth"), "the panel scrolls sideways"
        page.set_viewport_size({"width": width, "height": 2600})  # the whole panel, open, in one picture
        time.sleep(0.5)
        page.screenshot(path=screens / f"panel_{width}x{height}_all_open.png")
        assert not errors, errors
    finally:
        context.close()
    return found


def test_every_label_value_and_button_fits_at_three_sizes(app_url, tmp_path):
    screens = Path(os.environ.get("FFD_PANEL_SCREENS", ARTIFACTS))
    screens.mkdir(parents=True, exist_ok=True)
    found = {}
    with sync_playwright() as pw:
        for width, height in SIZES:
            found.update(measure_size(pw, app_url, width, height, tmp_path / f"profile_{width}", screens))
    ARTIFACTS.mkdir(exist_ok=True)
    (ARTIFACTS / "panel_fit.json").write_text(json.dumps(found, indent=1))
    assert not any(found.values()), json.dumps({k: v for k, v in found.items() if v})
