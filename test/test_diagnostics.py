"""/diagnostics: levels follow what the simulated servos do (heat, silence), through the real node."""
from __future__ import annotations

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus

from support.rig import X540, Rig, X

OK, WARN, ERROR = (int.from_bytes(b, "little") for b in (DiagnosticStatus.OK, DiagnosticStatus.WARN, DiagnosticStatus.ERROR))


class Diagnostics:
    def __init__(self, rig: Rig) -> None:
        self.rig = rig
        self.got: list[DiagnosticArray] = []
        with rig._lock:
            rig.node.create_subscription(DiagnosticArray, "/diagnostics", self.got.append, 20)

    def latest(self, starts: str) -> DiagnosticStatus | None:
        for msg in reversed(self.got):
            for status in msg.status:
                if status.name.startswith(starts):
                    return status
        return None

    def wait_level(self, starts: str, level: int, what: str, values: dict[str, str] | None = None) -> DiagnosticStatus:
        """The latest status of ``starts`` once it has ``level`` and the key/values given (a status
        published before a change on the bus was read can still be the latest for a period)."""
        def seen() -> bool:
            s = self.latest(starts)
            if s is None or _level(s) != level:
                return False
            have = {kv.key: kv.value for kv in s.values}
            return all(have.get(k) == v for k, v in (values or {}).items())
        self.rig.wait(seen, timeout=15, what=what)
        return self.latest(starts)

    def wait_value(self, starts: str, key: str, value: str, what: str) -> DiagnosticStatus:
        """The latest status of ``starts`` once its ``key`` reads ``value`` (levels and values move
        with the loop; a snapshot taken right after another status changed may be one period old)."""
        def seen() -> bool:
            s = self.latest(starts)
            return s is not None and {kv.key: kv.value for kv in s.values}.get(key) == value
        self.rig.wait(seen, timeout=15, what=what)
        return self.latest(starts)


def _level(status: DiagnosticStatus) -> int:
    return int.from_bytes(status.level, "little") if isinstance(status.level, bytes) else int(status.level)


def test_servo_levels_follow_temperature_hardware_errors_and_silence():
    rig = Rig({1: X, 2: X540}, "diagnostics.period_sec:=0.2", "pub_ratio/present.temperature:=5",
              "pub_ratio/error:=5", "pub_ratio/status:=5", "pub_ratio/limit:=50")
    try:
        diag = Diagnostics(rig)
        for i in (1, 2):
            rig.sim.servo(i).pin("present_temperature", 40)
        first = diag.wait_level("dynamixel_handler: ID 1 (XM430-W350)", OK, "ID 1 OK at 40 degC",
                                {"temperature [degC]": "40"})
        values = {kv.key: kv.value for kv in first.values}
        assert values["temperature limit [degC]"] == "80"
        assert values["torque"] == "on" and values["ping"] == "true"
        bus = diag.wait_level("dynamixel_handler: bus", OK, "bus OK")
        assert {kv.key for kv in bus.values} >= {"success rate [%]", "loop rate [Hz]", "reconnects", "watchdog trips"}

        rig.sim.servo(1).pin("present_temperature", 77)  # within 5 degC of the 80 degC limit
        warn = diag.wait_level("dynamixel_handler: ID 1", WARN, "ID 1 WARN when hot")
        assert "77 degC" in warn.message and "limit 80" in warn.message
        rig.sim.servo(1).pin("present_temperature", 81)
        err = diag.wait_level("dynamixel_handler: ID 1", ERROR, "ID 1 ERROR when overheating")
        assert "overheating" in err.message
        assert _level(diag.latest("dynamixel_handler: ID 2")) == OK  # the other servo is untouched

        rig.sim.servo(1).pin("present_temperature", 40)
        diag.wait_level("dynamixel_handler: ID 1", OK, "ID 1 back to OK once cool")
        rig.sim.set_hardware_error(2, 0x04)  # overheating error bit
        err = diag.wait_level("dynamixel_handler: ID 2", ERROR, "ID 2 ERROR on a hardware error")
        assert "hardware error: overheating" in err.message

        rig.sim.set_silent(1, True)
        err = diag.wait_level("dynamixel_handler: ID 1", ERROR, "ID 1 ERROR when it stops answering")
        assert "no response" in err.message
        assert {kv.key: kv.value for kv in err.values}["ping"] == "false"
        diag.wait_value("dynamixel_handler: bus", "servos not answering", "1", "the bus counting one silent servo")
        assert _level(diag.latest("dynamixel_handler: ID 2")) == ERROR  # still its hardware error, and answering
        assert {kv.key: kv.value for kv in diag.latest("dynamixel_handler: ID 2").values}["ping"] == "true"
        rig.sim.set_silent(1, False)
        diag.wait_level("dynamixel_handler: ID 1", OK, "ID 1 OK when it answers again")
    finally:
        assert rig.close() == 0


def test_the_bus_status_reports_a_lost_device_as_error(tmp_path):
    rig = Rig({1: X}, "diagnostics.period_sec:=0.2", sim_kwargs={"link": str(tmp_path / "ttyDXL")})
    try:
        diag = Diagnostics(rig)
        diag.wait_level("dynamixel_handler: bus", OK, "bus OK")
        rig.sim.vanish()
        err = diag.wait_level("dynamixel_handler: bus", ERROR, "bus ERROR when the device is gone")
        assert "is gone" in err.message
        rig.sim.reappear()
        warn = diag.wait_level("dynamixel_handler: bus", WARN, "bus WARN right after the reconnect")
        assert "reconnected 1 time(s)" in warn.message
        diag.wait_level("dynamixel_handler: bus", OK, "bus OK again")
    finally:
        assert rig.close() == 0
