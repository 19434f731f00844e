"""`sail-ros bag recover PATH`: a complete copy of a log cut short (a kill, a full disk).

A file the recorder could not finish has no summary and no metadata.yaml:
rosbags and mcap's default reader refuse it. `recover` reads every complete
record of it (as `sail_ros.bag.BagReader` does: up to the last complete
chunk) and writes them, with their topics, QoS, type hashes, schemas (as
recorded: the types need not be installed) and metadata records, into a new
rosbag2 folder with a summary and a metadata.yaml, the role of `ros2 bag
reindex` and `mcap recover`. The original stays as it is. The copy is built
under a temporary name beside the output (`.<name>.<random>.partial/`) and
renamed to it once complete: a recover that fails leaves nothing there.

Exit code 2 for a bad input (a path that is no log, a type that neither the log
nor the installation defines, an output that exists or cannot be created), 1 when
writing fails on the way (a full disk), each with one line on standard error.

    sail-ros bag recover out/run1
    sail-ros bag recover out/run1/run1_0.mcap -o out/run1_fixed
"""

from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
from pathlib import Path

from sail_ros.bag import BagReader, BagWriteError, BagWriter, DefinitionNotFoundError
from sail_ros.options import PHYSICS_DOC
from sail_ros.tools.common import tool_main

OWN_RECORDS = ("rosbag2",)  # written anew by the writer


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="sail-ros bag",
        description=__doc__.split("\n\n")[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="Examples:\n" + __doc__.split("\n\n")[-1].rstrip() + "\n\n" + PHYSICS_DOC,
    )
    verbs = parser.add_subparsers(dest="verb", required=True, metavar="VERB")
    recover = verbs.add_parser(
        "recover",
        help="a complete copy of a log cut short",
        description="A complete copy of a log cut short (a killed recorder's): every "
        "complete message and metadata record, indexed, in a new bag folder.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="Examples:\n" + __doc__.split("\n\n")[-1].rstrip(),
    )
    recover.add_argument("path", type=Path, help="bag folder or .mcap file")
    recover.add_argument(
        "-o", "--output", type=Path, help="new bag folder (default: <path>_recovered)"
    )
    return parser


def recover(source: Path, output: Path) -> tuple[int, list[Path]]:
    """Copy every complete message and metadata record of `source` into the new bag
    folder `output`, built under a temporary name and renamed to `output` when
    complete; returns (messages, the files that were incomplete).

    Raises:
        ValueError: `source` is not a log, a type of it has no definition, or `output`
            cannot be created.
        BagWriteError: writing failed (nothing is left at `output`).
    """
    reader = BagReader(source)
    try:
        output.parent.mkdir(parents=True, exist_ok=True)
        staging = Path(
            tempfile.mkdtemp(prefix=f".{output.name}.", suffix=".partial", dir=output.parent)
        )
    except OSError as error:
        where = f"'{error.filename}': " if error.filename else ""
        raise ValueError(
            f"--output '{output}' cannot be created: {where}{error.strerror or error}"
        ) from None
    try:
        count = _copy(reader, staging / output.name)
        (staging / output.name).rename(output)
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    return count, reader.incomplete_files


def _copy(reader: BagReader, folder: Path) -> int:
    count = 0
    with BagWriter(folder) as writer:
        for topic, info in sorted(reader.topics().items()):
            try:
                writer.add_topic(
                    topic,
                    info.type_name,
                    info.offered_qos_profiles,
                    info.type_hash or None,
                    definition=info.definition,
                )
            except DefinitionNotFoundError:
                raise ValueError(
                    f"'{reader.path}': {topic} has type {info.type_name!r}, which neither the "
                    "log (no schema) nor the installed packages define"
                ) from None
        for name, record in reader.metadata():
            if name not in OWN_RECORDS:
                writer.add_metadata(name, record)
        for message in reader.messages():
            writer.write(message.topic, message.data, message.log_time_ns, message.publish_time_ns)
            count += 1
    return count


def _bag(args) -> int:
    if not args.path.exists():
        raise ValueError(f"'{args.path}' does not exist")
    name = args.path.stem if args.path.is_file() else args.path.name
    output = args.output or args.path.parent / f"{name}_recovered"
    if output.exists():
        raise ValueError(f"--output '{output}' exists; give a new folder")
    try:
        count, incomplete = recover(args.path, output)
    except BagWriteError as error:
        print(
            f"error: recovering into '{output}' failed: {error}; nothing was left there",
            file=sys.stderr,
        )
        return 1
    state = (
        f"{len(incomplete)} incomplete file(s) read up to their last complete chunk"
        if incomplete
        else "no file was incomplete"
    )
    print(f"recovered {count} messages into {output} ({state})")
    return 0


main = tool_main(build_parser, _bag)
