"""Body-model commands keep stdout for their own output: warp's banner is quieted."""

from __future__ import annotations

import subprocess
import sys


def test_warp_banner_is_not_printed_on_stdout():
    code = ("from dressmeup.body.anny_model import _configure_caches\n"
            "_configure_caches()\n"
            "import warp\n"
            "warp.init()\n")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True)
    assert "Warp" not in proc.stdout and proc.stdout.strip() == "", proc.stdout
