"""The recent motor-drive changes of a served HAT, for the control channel's ``@drive_events``, and the
recent frames its devices received, for ``@device_frames`` (:class:`FrameLog`).

The in-process targets keep every ``pwm``/``led`` event (``drive_events``); a HAT served at
wall-clock pace (``buildhat-emulator --pty``, ``sil serve``) runs for as long as the host likes, so
it keeps only the newest ``limit`` changes, plus the last change of each port that fell out of that
window: the level a port was at when a window of interest began is then always known.
"""
from __future__ import annotations

import collections
from typing import Any, Deque, Dict, List, Tuple

__all__ = ["DriveLog", "DRIVE_KINDS", "FrameLog"]

DRIVE_KINDS = ("pwm", "led")
# About 50 s of a port whose drive changes at every 10 ms controller update; a reply with ``since``
# holds only the window asked for, so it stays far below the channel's backlog limit.
DEFAULT_LIMIT = 4096


class DriveLog:
    """Subscribe :meth:`record` to a HAT's ``on_event``; :meth:`since` answers what changed."""

    def __init__(self, limit: int = DEFAULT_LIMIT):
        self.recent: Deque[Dict[str, Any]] = collections.deque()
        self.limit = limit
        # the last change of each (kind, port) that fell out of ``recent``
        self.evicted: Dict[Tuple[str, int], Dict[str, Any]] = {}

    def record(self, event: Dict[str, Any]) -> None:
        if event.get("dir") not in DRIVE_KINDS:
            return
        if len(self.recent) >= self.limit:
            old = self.recent.popleft()
            self.evicted[_key(old)] = old
        self.recent.append(dict(event))

    def since(self, t: int) -> List[Dict[str, Any]]:
        """Each port's last change at or before HAT ms ``t``, then every change after ``t``, in time order."""
        before: Dict[Tuple[str, int], Dict[str, Any]] = dict(self.evicted)
        after: List[Dict[str, Any]] = []
        for event in self.recent:
            if int(event["t"]) <= t:
                before[_key(event)] = event
            else:
                after.append(event)
        return sorted(before.values(), key=lambda e: int(e["t"])) + after


def _key(event: Dict[str, Any]) -> Tuple[str, int]:
    return str(event.get("dir")), int(event.get("port", -1))


class FrameLog:
    """The newest ``limit`` frames the devices received (transcript ``dev`` events), as the
    in-process targets' ``device_frames``; subscribe :meth:`record` to a HAT's ``on_event``."""

    def __init__(self, limit: int = DEFAULT_LIMIT):
        self.recent: Deque[Dict[str, Any]] = collections.deque(maxlen=limit)

    def record(self, event: Dict[str, Any]) -> None:
        if event.get("dir") == "dev":
            self.recent.append(dict(event))

    def since(self, t: int) -> List[Dict[str, Any]]:
        """Every frame received at or after HAT ms ``t``, in time order."""
        return [e for e in self.recent if int(e["t"]) >= t]
