"""Replaying a capture onto a bus as an outside participant, as ``cansimctl
replay`` does (src/ctl/capture_replay.cpp): the frames go to cansimd
through Fleet1.QueueFrames, each at its simulated time, so on a timed bus
they arbitrate with the nodes' frames.

The pacing is cansimctl's: the first frame 100 ms after the call, the
file's spacing divided by ``speed``, handed over in batches of at most 512
and at most 1 s ahead; with ``loop`` the file again one mean frame gap
after its last frame.
"""

from __future__ import annotations

import os
import threading
import time
from typing import TYPE_CHECKING, Any, Iterable, List, Optional, Sequence, Tuple, Union

from ._bus import FLEET_IFACE, ROOT_PATH
from ._wire import Capture, Frame, frame_of_message, read_candump
from .errors import Error

if TYPE_CHECKING:
    from .simulator import Simulator

_LEAD_US = 100_000      # the first frame's time after the call
_AHEAD_US = 1_000_000   # frames handed over at most this far ahead
_BATCH = 512            # frames per QueueFrames call (its bound: 1024)
_RETRY_S = 0.02         # the daemon's queue was full: ask again after
_IDLE_S = 0.1           # the longest sleep (stop() is seen within it)

_EFF_FLAG, _RTR_FLAG = 0x80000000, 0x40000000

Source = Union[str, "os.PathLike[str]", Capture, Iterable[Any]]
FilterSpec = Union[str, int, Tuple[int, int], None]


def parse_filter(spec: FilterSpec) -> Optional[Tuple[int, int]]:
    """``"181:7FF"`` (hex, as cansimctl's --filter), an ID, or (ID, MASK)
    as (id, mask); MASK defaults to 1FFFFFFF."""
    if spec is None:
        return None
    if isinstance(spec, tuple):
        fid, mask = spec
    elif isinstance(spec, int):
        fid, mask = spec, 0x1FFFFFFF
    else:
        text, _, mask_text = str(spec).partition(":")
        try:
            fid = int(text, 16)
            mask = int(mask_text, 16) if mask_text else 0x1FFFFFFF
        except ValueError:
            raise ValueError(f"filter {spec!r}: expected ID[:MASK] in hex (181:7FF)") from None
    if not (0 <= fid <= 0x1FFFFFFF and 0 <= mask <= 0x1FFFFFFF):
        raise ValueError(f"filter {spec!r}: identifiers are at most 1FFFFFFF")
    return fid, mask


def frames_of(source: Source, skipped: List[str]) -> List[Frame]:
    """The frames of a candump -L file, a Capture, or python-can Messages."""
    if isinstance(source, (str, os.PathLike)):
        return read_candump(source, skipped)
    if isinstance(source, Capture):
        return source.raw()
    return [f if isinstance(f, Frame) else frame_of_message(f) for f in source]


