"""The documentation site builds as scripts/docs.sh builds it (offline, warnings as
errors, the examples run), its internal links and anchors all lead somewhere, every
public name of `sail_ros.model` has its entry in the API reference, and a browser shows
rendered pages rather than Markdown. Also: no dates in the package's comments and
docstrings (history lives in git)."""

import html.parser
import importlib
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path
from urllib.parse import unquote, urlsplit

import pytest
from harness import ROOT

pytestmark = pytest.mark.model


class Links(html.parser.HTMLParser):
    """The ids a page defines and the local links it holds (href and src)."""

    def __init__(self):
        super().__init__()
        self.ids: set[str] = set()
        self.links: list[str] = []

    def handle_starttag(self, tag, attrs):
        for name, value in attrs:
            if name == "id" and value:
                self.ids.add(value)
            elif name in ("href", "src") and value:
                self.links.append(value)


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    """The site, built afresh (no cached environment) into a temporary folder, as
    scripts/docs.sh builds it."""
    out = tmp_path_factory.mktemp("site")
    start = time.monotonic()
    built = subprocess.run(
        [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-b", "html", "-q", "-E",
         "-d", str(out / "doctrees"), "-c", "docs", ".", str(out / "html")],
        cwd=ROOT, capture_output=True, text=True, timeout=600,
        env={**os.environ, "MPLBACKEND": "Agg"},
    )  # fmt: skip
    seconds = time.monotonic() - start
    assert built.returncode == 0, built.stderr[-6000:]
    assert "WARNING" not in built.stderr and "ERROR" not in built.stderr, built.stderr[-6000:]
    print(f"documentation built in {seconds:.1f} s")
    return out / "html"


def pages(site: Path) -> dict[Path, Links]:
    parsed = {}
    for page in site.rglob("*.html"):
        links = Links()
        links.feed(page.read_text())
        parsed[page] = links
    return parsed


def test_every_internal_link_and_anchor_resolves(site):
    parsed = pages(site)
    broken = []
    for page, links in parsed.items():
        for link in links.links:
            parts = urlsplit(link)
            if parts.scheme or parts.netloc or link.startswith(("mailto:", "javascript:")):
                continue
            target = (page.parent / unquote(parts.path)).resolve() if parts.path else page
            if target.is_dir():
                target = target / "index.html"
            if not target.is_file():
                broken.append(f"{page.relative_to(site)}: {link}")
            elif parts.fragment and target.suffix == ".html":
                ids = parsed[target].ids if target in parsed else set()
                if unquote(parts.fragment) not in ids:
                    broken.append(f"{page.relative_to(site)}: {link} (no such anchor)")
    assert not broken, "\n".join(broken[:40])
    assert len(parsed) > 40  # the guide, the reference, the interfaces, the API, examples


def test_the_guide_shows_the_figures_the_examples_drew(site):
    figures = sorted((site / "_images").glob("*.png"))
    guide = "".join(page.read_text() for page in (site / "docs" / "guide").glob("*.html"))
    shown = set(re.findall(r'src="[^"]*/_images/([^"]+\.png)"', guide))
    assert len(shown) >= 10 and shown <= {figure.name for figure in figures}


def test_every_public_name_of_the_model_is_in_the_api_reference(site):
    model = importlib.import_module("sail_ros.model")
    api = (site / "docs" / "_generated" / "api").glob("*.html")
    ids = set().union(*(pages_ids(page) for page in api))
    missing = []
    for name in model.__all__:
        value = getattr(model, name)
        qualified = f"{value.__module__}.{value.__qualname__}"
        if qualified not in ids:
            missing.append(qualified)
    assert not missing, missing
    assert "sail_ros.model.sail_model.SailModel.simulate" in ids  # members too


def pages_ids(page: Path) -> set[str]:
    links = Links()
    links.feed(page.read_text())
    return links.ids


CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")


@pytest.mark.skipif(
    CHROMIUM is None,
    reason="no chromium on PATH (Debian: apt-get install chromium); the rendered pages "
    "are then checked only as HTML",
)
def test_a_browser_shows_the_rendered_index_and_an_api_page(site, tmp_path):
    def dom(page: Path) -> str:
        shown = subprocess.run(
            [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
             f"--user-data-dir={tmp_path / 'profile'}", "--dump-dom", page.as_uri()],
            capture_output=True, text=True, timeout=120,
        )  # fmt: skip
        assert shown.returncode == 0, shown.stderr[-2000:]
        return shown.stdout

    index = dom(site / "docs" / "index.html")
    assert "<h1>sail_ros" in index and "Getting started" in index
    assert "{toctree}" not in index and "```" not in index  # Markdown rendered, not shown
    api = dom(site / "docs" / "_generated" / "api" / "sail_ros.model.html")
    text = re.sub(r"<[^>]+>", "", api)
    assert "class sail_ros.model.sail_model.SailModel" in re.sub(r"\s+", " ", text)
    assert "Parameters:" in text or "Returns:" in text  # napoleon's fields, rendered
    assert "Args:" not in text and "```" not in text


MONTHS = "January|February|March|April|May|June|July|August|September|October|November|December"
DATES = re.compile(
    rf"\b(19|20)\d\d-[01]\d-[0-3]\d\b|\b\d{{1,2}} ({MONTHS}),? (19|20)\d\d\b"
    rf"|\b({MONTHS}) \d{{1,2}}(st|nd|rd|th)?,? (19|20)\d\d\b"
)


def test_no_dates_in_the_package():
    """Comments and docstrings give reasons, not history: a date in `sail_ros/` is a
    story that belongs in a commit message."""
    found = [
        f"{path.relative_to(ROOT)}:{number}: {line.strip()}"
        for path in sorted((ROOT / "sail_ros").rglob("*.py"))
        for number, line in enumerate(path.read_text().splitlines(), start=1)
        if DATES.search(line)
    ]
    assert not found, "\n".join(found)


def test_the_date_pattern_finds_dates():
    for text in ("measured 2026-12-04", "on 4 December 2026", "December 4, 2026"):
        assert DATES.search(text), text
    for text in ("version 2026.8.0", "seed 2026", "%Y-%m-%d", "1e-3 2e-3"):
        assert not DATES.search(text), text
