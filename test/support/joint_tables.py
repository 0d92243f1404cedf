"""A servo table of XM430-W350s at given angles, for the joint maths' tests (no bus)."""
from __future__ import annotations

from dynamixel_handler.control_table import model_by_number
from dynamixel_handler.servo.table import ServoTable

XM430 = 1020


def table_at(servo_deg: dict[int, float], number: int = XM430) -> ServoTable:
    """Servos of model ``number`` whose present positions read ``servo_deg`` (ID: deg), to a pulse."""
    table = ServoTable()
    model = model_by_number(number)
    for dxl_id, deg in servo_deg.items():
        table.add(dxl_id, model)
        table.set_value("present_position", dxl_id, model.position_zero_pulse + round(deg / model.position_deg_per_pulse))
    return table
