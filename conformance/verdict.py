"""Per-test verdict: pass / fail / skip / known deviation / informational, and the two that
are not about the protocol: target-fault (the target misbehaved as a device: silent, dead,
restarted, garbled, not reading; conformance/target_fault.py) and not-run (the run stopped
talking to the target before the case).

A test states what the document requires and what this release is known to do instead;
:meth:`Verdict.document` turns that into the verdict. Failures go through ``pytest.fail``
so pytest's own outcome and exit status stay the single source of "did it fail".
"""
from __future__ import annotations

from typing import List, Optional, Tuple

import pytest

from .deviations import deviation

__all__ = ["Verdict", "PASS", "FAIL", "SKIP", "KNOWN", "INFO", "TARGET_FAULT", "NOT_RUN", "VERDICTS"]

PASS, FAIL, SKIP, KNOWN, INFO = "pass", "fail", "skip", "known deviation", "informational"
TARGET_FAULT, NOT_RUN = "target-fault", "not-run"
#: Every verdict, in the order summaries show them.
VERDICTS = (PASS, FAIL, TARGET_FAULT, NOT_RUN, SKIP, KNOWN, INFO)


class Verdict:
    def __init__(self, profile_name: str):
        self.profile_name = profile_name
        self.known: List[Tuple[str, str]] = []      # (deviation key, what was seen)
        self.notes: List[str] = []
        self.informational = False

    def document(self, document_ok: bool, *, key: Optional[str] = None, firmware_ok: bool = False,
                 seen: str = "") -> None:
        """Judge one observation.

        ``document_ok``: the target did what the document says. ``key``: the deviation in
        deviations.json this check can show; ``firmware_ok``: the target did exactly what
        that deviation says the release does instead.
        """
        if document_ok:
            return
        if key is None:
            pytest.fail(f"deviates from the document: {seen}", pytrace=False)
        dev = deviation(key)
        if dev.applies_to(self.profile_name) and firmware_ok:
            self.known.append((key, seen))
            return
        if dev.applies_to(self.profile_name):
            pytest.fail(f"{key}: neither the document ({dev.document}) nor the known behaviour of "
                        f"{self.profile_name} ({dev.firmware}); seen: {seen}", pytrace=False)
        pytest.fail(f"{key}: the document requires: {dev.document}; {self.profile_name} is not known to "
                    f"deviate here (FIRMWARE-FACTS {dev.facts}); seen: {seen}", pytrace=False)

    def inform(self, note: str) -> None:
        """Mark the case informational: it measured something the document does not bound."""
        self.informational = True
        self.notes.append(note)

    def note(self, text: str) -> None:
        self.notes.append(text)

    @property
    def verdict_class(self) -> str:
        if self.known:
            return KNOWN
        if self.informational:
            return INFO
        return PASS
