"""One connection to a labgrid coordinator, through labgrid's own client session.

labgrid's ``ClientSession`` (``labgrid.remote.client``) is asyncio; this wraps the few calls a
run needs in a synchronous face: the places and their state, acquire, release, and a labgrid
``Target`` holding the place's resources (``RemotePlace``, as ``labgrid-client`` builds it).
One session per process and coordinator: labgrid's ``RemotePlaceManager`` is a singleton.
"""
from __future__ import annotations

import asyncio
import contextlib
import logging
import os
import threading
from dataclasses import dataclass, field
from typing import Any, Dict, Iterator, List, Optional, Tuple

from ..targets.base import TargetError
from . import coordinator_address, need_labgrid

__all__ = ["LabClient", "PlaceState", "client_for", "PlaceHeld"]


class PlaceHeld(TargetError):
    """The place is acquired by someone else (or by another run of this user)."""


@dataclass
class PlaceState:
    name: str
    acquired: str = ""                  # "host/user" of the holder, "" when free
    tags: Dict[str, str] = field(default_factory=dict)
    comment: str = ""
    aliases: List[str] = field(default_factory=list)

    def holder_text(self) -> str:
        return f"held by {self.acquired}" if self.acquired else "free"


class LabClient:
    """The coordinator at ``address`` (HOST:PORT). Raises TargetError when it cannot be reached."""

    def __init__(self, address: str = ""):
        need_labgrid()
        # A run forks its pytest child while this session's gRPC threads live; gRPC's fork
        # handlers only warn then (the child never uses the parent's channel).
        os.environ.setdefault("GRPC_ENABLE_FORK_SUPPORT", "false")
        from labgrid.remote.client import Error, start_session

        self.address = coordinator_address(address)
        # labgrid's session lives on an event loop of its own, driven only while we wait on it;
        # grpc's aio channel binds to the loop current at creation, hence set_event_loop.
        self.loop = asyncio.new_event_loop()
        asyncio.set_event_loop(self.loop)
        self._lock = threading.Lock()
        try:
            with _quiet():
                self.session: Any = start_session(self.address, loop=self.loop)
        except (Error, OSError) as exc:
            self.loop.close()
            why = " ".join(" ".join(str(a) for a in exc.args).split()) or type(exc).__name__
            raise TargetError(f"cannot reach the labgrid coordinator at {self.address} ({why}): is "
                              "labgrid-coordinator running there? (LG_COORDINATOR or ?coordinator=HOST:PORT)"
                              ) from None
        self.me: str = f"{self.session.gethostname()}/{self.session.getuser()}"

    # -- the lab's state -------------------------------------------------------------------
    def _run(self, coro: Any) -> Any:
        with self._lock:
            return self.loop.run_until_complete(coro)

    def refresh(self) -> None:
        """Take in every update the coordinator has sent so far."""
        if not self._run(self.session.sync_with_coordinator()):
            raise TargetError(f"the labgrid coordinator at {self.address} went away")

    def places(self) -> List[PlaceState]:
        self.refresh()
        return [self._state(p) for _n, p in sorted(self.session.places.items())]

    def place(self, name: str) -> PlaceState:
        self.refresh()
        found = self.session.places.get(name)
        if found is None:
            known = ", ".join(sorted(self.session.places)) or "none"
            raise TargetError(f"no place {name!r} on the labgrid coordinator at {self.address} "
                              f"(places: {known}; 'buildhat-conformance targets' lists them)")
        return self._state(found)

    @staticmethod
    def _state(place: Any) -> PlaceState:
        return PlaceState(place.name, place.acquired or "", dict(place.tags or {}), place.comment or "",
                          list(place.aliases or []))

    # -- acquire and release ---------------------------------------------------------------
    def acquire(self, name: str) -> None:
        """Acquire ``name`` for this host/user; PlaceHeld when someone holds it."""
        import grpc
        from labgrid.remote.generated import labgrid_coordinator_pb2 as pb2

        state = self.place(name)
        if state.acquired:
            raise PlaceHeld(self.held_text(state))
        try:
            self._run(self.session.stub.AcquirePlace(pb2.AcquirePlaceRequest(placename=name)))
        except grpc.aio.AioRpcError as exc:
            state = self.place(name)
            if state.acquired:               # taken between our look and our request
                raise PlaceHeld(self.held_text(state)) from None
            raise TargetError(f"labgrid could not acquire place {name}: {exc.details()}") from None
        self.refresh()

    def release(self, name: str) -> None:
        """Release ``name`` (held by this user). Errors are TargetErrors, one line."""
        import grpc
        from labgrid.remote.generated import labgrid_coordinator_pb2 as pb2

        try:
            self._run(self.session.stub.ReleasePlace(pb2.ReleasePlaceRequest(placename=name)))
            self.refresh()
        except grpc.aio.AioRpcError as exc:
            raise TargetError(f"labgrid could not release place {name}: {exc.details()}") from None

    def held_text(self, state: PlaceState) -> str:
        return (f"place {state.name} is held by {state.acquired} (labgrid coordinator {self.address}); "
                f"wait for it (--lab-wait SECONDS) or, if that holder is gone, free it with "
                f"'labgrid-client -x {self.address} -p {state.name} release --kick'")

    # -- the place's resources -------------------------------------------------------------
    def labgrid_target(self, name: str) -> Any:
        """A labgrid ``Target`` with the acquired place's resources (``RemotePlace``)."""
        from labgrid import Target
        from labgrid.resource.remote import RemotePlace, RemotePlaceManager

        manager: Any = RemotePlaceManager.get()     # the singleton; typed as its base class
        if manager.session is not None and manager.session is not self.session:
            raise TargetError("one process uses one labgrid coordinator; this one already uses another")
        manager.session, manager.loop = self.session, self.loop
        target: Any = Target(name)  # pyright: ignore[reportCallIssue]  # attrs fields, unseen
        with self._lock:
            RemotePlace(target, name=name)  # pyright: ignore[reportCallIssue]  # attrs fields, unseen
        return target

    def resources(self, name: str) -> List[Tuple[str, str]]:
        """(name, class) of every resource the acquired place has."""
        place = self.session.places[name]
        return sorted((n, cls) for (n, cls) in self.session.get_target_resources(place))

    def close(self) -> None:
        try:
            with _quiet():
                self._run(self.session.stop())
                self._run(self.session.close())
        except Exception:  # noqa: BLE001 - closing a session that already failed
            pass


@contextlib.contextmanager
def _quiet() -> Iterator[None]:
    """labgrid logs a failed connection on the root logger (with its own format); the caller
    says it in one line instead."""
    root = logging.getLogger()
    level = root.level
    root.setLevel(logging.CRITICAL)
    try:
        yield
    finally:
        root.setLevel(level)


_CLIENTS: Dict[str, LabClient] = {}


def client_for(address: str = "") -> LabClient:
    """This process's session with the coordinator at ``address`` (made on first use)."""
    key = coordinator_address(address)
    found: Optional[LabClient] = _CLIENTS.get(key)
    if found is None:
        found = _CLIENTS[key] = LabClient(key)
    return found
