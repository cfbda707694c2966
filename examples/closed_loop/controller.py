#!/usr/bin/env python3
"""The controller under test of examples/closed_loop: a PI pressure
controller with python-can, outside cansimd, as a PLC would be.

Every cycle (50 ms) it sends SYNC (the Gems transmitter answers on it), the
pump command (0x300: 0.01 % per count) and, closed loop, the vent command by
RPDO1 to the actuator (0x6411:01, 0.01 % of stroke). It reads both
transmitters from their TPDOs and their EMCYs: the Gems 9000 (primary,
INTEGER16 bar x 1000) and the Honeywell DPS (backup, INTEGER32 psi x 1000).
A transmitter that sends an EMCY with an error code, or nothing for 0.5 s,
is broken until its error reset; the controller then holds the pressure
with the other one.

    python3 examples/closed_loop/controller.py --interface vcan0 --setpoint 6

The vent lowers the pressure: more error, more opening (reverse acting).
"""

from __future__ import annotations

import argparse
import struct
import threading
import time
from dataclasses import dataclass, field
from typing import List, Optional, Tuple

import can

PSI = 0.0689475729  # bar
NMT, SYNC = 0x000, 0x080
PUMP_COMMAND = 0x300
ACTUATOR_ID = 0x30


@dataclass
class Transmitter:
    """One pressure transmitter as the controller reads it."""

    name: str
    node_id: int
    bar_of: "object"  # data -> gauge bar
    value: Optional[float] = None
    seen: float = 0.0  # monotonic time of the last value
    error: bool = False  # an EMCY with an error code, until the error reset
    emcys: List[Tuple[float, int]] = field(default_factory=list)

    def healthy(self, now: float) -> bool:
        return not self.error and self.value is not None and now - self.seen < 0.5


def frame_filters(ids: List[int]) -> List[dict]:
    """Receive filters for these CAN-IDs (the process sees no other frame).
    No "extended" key: python-can's socketcand client marks every frame
    extended, so a filter on the frame format would drop them all there."""
    return [{"can_id": i, "can_mask": 0x1FFFFFFF} for i in ids]


def gems_bar(data: bytes) -> float:  # TPDO: 0x7130:01 INTEGER16, 0x6132 = 3 decimals, bar
    return struct.unpack_from("<h", data)[0] / 1000.0


def dps_bar(data: bytes) -> float:  # TPDO1: 0x6130:01 INTEGER32, 3 decimals, psi
    return struct.unpack_from("<i", data)[0] / 1000.0 * PSI


@dataclass
class Sample:
    """What the controller saw and did in one cycle (for a bench's checks)."""

    t: float  # time.time()
    pressure: Optional[float]  # the measurement it used, bar gauge
    source: str  # which transmitter
    opening: float  # vent command, %
    pump: float  # pump command, %


