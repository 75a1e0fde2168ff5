"""What the attitude-report tests share: the command, and checks of its figures and of
its summary table."""

import html
import json
import re
import subprocess
import sys
from pathlib import Path

from PIL import Image

ROOT = Path(__file__).resolve().parents[2]
BIN = Path(sys.prefix) / "bin"


def report(*args, timeout=120):
    return subprocess.run(
        [str(BIN / "attitude-report"), *map(str, args)],
        capture_output=True,
        text=True,
        timeout=timeout,
    )


def assert_valid_figure(path: Path) -> None:
    assert path.is_file() and path.stat().st_size > 0, path
    with Image.open(path) as im:
        im.verify()
    with Image.open(path) as im:
        assert im.format == "PNG"
        assert im.width > 300 and im.height > 300, (path, im.size)
        rgb = im.convert("RGB")
        assert any(lo != hi for lo, hi in rgb.getextrema()), f"{path}: one flat colour"
        assert len(rgb.getcolors(maxcolors=1 << 24)) > 50, path


def summary_cells(page: str) -> dict:
    """data-key -> list of (exact JSON value, shown text) of the summary table cells."""
    cells = {}
    for key, exact, shown in re.findall(
        r'<td[^>]*data-key="([^"]*)" data-value="([^"]*)"[^>]*>([^<]*)</td>', page
    ):
        cells.setdefault(html.unescape(key), []).append(
            (json.loads(html.unescape(exact)), html.unescape(shown))
        )
    return cells
