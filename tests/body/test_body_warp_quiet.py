"""Body-model commands keep stdout for their own output and stderr for what matters: warp's
banner is quieted, its "no CUDA driver" notice dropped."""

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


def test_the_no_cuda_notice_is_left_out_of_stderr():
    """warp's native "no NVIDIA driver" notice (fprintf to stderr, on every CPU-only machine)
    is dropped, and stderr works as before afterwards."""
    import pytest

    from dressmeup.body.anny_model import NO_CUDA_NOTICE

    bare = subprocess.run([sys.executable, "-c", "import warp\nwarp.init()\n"],
                          capture_output=True, text=True, check=True)
    if NO_CUDA_NOTICE not in bare.stderr:
        pytest.skip("this machine's warp prints no such notice (an NVIDIA driver is present)")
    code = ("import os, sys\n"
            "from dressmeup.body.anny_model import _configure_caches\n"
            "_configure_caches()\n"
            "import warp\n"
            "warp.init()\n"
            "os.write(2, b'after\\n')\n")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True)
    assert NO_CUDA_NOTICE not in proc.stderr, proc.stderr
    assert proc.stderr.strip().endswith("after"), proc.stderr
    assert proc.stdout.strip() == "", proc.stdout


def test_what_a_failing_init_wrote_still_reaches_stderr(monkeypatch, capfd):
    """Nothing is lost when warp's initialisation fails: its own stderr is passed on."""
    import os

    import pytest
    import warp

    from dressmeup.body.anny_model import NO_CUDA_NOTICE, init_warp_quietly

    def failing_init():
        os.write(2, f"Warp CUDA warning: {NO_CUDA_NOTICE}.\nthe real problem\n".encode())
        raise RuntimeError("init failed")

    monkeypatch.setattr(warp, "init", failing_init)
    with pytest.raises(RuntimeError, match="init failed"):
        init_warp_quietly()
    err = capfd.readouterr().err
    assert "the real problem" in err and NO_CUDA_NOTICE not in err
