"""A plant of the fleet's ``plants:`` section (docs/plants.md): its
variables in units, its inputs and their overrides, its faults.

    vessel = sim.plant("vessel")
    vessel.pressure                       # Quantity(7.01, 'bar'): a float, with .unit
    vessel.value("pressure", "psi")       # the same in psi
    vessel.input("valve").override(40, "%")
    with vessel.fault("leak", target="tank", kv=0.05):
        ...
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Dict, List, NamedTuple, Optional, Tuple, Union

from .errors import Refused
from .node import _ArmedFault, _fault_texts

if TYPE_CHECKING:
    from .simulator import Simulator

PLANT_IFACE = "io.cansim.Plant1"
_FLEET_PATH = "/io/cansim/Cansimd1"
_FLEET_IFACE = "io.cansim.Fleet1"


class Quantity(float):
    """A plant value: a float in ``unit`` (``""`` for a plain number)."""

    unit: str

    def __new__(cls, value: float, unit: str) -> "Quantity":
        q = super().__new__(cls, value)
        q.unit = unit
        return q

    def __repr__(self) -> str:
        return f"Quantity({float(self)!r}, {self.unit!r})"

    def __str__(self) -> str:
        return f"{float(self):g} {self.unit}".rstrip()


class InputState(NamedTuple):
    """One input of a plant as it is now."""

    name: str
    value: Quantity
    updated: Optional[float]
    """simulated time (s) its source last gave it a value; None: never"""
    source: str
    """where its values come from: ``frame vcan0 0x300 ...``, ``output 1 of node actuator``, ``the control API`` ..."""
    overridden: bool
    stuck: bool
    """a ``valve_stuck`` fault freezes it"""
    lost: bool
    """an ``input_lost`` fault drops what its source sends"""
    timed_out: bool
    """no value for its ``timeout:``: its ``on_timeout`` behaviour shows"""


class PlantInput:
    """An input of a plant: set it as its source would, or override it."""

    def __init__(self, plant: "Plant", name: str) -> None:
        self.plant = plant
        self.name = name

    def __repr__(self) -> str:
        return f"<PlantInput {self.plant.name}.{self.name}>"

    def state(self) -> InputState:
        for s in self.plant.inputs():
            if s.name == self.name:
                return s
        raise Refused("io.cansim.Error.UnknownVariable", f"plant {self.plant.name} has no input {self.name!r}")

    @property
    def value(self) -> Quantity:
        """What the plant uses now, in the input's unit."""
        return self.state().value

    @property
    def age(self) -> Optional[float]:
        """Seconds since its source last gave it a value (None: never)."""
        updated = self.state().updated
        return None if updated is None else max(0.0, self.plant._sim.time - updated)

    def set(self, value: float, unit: Optional[str] = None) -> None:
        """A value as if its source sent it now (an input without a source is
        set this way; a frame's next value replaces it)."""
        self.plant._act("Set", "sds", self.name, float(value), unit or "")

    def override(self, value: float, unit: Optional[str] = None) -> None:
        """The input is ``value`` (``unit``: default the input's own) whatever
        its source says, until clear_override()."""
        self.plant._act("Override", "sds", self.name, float(value), unit or "")

    def clear_override(self) -> None:
        self.plant._act("ClearOverride", "s", self.name)


class PlantFault(_ArmedFault):
    """A fault armed on a plant (``target``: a block or an input); a context
    manager that cancels it on exit."""

    def __init__(self, plant: "Plant", id: int, kind: str, target: str) -> None:
        super().__init__(plant, id, kind)
        self.plant = plant
        self.target = target

    def __repr__(self) -> str:
        return f"<PlantFault {self.id} {self.kind} on {self.plant.name}.{self.target}>"


