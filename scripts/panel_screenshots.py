"""Screenshots of the operator station for docs/panel.md, from a real run (issue 24).

The table's legs with the kinematic model (the arms drawn from their joint states), one bolt no
arm reaches (so the person is asked), the panel served on loopback and opened in Debian's
headless chromium at desktop (1280 px) and tablet (1024 px) widths:

    python scripts/panel_screenshots.py [--out docs/img]

writes panel-operator.png, panel-operator-tablet.png and panel-3d.png (the 3D view while an
arm moves, with its planned path). Look at them before committing.
"""

from __future__ import annotations

import argparse
import shutil
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

from flexhrc.web.local import PanelConfig, serve_panel, table_legs


def _until(page: object, check: str, timeout: float = 90.0) -> None:
    deadline = time.monotonic() + timeout
    while not page.evaluate(check):  # type: ignore[attr-defined]
        if time.monotonic() > deadline:
            raise SystemExit(f"timed out waiting for: {check}")
        page.wait_for_timeout(50)  # type: ignore[attr-defined]


def main() -> int:
    ap = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("--out", default="docs/img", help="folder for the PNG files")
    ap.add_argument("--chromium", default=shutil.which("chromium") or "/usr/bin/chromium")
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)  # before the run: a bad folder fails at once
    probe = out / ".flexhrc-write-check"
    probe.write_text("")
    probe.unlink()
    from playwright.sync_api import sync_playwright

    coop = serve_panel(
        PanelConfig(table_legs(4, unreachable_bolts=(1,)), speed=0.5, simulator="kinematic", port=0)
    )
    assert coop.server is not None
    try:
        with sync_playwright() as pw:
            browser = pw.chromium.launch(
                executable_path=args.chromium,
                args=["--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage"],
            )
            pages = {
                w: browser.new_context(viewport={"width": w, "height": 900}).new_page()
                for w in (1280, 1024)
            }
            for page in pages.values():
                page.goto(coop.server.url)
            desktop = pages[1280]
            # an arm moving with its path drawn: the 3D view
            _until(
                desktop, "window.__scene3d && Object.keys(window.__scene3d.planned()).length > 0"
            )
            desktop.locator("#cell3d").screenshot(path=str(out / "panel-3d.png"))
            # the person asked: the operator's view, then a what-if on the card
            _until(desktop, "document.querySelector('#turn').dataset.turn === 'yours'")
            desktop.locator("#op-whatif").click()
            _until(desktop, "!document.querySelector('#whatif-text').hidden")
            desktop.screenshot(path=str(out / "panel-operator.png"), full_page=True)
            tablet = pages[1024]
            _until(tablet, "document.querySelector('#turn').dataset.turn === 'yours'")
            tablet.screenshot(path=str(out / "panel-operator-tablet.png"))
            browser.close()
    finally:
        coop.close()
    for name in ("panel-operator.png", "panel-operator-tablet.png", "panel-3d.png"):
        print(f"wrote {out / name}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
