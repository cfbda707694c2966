"""cansim: drive cansimd, the simulated CANopen sensor fleet, from Python.

    import cansim

    with cansim.start("config/cansimd.yaml") as sim:
        node = sim.node("generic/0")
        node.pressure.set(8.0, "bar", ramp=3)
        with node.fault("open"):
            print(node.wait_for("NmtStateChanged", timeout=5))

Everything goes through cansimd's D-Bus control API (docs/control-api.md)
with jeepney; the full API is in docs/python.md.
"""

from .errors import Error, NoSuchNode, Refused, Timeout
from .events import EVENT_NAMES, Event, Mark
from .node import Channel, Emcy, Fault, FaultState, Node, NodeState, Reading
from .simulator import BusStatistics, Simulator, connect, find_binary, start

__version__ = "0.1.0"

__all__ = [
    "start", "connect", "find_binary",
    "Simulator", "Node", "Channel", "Fault", "Event", "Mark",
    "NodeState", "Reading", "Emcy", "FaultState", "BusStatistics", "EVENT_NAMES",
    "Error", "NoSuchNode", "Refused", "Timeout",
]
