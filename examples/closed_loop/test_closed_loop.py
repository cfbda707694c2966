"""The closed loop on the wire (examples/closed_loop/README.md): cansimd runs
the vessel, the actuator and two transmitters; the PI controller of
controller.py (python-can, outside cansimd) holds 6 bar; this bench watches
the bus with its own python-can socket and checks what goes over it.

    CANSIMD=build/cansimd PYTHONPATH=python python3 -m pytest -q examples/closed_loop
"""

import math
import os
import re
import struct
import sys
import time

import can
import pytest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from controller import PSI, PressureController, frame_filters  # noqa: E402

pytest_plugins = ["cansim.pytest_plugin"]

HERE = os.path.dirname(os.path.abspath(__file__))
with open(os.path.join(HERE, "fleet.yaml"), encoding="utf-8") as f:
    FLEET = f.read()

# The plant's analytic solution (docs/plants.md): in the choked regime the
# vessel is a first-order system. C = V / (R T) [kg/Pa]; the vent's Kv law,
# choked: m = c p1 with c = 257 Kv x rho_n / (3600 1e5 sqrt(rho_n T1))
# [kg/s per Pa]; the compressor m = speed x flow. tau = C / c, p = m / c.
R_AIR, T = 287.05, 293.15
RHO_N = 101325.0 / (R_AIR * 273.15)
V = float(re.search(r"volume: ([0-9.]+) l", FLEET).group(1)) * 1e-3
KV = float(re.search(r"kv: ([0-9.]+)", FLEET).group(1))
FLOW = float(re.search(r"flow: ([0-9.]+) Nl/min", FLEET).group(1)) / 60000.0 * RHO_N  # kg/s at full speed
ATM = 1.01325  # bar: the transmitters read gauge pressure
# What each transmitter's value may be off by: the Gems' resolution (1 mbar
# in its INTEGER16 PV) and noise; the DPS's total error band (2 psi).
ACCURACY = {"gems": 0.01, "dps": 2.0 * PSI + 0.01}


def vent_coefficient(opening_percent):
    return 257.0 * KV * opening_percent / 100.0 * RHO_N / (3600.0 * 1e5 * math.sqrt(RHO_N * T))


def analytic(opening_percent, pump_percent):
    """(tau in s, final gauge pressure in bar) of the vessel."""
    c = vent_coefficient(opening_percent)
    return V / (R_AIR * T) / c, pump_percent / 100.0 * FLOW / c / 1e5 - ATM


@pytest.fixture(scope="module")
def cansim_config():
    return FLEET


@pytest.fixture(scope="module")
def controller(cansim):
    # The controller's own python-can bus: SocketCAN on vcan0, the socketcand
    # client where there is no kernel CAN (the plugin's kernel-free bus).
    with cansim.open_bus() as bus:
        c = PressureController(bus, setpoint=6.0, pump=30.0, opening=50.0)
        bus.set_filters(c.filters())  # a PLC's receive filters: python-can sees only what it reads
        c.start_nodes()
        with c:
            yield c


@pytest.fixture(scope="module")
def bench(cansim_bus):
    """The bench's own socket, seeing the transmitters' TPDOs and the vent commands (RPDO1 to the actuator)."""
    cansim_bus.set_filters(frame_filters([0x191, 0x192, 0x230]))
    return cansim_bus


def received(bus, seconds):
    """The frames the bench receives from now on, for `seconds`."""
    out, start, end = [], time.time(), time.monotonic() + seconds
    while time.monotonic() < end:
        m = bus.recv(max(0.0, end - time.monotonic()))
        if m is not None and m.timestamp >= start:
            out.append(m)
    return out


def transmitter_frames(bus, seconds):
    """(time, transmitter, gauge bar) of every TPDO of both transmitters for `seconds`."""
    out = []
    for m in received(bus, seconds):
        if m.arbitration_id == 0x191 and len(m.data) >= 2:
            out.append((m.timestamp, "gems", struct.unpack_from("<h", m.data)[0] / 1000.0))
        elif m.arbitration_id == 0x192 and len(m.data) >= 4:
            out.append((m.timestamp, "dps", struct.unpack_from("<i", m.data)[0] / 1000.0 * PSI))
    return out


def diagnosis(controller, vessel):
    """What the controller did lately and what the plant's inputs are: for a failure's message."""
    lines = [f"{s.t:.3f} {s.source} {s.pressure} vent {s.opening:.1f} pump {s.pump:.0f}" for s in controller.history[-30:]]
    gaps = [b.t - a.t for a, b in zip(controller.history[-200:], controller.history[-199:])]
    return "\n".join(lines + [f"longest cycle of the last 200: {max(gaps, default=0):.3f} s"] +
                     [str(i) for i in vessel.inputs()])


def until(check, timeout, what):
    deadline = time.monotonic() + timeout
    while not check():
        assert time.monotonic() < deadline, what
        time.sleep(0.05)


def fit_first_order(samples):
    """Least squares p(t) = a + b exp(-t / tau): (tau, a)."""
    t0 = samples[0][0]
    ts = [t - t0 for t, _ in samples]
    ps = [p for _, p in samples]

    def solve(tau):
        xs = [math.exp(-t / tau) for t in ts]
        n, sx, sy = len(xs), sum(xs), sum(ps)
        sxx, sxy = sum(x * x for x in xs), sum(x * y for x, y in zip(xs, ps))
        b = (n * sxy - sx * sy) / (n * sxx - sx * sx)
        a = (sy - b * sx) / n
        return sum((a + b * x - y) ** 2 for x, y in zip(xs, ps)), a

    lo, hi = 0.2, 20.0
    for _ in range(80):  # golden section on tau
        m1, m2 = lo + 0.382 * (hi - lo), lo + 0.618 * (hi - lo)
        if solve(m1)[0] < solve(m2)[0]:
            hi = m2
        else:
            lo = m1
    tau = (lo + hi) / 2
    return tau, solve(tau)[1]


