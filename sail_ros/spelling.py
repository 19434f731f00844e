"""The one "did you mean" of every program: the known name nearest a misspelt one.

Standard library only, so that every layer (the model's tables, the command line,
the nodes' parameters) names the likely intent the same way.
"""

import difflib


def nearest(name: str, known, cutoff: float = 0.6) -> str | None:
    """The known name closest to `name`, or None if none is close (difflib's ratio
    below `cutoff`)."""
    close = difflib.get_close_matches(name, sorted(known), n=1, cutoff=cutoff)
    return close[0] if close else None


def did_you_mean(name: str, known, cutoff: float = 0.6) -> str:
    """The text " (did you mean 'x'?)" for the known name x nearest `name`, or ""."""
    close = nearest(name, known, cutoff)
    return f" (did you mean {close!r}?)" if close else ""