class Plant:
    """A plant by name. Its variables read as attributes (``plant.pressure``,
    the names docs/plants.md gives: ``BLOCK``, ``OUTPUT`` when one block has
    it, an input's name) or by item (``plant["tank.pressure"]``): each read
    asks cansimd for the value now."""

    _sim: "Simulator"
    path: str
    name: str

    def __init__(self, sim: "Simulator", name: str) -> None:
        (path,) = sim._conn.method(_FLEET_PATH, _FLEET_IFACE, "GetPlant", "s", (str(name),))
        self.__dict__["_sim"] = sim
        self.__dict__["path"] = path
        self.__dict__["name"] = str(name)

    def __repr__(self) -> str:
        return f"<Plant {self.name}>"

    # ------------------------------------------------------------ plumbing
    def _call(self, member: str, signature: Optional[str] = None, *args: Any) -> Tuple[Any, ...]:
        return tuple(self._sim._conn.method(self.path, PLANT_IFACE, member, signature, tuple(args)))

    def _act(self, member: str, signature: Optional[str] = None, *args: Any) -> Tuple[Any, ...]:
        self._sim._action()
        return self._call(member, signature, *args)

    def _get(self, prop: str) -> Any:
        return self._sim._conn.get(self.path, PLANT_IFACE, prop)

    # ------------------------------------------------------------ values
    def value(self, variable: str, unit: Optional[str] = None) -> Quantity:
        """A variable now, in ``unit`` (default: its own: bar, degC, g/s, %...)."""
        value, got_unit = self._call("Get", "ss", variable, unit or "")
        return Quantity(value, got_unit)

    def __getattr__(self, name: str) -> Quantity:
        if name.startswith("_"):
            raise AttributeError(name)
        try:
            return self.value(name)
        except Refused as e:
            if e.name == "io.cansim.Error.UnknownVariable":
                raise AttributeError(f"plant {self.name} has no variable {name!r}") from e
            raise

    def __getitem__(self, variable: str) -> Quantity:
        return self.value(variable)

    def __setattr__(self, name: str, value: Any) -> None:
        raise AttributeError(f"set a plant's inputs with plant.input({name!r}).set(...) or .override(...)")

    def variables(self) -> Dict[str, Quantity]:
        """Every variable now, in its unit, from one call."""
        return {name: Quantity(value, unit) for name, _kind, value, unit in self._get("Variables")}

    @property
    def time(self) -> float:
        """The simulated time (s) the plant has been computed to."""
        return float(self._get("Time")) / 1e6

    @property
    def step(self) -> float:
        """Its fixed step, in seconds."""
        return float(self._get("Step")) / 1e6

    # ------------------------------------------------------------ inputs
    def input(self, name: str) -> PlantInput:
        return PlantInput(self, name)

    def inputs(self) -> List[InputState]:
        out = []
        for name, value, unit, updated, source, overridden, stuck, lost, timed_out in self._get("Inputs"):
            out.append(InputState(name, Quantity(value, unit), None if updated < 0 else updated / 1e6, source,
                                  bool(overridden), bool(stuck), bool(lost), bool(timed_out)))
        return out

    # ------------------------------------------------------------ faults
    def fault(self, kind: str, *, target: str, duration: Optional[Union[float, str]] = None,
              at: Optional[Union[float, str]] = None, **params: Any) -> PlantFault:
        """Arm a plant fault on a block or an input (``target``): ``leak``
        (a gas volume; ``kv=`` of the hole or ``flow=`` a constant outflow),
        ``blocked`` (a valve, pump or line), ``valve_stuck`` (a valve or an
        input), ``input_lost`` (an input). Numbers for ``duration``, ``at``,
        ``after``, ``period`` are seconds; other values YAML text with their
        unit (``flow="2 g/s"``). ``with`` cancels it."""
        texts = _fault_texts(dict(params, target=target), duration, at)
        (fault_id,) = self._act("ArmFault", "sa{ss}", kind, texts)
        return PlantFault(self, int(fault_id), kind, target)

    def faults(self) -> List[PlantFault]:
        """The faults armed on this plant now."""
        return [PlantFault(self, int(f[0]), f[1], f[2]) for f in self._call("ListFaults")[0]]


def plants(sim: "Simulator") -> List[Plant]:
    """Every plant of the fleet."""
    return [Plant(sim, name) for _path, name in sim._conn.method(_FLEET_PATH, _FLEET_IFACE, "ListPlants")[0]]


__all__ = ["Plant", "PlantInput", "PlantFault", "InputState", "Quantity", "plants", "PLANT_IFACE"]
