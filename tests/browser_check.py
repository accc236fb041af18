"""Render a report in headless Chromium at 1400x900: a screenshot of the first screen, and a
measurement of everything that runs off the page (or scrolls inside a box) with every
``<details>`` opened. Used by tests/end_to_end/test_report_browser.py; also a script:
``python tests/browser_check.py reports/index.html shot.png``."""
from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
from typing import List, Optional, TypedDict

WIDTH, HEIGHT = 1400, 900

# Injected into a copy of the report only: the report itself has no script.
_PROBE = """<script>(function(){
var W=document.documentElement.clientWidth,out=[];
var SW=document.documentElement.scrollWidth;
if(SW>W)out.push('page is '+SW+' px wide');
var all=document.body.getElementsByTagName('*');
for(var i=0;i<all.length;i++){var el=all[i],r=el.getBoundingClientRect();
 if(r.width===0&&r.height===0)continue;
 var what=el.tagName+' '+(el.textContent||'').replace(/\\s+/g,' ').slice(0,80);
 // a box, or its content overflowing it visibly (SVG parts: their box; their scrollWidth is in
 // the picture's own units)
 var right=el instanceof HTMLElement?r.left+Math.max(r.width,el.scrollWidth):r.right;
 if(right>W+1)out.push('runs off the right edge by '+Math.round(right-W)+' px: '+what);
 else if(el instanceof HTMLElement&&el.scrollWidth>el.clientWidth+1&&
   getComputedStyle(el).overflowX!=='visible')
  out.push('scrolls sideways inside: '+what);}
function box(sel){var e=document.querySelector(sel);return e?e.getBoundingClientRect():null;}
function top(sel){var b=box(sel);return b?Math.round(b.top):-1;}
function bottom(sel){var b=box(sel);return b?Math.round(b.bottom):-1;}
var p=document.createElement('pre');p.id='browser-probe';
p.textContent=JSON.stringify({overflow:out.slice(0,40),failures_top:top('#failures'),
 first_group_bottom:bottom('table.groups tr:nth-child(2)'),width:W});
document.body.appendChild(p);})();</script>"""


def chromium() -> Optional[str]:
    for name in ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable"):
        path = shutil.which(name)
        if path:
            return path
    return None


def _argv(exe: str) -> list:
    return [exe, "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
            "--force-device-scale-factor=1", f"--window-size={WIDTH},{HEIGHT}"]


def screenshot(html_path: str, png_path: str, exe: str) -> None:
    subprocess.run(_argv(exe) + [f"--screenshot={os.path.abspath(png_path)}",
                                 "file://" + os.path.abspath(html_path)],
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, timeout=120, check=True)


class Layout(TypedDict):
    """What the page script measures (JSON): the boxes that run off the page, where the failures start
    and the first group ends (px from the top), and the window width."""

    overflow: List[str]
    failures_top: float
    first_group_bottom: float
    width: int


def measure(html_path: str, exe: str) -> Layout:
    """Chromium's own layout of the report, every <details> open: what overflows and where
    the failures start."""
    with open(html_path, encoding="utf-8") as fh:
        text = fh.read()
    text = re.sub(r"<details(?![^>]*\bopen\b)", "<details open", text).replace("</body>", _PROBE + "</body>")
    with tempfile.TemporaryDirectory() as tmp:
        probe = os.path.join(tmp, "probe.html")
        with open(probe, "w", encoding="utf-8") as fh:
            fh.write(text)
        done = subprocess.run(_argv(exe) + ["--dump-dom", "file://" + probe], stdout=subprocess.PIPE,
                              stderr=subprocess.DEVNULL, timeout=180, check=True)
        out = done.stdout.decode("utf-8", "replace")
    m = re.search(r'<pre id="browser-probe">(.*?)</pre>', out, re.S)
    if not m:
        raise RuntimeError("the probe did not run (no result in the dumped DOM)")
    import html as _html
    return json.loads(_html.unescape(m.group(1)))


if __name__ == "__main__":
    exe = chromium()
    if exe is None:
        sys.exit("chromium is not installed (Debian: apt-get install chromium)")
    screenshot(sys.argv[1], sys.argv[2], exe)
    result = measure(sys.argv[1], exe)
    print(json.dumps(result, indent=1))
    sys.exit(1 if result["overflow"] else 0)
