"""The demo's HTML report renders in headless Chromium with the network cut off.

Playwright drives the system's Chromium (``/usr/bin/chromium`` from Debian's ``chromium``
package, or ``AVTRACK_CHROMIUM``); every request other than ``file:`` and ``data:`` is aborted
and recorded. The page must load its figures and the video overlay, show the scores, and give
a non-blank screenshot; at 400 and 1280 px it must not scroll sideways, show each figure in
the layout for that width with text of at least 10 px on screen, and play the H.264 MP4.
``.ci/run`` installs Chromium and sets ``AVTRACK_REQUIRE_BROWSER=1``, so in CI a missing
browser is a failure, not a skip.
"""

from __future__ import annotations

import os
import shutil

import numpy as np
import pytest

from avtrack.cli.main import main

REQUIRED = os.environ.get("AVTRACK_REQUIRE_BROWSER") == "1"
FLAGS = ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--autoplay-policy=no-user-gesture-required"]  # fmt: skip


def _browser() -> str | None:
    env = os.environ.get("AVTRACK_CHROMIUM")
    if env:
        return env
    for name in ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable"):
        found = shutil.which(name)
        if found:
            return found
    return None


def _unavailable(reason: str):
    if REQUIRED:
        pytest.fail(f"AVTRACK_REQUIRE_BROWSER=1 but {reason}")
    pytest.skip(reason)


@pytest.fixture(scope="module")
def chromium_page():
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        _unavailable("playwright is not installed (pip install '.[test]')")
    exe = _browser()
    if exe is None:
        _unavailable("no Chromium found (apt-get install chromium, or set AVTRACK_CHROMIUM)")
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=exe, args=FLAGS)
        try:
            yield browser.new_page(viewport={"width": 1100, "height": 900})
        finally:
            browser.close()


@pytest.fixture(scope="module")
def demo_report(tmp_path_factory):
    out = tmp_path_factory.mktemp("browser") / "demo"
    assert main(["demo", "-o", str(out), "--duration", "4", "--seed", "1", "-q"]) == 0
    return out


def test_demo_report_renders_offline_in_chromium(chromium_page, demo_report, tmp_path):
    page = chromium_page
    blocked: list[str] = []

    def offline(route):
        url = route.request.url
        if url.startswith(("file:", "data:")):
            route.continue_()
        else:
            blocked.append(url)
            route.abort()

    page.route("**/*", offline)
    page.goto((demo_report / "index.html").as_uri(), wait_until="load")
    assert blocked == [], f"the report asked the network for {blocked}"
    images = page.evaluate(
        "Array.from(document.images).map(i => [i.alt, i.complete, i.naturalWidth])"
    )
    assert len(images) >= 3
    for alt, complete, width in images:
        assert complete and width > 100, (alt, complete, width)
    rows = page.evaluate("document.querySelectorAll('#scores tr').length")
    assert rows >= 4
    assert "MOTA" in page.inner_text("#scores")
    # the video overlay decodes: frames of the rendered size, a duration of the scene's
    page.wait_for_function(
        "() => { const v = document.getElementById('overlay'); "
        "return v && v.readyState >= 2 && v.videoWidth > 0; }",
        timeout=20000,
    )
    video = page.evaluate(
        "(() => { const v = document.getElementById('overlay'); "
        "return [v.videoWidth, v.videoHeight, v.duration, v.error]; })()"
    )
    assert video[0] >= 320 and video[1] >= 240 and 3.0 < video[2] < 5.0 and video[3] is None
    shot = tmp_path / "report.png"
    page.screenshot(path=str(shot), full_page=True)
    import matplotlib.image as mpimg

    pixels = mpimg.imread(shot)
    assert pixels.shape[0] > 1500 and pixels.shape[1] >= 1000  # the whole page
    assert float(np.std(pixels[..., :3])) > 0.05  # figures drawn, not a blank page


def test_demo_report_is_readable_on_a_400_px_screen(chromium_page, demo_report):
    """On a phone-sized screen the page does not scroll sideways, every figure is scaled to
    the screen, and each score carries its one-line explanation."""
    page = chromium_page
    page.set_viewport_size({"width": 400, "height": 800})
    try:
        page.goto((demo_report / "index.html").as_uri(), wait_until="load")
        width = page.evaluate("document.documentElement.scrollWidth")
        assert width <= 400, f"the page is {width} px wide on a 400 px screen"
        images = page.evaluate(
            "Array.from(document.images).map(i => i.getBoundingClientRect().width)")
        assert images and all(0 < w <= 400 for w in images), images
        helps = page.evaluate(
            "Array.from(document.querySelectorAll('#scores td.help')).map(t => t.innerText)")
        assert len(helps) >= 8 and all(("better" in h or "real time" in h) for h in helps)
    finally:
        page.set_viewport_size({"width": 1280, "height": 900})


