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

from ._decode import MappedEntry, PdoMapping
from ._replay import Replay
from ._wire import BusAddress, Capture, read_candump, write_candump
from .errors import Error, NoSuchNode, Refused, Timeout
from .events import EVENT_NAMES, Event, Mark
from .node import Channel, Emcy, Fault, FaultState, Node, NodeState, Reading
from .pdo import PdoSample, Tpdo
from .plant import Plant, PlantFault, PlantInput, Quantity
from .simulator import BusStatistics, Simulator, connect, find_binary, start

__version__ = "0.1.0"

__all__ = [
    "start", "connect", "find_binary",
    "Simulator", "Node", "Channel", "Fault", "Event", "Mark",
    "NodeState", "Reading", "Emcy", "FaultState", "BusStatistics", "EVENT_NAMES",
    "Capture", "BusAddress", "Tpdo", "PdoSample", "PdoMapping", "MappedEntry", "read_candump", "write_candump", "Replay",
    "Error", "NoSuchNode", "Refused", "Timeout",
    "Plant", "PlantInput", "PlantFault", "Quantity",
]