def test_open_loop_step_response(cansim, bench, controller):
    """The pump steps from 30 % to 60 % with the vent held at 50 %: both
    transmitters report the vessel's first-order response (tau within 5 %,
    final value within the transmitter's accuracy)."""
    controller.open_loop(opening=50.0, pump=30.0)
    vessel = cansim.plant("vessel")
    until(lambda: abs(vessel.valve - 50.0) < 0.05, 15, "the vent reached 50 %")
    until(lambda: vessel.pressure > 2.2, 15, "the vessel is choked (above 2 bar absolute)")
    controller.open_loop(opening=50.0, pump=60.0)
    tau, final = analytic(50.0, 60.0)
    first = len(controller.history)
    frames = transmitter_frames(bench, 5 * tau)
    cycles = [b.t - a.t for a, b in zip(controller.history[first:], controller.history[first + 1:])]
    assert max(cycles) < 0.9, f"the pump command must keep coming (1 s timeout): a cycle took {max(cycles):.2f} s"
    for name in ("gems", "dps"):
        samples = [(t, p) for t, n, p in frames if n == name]
        assert len(samples) > 50, f"{name}: {len(samples)} TPDOs in {5 * tau:.0f} s"
        fitted_tau, fitted_final = fit_first_order(samples)
        print(f"{name}: tau {fitted_tau:.3f} s (analytic {tau:.3f} s), final {fitted_final:.4f} bar "
              f"(analytic {final:.4f} bar)")
        assert abs(fitted_tau - tau) <= 0.05 * tau, name
        assert abs(fitted_final - final) <= ACCURACY[name], name


def settled(bus, name, target, tolerance, seconds):
    samples = [p for _, n, p in transmitter_frames(bus, seconds) if n == name]
    return bool(samples) and all(abs(p - target) <= tolerance for p in samples)


def test_the_loop_holds_6_bar(cansim, bench, controller):
    controller.open_loop(opening=controller.opening, pump=80.0)
    controller.close_loop()
    until(lambda: settled(bench, "gems", 6.0, 0.05, 2.0), 60, "6 bar within 60 s")
    frames = transmitter_frames(bench, 2.0)
    gems = [p for _, n, p in frames if n == "gems"]
    dps = [p for _, n, p in frames if n == "dps"]
    assert gems and dps
    assert abs(sum(gems) / len(gems) - 6.0) < 0.02
    # The other vendor's transmitter reports the same vessel, within its accuracy.
    assert abs(sum(dps) / len(dps) - 6.0) < ACCURACY["dps"]


def mean(values):
    return sum(values) / len(values)


def test_the_controller_answers_a_leak(cansim, bench, controller):
    until(lambda: settled(bench, "gems", 6.0, 0.05, 1.0), 60, "settled at 6 bar")
    level = {n: mean([p for _, m, p in transmitter_frames(bench, 1.0) if m == n]) for n in ("gems", "dps")}
    before = controller.opening
    vessel = cansim.plant("vessel")
    with vessel.fault("leak", target="tank", kv=0.1):
        seen = []

        def dipped():
            seen.extend(transmitter_frames(bench, 0.25))
            return any(n == "gems" and p < 5.95 for _, n, p in seen)

        until(dipped, 10, "the leak shows on the Gems")
        seen.extend(transmitter_frames(bench, 0.5))
        depth = level["gems"] - min(p for _, n, p in seen if n == "gems")
        # The DPS saw the same dip (the same vessel): at least half as deep below its own level.
        dps_depth = level["dps"] - min(p for _, n, p in seen if n == "dps")
        assert dps_depth > depth / 2, f"Gems dipped {depth:.3f} bar, DPS {dps_depth:.3f} bar"
        until(lambda: settled(bench, "gems", 6.0, 0.05, 1.0), 60, "back at 6 bar despite the leak")
        # The controller closed the vent to make up for the leak: on the wire, RPDO1 to the actuator.
        rpdo = [m for m in received(bench, 0.3) if m.arbitration_id == 0x230]
        assert rpdo, "the controller commands the vent"
        commanded = struct.unpack_from("<H", rpdo[-1].data)[0] / 100.0
        assert commanded < before - 10.0, f"vent {before:.1f} % before the leak, {commanded:.1f} % with it"


def test_a_broken_transmitter_and_the_other_one(cansim, bench, controller):
    until(lambda: settled(bench, "gems", 6.0, 0.05, 1.0), 60, "settled at 6 bar")
    gems, dps = controller.transmitters
    vessel = cansim.plant("vessel")
    with cansim.node("pt-gems").fault("open"):
        until(lambda: gems.error, 5, "the Gems' EMCY reached the controller")
        assert gems.emcys and gems.emcys[-1][1] == 0x2201  # sensor failure (Gems manual Fig. 28)
        until(lambda: controller.history[-1].source == "dps", 5, "the controller switched to the DPS")
        frames = transmitter_frames(bench, 3.0)
        backup = [(t, p) for t, n, p in frames if n == "dps"]
        assert len(backup) >= 20, "the DPS keeps reporting (every 100 ms)"
        # It reports the same vessel: the plant's pressure, within its accuracy; the loop holds on it.
        truth = vessel.pressure - ATM
        why = diagnosis(controller, vessel)
        assert abs(backup[-1][1] - truth) < ACCURACY["dps"] + 0.05, why
        assert abs(truth - 6.0) < ACCURACY["dps"] + 0.05, why
    until(lambda: not gems.error, 5, "the Gems' error reset")
    until(lambda: controller.history[-1].source == "gems", 5, "back on the Gems")
