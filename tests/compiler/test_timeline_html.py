"""The interactive HTML timeline, opened in a real headless Chromium (Debian's chromium and
chromium-driver, driven by selenium): it is self-contained, draws without a script error, zooms
at the pointer on a real wheel event, and a real mouse hover shows the cue with its source line.
"""

from __future__ import annotations

import itertools
import re
import shutil
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from xgo_show.choreo import load_show
from xgo_show.compiler import compile_show, plot_schedule

ROUTINE = Path(__file__).parent / "data" / "timeline_show.yaml"
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
DRIVER = shutil.which("chromedriver")

pytestmark = pytest.mark.skipif(
    CHROMIUM is None or DRIVER is None,
    reason="needs Debian's chromium and chromium-driver (apt-get install chromium "
    "chromium-driver; .ci/run installs them)",
)


@pytest.fixture(scope="module")
def page(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Any]:
    webdriver = pytest.importorskip("selenium.webdriver")
    from selenium.webdriver.chrome.service import Service

    folder = tmp_path_factory.mktemp("timeline")
    path = plot_schedule(compile_show(load_show(ROUTINE)), folder / "show.html")
    options = webdriver.ChromeOptions()
    options.binary_location = str(CHROMIUM)
    for flag in ("--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
                 "--no-first-run", "--disable-background-networking",
                 "--disable-component-update", "--disable-sync",
                 f"--user-data-dir={folder / 'profile'}", "--window-size=1400,1000"):
        options.add_argument(flag)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    driver = webdriver.Chrome(options=options, service=Service(str(DRIVER)))
    try:
        driver.get(path.as_uri())
        assert driver.execute_script("return window.timelineReady") is True
        yield driver
    finally:
        driver.quit()


def _view(page: Any) -> tuple[float, float]:
    t0, t1 = page.execute_script("return window.timelineView")
    return float(t0), float(t1)


def _tip(page: Any) -> str:
    tip = page.find_element("id", "tip")
    return str(tip.text) if tip.is_displayed() else ""


def test_the_file_stands_alone_and_draws_without_errors(page: Any) -> None:
    source = Path(page.execute_script("return location.pathname")).read_text()
    # Nothing to fetch: no external script, style, image or font (the SVG namespace is a name).
    assert not re.search(r"""<[a-z]+\s[^>]*\b(src|href)\s*=|@import|url\((?!#)""", source)
    assert page.execute_script("return performance.getEntriesByType('resource').length") == 0
    assert [e for e in page.get_log("browser") if e["level"] == "SEVERE"] == []
    labels = page.execute_script(
        "return [...document.querySelectorAll('.cue-label')].map(e => {"
        "const r = e.getBoundingClientRect(); return [e.textContent, r.left, r.top, r.right,"
        " r.bottom]})")
    assert {"stand_up (action 2)", "wave (action 13)", "gait=walk"} <= {x[0] for x in labels}
    for a, b in itertools.combinations(labels, 2):  # no label overprints another
        assert a[3] <= b[1] or b[3] <= a[1] or a[4] <= b[2] or b[4] <= a[2], (a[0], b[0])


def test_hover_shows_the_cue_and_its_source_line(page: Any) -> None:
    from selenium.webdriver.common.action_chains import ActionChains

    page.find_element("id", "whole").click()
    wave = next(e for e in page.find_elements("css selector", "rect.cue.action")
                if page.execute_script(
                    "const [_, p, i] = arguments[0].dataset.k.split(':');"
                    "return D.performers[p].events[i][3]", e) == "wave (action 13)")
    ActionChains(page).move_to_element(wave).perform()
    text = _tip(page)
    assert "rex: wave (action 13)" in text
    assert f"at {ROUTINE}:17" in text  # the wave cue's line in the routine
    assert "from 6.000 s (bar 4 beat 1.00)" in text
    # Over a curve: each value in effect and the cue that set it.
    lane = page.find_elements("css selector", "rect.lane")[0]  # rex, mm
    x = page.execute_script("return X(5.0)") - page.execute_script(
        "return arguments[0].getBoundingClientRect().left - "
        "document.getElementById('chart').getBoundingClientRect().left", lane)
    ActionChains(page).move_to_element_with_offset(
        lane, int(x - lane.size["width"] / 2), 0).perform()
    text = _tip(page)
    assert re.search(r"body_z = 110(\.0+)? mm", text), text
    assert f"at {ROUTINE}:16" in text  # the move cue


def test_the_wheel_zooms_around_the_pointer(page: Any) -> None:
    from selenium.webdriver.common.actions.wheel_input import ScrollOrigin
    from selenium.webdriver.common.action_chains import ActionChains

    page.find_element("id", "whole").click()
    whole = _view(page)
    chart = page.find_element("id", "chart")
    left = page.execute_script("return X(7.0)")  # 7 s, in the chart's own pixels
    offset = (int(left - chart.size["width"] / 2), -int(chart.size["height"] / 4))
    ActionChains(page).scroll_from_origin(
        ScrollOrigin.from_element(chart, *offset), 0, -300).perform()
    zoomed = _view(page)
    assert zoomed[1] - zoomed[0] < 0.85 * (whole[1] - whole[0])
    # The time under the pointer stays under the pointer.
    assert page.execute_script(f"return T({left})") == pytest.approx(7.0, abs=0.05)
    # The double-click back to the whole show is dispatched as a DOM event: chromedriver
    # makes two clicks a double-click only if they land within its 500 ms, which a loaded
    # machine can miss (seen once under a mutation run), and that is not the page's code.
    page.execute_script(
        "arguments[0].dispatchEvent(new MouseEvent('dblclick', {bubbles: true}))", chart)
    assert _view(page) == pytest.approx(whole)
