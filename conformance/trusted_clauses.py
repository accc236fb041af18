"""The protocol clauses the suite's own set-up and fences rely on, checked before they are trusted.

The harness talks to the HAT through the protocol it is testing: its fence asks ``version`` and
counts the CRLF each CR gives; its sync between cases turns echo on and off; its set-up puts
several commands on one line with ``;``. A HAT that breaks one of those clauses would otherwise
make every case look like a target fault (issue 24). So the first cases of a run
(``conformance/cases/test_link_clauses.py``, marked ``link_clause``) check each clause as a conformance
case, and until a clause has passed the harness does without it:

- ``separator`` (SYN-SEMICOLON) untrusted: set-up lines go one command per line;
- ``echo`` (CMD-ECHO) untrusted: between cases the link is found by the counted ``version``
  fence, and the sync (which needs echo) only when that fails.

A clause that failed stays distrusted for the rest of the run, and the run says which one broke
(terminal summary, JUnit property ``broken_clauses``). ``version`` and CR/LF are checked too: the
session could not have opened without them, so they are never assumed away, but a failure of
either is reported as the clause it breaks. A HAT whose `version` never gives its line, but whose
answers show a Build HAT (harness/hat_evidence.py), fails the version case at once and the rest
is not-run (plugin/run.py, plugin/case_fixtures.py).
"""
from __future__ import annotations

from typing import Dict, List, Tuple

__all__ = ["CLAUSES", "TrustedClauses", "MARKER"]

MARKER = "link_clause"

#: clause -> (requirement ID, what the harness relies on)
CLAUSES: Dict[str, Tuple[str, str]] = {
    "crlf": ("FW-LINE-CR-CRLF", "CR ends a line and is answered with CRLF"),
    "version": ("CMD-VERSION", "`version` prints `Firmware version: ...`"),
    "echo": ("CMD-ECHO", "`echo 1` echoes what is typed and prompts, `echo 0` stops it"),
    "separator": ("SYN-SEMICOLON", "`;` separates commands on one line"),
}

_OK = "ok"


class TrustedClauses:
    """What the run has learnt about the clauses in :data:`CLAUSES`: unchecked, held, broken."""

    def __init__(self) -> None:
        self._state: Dict[str, str] = {}      # clause -> "ok" | one line: the case that failed
        self._cases: Dict[str, List[str]] = {}

    def trusted(self, clause: str) -> bool:
        """True once a case checked the clause and none saw it broken."""
        return self._state.get(clause) == _OK

    def held(self, clause: str) -> None:
        if clause not in self._state:
            self._state[clause] = _OK

    def broke(self, clause: str, nodeid: str) -> None:
        """A case of the clause failed: distrusted for the rest of the run (sticky)."""
        if self._state.get(clause, _OK) == _OK:
            self._state[clause] = nodeid

    def broken(self) -> List[str]:
        """One line per broken clause: its requirement, what it says and the case that failed."""
        out = []
        for clause, state in self._state.items():
            if state != _OK:
                req, what = CLAUSES.get(clause, (clause, clause))
                out.append(f"{req} ({what}) failed in {state.rsplit('/', 1)[-1]}")
        return out

    def split(self, line: str) -> List[str]:
        """``line`` as the harness may send it: whole when ``;`` is trusted, else one command
        per line (set-up lines only: their ``;`` separates commands, never arguments)."""
        if self.trusted("separator"):
            return [line]
        return [part.strip() for part in line.split(";") if part.strip()]
