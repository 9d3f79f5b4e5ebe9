"""Ctrl-C during Scene.run: the frames in progress finish, the report lists the missing frames,
then KeyboardInterrupt is raised with the command line's message."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import time

from conftest import write_scene

# A shell without job control starts background commands with SIGINT ignored, and Python keeps
# an ignored SIGINT ignored: the child restores Python's own handler, so the test does not
# depend on how the test run was started.
SCRIPT = """
import signal, sys, squish
signal.signal(signal.SIGINT, signal.default_int_handler)
scene = squish.Scene.load(sys.argv[1])
try:
    scene.run(sys.argv[2], threads=2)
except KeyboardInterrupt as stop:
    print("KeyboardInterrupt:", stop)
    sys.exit(130)
print("finished")
"""


FRAMES = 400


def test_ctrl_c_stops_a_run_cleanly(tmp_path):
    scene = write_scene(tmp_path, frames=FRAMES)
    out = tmp_path / "out"
    child = subprocess.Popen(
        [sys.executable, "-c", SCRIPT, str(scene), str(out)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    start = time.monotonic()
    while not (out / "ball" / "0001.obj").exists():
        assert time.monotonic() - start < 120 and child.poll() is None, "no frame written"
        time.sleep(0.02)
    child.send_signal(signal.SIGINT)
    stdout, stderr = child.communicate(timeout=120)
    assert child.returncode == 130, stdout + stderr
    assert "interrupted:" in stdout and "run the missing frames: frames=range(" in stdout, stdout
    assert "--frames" not in stdout, stdout

    report = json.loads((out / "report.json").read_text())
    assert report["run"]["status"] == "interrupted" and report["missing_frames"]
    done = [f["frame"] for f in report["per_frame"]]
    assert 0 < len(done) < FRAMES
    for name in ("ball", "slab"):
        files = sorted(p.name for p in (out / name).iterdir())
        assert files == [f"{f:04}.obj" for f in done], name  # exactly the frames reported, no temporaries
