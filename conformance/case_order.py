"""The order the suite's cases run in: the suite's own, or shuffled with a seed that repeats it.

Every case sets up what it needs (the set-up between cases, conformance/resync.py, and the case's
own commands), so its verdict must not depend on the cases before it. ``run --random-order [SEED]``
checks that: the cases run in an order shuffled by pytest-randomly (a maintained plugin that
shuffles modules, then the cases in each, from one seed, xdist workers included), and the seed is
printed so that an order that changes a verdict can be run again. Without it the plugin, where
installed, is switched off: the suite's own order stays the default.

Cases that really must share state say so with ``@pytest.mark.together("NAME")``: the shuffle
keeps the cases of one name next to each other, in the order they are written, where the first of
them fell. The clauses the harness relies on still run first (plugin/run.py).
"""
from __future__ import annotations

import importlib.util
import random
from typing import Any, Dict, List, Optional

from ..plumbing.optional_extras import install_hint

__all__ = ["MARKER", "RANDOM", "resolve_seed", "order_argv", "keep_together", "seed_in_use"]

MARKER = "together"
#: ``--random-order`` without a seed: the run picks one (and prints it).
RANDOM = "random"
PLUGIN = "randomly"        # pytest-randomly's plugin name (``-p no:randomly`` switches it off)


def resolve_seed(value: Optional[str]) -> Optional[int]:
    """The seed for ``--random-order VALUE`` (None: the suite's own order). Raises ValueError
    with one line when the value is no seed, or pytest-randomly is not installed."""
    if value is None:
        return None
    if importlib.util.find_spec("pytest_randomly") is None:
        raise ValueError("--random-order needs pytest-randomly, which is not installed: "
                         + install_hint("order"))
    if value == RANDOM:
        return random.SystemRandom().randrange(2 ** 32)
    if not value.isdigit():
        raise ValueError(f"--random-order {value}: a seed is a whole number (0 to 2**32-1), or nothing "
                         "for a new one")
    return int(value)


def order_argv(seed: Optional[int]) -> List[str]:
    """pytest's options for the order: pytest-randomly off, or on with ``seed``."""
    if seed is None:
        return ["-p", f"no:{PLUGIN}"]
    return ["-p", PLUGIN, f"--randomly-seed={seed}"]


def keep_together(items: List[Any]) -> None:
    """Move the cases marked ``together(NAME)`` next to the first of them, in the order they are
    written (their place in their module)."""
    groups: Dict[str, List[Any]] = {}
    for item in items:
        mark = item.get_closest_marker(MARKER)
        if mark is not None:
            groups.setdefault(str(mark.args[0]), []).append(item)
    if not groups:
        return
    out: List[Any] = []
    placed = set()
    for item in items:
        mark = item.get_closest_marker(MARKER)
        if mark is None:
            out.append(item)
            continue
        name = str(mark.args[0])
        if name not in placed:
            placed.add(name)
            out += sorted(groups[name], key=_written)
    items[:] = out


def _written(item: Any) -> tuple:
    """Where a case is written: its file, its function's line, its parameters' places."""
    callspec = getattr(item, "callspec", None)
    return (str(item.fspath), item.location[1] or 0,
            tuple(callspec.indices.values()) if callspec is not None else ())


def seed_in_use(config: Any) -> Optional[int]:
    """The seed the cases were shuffled with, or None (the suite's own order)."""
    if not config.pluginmanager.has_plugin(PLUGIN):
        return None
    seed = getattr(config.option, "randomly_seed", None)
    reorganize = getattr(config.option, "randomly_reorganize", True)
    return seed if isinstance(seed, int) and reorganize else None
