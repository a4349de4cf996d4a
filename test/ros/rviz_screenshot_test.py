#!/usr/bin/env python3
"""rviz under Xvfb shows the inferred interior.

Starts a virtual X server and rviz with rviz/topo_gaussian.rviz, takes a screenshot (xwd +
ImageMagick) before any interior exists, then asks interior_inference for one (~infer), and takes
screenshots until the solid colour (kSolidRgb, red) covers enough of the view. The last PNG is kept
(~artifact_dir/rviz_screenshot.png) next to the one taken before (rviz_before.png).
"""
import os
import subprocess
import sys
import tempfile
import time
import unittest

import numpy
import rospy
import rostest
from topo_gaussian.srv import Infer, InferRequest

PKG = "topo_gaussian"


def solid_pixels(png):
    """Pixels of the solid colour (220, 40, 40), shaded: red clearly above green and blue."""
    size = subprocess.run(["identify", "-format", "%w %h", png], check=True, stdout=subprocess.PIPE).stdout
    w, h = (int(v) for v in size.split())
    raw = subprocess.run(["convert", png, "-depth", "8", "rgb:-"], check=True, stdout=subprocess.PIPE).stdout
    img = numpy.frombuffer(raw, dtype=numpy.uint8)[: w * h * 3].reshape(h, w, 3).astype(int)
    r, g, b = img[:, :, 0], img[:, :, 1], img[:, :, 2]
    return int(numpy.count_nonzero((r > 90) & (r > 2 * g) & (r > 2 * b))), w * h


class RvizScreenshot(unittest.TestCase):
    def setUp(self):
        self.procs = []

    def tearDown(self):
        for p in reversed(self.procs):
            p.terminate()
            try:
                p.wait(10)
            except subprocess.TimeoutExpired:
                p.kill()

    def start_xvfb(self):
        r, w = os.pipe()
        xvfb = subprocess.Popen(["Xvfb", "-displayfd", str(w), "-screen", "0", "1280x900x24", "-nolisten", "tcp"],
                                pass_fds=(w,), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        os.close(w)
        self.procs.append(xvfb)
        with os.fdopen(r) as f:
            display = ":" + f.readline().strip()
        self.assertNotEqual(display, ":", "Xvfb did not start (is the xvfb package installed?)")
        return display

    def screenshot(self, display, png):
        xwd = subprocess.run(["xwd", "-root", "-silent", "-display", display], check=True, stdout=subprocess.PIPE).stdout
        subprocess.run(["convert", "xwd:-", png], input=xwd, check=True)
        return solid_pixels(png)

    def test_interior_is_visible_in_rviz(self):
        artifacts = rospy.get_param("~artifact_dir", tempfile.gettempdir())
        config = rospy.get_param("~rviz_config")
        os.makedirs(artifacts, exist_ok=True)
        display = self.start_xvfb()
        env = dict(os.environ, DISPLAY=display, LIBGL_ALWAYS_SOFTWARE="1")
        self.procs.append(subprocess.Popen(["rviz", "-d", config, "__name:=rviz_screenshot_viewer"], env=env,
                                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        before_png = os.path.join(artifacts, "rviz_before.png")
        before = 0
        deadline = time.time() + 60
        while time.time() < deadline:  # rviz up: its window changes the screen from black
            time.sleep(3)
            before, total = self.screenshot(display, before_png)
            mean = subprocess.run(["convert", before_png, "-format", "%[fx:mean]", "info:"], check=True,
                                  stdout=subprocess.PIPE).stdout
            if float(mean) > 0.05:
                break
        time.sleep(3)
        before, total = self.screenshot(display, before_png)

        rospy.wait_for_service("/interior_inference/infer", 60)
        infer = rospy.ServiceProxy("/interior_inference/infer", Infer)
        res = infer(InferRequest(task="tumbler", targets=["period_s=0.29"], ignore_motion_features=True, max_iterations=8))
        self.assertTrue(res.success, res.message)

        after_png = os.path.join(artifacts, "rviz_screenshot.png")
        after = 0
        deadline = time.time() + 60
        while time.time() < deadline:
            time.sleep(3)
            after, total = self.screenshot(display, after_png)
            if after > 0.01 * total:
                break
        print("[rviz] solid-coloured pixels: %d before the interior, %d after (of %d); screenshot %s"
              % (before, after, total, after_png))
        self.assertLess(before, 0.001 * total, "red in the view before any interior was published: " + before_png)
        self.assertGreater(after, 0.01 * total, "the interior's solid colour is not in rviz's view: " + after_png)


if __name__ == "__main__":
    rospy.init_node("rviz_screenshot_test")
    rostest.rosrun(PKG, "rviz_screenshot", RvizScreenshot, sys.argv)
