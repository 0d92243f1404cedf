"""A servo family that does not exist, "Z", as an installed package would add it: its data (a
``ServoFamily``), one behaviour object of its own and its model's control table, given to the
handler through the entry-point group ``dynamixel_handler.families`` (``FamilyPlugin``).

The ZM430-T100 (model number 9001, which no ROBOTIS model has) is an XM430-W350's table under
another number; its one behaviour difference: Hardware Error Status holds overload at bit 0,
overheating at bit 1 and input voltage at bit 2 (the X layout: input voltage 0, overheating 2,
overload 5), and an error reads "Z error 0x01". It has no command messages of its own: it is
driven through the series-independent topics.

The test copies this file into a folder of its own beside a ``z_family-1.0.dist-info`` whose
``entry_points.txt`` names ``PLUGIN`` (and the refused plug-ins below), and puts that folder on the
path of the node and simulator processes only.
"""
from __future__ import annotations

import dataclasses
from typing import Iterable

from dynamixel_handler.control_table import FamilyPlugin, Model, ServoFamily
from dynamixel_handler.control_table.behaviour import FamilyBehaviour

#: the ZM430-T100's model number and the XM430-W350's, whose table it has
NUMBER, XM430 = 9001, 1020
NAME = "ZM430-T100"
#: (cause, bit) of its Hardware Error Status
Z_BITS = (("overload", 0), ("overheating", 1), ("input_voltage", 2))


class ZBehaviour(FamilyBehaviour):
    """Hardware Error Status bits in the Z order (``Z_BITS``), read as "Z error 0x01"."""

    def __init__(self) -> None:
        super().__init__(error_bits=Z_BITS)

    def describe(self, value: int) -> str:
        return f"Z error 0x{value:02X}"


Z = ServoFamily(
    name="Z", title="Z", suffix="z", modes=frozenset({"current", "velocity", "position", "ex_position"}),
    dummy_model=NUMBER, x_table=True, profile_max=32767, multi_turn_goal=1_048_575, behaviour=ZBehaviour(),
    series_topics=False,
)


def z_models(built_in) -> Iterable[Model]:
    return (dataclasses.replace(built_in(XM430), number=NUMBER, name=NAME, family=Z),)


PLUGIN = FamilyPlugin(Z, z_models)

# Plug-ins the handler refuses, each with one log line, the Z family going on.
#: the name of a built-in family
SAME_NAME = FamilyPlugin(dataclasses.replace(Z, name="X", title="Xz", suffix="xz"), z_models)
#: the model number of a built-in model (the XM430-W350's)
SAME_NUMBER = FamilyPlugin(
    dataclasses.replace(Z, name="Z2", title="Z2", suffix="z2", dummy_model=XM430),
    lambda built_in: (dataclasses.replace(built_in(XM430), name="ZM430-T200", family=SAME_NUMBER.family),))
#: not a FamilyPlugin
NOT_A_PLUGIN = Z
