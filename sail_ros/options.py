"""How every program reads its command line.

`ToolParser` is the tools' argument parser: an unknown option is answered with
the nearest known one, a number such as `-inf` or `-1e-3` is a value, not an
option, and `--help` ends with the tool's examples (`help_epilog`). Standard library
only: the nodes and the umbrella command (`sail_ros.cli`) read it too.
"""

import argparse
import re
import sys
import textwrap

from sail_ros.spelling import did_you_mean

PHYSICS_DOC = (
    "The physics, its choices and checks: docs/model.md (installed as "
    "share/sail_ros/docs/model.md)."
)


def docstring_examples(doc: str) -> list[str]:
    """The example commands of a module docstring: its lines indented by four spaces that
    start with `sail-ros `."""
    return [line.strip() for line in doc.splitlines() if line.startswith("    sail-ros ")]


# a value such as -1, -.5, -1e-3, -inf or -nan: argparse's own pattern takes only the
# first two, so `--values -inf` read as an unknown option
NEGATIVE_NUMBER = re.compile(
    r"^-(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$|^-(inf|infinity|nan)$", re.IGNORECASE
)


class ToolParser(argparse.ArgumentParser):
    """An `argparse.ArgumentParser` that reads negative numbers of any form as values
    and names the nearest option for an unknown one (its subcommands' parsers too)."""

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("formatter_class", argparse.RawDescriptionHelpFormatter)
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = NEGATIVE_NUMBER

    @classmethod
    def for_tool(cls, tool: str, description: str, examples, writes: str = "", notes: str = ""):
        """The parser of `sail-ros <tool>`, its `--help` ending as `help_epilog` makes it."""
        return cls(
            prog=f"sail-ros {tool}",
            description=description,
            epilog=help_epilog(examples, writes, notes),
        )

    def parse_args(self, args=None, namespace=None):
        return parse_arguments(self, sys.argv[1:] if args is None else args, namespace)


def parse_arguments(parser: argparse.ArgumentParser, args, namespace=None):
    """`parser.parse_args(args)`, but an unknown option is named with the nearest option
    of the parser (or of the subcommand given): `unrecognized arguments: --lenghts
    (did you mean '--lengths'?)`. Exits as argparse does (code 2) on a bad command line.
    """
    parsed, extras = parser.parse_known_args(args, namespace)
    if extras:
        unknown = next((item for item in extras if item.startswith("-")), "")
        name = unknown.partition("=")[0]
        hint = ""
        if name in _option_strings(parser, None):  # an option of the tool after its command
            hint = f" ({name} goes before the command)"
        elif name:
            # options share their "--": a higher bar than for names
            hint = did_you_mean(name, _option_strings(parser, parsed), 0.75)
        parser.error(f"unrecognized arguments: {' '.join(extras)}{hint}")
    return parsed


def _option_strings(parser: argparse.ArgumentParser, parsed) -> set[str]:
    """The long options of `parser` and of the subcommand parsers `parsed` chose (None:
    of `parser` alone)."""
    found = set()
    for action in parser._actions:
        found.update(option for option in action.option_strings if option.startswith("--"))
        if isinstance(action, argparse._SubParsersAction):
            chosen = action.choices.get(getattr(parsed, action.dest, None) or "")
            if chosen is not None:
                found |= _option_strings(chosen, parsed)
    return found


def paragraphs(text: str, *indices: int) -> str:
    """The paragraphs of `text` at `indices`, joined again: a tool's `--help` description
    from its module docstring."""
    parts = text.split("\n\n")
    return "\n\n".join(parts[i] for i in indices)


def add_lengths_option(parser, help: str) -> None:
    """`--lengths L [L ...]`, boom lengths [m], as the studies at frozen lengths take them
    (`help` says how many and their default)."""
    parser.add_argument("--lengths", type=float, nargs="+", metavar="L", help=help)


def help_epilog(examples, writes: str = "", notes: str = "") -> str:
    """The end of a tool's `--help`: `notes` (paragraphs), the files it writes, where the
    physics is documented, and last the examples (commands, one a line; a comment after
    `#` is kept)."""
    paragraphs = [_filled(p) for p in notes.split("\n\n") if p.strip()]
    if writes:
        paragraphs.append(textwrap.fill("Writes: " + " ".join(writes.split()), 88))
    paragraphs.append(textwrap.fill(PHYSICS_DOC, 88))
    paragraphs.append("Examples:\n" + "\n".join(f"  {line}" for line in examples))
    return "\n\n".join(paragraphs)


def _filled(paragraph: str) -> str:
    """A paragraph of a docstring wrapped to 88 columns, a list (lines starting "- ") as a
    list: each item wrapped under its dash."""
    lines = []
    for item in re.split(r"\n\s*(?=- )", paragraph.strip()):
        text = " ".join(item.split())
        if text.startswith("- "):
            lines.append(textwrap.fill(text[2:], 88, initial_indent="- ", subsequent_indent="  "))
        else:
            lines.append(textwrap.fill(text, 88))
    return "\n".join(lines)
