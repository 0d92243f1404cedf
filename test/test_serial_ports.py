"""device_name serial:<USB serial number>: the adapter found among by-id links (a folder of links
made here, pointing at virtual buses) or pyserial's port list, and the node says which it chose."""
from __future__ import annotations

import os
from types import SimpleNamespace

import pytest

from dynamixel_handler.errors import StartupError
from dynamixel_handler.serial_ports import BY_ID_ENV, resolve, serial_of_link
from dynamixel_handler.sim import VirtualBus

from support.rig import Rig, X
from support.ros import NodeProcess, node_command

FTDI = "usb-FTDI_USB__-__Serial_Converter_{}-if00-port0"


def _links(folder, targets: dict[str, str]) -> None:
    folder.mkdir(exist_ok=True)
    for name, target in targets.items():
        os.symlink(target, folder / name)


def test_serial_numbers_are_read_from_by_id_link_names():
    assert serial_of_link(FTDI.format("FT4TFSJ1")) == "FT4TFSJ1"
    assert serial_of_link("usb-ROBOTIS_OpenRB-150_0C4D5E6F50304B5A2E3120FF0A1D1A1D-if00") == \
        "0C4D5E6F50304B5A2E3120FF0A1D1A1D"
    assert serial_of_link("usb-1a86_USB_Serial-if00-port0") == "Serial"  # no number of its own: the last word
    assert serial_of_link("not-a-usb-link") is None


def test_resolve_picks_the_link_with_the_serial_number_and_lists_the_others_when_missing(tmp_path):
    a, b = tmp_path / "ttyUSB3", tmp_path / "ttyACM0"
    a.touch()
    b.touch()
    by_id = tmp_path / "by-id"
    _links(by_id, {FTDI.format("AB12CD"): str(a), "usb-ROBOTIS_OpenRB-150_99887766-if00": str(b)})
    none = lambda: []  # noqa: E731 (no pyserial ports)
    path, line = resolve("serial:AB12CD", str(by_id), none)
    assert path == str(by_id / FTDI.format("AB12CD"))  # the link, which survives a re-enumeration
    assert "AB12CD" in line and str(a) in line and "by-id" in line
    assert resolve("serial:ab12cd", str(by_id), none)[0] == path  # case does not matter when unambiguous
    assert resolve("/dev/ttyUSB0", str(by_id), none) == ("/dev/ttyUSB0", None)
    with pytest.raises(StartupError) as err:
        resolve("serial:ZZZ", str(by_id), none)
    assert f"AB12CD ({a})" in str(err.value) and f"99887766 ({b})" in str(err.value)
    with pytest.raises(StartupError, match="gives no serial number"):
        resolve("serial:", str(by_id), none)
    # pyserial's list where no link has it (no udev, e.g. in a container)
    ports = lambda: [SimpleNamespace(device="/dev/ttyUSB7", serial_number="PY777")]  # noqa: E731
    assert resolve("serial:PY777", str(tmp_path / "missing"), ports)[0] == "/dev/ttyUSB7"


def test_the_node_opens_the_adapter_named_by_its_serial_number(tmp_path):
    by_id = tmp_path / "by-id"
    decoy = VirtualBus(servos={}, wire_timing=False)
    decoy_path = decoy.start()
    rig = None
    try:
        def link(sim: VirtualBus) -> None:
            _links(by_id, {FTDI.format("DXL0001"): sim.path, FTDI.format("OTHER99"): decoy_path})
        rig = Rig({1: X}, "device_name:=serial:DXL0001", before_start=link, env={BY_ID_ENV: str(by_id)})
        line = rig.wait_log("device_name 'serial:DXL0001': adapter")
        # the tty the by-id link leads to (the rig's bus is itself a link to its pty)
        assert FTDI.format("DXL0001") in line and f"(now {os.path.realpath(rig.sim.path)}," in line
    finally:
        if rig is not None:
            assert rig.close() == 0
        decoy.close()


def test_an_unknown_serial_number_stops_the_node_with_the_adapters_seen(tmp_path):
    by_id = tmp_path / "by-id"
    sim = VirtualBus(servos={1: X}, wire_timing=False)
    try:
        _links(by_id, {FTDI.format("DXL0001"): sim.start()})
        node = NodeProcess(node_command("device_name:=serial:NOPE42"), env={BY_ID_ENV: str(by_id)})
        assert node.wait_exit() == 1
        fatal = [line for line in node.output.splitlines() if "NOPE42" in line and "FATAL" in line]
        assert len(fatal) == 1 and "adapters seen: DXL0001" in fatal[0]
        assert "Traceback" not in node.output
    finally:
        sim.close()
