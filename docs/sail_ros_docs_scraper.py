"""The gallery's image scraper: the figures an example's tool wrote to its folder.

The examples call the command-line tools and plotting functions of sail_ros, which save
their figures to files and close them; this scraper shows each PNG that appeared in the
example's `FIGURES` folder during a code block, in the order of their names.
"""

import shutil
from pathlib import Path

from sphinx_gallery.scrapers import figure_rst

_SHOWN: set[Path] = set()


def scrape_written_figures(block, block_vars, gallery_conf):
    folder = block_vars["example_globals"].get("FIGURES")
    if folder is None:
        return ""
    new = sorted(path for path in Path(folder).rglob("*.png") if path not in _SHOWN)
    shown = []
    for path, target in zip(new, block_vars["image_path_iterator"]):
        shutil.copyfile(path, target)
        _SHOWN.add(path)
        shown.append(target)
    return figure_rst(shown, gallery_conf["src_dir"])
