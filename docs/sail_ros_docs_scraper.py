"""The gallery's image scraper: the figures an example's tool wrote to its folder.

The examples call the command-line tools and plotting functions of sail_ros, which save
their figures to files and close them; this scraper shows each PNG that appeared in the
example's `FIGURES` folder during a code block, in the order they were written, and
keeps a copy under a stable name, `docs/gallery/figures/<example>/<path in FIGURES>`,
for the guide's pages to show.
"""

import shutil
from pathlib import Path

from sphinx_gallery.scrapers import figure_rst

_SHOWN: set[Path] = set()


def scrape_written_figures(block, block_vars, gallery_conf):
    folder = block_vars["example_globals"].get("FIGURES")
    if folder is None:
        return ""
    folder = Path(folder)
    new = sorted(
        (path for path in folder.rglob("*.png") if path not in _SHOWN),
        key=lambda path: (path.stat().st_mtime_ns, path.name),
    )
    example = Path(block_vars["src_file"]).stem.removeprefix("plot_")
    stable = Path(gallery_conf["src_dir"]) / "docs" / "gallery" / "figures" / example
    shown = []
    for path, target in zip(new, block_vars["image_path_iterator"], strict=False):
        shutil.copyfile(path, target)
        copy = stable / path.relative_to(folder)
        copy.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(path, copy)
        _SHOWN.add(path)
        shown.append(target)
    # one figure per line: the tools' figures are wide
    return "".join(figure_rst([path], gallery_conf["src_dir"]) for path in shown)
