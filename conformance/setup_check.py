"""Which of the suite's set-up commands the target accepts, learnt once and checked after.

The set-up between cases (conformance/resync.py) puts the HAT in a known state: echo and debug
off, every port's reports stopped, direct PWM at a zero set-point, bias and PWM parameters at
their defaults. The target answers a command it does not have with `Error` and drops the rest of
that line (docs/FIRMWARE-BEHAVIOUR.md#fb-errors), so one refused command in a long set-up line
would silently leave the ports as the last case left them. A build whose command set differs
from its profile's (a development build without `bias`, judged as the release before it) does
exactly that.

So at the start of a run, and after a restart, each set-up command is sent once on its own line
with a fence, and its answer looked at. A refused command is said once, in one line ("this build
has no `bias`: set-up goes on without it"), and left out of later set-ups; what it resets is reset
another way where the protocol has one (:data:`RESETS`). Later set-ups go back to back as before
(fast: a fence each would be three round trips per case), and an `Error` among their output makes
the set-up learn again at once. A target that refuses `port`, or every command, refuses its
set-up altogether: :class:`SetupRefused`, and the run says it could not do its job.
"""
from __future__ import annotations

from typing import Any, Callable, Dict, Iterable, List, Optional, Sequence, Tuple

__all__ = ["SetupCheck", "SetupRefused", "RESETS", "verb"]

#: A set-up command -> (commands that reset the same where the target refuses it, what stays
#: unreset without any of them). None: only that command changes what it resets (`echo`, `debug`,
#: `select`, `bias`, `pwmparams`), so a build without it cannot have had it changed by a case.
RESETS: Dict[str, Tuple[Tuple[str, ...], Optional[str]]] = {
    "echo": ((), None),
    "debug": ((), None),
    "port": ((), "every port's state"),
    "select": ((), None),
    # pwm leaves a PID controller; `coast` at least stops the drive (#fb-pwm, #fb-commands).
    "pwm": (("coast",), "the drive mode (PID or direct PWM)"),
    # off is a constant set-point of 0 and nothing more (#fb-on-off): `set 0` is the same.
    "off": (("set 0",), "the set-point"),
    "bias": ((), None),
    "pwmparams": ((), None),
}


def verb(command: str) -> str:
    """The command word of one set-up command (``bias 0`` -> ``bias``)."""
    return command.split()[0] if command.split() else command


class SetupRefused(RuntimeError):
    """The target refuses the suite's set-up altogether (one line: what it refused)."""


class SetupCheck:
    """What the run knows of the target's answers to the set-up commands."""

    def __init__(self) -> None:
        #: command word -> accepted; empty until learnt
        self.accepted: Dict[str, bool] = {}
        #: fallback command -> accepted
        self._fallback_ok: Dict[str, bool] = {}
        self.due = True
        #: one line per refused command, in the order learnt (terminal summary, JUnit)
        self.said: List[str] = []
        #: what no accepted command resets (the cases that fail are then informational)
        self.unreset: List[str] = []

    def learn(self, commands: Sequence[str], exchange: Callable[[str], Any]) -> List[str]:
        """Send each command word's first command of ``commands`` (and, for a refused one, its
        fallbacks) on its own line through ``exchange`` (a fenced exchange: its reply's
        ``errors`` counts `Error` lines). Returns the lines said for the first time."""
        self.due = False
        first: Dict[str, str] = {}
        for command in commands:
            first.setdefault(verb(command), command)
        for word, command in first.items():
            self.accepted[word] = exchange(command).errors == 0
        new: List[str] = []
        for word, ok in self.accepted.items():
            if ok:
                continue
            fallbacks, what = RESETS.get(word, ((), None))
            used = [f for f in fallbacks if self._fallback(f, exchange)]
            line = f"this build has no `{word}`: set-up goes on without it"
            if used:
                line += f" (resets with `{'`, `'.join(used)}` instead)"
            elif what is not None:
                line += f"; {what} is not reset between cases: a case that fails is informational"
                if what not in self.unreset:
                    self.unreset.append(what)
            if line not in self.said:
                self.said.append(line)
                new.append(line)
        if first and (not self.accepted.get("port", True) or not any(self.accepted.values())):
            refused = ", ".join(f"`{w}`" for w, ok in self.accepted.items() if not ok)
            raise SetupRefused(f"the target refuses the suite's set-up ({refused} answer `Error`): no case "
                               "can begin from a known state")
        return new

    def _fallback(self, command: str, exchange: Callable[[str], Any]) -> bool:
        if command not in self._fallback_ok:
            self._fallback_ok[command] = exchange(command).errors == 0
        return self._fallback_ok[command]

    def commands(self, commands: Iterable[str]) -> List[str]:
        """``commands`` without the refused ones, each in its accepted fallbacks' place."""
        out: List[str] = []
        for command in commands:
            word = verb(command)
            if self.accepted.get(word, True):
                out.append(command)
            else:
                out += [f for f in RESETS.get(word, ((), None))[0] if self._fallback_ok.get(f)]
        return out

    def refusals_seen(self, events: Iterable[Any]) -> bool:
        """Whether the output of a set-up holds an `Error`: something refused that was accepted
        when learnt (or a line the last case left half typed, ended by the set-up's first CR);
        the set-up learns again."""
        if any(getattr(e, "kind", None) == "error" for e in events):
            self.due = True
        return self.due
