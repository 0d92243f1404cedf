"""Torque per ampere of each model with a current sensor, from its e-Manual specification: the
joints' effort in N·m (``joint_state.effort_unit: Nm``) is the present current times this.

It is an approximation: the e-Manual gives a stall torque and a stall current (X, MX 2.0), or a
continuous torque and current (P, PRO), or a maximum torque and current (Y), at one supply voltage;
their ratio stands in for the motor's torque constant, which in truth falls at high current, varies
with temperature and from unit to unit, and ignores the gear's friction. Good to a few tens of
per cent: enough to see a load, not to weigh one. Models without a figure here (no current sensor,
no figure on their page, or figures in doubt) give NaN in N·m."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

_PAGE = "https://emanual.robotis.com/docs/en/dxl/"


@dataclass(frozen=True)
class TorqueFigures:
    """The e-Manual's torque and current of one model, as its page gives them."""

    torque_nm: float
    current_a: float
    volts: float
    kind: str     #: "stall", "continuous" (P, PRO) or "maximum" (Y)
    source: str   #: the e-Manual page

    @property
    def nm_per_a(self) -> float:
        return self.torque_nm / self.current_a


def _x(torque: float, current: float, volts: float, page: str, kind: str = "stall") -> TorqueFigures:
    return TorqueFigures(torque, current, volts, kind, _PAGE + page)


#: model name -> its figures (the supply voltage its page recommends)
TORQUE: dict[str, TorqueFigures] = {
    "XM430-W210": _x(3.0, 2.3, 12.0, "x/xm430-w210/"),
    "XM430-W350": _x(4.1, 2.3, 12.0, "x/xm430-w350/"),
    "XM540-W150": _x(7.3, 4.4, 12.0, "x/xm540-w150/"),
    "XM540-W270": _x(10.6, 4.4, 12.0, "x/xm540-w270/"),
    "XH430-W210": _x(2.5, 1.3, 12.0, "x/xh430-w210/"),
    "XH430-W350": _x(3.4, 1.3, 12.0, "x/xh430-w350/"),
    "XH430-V210": _x(2.6, 0.7, 24.0, "x/xh430-v210/"),
    "XH430-V350": _x(3.3, 0.7, 24.0, "x/xh430-v350/"),
    "XH540-W150": _x(7.1, 4.9, 12.0, "x/xh540-w150/"),
    "XH540-W270": _x(9.9, 4.9, 12.0, "x/xh540-w270/"),
    "XH540-V150": _x(6.4, 2.4, 24.0, "x/xh540-v150/"),
    "XH540-V270": _x(9.2, 2.4, 24.0, "x/xh540-v270/"),
    "XD430-T210": _x(2.5, 1.3, 12.0, "x/xd430-t210/"),
    "XD430-T350": _x(3.4, 1.3, 12.0, "x/xd430-t350/"),
    "XD540-T150": _x(7.1, 4.9, 12.0, "x/xd540-t150/"),
    "XD540-T270": _x(9.9, 4.9, 12.0, "x/xd540-t270/"),
    "XW430-T333": _x(3.1, 1.3, 12.0, "x/xw430-t333/"),
    "XW540-T140": _x(6.9, 4.9, 12.0, "x/xw540-t140/"),
    "XW540-T260": _x(9.5, 4.9, 12.0, "x/xw540-t260/"),
    "XC430-W150": _x(1.6, 1.4, 12.0, "x/xc430-w150/"),
    "XC430-W240": _x(1.9, 1.4, 12.0, "x/xc430-w240/"),
    "XC330-M181": _x(0.60, 1.80, 5.0, "x/xc330-m181/"),
    "XC330-M288": _x(0.93, 1.80, 5.0, "x/xc330-m288/"),
    "XC330-T181": _x(0.76, 0.80, 11.1, "x/xc330-t181/"),
    "XC330-T288": _x(0.92, 0.80, 11.1, "x/xc330-t288/"),
    "XL330-M077": _x(0.215, 1.47, 5.0, "x/xl330-m077/"),
    "XL330-M288": _x(0.52, 1.47, 5.0, "x/xl330-m288/"),
    "MX-64(2.0)": _x(6.0, 4.1, 12.0, "mx/mx-64-2/"),
    "MX-106(2.0)": _x(8.4, 5.2, 12.0, "mx/mx-106-2/"),
    "PH42-020-S300-R": _x(5.1, 1.5, 24.0, "p/ph42-020-s300-r/", "continuous"),
    "PH54-100-S500-R": _x(25.3, 5.5, 24.0, "p/ph54-100-s500-r/", "continuous"),
    "PH54-200-S500-R": _x(44.7, 9.3, 24.0, "p/ph54-200-s500-r/", "continuous"),
    "PM42-010-S260-R": _x(1.7, 0.6, 24.0, "p/pm42-010-s260-r/", "continuous"),
    "PM54-040-S250-R": _x(3.9, 1.9, 24.0, "p/pm54-040-s250-r/", "continuous"),
    "PM54-060-S250-R": _x(10.1, 3.0, 24.0, "p/pm54-060-s250-r/", "continuous"),
    "H42-20-S300-R": _x(5.1, 1.5, 24.0, "pro/h42-20-s300-r/", "continuous"),
    "H54-100-S500-R": _x(25.3, 5.5, 24.0, "pro/h54-100-s500-r/", "continuous"),
    "H54-200-S500-R": _x(44.7, 9.3, 24.0, "pro/h54-200-s500-r/", "continuous"),
    "M42-10-S260-R": _x(1.7, 0.6, 24.0, "pro/m42-10-s260-r/", "continuous"),
    "M54-40-S250-R": _x(3.9, 1.9, 24.0, "pro/m54-40-s250-r/", "continuous"),
    "M54-60-S250-R": _x(10.1, 3.0, 24.0, "pro/m54-60-s250-r/", "continuous"),
    "YM070-210-M001-RH": _x(0.64, 20.8, 24.0, "y/ym070-210-m001-rh/", "maximum"),
    "YM070-210-R051-RH": _x(16.3, 20.8, 24.0, "y/ym070-210-r051-rh/", "maximum"),
    "YM070-210-R099-RH": _x(31.7, 20.8, 24.0, "y/ym070-210-r099-rh/", "maximum"),
    "YM080-230-M001-RH": _x(1.24, 22.4, 24.0, "y/ym080-230-m001-rh/", "maximum"),
    "YM080-230-R051-RH": _x(31.6, 22.4, 24.0, "y/ym080-230-r051-rh/", "maximum"),
    "YM080-230-R099-RH": _x(61.4, 22.4, 24.0, "y/ym080-230-r099-rh/", "maximum"),
}


def torque_figures(model_name: str) -> Optional[TorqueFigures]:
    """The figures of a model (the (A) variants of the PRO take their base model's), None if none."""
    return TORQUE.get(model_name) or TORQUE.get(model_name.removesuffix("(A)"))


__all__ = ["TORQUE", "TorqueFigures", "torque_figures"]
