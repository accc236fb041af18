"""What every scenario script shares. Runs inside a library venv: standard library only.

A scenario is a plain script that drives the real, unmodified ``buildhat`` library over the emulator's
pty and prints what the library reported, one JSON record per line, for the test to judge. World
changes (a sensor reading, a shaft turned) go through the emulator's control channel with
:func:`ctl`; the values always come from the test (``PARAMS``), so the expectation lives in one place.
"""
from __future__ import annotations

import json
import os
import socket
import sys
import threading
import time
import traceback
from typing import Any, Callable, Optional

os.environ.setdefault("GPIOZERO_PIN_FACTORY", "mock")

_ARG = json.loads(sys.argv[1])
PTY: str = _ARG["pty"]
CONTROL: str = _ARG["control"]
PARAMS: dict = _ARG.get("params", {})
_T0 = time.monotonic()
_LOCK = threading.Lock()


def emit(name: str, value: Any) -> None:
    """One result record (callbacks run on library threads, hence the lock)."""
    line = json.dumps({"name": name, "value": value, "t": round(time.monotonic() - _T0, 3)}, default=repr)
    with _LOCK:
        sys.stdout.write(line + "\n")
        sys.stdout.flush()


def ctl(line: str) -> str:
    """One control-channel action; returns the text after ``ok``. A refusal stops the scenario."""
    with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as sock:
        sock.settimeout(10)
        sock.connect(CONTROL)
        sock.sendall(line.encode() + b"\n")
        data = b""
        while not data.endswith(b"\n"):
            chunk = sock.recv(65536)
            if not chunk:
                break
            data += chunk
    reply = data.decode(errors="replace").strip()
    if reply == "ok":
        return ""
    if reply.startswith("ok "):
        return reply[3:]
    raise RuntimeError(f"control {line!r} refused: {reply!r}")


def ctl_all(lines: Any) -> None:
    for line in lines or ():
        ctl(line)


def connect(buildhat) -> Any:
    """``Hat(device=PTY)``, with the library's own debug log on where it has one (0.6+), so a failing
    run shows every line the library sent and received (the runner collects the log)."""
    import inspect

    options = {"debug": True} if "debug" in inspect.signature(buildhat.Hat).parameters else {}
    started = time.monotonic()
    hat = buildhat.Hat(device=PTY, **options)
    emit("connected", round(time.monotonic() - started, 2))
    return hat


def library_version() -> str:
    try:
        from importlib.metadata import version
        return version("buildhat")
    except Exception:  # noqa: BLE001 - metadata missing means an odd install; say so in the output
        return "unknown"


def step(name: str, fn: Callable[[], Any]) -> Optional[Any]:
    """Run one library call, record its value (or its exception, and carry on with the next step)."""
    emit(f"{name}.start", None)
    try:
        value = fn()
    except Exception as exc:  # noqa: BLE001 - the test decides whether this step was allowed to fail
        emit(f"{name}.error", f"{type(exc).__name__}: {exc}")
        return None
    emit(name, value)
    return value


def wait_for(predicate: Callable[[], bool], seconds: float, poll: float = 0.02) -> bool:
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(poll)
    return predicate()


def run(main: Callable[[], None]) -> None:
    """Run the scenario; a crash is recorded with its traceback and gives exit status 1."""
    emit("library", library_version())
    try:
        main()
    except BaseException:  # noqa: BLE001 - report everything, including KeyboardInterrupt
        emit("crash", traceback.format_exc())
        sys.stdout.flush()
        os._exit(1)
    emit("finished", True)
