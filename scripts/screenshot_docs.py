"""Look at the documentation site as a reader's browser shows it: build it, serve it on localhost, and take headless
Chromium screenshots of the landing page and a tutorial page.

Usage (from the repository root, with the ``docs`` extra installed and Debian's ``chromium`` on the PATH:
``apt-get install chromium``)::

    python scripts/screenshot_docs.py                      # PNGs in docs-screenshots/
    python scripts/screenshot_docs.py --out /tmp/shots --site site   # an already built site

This is a manual check, not a test: CI has no browser. ``mkdocs build --strict`` (``tests/test_docs.py``) catches
broken links, references and includes; this script shows what the theme actually renders (layout, code blocks,
tables, images), offline: the site is configured to load no font or script from the network.
"""

from __future__ import annotations

import argparse
import functools
import http.server
import shutil
import subprocess
import sys
import tempfile
import threading
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PAGES = {"landing": "", "tutorial-motion-capture": "tutorials/motion-capture/"}
CHROMIUM_FLAGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
    "--hide-scrollbars",
]


class _QuietHandler(http.server.SimpleHTTPRequestHandler):
    def log_message(self, format, *args):  # no request log on the terminal
        pass


def build_site(target: Path) -> None:
    subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(target)], cwd=ROOT, check=True
    )


def screenshot(chromium: str, url: str, png: Path, width: int, height: int) -> None:
    with tempfile.TemporaryDirectory() as profile:
        subprocess.run(
            [
                chromium,
                *CHROMIUM_FLAGS,
                f"--user-data-dir={profile}",
                f"--window-size={width},{height}",
                f"--screenshot={png}",
                url,
            ],
            check=True,
            timeout=120,
            capture_output=True,
        )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--site", type=Path, help="a built site (default: build one into a temporary folder)")
    parser.add_argument("--out", type=Path, default=ROOT / "docs-screenshots", help="folder for the PNGs")
    parser.add_argument("--chromium", default=shutil.which("chromium") or shutil.which("chromium-browser"))
    parser.add_argument("--width", type=int, default=1280)
    parser.add_argument("--height", type=int, default=1800)
    parser.add_argument(
        "--page", action="append", default=[], metavar="NAME=PATH", help="another page, e.g. api=reference/io/"
    )
    args = parser.parse_args(argv)
    if not args.chromium:
        parser.error("no chromium on the PATH (apt-get install chromium), or give --chromium PATH")
    with tempfile.TemporaryDirectory() as tmp:
        site = args.site or Path(tmp) / "site"
        if args.site is None:
            build_site(site)
        handler = functools.partial(_QuietHandler, directory=str(site))
        server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
        thread = threading.Thread(target=server.serve_forever, daemon=True)
        thread.start()
        try:
            args.out.mkdir(parents=True, exist_ok=True)
            pages = dict(PAGES, **dict(p.split("=", 1) for p in args.page))
            for name, page in pages.items():
                url = f"http://127.0.0.1:{server.server_port}/{page}"
                png = args.out / f"{name}.png"
                screenshot(args.chromium, url, png, args.width, args.height)
                print(f"{url} -> {png}")
        finally:
            server.shutdown()
            server.server_close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
