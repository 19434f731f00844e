"""The tables of docs/scenarios.md, made from the code's declarations.

docs/scenarios.md is prose around generated blocks, each between
`<!-- BEGIN generated: NAME -->` and `<!-- END generated: NAME -->`; the blocks come
from the sections of the scenario and study readers (`analysis.scenario`,
`analysis.montecarlo`) and the field tables of the sail, the policy and the
controller's design. A test
checks that the page holds what this module makes; after a change of a table,

    python -m sail_ros.tools.scenario_docs docs/scenarios.md

rewrites the blocks in place.
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

from sail_ros.analysis import montecarlo, scenario
from sail_ros.control.settings import DesignSettings
from sail_ros.model import SailParameters
from sail_ros.model.fields import markdown_table, settings_of
from sail_ros.policy import Policy

BLOCK = re.compile(
    r"(<!-- BEGIN generated: (?P<name>[\w-]+) -->\n)(?P<body>.*?)"
    r"(<!-- END generated: (?P=name) -->)",
    re.DOTALL,
)


def _sections(sections) -> str:
    return "\n\n".join(
        f"#### `{section.path}`\n\n{section.doc}\n\n{section.markdown()}" for section in sections
    )


def blocks() -> dict[str, str]:
    """Block name -> its Markdown, as the code declares it."""
    return {
        "scenario": _sections(scenario.SECTIONS),
        "sail": markdown_table(settings_of(SailParameters)),
        "limits": markdown_table(settings_of(Policy)),
        "controller": markdown_table(settings_of(DesignSettings)),
        "study": _sections(montecarlo.SECTIONS),
    }


def update(text: str) -> str:
    """`text` with every generated block made anew; ValueError for an unknown block or a
    missing one."""
    made = blocks()
    found = [match["name"] for match in BLOCK.finditer(text)]
    if sorted(found) != sorted(made):
        raise ValueError(f"generated blocks: the page has {found}, the code makes {list(made)}")
    return BLOCK.sub(lambda m: f"{m[1]}\n{made[m['name']]}\n\n{m[4]}", text)


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if len(argv) != 1:
        print("usage: python -m sail_ros.tools.scenario_docs docs/scenarios.md", file=sys.stderr)
        return 2
    path = Path(argv[0])
    try:
        text = update(path.read_text())
    except (OSError, ValueError) as error:
        print(f"error: {path}: {error}", file=sys.stderr)
        return 2
    path.write_text(text)
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
