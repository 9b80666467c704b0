"""Screenshots of the web viewer in headless Chromium, over the DevTools protocol: the docs'
pictures and the smoke test that the viewer renders. Chromium (Debian's `chromium`) runs with a
fresh profile, no sandbox, software rendering and no background traffic.

    python -m assembly.observe.screenshot URL OUT.png [--wait SECONDS] [--size 1600x1000]
"""

from __future__ import annotations

import argparse
import base64
import json
import shutil
import subprocess
import tempfile
import time
import urllib.request
from collections.abc import Callable
from pathlib import Path

from fvfiles.errors import FvtreeError

FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
         "--disable-component-update", "--disable-sync", "--no-first-run", "--use-angle=swiftshader",
         "--enable-unsafe-swiftshader", "--remote-debugging-address=127.0.0.1", "--remote-debugging-port=0"]


def chromium() -> str:
    """The Chromium program, or FvtreeError saying how to get it."""
    for name in ("chromium", "chromium-browser", "google-chrome"):
        found = shutil.which(name)
        if found:
            return found
    raise FvtreeError("no Chromium found for the web-viewer screenshot",
                      hint="install Debian's package: apt-get install chromium")


def screenshot(url: str, out: Path, wait: float = 20.0, size: tuple[int, int] = (1600, 1000),
               timeout: float = 60.0, ready: Callable[[bytes], bool] | None = None) -> Path:
    """Open `url` in headless Chromium, let it render for `wait` s, save a PNG at `out`; with
    `ready`, take a picture every 2 s and keep the first one `ready` accepts (at most `wait` s)."""
    from websockets.sync.client import connect  # test extra: only screenshots need it

    profile = Path(tempfile.mkdtemp(prefix="fvtree-chromium-"))
    process = subprocess.Popen([chromium(), *FLAGS, f"--user-data-dir={profile}",
                                f"--window-size={size[0]},{size[1]}", "about:blank"],
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, stdin=subprocess.DEVNULL)
    try:
        port = _devtools_port(profile, process, timeout)
        pages = json.loads(urllib.request.urlopen(f"http://127.0.0.1:{port}/json/list", timeout=10).read())
        target = next(p for p in pages if p.get("type") == "page")
        with connect(target["webSocketDebuggerUrl"], max_size=None, open_timeout=timeout) as ws:
            calls = iter(range(1, 1_000_000))

            def call(method: str, **params) -> dict:
                number = next(calls)
                ws.send(json.dumps({"id": number, "method": method, "params": params}))
                while True:
                    reply = json.loads(ws.recv(timeout=timeout))
                    if reply.get("id") == number:
                        if "error" in reply:
                            raise FvtreeError(f"Chromium {method}: {reply['error'].get('message')}")
                        return reply.get("result", {})

            call("Emulation.setDeviceMetricsOverride", width=size[0], height=size[1], deviceScaleFactor=1,
                 mobile=False)
            call("Page.navigate", url=url)
            deadline = time.monotonic() + wait
            while True:
                time.sleep(2.0 if ready else wait)
                png = base64.b64decode(call("Page.captureScreenshot", format="png")["data"])
                if ready is None or ready(png) or time.monotonic() > deadline:
                    break
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_bytes(png)
        return out
    finally:
        process.terminate()
        try:
            process.wait(timeout=10)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()
        shutil.rmtree(profile, ignore_errors=True)


def _devtools_port(profile: Path, process: subprocess.Popen, timeout: float) -> int:
    """The DevTools port Chromium chose (it writes it into the profile)."""
    deadline = time.monotonic() + timeout
    marker = profile / "DevToolsActivePort"
    while time.monotonic() < deadline:
        if process.poll() is not None:
            raise FvtreeError(f"Chromium exited at start (code {process.returncode})")
        if marker.is_file():
            text = marker.read_text().split()
            if text:
                return int(text[0])
        time.sleep(0.1)
    raise FvtreeError(f"Chromium did not open its DevTools port within {timeout:g} s")


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m assembly.observe.screenshot", description=__doc__.splitlines()[0])
    p.add_argument("url")
    p.add_argument("out", type=Path)
    p.add_argument("--wait", type=float, default=20.0, help="seconds to let the page render")
    p.add_argument("--size", default="1600x1000", help="WIDTHxHEIGHT")
    args = p.parse_args(argv)
    width, height = (int(v) for v in args.size.split("x"))
    print(f"wrote {screenshot(args.url, args.out, args.wait, (width, height))}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
