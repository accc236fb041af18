"""``--operator``: ask a person to do what the rig cannot (plug a device, cause a fault)."""
from __future__ import annotations

from typing import Any

__all__ = ["ask"]


def ask(config: Any, instruction: str) -> bool:
    """Show the instruction and wait for Enter; True if done, False if the person typed 's'."""
    capture = config.pluginmanager.getplugin("capturemanager")
    prompt = f"\n[operator] {instruction}\n[operator] press Enter when done, or type s and Enter to skip: "
    if capture is not None:
        with capture.global_and_fixture_disabled():
            answer = input(prompt)
    else:
        answer = input(prompt)
    return answer.strip().lower() != "s"
