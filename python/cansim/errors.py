"""The exceptions of the cansim client.

Every failure is a :class:`Error`; a refusal by cansimd carries the daemon's
error name (``io.cansim.Error.OutOfRange`` ...) and message unchanged.
"""

from __future__ import annotations

from typing import Any, List, Optional

__all__ = ["Error", "NoSuchNode", "Refused", "Timeout"]


class Error(Exception):
    """Anything that went wrong talking to or running cansimd."""


class Refused(Error):
    """cansimd refused a call: ``name`` is its D-Bus error name
    (``io.cansim.Error.OutOfRange``, ``io.cansim.Error.Refused`` ...),
    ``message`` its explanation."""

    def __init__(self, name: str, message: str) -> None:
        super().__init__(f"{name}: {message}" if message else name)
        self.name = name
        self.message = message


class NoSuchNode(Refused, LookupError):
    """No node by that name (``io.cansim.Error.UnknownNode``), or the node was
    removed since it was looked up."""


class Timeout(Error, TimeoutError):
    """An awaited event did not come, or cansimd did not answer, in time."""

    def __init__(self, message: str, seen: Optional[List[Any]] = None) -> None:
        super().__init__(message)
        #: the events of the awaited node received while waiting (for the report)
        self.seen = seen or []