# what each figure's images say about themselves: their rendition (narrow when the page
# shows the <source>'s image), the size on screen and in the image, and the smallest text
_FIGURES_JS = """
Array.from(document.querySelectorAll('figure picture')).map(p => {
  const img = p.querySelector('img'), src = p.querySelector('source');
  const narrow = img.currentSrc === src.srcset;
  return {alt: img.alt, complete: img.complete, natural: img.naturalWidth, narrow: narrow,
          shown: img.getBoundingClientRect().width,
          font: parseFloat((narrow ? src : img).dataset.fontPx)};
})
"""


@pytest.mark.parametrize("width", [400, 1280])
def test_demo_report_at_phone_and_desktop_widths(chromium_page, demo_report, tmp_path, width):
    """At 400 and 1280 px: offline, no sideways scrolling, each figure in its layout for
    the width (narrow rendition on the phone) with text of at least 10 px on screen, the
    H.264 MP4 offered first and playing, and a non-blank screenshot."""
    from avtrack.viz.report import MIN_SCREEN_FONT_PX, NARROW_MAX_PX
    from avtrack.viz.video import h264_available

    page = chromium_page
    blocked: list[str] = []

    def offline(route):
        if route.request.url.startswith(("file:", "data:")):
            route.continue_()
        else:
            blocked.append(route.request.url)
            route.abort()

    page.route("**/*", offline)
    page.set_viewport_size({"width": width, "height": 900})
    try:
        page.goto((demo_report / "index.html").as_uri(), wait_until="load")
        assert blocked == [], f"the report asked the network for {blocked}"
        scroll = page.evaluate("document.scrollingElement.scrollWidth")
        assert scroll <= width, f"the page is {scroll} px wide on a {width} px screen"
        figures = page.evaluate(_FIGURES_JS)
        assert len(figures) == 4, figures
        for f in figures:
            assert f["complete"] and f["natural"] > 100, f
            assert f["narrow"] == (width <= NARROW_MAX_PX), f  # re-laid out, not shrunk
            assert 0 < f["shown"] <= width, f
            on_screen = f["shown"] / f["natural"] * f["font"]  # CSS px of the smallest text
            assert on_screen >= MIN_SCREEN_FONT_PX, (f["alt"], on_screen)
        types = page.evaluate(
            "Array.from(document.querySelectorAll('#overlay source')).map(s => s.type)")
        if h264_available():
            assert types[0].startswith('video/mp4; codecs="avc1.') and len(types) == 2, types
        assert types[-1].startswith("video/webm"), types
        links = page.evaluate("Array.from(document.links).map(a => a.textContent)")
        assert "tracks.webm" in links and ("tracks.mp4" in links) == h264_available(), links
        assert links.index("tracks.mp4" if h264_available() else "tracks.webm") == 0, links
        page.evaluate("document.getElementById('overlay').play()")
        page.wait_for_function(
            "() => { const v = document.getElementById('overlay'); "
            "return v.readyState >= 2 && v.currentTime > 0.2; }",
            timeout=20000,
        )
        played = page.evaluate(
            "(() => { const v = document.getElementById('overlay'); return [v.currentSrc.slice("
            "0, 16), v.videoWidth, v.error, v.getBoundingClientRect().width]; })()"
        )
        mime = "data:video/mp4;" if h264_available() else "data:video/webm"
        assert played[0].startswith(mime[:15]) and played[1] >= 320 and played[2] is None
        assert 0 < played[3] <= width, played
        shot = tmp_path / f"report-{width}.png"
        page.screenshot(path=str(shot), full_page=True)
        import matplotlib.image as mpimg

        pixels = mpimg.imread(shot)
        assert pixels.shape[1] == width and pixels.shape[0] > 1500  # the whole page, no wider
        assert float(np.std(pixels[..., :3])) > 0.05  # figures drawn, not a blank page
    finally:
        page.unroute("**/*")
        page.set_viewport_size({"width": 1280, "height": 900})
