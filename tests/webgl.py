"""Headless-Chromium harness for the export's WebGL2 tests: build a viewer page with given self-test cases, run
it in ``chromium-headless-shell`` (SwiftShader), return the page's JSON report."""

from __future__ import annotations

import html
import json
import os
import re
import shutil
import subprocess
from pathlib import Path
from typing import Any

import pytest

BROWSERS = ("chromium-headless-shell", "chromium", "chromium-browser", "google-chrome", "headless_shell")


def find_browser() -> str | None:
    env = os.environ.get("TILESYNTH_BROWSER")
    if env:
        return env
    for name in BROWSERS:
        path = shutil.which(name)
        if path:
            return path
    return None


def browser_or_skip() -> str:
    path = find_browser()
    if path is None:
        pytest.skip(
            "no headless Chromium found (apt-get install chromium-headless-shell, or TILESYNTH_BROWSER=/path): "
            "the WebGL2 tests need a real browser"
        )
    return path


def run_page(browser: str, page: Path, query: str = "", timeout: float = 240.0) -> dict[str, Any]:
    """Load ``page`` and return the JSON of ``#selftest-result`` (raises if the page did not report)."""
    cmd = [browser, "--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--headless",
           "--dump-dom", page.resolve().as_uri() + query]
    if Path(browser).name == "chromium-headless-shell":
        cmd.remove("--headless")
    out = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    m = re.search(r'<pre id="selftest-result"[^>]*>(.*?)</pre>', out.stdout, re.S)
    if not m or not m.group(1).strip():
        raise AssertionError(f"the page reported nothing; stderr tail:\n{out.stderr[-2000:]}")
    report = json.loads(html.unescape(m.group(1)))
    status = re.search(r'<div id="selftest-status">([^<]*)</div>', out.stdout)
    report["dom_status"] = status.group(1) if status else None
    return report