class Replay:
    """A replay running in the background: ``wait()`` until its last frame
    has had its time (``loop``: until ``stop()``), a context manager that
    stops it on exit. ``sent``: frames cansimd took so far."""

    def __init__(self, sim: "Simulator", frames: Sequence[Frame], bus: str, loop: bool, speed: float,
                 filtered: int, skipped: int) -> None:
        self._sim = sim
        self._frames = frames
        self.bus = bus
        self.loop = loop
        self.speed = speed
        self.filtered = filtered
        self.skipped = skipped
        self.sent = 0
        self._halt = threading.Event()
        self._error: Optional[BaseException] = None
        self._thread = threading.Thread(target=self._run, name=f"cansim-replay-{bus}", daemon=True)
        self._sim_at_start = self._sim_now_from_daemon()
        self._mono_at_start = time.monotonic()
        self._thread.start()

    def _sim_now_from_daemon(self) -> int:
        return int(self._sim._conn.get(ROOT_PATH, FLEET_IFACE, "SimulatedTime"))

    def _sim_now(self) -> int:
        return self._sim_at_start + round((time.monotonic() - self._mono_at_start) * 1e6)

    def _queue(self, batch: Sequence[Tuple[int, Frame]]) -> int:
        rows = [(at, f.can_id | (_EFF_FLAG if f.extended else 0) | (_RTR_FLAG if f.rtr else 0), f.dlc,
                 b"" if f.rtr else f.data) for at, f in batch]
        (taken,) = self._sim._conn.method(ROOT_PATH, FLEET_IFACE, "QueueFrames", "sa(xuyay)", (self.bus, rows))
        return int(taken)

    def _run(self) -> None:
        try:
            self._play()
        except BaseException as e:  # handed to wait()
            self._error = e

    def _play(self) -> None:
        frames = self._frames
        start = self._sim_at_start + _LEAD_US
        first = round(frames[0].timestamp * 1e6)
        span = round(frames[-1].timestamp * 1e6) - first
        gap = max(span // (len(frames) - 1), 1) if len(frames) > 1 else 1000
        offset, i, last_at = 0, 0, 0
        batch: List[Tuple[int, Frame]] = []
        while not self._halt.is_set():
            while i < len(frames) and len(batch) < _BATCH:
                at = start + offset + round((round(frames[i].timestamp * 1e6) - first) / self.speed)
                if at > self._sim_now() + _AHEAD_US:
                    break
                batch.append((at, frames[i]))
                last_at = at
                i += 1
            if batch:
                taken = self._queue(batch)
                self.sent += taken
                del batch[:taken]
                if batch:
                    self._halt.wait(_RETRY_S)
                continue
            if i == len(frames):
                if not self.loop:
                    break
                offset += round((span + gap) / self.speed)
                i = 0
                continue
            due = start + offset + round((round(frames[i].timestamp * 1e6) - first) / self.speed) - _AHEAD_US
            self._halt.wait(min(max(due - self._sim_now(), 0) / 1e6, _IDLE_S))
        while not self._halt.is_set() and self._sim_now() < last_at:  # the last frame has had its time
            self._halt.wait(min((last_at - self._sim_now() + 1000) / 1e6, _IDLE_S))

    def wait(self, timeout: Optional[float] = None) -> int:
        """Until the replay is over; the frames sent. Raises what stopped it
        (cansim.Refused from cansimd ...), or cansim.Timeout."""
        self._thread.join(timeout)
        if self._thread.is_alive():
            from .errors import Timeout
            raise Timeout(f"the replay onto {self.bus} is still running after {timeout} s ({self.sent} sent)")
        if self._error is not None:
            raise self._error
        return self.sent

    def stop(self) -> int:
        """Stops handing frames over (those already queued are still sent); the frames sent."""
        self._halt.set()
        self._thread.join()
        return self.sent

    @property
    def running(self) -> bool:
        return self._thread.is_alive()

    def __enter__(self) -> "Replay":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.stop()

    def __repr__(self) -> str:
        return f"<Replay onto {self.bus}: {self.sent} of {len(self._frames)} frame(s) sent>"


def replay(sim: "Simulator", source: Source, on: str, *, loop: bool = False, filter: FilterSpec = None,
           speed: float = 1.0) -> Replay:
    """Starts a replay (see Simulator.replay)."""
    if not (speed > 0 and speed <= 1000):
        raise ValueError(f"speed {speed!r}: expected a factor above 0, at most 1000 (2: twice as fast)")
    names = [b.name for b in sim.buses()]
    if on not in names:
        raise ValueError(f"replay onto {on!r}: the fleet's buses are {', '.join(names) or 'none'}")
    wanted = parse_filter(filter)
    skipped: List[str] = []
    frames = frames_of(source, skipped)
    kept = [f for f in frames if wanted is None or (f.can_id & wanted[1]) == (wanted[0] & wanted[1])]
    if not kept:
        why = f"{len(frames) - len(kept)} filtered out, " if frames else ""
        raise Error(f"no frame to replay ({why}{len(skipped)} error or CAN FD frame(s) not replayed)")
    return Replay(sim, kept, on, loop, speed, len(frames) - len(kept), len(skipped))
