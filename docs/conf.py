"""Sphinx configuration of the sail_ros documentation (scripts/docs.sh builds it).

The source folder is the repository's root, so a link between pages is the same on the
site as in the tree (`docs/model.md`, `msg_docs/control.md`); only `docs/` and
`msg_docs/` are read. Pages written by hand are Markdown (MyST). Two kinds of page are
made at build time into `docs/_generated/` (git-ignored), so neither can go stale: the
API reference (one page per package, one section per module, from the docstrings) and
the benchmarks page (rendered from the committed results of the latest run,
`benchmarks/results/latest.json`). The examples under `examples/` run at build time
(sphinx-gallery) and draw the guide's figures with the tools' own plotting functions.
"""

import importlib
import pkgutil
import re
import shutil
import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
GENERATED = DOCS / "_generated"
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

project = "sail_ros"
author = "the sail_ros developers"
copyright = "the sail_ros developers, Apache-2.0"  # noqa: A001 (Sphinx's name)

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.napoleon",
    "sphinx.ext.mathjax",
    "sphinx_gallery.gen_gallery",
]

source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
root_doc = "docs/index"
include_patterns = ["docs/**", "msg_docs/**"]
exclude_patterns = ["docs/_build", "docs/examples", "docs/gallery/*.ipynb", "docs/gallery/*.py",
                    "docs/gallery/*.md5", "docs/gallery/*.zip", "docs/sail_ros_docs_scraper.py",
                    "docs/conf.py"]  # fmt: skip
html_theme = "alabaster"
html_theme_options = {"nosidebar": False, "page_width": "1100px"}
html_title = "sail_ros"
html_static_path: list[str] = []
html_show_sourcelink = False

# MyST: `$...$` maths, heading anchors for the `page.md#section` links of the pages
myst_enable_extensions = ["dollarmath", "colon_fence"]
myst_heading_anchors = 4
suppress_warnings = ["myst.header"]  # msg_docs pages start at level 1 and skip to 3

# The docstrings are Google style (Args:, Returns:, Raises:, Attributes:), with
# `name` in single backquotes meaning code.
napoleon_google_docstring = True
napoleon_numpy_docstring = False
napoleon_use_ivar = True
default_role = "code"
autodoc_member_order = "bysource"
autodoc_typehints = "description"
autodoc_default_options = {"members": True, "show-inheritance": False}
nitpicky = False

API = {  # package: what its page says it is
    "sail_ros.model": "The structural model: parameters, matrices, modes, profiles (no ROS).",
    "sail_ros.integrate": "Time integration: the stepper, step control, dense output, "
    "the batch driver and its observers (model.md §11).",
    "sail_ros.analysis": "Studies and log analysis behind the offline tools.",
    "sail_ros.bag": "MCAP logs as rosbag2 writes them: writer, reader, metadata, QoS.",
    "sail_ros.messages": "One module per message: builders, status keys, exact CDR bytes.",
    "sail_ros.runtime": "The simulator without ROS: real-time stepping on an injected clock, "
    "commands, pacing, diagnosis, configuration.",
}

sphinx_gallery_conf = {
    "examples_dirs": "docs/examples",
    "gallery_dirs": "docs/gallery",
    "filename_pattern": r"/plot_",
    "within_subsection_order": "FileNameSortKey",
    "download_all_examples": False,
    "remove_config_comments": True,
    "show_memory": False,
    "plot_gallery": "True",
    "image_scrapers": ("sail_ros_docs_scraper.scrape_written_figures",),
    "reset_modules": (),
    "min_reported_time": 1,
    "write_computation_times": False,
    "run_stale_examples": True,  # every build runs every example: no figure goes stale
}
sys.path.insert(0, str(DOCS))


def _modules(package: str) -> list[str]:
    """The package's modules, in name order (namespace packages too)."""
    module = importlib.import_module(package)
    names = sorted(info.name for info in pkgutil.iter_modules(module.__path__))
    return [f"{package}.{name}" for name in names if not name.startswith("_")]


def _api_pages() -> None:
    folder = GENERATED / "api"
    folder.mkdir(parents=True, exist_ok=True)
    index = ["# API reference", "", "Generated from the docstrings at every build.", ""]
    index += ["```{toctree}", ":maxdepth: 1", ""] + [f"{name}" for name in API] + ["```", ""]
    _write(folder / "index.md", "\n".join(index))
    for package, summary in API.items():
        lines = [f"# `{package}`", "", summary, ""]
        package_doc = importlib.import_module(package).__doc__
        if package_doc:
            lines += ["```{eval-rst}", f".. automodule:: {package}", "   :no-members:", "```", ""]
        for name in _modules(package):
            lines += [f"## `{name}`", "", "```{eval-rst}", f".. automodule:: {name}", "```", ""]
        _write(folder / f"{package}.md", "\n".join(lines))


def _benchmarks_page() -> None:
    from render_results import render

    _write(GENERATED / "benchmarks.md", render(ROOT / "benchmarks" / "results" / "latest.json"))


def _write(path: Path, text: str) -> None:
    """Write only what changed, so Sphinx rebuilds only what changed."""
    if not path.is_file() or path.read_text() != text:
        path.write_text(text)


def _generate(app) -> None:
    if GENERATED.is_dir() and not (GENERATED / "api").is_dir():
        shutil.rmtree(GENERATED)
    _api_pages()
    _benchmarks_page()


# `|x|` in a docstring is an absolute value or a norm, as in the equations of model.md,
# never an RST substitution; `code` spans are left as they are.
_CODE_OR_BARS = re.compile(r"(``?[^`]+``?)|(?<![\\|])\|(?=[^|\s])([^|`\n]*?[^|\s\\])\|(?!\|)")


def _absolute_values(app, what, name, obj, options, lines) -> None:
    for index, line in enumerate(lines):
        lines[index] = _CODE_OR_BARS.sub(lambda m: m.group(1) or rf"\|{m.group(2)}\|", line)


def setup(app):
    app.connect("builder-inited", _generate)
    app.connect("autodoc-process-docstring", _absolute_values)
