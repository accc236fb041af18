"""The `run:` scripts of an example GitHub Actions workflow (examples/*.yml), to run them as the runner
would: a tiny reader for those files' own layout, not a YAML parser."""
from __future__ import annotations

import pathlib
import re
from typing import Dict


def job_steps(workflow: pathlib.Path, job: str) -> Dict[str, str]:
    """step name -> its `run: |` script (or one-line `run:`), for one job of ``workflow``."""
    lines = workflow.read_text().splitlines()
    start = lines.index(f"  {job}:")
    steps: Dict[str, str] = {}
    name = None
    i = start + 1
    while i < len(lines) and (not lines[i].strip() or lines[i].startswith("    ")):
        line = lines[i]
        found = re.match(r"\s+- name: (.+)$", line)
        if found:
            name = found.group(1)
        elif name and line.strip() == "run: |":
            indent = len(lines[i + 1]) - len(lines[i + 1].lstrip())
            body = []
            i += 1
            while i < len(lines) and (not lines[i].strip() or lines[i].startswith(" " * indent)):
                body.append(lines[i][indent:])
                i += 1
            steps[name] = "\n".join(body) + "\n"
            continue
        elif name and line.strip().startswith("run: "):
            steps[name] = line.strip()[5:] + "\n"
        i += 1
    return steps
