"""The seam of emulator/services.py: a port and the fault monitor built and ticked with a small
fake of the services they declare, no ``Hat``. The fakes implement only what the Protocols name,
so a part that reached for anything else would fail here with AttributeError.

Expectations come from FIRMWARE-FACTS §4.2 (state 0 resets the controller), §5 (passive
detection: 6 matching scans of about 98 ms on R3+; power-fault timing) and §7.4 (debug 4 line,
R3+ signature 0x0C40 for passive ID 8).
"""
from __future__ import annotations

from typing import Any, Dict, List, Tuple, Union

from buildhat_conformance.emulator.motor.pwm_drive import Duty
from buildhat_conformance.emulator.ports.device_uart import PortUart
from buildhat_conformance.emulator.ports.port import Port
from buildhat_conformance.emulator.power_faults import FaultMonitor
from buildhat_conformance.emulator.services import FaultServices, PortServices, UartServices
from buildhat_conformance.protocol.profiles import Profile, get_profile

CRLF = b"\r\n"


class _Output:
    def __init__(self) -> None:
        self.out = bytearray()
        self.lines_at: List[Tuple[int, bytes]] = []
        self.now = 0

    def emit(self, line: Union[bytes, str]) -> None:
        data = line.encode() if isinstance(line, str) else bytes(line)
        self.out += data + CRLF
        self.lines_at.append((self.now, data))

    def write_out(self, data: bytes) -> None:
        self.out += data


class _Controller:
    """What a port may use of its controller (services.ControllerLink)."""

    def __init__(self) -> None:
        self.resets = 0

    def reset(self) -> None:
        self.resets += 1

    def autopower(self) -> None:
        pass

    def motor_output(self) -> Duty:
        return 0


class FakePortServices(_Output):
    def __init__(self, profile: Profile, debug: int = 0) -> None:
        super().__init__()
        self.profile = profile
        self.debug = debug
        self.seed = 0
        self.controllers = [_Controller() for _ in range(4)]
        self.events: List[Tuple[str, Dict[str, Any]]] = []
        self.wakes = 0

    def event(self, kind: str, **fields: Any) -> None:
        self.events.append((kind, fields))

    def note(self, text: str) -> None:
        self.event("note", text=text)

    def wake(self) -> None:
        self.wakes += 1

    def tx_pending(self) -> int:
        return 0


class _Wakeable:
    def __init__(self) -> None:
        self.wakes = 0

    def wake(self) -> None:
        self.wakes += 1


class FakeFaultServices(_Output):
    def __init__(self, profile: Profile) -> None:
        super().__init__()
        self.profile = profile
        self.ports: List[_Wakeable] = [_Wakeable() for _ in range(4)]   # Wakeables that count
        self.wakes = 0

    def wake(self) -> None:
        self.wakes += 1


class FakeUartServices(_Output):
    def __init__(self, debug: int = 0) -> None:
        super().__init__()
        self.debug = debug
        self.events: List[Tuple[str, Dict[str, Any]]] = []

    def event(self, kind: str, **fields: Any) -> None:
        self.events.append((kind, fields))

    def note(self, text: str) -> None:
        self.events.append(("note", {"text": text}))


def _run(services: _Output, part: Any, until: int) -> None:
    for now in range(1, until + 1):
        services.now = now
        if now >= part.due:
            part.tick(now)


def test_a_port_detects_a_passive_device_through_a_fake_of_its_services():
    profile = get_profile("R7")
    fake = FakePortServices(profile, debug=4)
    services: PortServices = fake          # the fake satisfies the Protocol (pyright checks it)
    port = Port(services, 2)
    port.plug(("passive", 8))
    assert fake.wakes >= 1                 # a world action wakes the scheduler
    _run(fake, port, 1000)
    lines = [line for _, line in fake.lines_at]
    assert b"P2: D5 signature=0C40 id=8" in lines
    connected = [at for at, line in fake.lines_at if line == b"P2: connected to passive ID 8"]
    assert len(connected) == 1
    # Six matching scans of about 98 ms (R3+) before the line: about 0.5-0.6 s after plug-in.
    assert 6 * 90 <= connected[0] <= 700
    assert fake.controllers[2].resets >= 1          # state 0 ran port_initpwm (§4.2)
    assert all(c.resets == 0 for i, c in enumerate(fake.controllers) if i != 2)
    assert port.connected and port.describe() == ["P2: connected to passive ID 8"]


def test_the_fault_monitor_reports_through_a_fake_of_its_services():
    fake = FakeFaultServices(get_profile("R7"))
    services: FaultServices = fake
    monitor = FaultMonitor(services)
    monitor.port_fault(True)
    assert fake.wakes == 1
    _run(fake, monitor, 1100)
    at = [t for t, line in fake.lines_at if line == b"Port power fault"]
    # Low for more than 10 ms, then every 1000 ms while low (§5).
    assert len(at) == 2 and 11 <= at[0] <= 12 and at[1] - at[0] == 1000
    monitor.motor_fault(True, 1)
    assert fake.ports[1].wakes >= 1        # a latched driver changes what port 1's motor sees
    assert monitor.output_disabled(1) and not monitor.output_disabled(0)


def test_a_port_uart_syncs_on_silence_and_overruns_its_queue_through_a_fake():
    # §10: parsing starts after 100 ms of silence; §5 item 6: "MQ overrun!" when a port's 4-slot
    # queue is full; §7.4 debug 1: each byte as 2 hex digits and the receiver state (n: waiting
    # for sync), ACK after an ACK type byte, no separators.
    fake = FakeUartServices(debug=1)
    services: UartServices = fake
    uart = PortUart(services, 1)
    uart.receive(500.0, 0x04)
    assert fake.out == b"" and not uart.queue           # UART off: the byte is lost
    uart.start(1000)
    uart.receive(1050.0, 0x04)                           # 50 ms after switching on: no sync yet
    uart.receive(1140.0, 0x04)                           # 90 ms after that byte: still none
    assert not uart.queue and fake.out == b"04n04n"
    uart.receive(1240.5, 0x04)                           # 100.5 ms of silence: synced, parsed
    assert [m.header for m in uart.queue] == [0x04] and fake.out.endswith(b"04ACK")
    for i in range(1, 5):
        uart.receive(1240.5 + i / 10, 0x04)
    assert len(uart.queue) == 4                          # the fifth found the queue full
    assert fake.lines_at == [(0, b"MQ overrun!")]
    assert [k for k, _ in fake.events] == ["devrx"] * 5
