"""The emulator against the firmware in the loop, same world (issue 37): every scenario script of
transcripts/data/ and transcripts/data/timing/ on ``sil:<tree>`` and on the emulator (R7, a
115200-baud wire), compared line by line and by time (transcripts/same_world.py): how many lines
are equal, and how many of those within 1 ms of the firmware's."""
from __future__ import annotations

from pathlib import Path
from typing import Dict, List, Optional

from ..emulator.api import Emulator
from ..sil.target import from_url
from ..transcripts.same_world import DATA_LINE, compare, run_lines
from ..transcripts.script import load_script
from .sil import firmware_tree

__all__ = ["scripts", "measure"]

_DATA = Path(__file__).resolve().parent.parent / "transcripts" / "data"


def scripts() -> List[Path]:
    return sorted(_DATA.glob("*.script")) + sorted((_DATA / "timing").glob("*.script"))


def measure(paths: Optional[List[Path]] = None) -> Dict:
    tree = firmware_tree()
    lines = equal = timely = noise = 0
    differing: List[str] = []
    for path in paths if paths is not None else scripts():
        script = load_script(path)
        fw = run_lines(from_url(f"sil:{tree}?booted=0").new_hat(devices=script.devices), script)
        emu = run_lines(Emulator(firmware="R7", devices=script.devices, baud=115200), script)
        result = compare(fw, emu, noise=DATA_LINE)
        lines += result.pairs
        equal += result.equal
        timely += result.in_time
        noise += result.noise
        if result.differences:
            differing.append(f"{path.name} ({len(result.differences)})")
    return {"lines": lines, "equal_pct": 100.0 * equal / lines if lines else 0.0,
            "within_1ms_pct": 100.0 * timely / equal if equal else 0.0,
            "note": f"{lines} lines in {len(paths or scripts())} scripts; {noise} device-data lines of "
                    f"other values (noise); scripts with differences: {', '.join(differing) or 'none'}"}