class PressureController:
    """PI on the vent: opening = Kp e + Ki integral(e), e = p - setpoint.

    Open loop (``closed = False``) it sends the commands it is given; closed
    loop it computes the opening. ``history`` keeps every cycle."""

    def __init__(self, bus: can.BusABC, *, setpoint: float = 6.0, kp: float = 15.0, ki: float = 9.0,
                 period: float = 0.05, pump: float = 80.0, opening: float = 50.0) -> None:
        self.bus = bus
        self.setpoint = setpoint
        self.kp, self.ki = kp, ki
        self.period = period
        self.pump = pump
        self.opening = opening
        self.closed = False
        self.transmitters = [Transmitter("gems", 0x11, gems_bar), Transmitter("dps", 0x12, dps_bar)]
        self.history: List[Sample] = []
        self._integral = opening
        self._stop = threading.Event()
        self._thread: Optional[threading.Thread] = None
        self._lock = threading.Lock()

    # ------------------------------------------------------------ commands
    def send(self, can_id: int, data: bytes) -> None:
        self.bus.send(can.Message(arbitration_id=can_id, data=data, is_extended_id=False))

    def filters(self) -> List[dict]:
        """What the controller reads: the transmitters' TPDOs and EMCYs."""
        return frame_filters([0x180 + t.node_id for t in self.transmitters] + [0x80 + t.node_id for t in self.transmitters])

    def start_nodes(self) -> None:
        self.send(NMT, bytes([0x01, 0x00]))  # NMT start all

    def close_loop(self) -> None:
        """Closed loop from now, bumpless (the integral starts at the opening)."""
        with self._lock:
            self._integral = self.opening
            self.closed = True

    def open_loop(self, opening: float, pump: Optional[float] = None) -> None:
        with self._lock:
            self.closed = False
            self.opening = opening
            if pump is not None:
                self.pump = pump

    # ------------------------------------------------------------ the cycle
    def measurement(self, now: float) -> Tuple[Optional[float], str]:
        for t in self.transmitters:
            if t.healthy(now):
                return t.value, t.name
        return None, "none"

    def read(self, deadline: float) -> None:
        while True:
            msg = self.bus.recv(max(0.0, deadline - time.monotonic()))
            if msg is None:
                return
            for t in self.transmitters:
                if msg.arbitration_id == 0x180 + t.node_id and len(msg.data) >= 2:
                    t.value = t.bar_of(bytes(msg.data))
                    t.seen = time.monotonic()
                elif msg.arbitration_id == 0x80 + t.node_id and len(msg.data) >= 2:
                    code = msg.data[0] | (msg.data[1] << 8)
                    t.error = code != 0
                    t.emcys.append((msg.timestamp, code))

    def step(self) -> None:
        now = time.monotonic()
        p, source = self.measurement(now)
        with self._lock:
            if self.closed and p is not None:
                e = p - self.setpoint
                unclamped = self._integral + self.ki * e * self.period
                self._integral = min(100.0, max(0.0, unclamped))  # anti-windup: the valve's stroke
                self.opening = min(100.0, max(0.0, self.kp * e + self._integral))
            opening, pump = self.opening, self.pump
        self.send(SYNC, b"")
        self.send(PUMP_COMMAND, struct.pack("<H", round(pump * 100)))
        self.send(0x200 + ACTUATOR_ID, struct.pack("<Hhhh", round(opening * 100), 0, 0, 0))
        self.history.append(Sample(time.time(), p, source, opening, pump))

    def run(self) -> None:
        next_cycle = time.monotonic()
        while not self._stop.is_set():
            self.step()
            next_cycle += self.period
            self.read(next_cycle)
            if time.monotonic() > next_cycle + 5 * self.period:  # far behind (a loaded host): no burst of cycles
                next_cycle = time.monotonic()

    def start(self) -> "PressureController":
        self._thread = threading.Thread(target=self.run, name="pressure-controller", daemon=True)
        self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        if self._thread:
            self._thread.join(timeout=5)

    def __enter__(self) -> "PressureController":
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--interface", default="vcan0")
    p.add_argument("--bustype", default="socketcan", help="python-can interface (socketcan, socketcand ...)")
    p.add_argument("--setpoint", type=float, default=6.0, help="bar gauge")
    p.add_argument("--pump", type=float, default=80.0, help="pump speed, %%")
    args = p.parse_args()
    with can.Bus(interface=args.bustype, channel=args.interface) as bus:
        controller = PressureController(bus, setpoint=args.setpoint, pump=args.pump)
        bus.set_filters(controller.filters())
        controller.start_nodes()
        controller.close_loop()
        with controller:
            try:
                while True:
                    time.sleep(1)
                    s = controller.history[-1] if controller.history else None
                    if s:
                        print(f"{s.pressure if s.pressure is not None else float('nan'):6.3f} bar ({s.source}), "
                              f"vent {s.opening:5.1f} %", flush=True)
            except KeyboardInterrupt:
                pass


if __name__ == "__main__":
    main()
