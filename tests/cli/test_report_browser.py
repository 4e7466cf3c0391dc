"""report.html in a real browser: Debian's Chromium driven through Selenium (chromium-driver).

Each page must load with no JavaScript error, fetch nothing from the network, draw a 3D view
that is not blank, and redraw it when the time slider moves. CI installs the browser
(.ci/run); without it these tests fail, they do not skip.
"""

import io
import json
import re
import shutil
import time

import numpy as np
import pytest

from coopsat.cli import main

CHROMIUM_FLAGS = (
    "--headless=new", "--no-sandbox", "--disable-dev-shm-usage", "--window-size=1400,1000",
    # WebGL without a GPU: Chromium's software rasteriser, which it enables only when asked
    "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
    # a closed network: no background traffic of the browser's own in the request log
    "--disable-background-networking", "--disable-component-update", "--disable-sync", "--no-first-run",
)


@pytest.fixture(scope="module")
def browser():
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    chromium, driver_path = shutil.which("chromium"), shutil.which("chromedriver")
    if chromium is None or driver_path is None:
        pytest.fail("the report tests need Debian's chromium and chromium-driver (apt install chromium chromium-driver)")
    options = webdriver.ChromeOptions()
    options.binary_location = chromium
    for flag in CHROMIUM_FLAGS:
        options.add_argument(flag)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL", "performance": "ALL"})
    driver = webdriver.Chrome(service=Service(driver_path), options=options)
    yield driver
    driver.quit()


def _open(driver, path):
    driver.get(path.resolve().as_uri())
    deadline = time.monotonic() + 60
    while driver.execute_script("return window.coopsatReport === undefined"):
        if time.monotonic() > deadline:
            raise AssertionError(f"the report did not finish drawing: {_errors(driver)}")
        time.sleep(0.2)


def _errors(driver):
    return [e["message"] for e in driver.get_log("browser") if e["level"] == "SEVERE"]


def _requested_urls(driver):
    urls = []
    for entry in driver.get_log("performance"):
        message = json.loads(entry["message"])["message"]
        if message["method"] == "Network.requestWillBeSent":
            urls.append(message["params"]["request"]["url"])
    return urls


def _image(driver, element_id):
    from PIL import Image

    png = driver.find_element("id", element_id).screenshot_as_png
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"))


def _drawn(pixels):
    """Fraction of pixels that are not the page's white, and the number of distinct colours."""
    flat = pixels.reshape(-1, 3)
    return float(np.mean(np.any(flat < 245, axis=1))), len(np.unique(flat, axis=0))


def _scene_coordinates(driver):
    return driver.execute_script(
        "const gd = document.getElementById('scene');"
        "return gd.data.filter(t => t.type === 'scatter3d' && t.mode !== undefined && !t.name.endsWith(' path'))"
        ".map(t => [Array.from(t.x), Array.from(t.y), Array.from(t.z)]);")


def _check_page(driver, path):
    from selenium.webdriver.common.keys import Keys

    driver.get_log("browser")
    driver.get_log("performance")
    _open(driver, path)
    assert _errors(driver) == []
    outside = [u for u in _requested_urls(driver) if not re.match(r"(file|data|blob|about):", u)]
    assert outside == [], f"the page fetched {outside}"
    before = _image(driver, "scene")
    drawn, colours = _drawn(before)
    assert drawn > 0.02 and colours > 20, f"blank 3D view: {drawn:.1%} drawn, {colours} colours"
    coordinates = _scene_coordinates(driver)

    slider = driver.find_element("id", "frame")
    slider.send_keys(Keys.END)  # a real key press: the browser fires the slider's input event
    last = driver.execute_script("return window.coopsatReport.frames - 1")
    deadline = time.monotonic() + 20
    while driver.execute_script("return window.coopsatReport.frame") != last:
        assert time.monotonic() < deadline, "the slider did not move the report's frame"
        time.sleep(0.1)
    time.sleep(0.5)  # the WebGL canvas redraws on the next animation frame
    assert _scene_coordinates(driver) != coordinates
    assert np.any(_image(driver, "scene") != before), "the 3D view did not change with the slider"
    assert driver.find_element("id", "frame-time").text.startswith("t = ")
    assert _errors(driver) == []


def test_main_job_report_loads_offline_and_its_slider_moves_the_view(browser, tmp_path):
    """Issue 29's done-when: consensus-sync-a-stable, 60 s."""
    out = tmp_path / "run"
    assert main(["run", "consensus-sync-a-stable", "--set", "sim.t_final_s=60", "--out", str(out), "-q",
                 "--no-figures"]) == 0
    _check_page(browser, out / "report.html")
    series = browser.execute_script("return document.querySelectorAll('#series .series').length")
    assert series >= 3  # attitude error, rates, torque at least


@pytest.mark.slow
def test_orbit_and_observation_reports_draw_the_earth_and_targets_a_delay_report_its_random_delay(browser, tmp_path):
    import coopsat

    orbit = coopsat.Scenario.load("rigid-body-gravity-gradient").set("sim.t_final_s", 600.0)
    coopsat.run(orbit, out_dir=tmp_path / "orbit")
    _check_page(browser, tmp_path / "orbit" / "report.html")
    assert browser.execute_script("return document.getElementById('scene').data.some(t => t.type === 'surface')")

    # the target rises at 665 s: the cameras' lines of sight end on the ground after it
    observation = coopsat.Scenario.load("observation-cooperative").set("sim.t_final_s", 800.0)
    coopsat.run(observation, out_dir=tmp_path / "observation")
    _check_page(browser, tmp_path / "observation" / "report.html")
    targets = browser.execute_script(
        "const t = document.getElementById('scene').data.find(t => t.name === 'ground target');"
        "return t === undefined ? null : Array.from(t.x);")
    assert targets is not None and all(x is not None for x in targets)  # the slider is at the last frame

    delay = coopsat.Scenario.load("delay-designed").set("sim.t_final_s", 5.0)
    coopsat.run(delay, out_dir=tmp_path / "delay")
    _check_page(browser, tmp_path / "delay" / "report.html")
    title = browser.execute_script("return document.getElementById('network').layout.title.text")
    assert "τ = " in title and "per hop" in title


def test_report_command_remakes_the_page_from_the_run_folder(tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["run", "consensus-sync-a-stable", "--set", "sim.t_final_s=2", "--out", str(out), "-q", "--no-figures",
                 "--no-report"]) == 0
    assert not (out / "report.html").exists()
    assert main(["report", str(out)]) == 0
    page = (out / "report.html").read_text()
    assert capsys.readouterr().out.strip().endswith("report.html")
    assert "consensus-sync-a-stable" in page and 'id="coopsat-data"' in page
    assert main(["report", str(tmp_path)]) == 2  # not a run folder: one line, exit 2
    assert "not a run folder" in capsys.readouterr().err
