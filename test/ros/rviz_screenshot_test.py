#!/usr/bin/env python3
"""rviz under Xvfb shows the inferred interior, its cavity and the camera.

Starts a virtual X server and rviz with rviz/topo_gaussian.rviz, takes a screenshot (xwd +
ImageMagick) before any interior exists, then asks interior_inference for one (~infer), and takes
screenshots until the solid colour (kSolidRgb, red) covers enough of the view. When the inferred
interior has a cavity in the half the markers keep (the cut-away, ros/interior_markers.h), its
highlight colour (cyan) must be in the view too. A test pattern published on /image (green and
magenta stripes) must show in the camera panel (not "No Image"). The last PNG is kept
(~artifact_dir/rviz_screenshot.png) next to the one taken before (rviz_before.png).
"""
import os
import subprocess
import sys
import tempfile
import time
import unittest

import threading

import numpy
import rospy
import rostest
from sensor_msgs.msg import Image
from topo_gaussian.srv import Infer, InferRequest
from visualization_msgs.msg import MarkerArray

PKG = "topo_gaussian"


def pixels(png):
    size = subprocess.run(["identify", "-format", "%w %h", png], check=True, stdout=subprocess.PIPE).stdout
    w, h = (int(v) for v in size.split())
    raw = subprocess.run(["convert", png, "-depth", "8", "rgb:-"], check=True, stdout=subprocess.PIPE).stdout
    img = numpy.frombuffer(raw, dtype=numpy.uint8)[: w * h * 3].reshape(h, w, 3).astype(int)
    return img[:, :, 0], img[:, :, 1], img[:, :, 2]


def solid_pixels(png):
    """Pixels of the solid colour (220, 40, 40), shaded or translucent on the dark background (~(90, 20, 20)):
    red clearly above green and blue."""
    r, g, b = pixels(png)
    return int(numpy.count_nonzero((r > 70) & (r > 2.5 * g) & (r > 2.5 * b))), r.size


def hollow_pixels(png):
    """Pixels of the cavity's highlight (32, 220, 230), shaded: cyan, green and blue far above red."""
    r, g, b = pixels(png)
    return int(numpy.count_nonzero((g > 110) & (b > 110) & (g > 2 * r) & (b > 2 * r)))


def pattern_pixels(png):
    """Pixels of the test pattern on /image: pure green or pure magenta."""
    r, g, b = pixels(png)
    green = (g > 200) & (r < 60) & (b < 60)
    magenta = (r > 200) & (b > 200) & (g < 60)
    return int(numpy.count_nonzero(green)), int(numpy.count_nonzero(magenta))


def pattern_image():
    """A 160 x 120 bgr8 image of vertical green and magenta stripes."""
    msg = Image(height=120, width=160, encoding="bgr8", step=160 * 3)
    row = bytearray()
    for x in range(160):
        row += bytes((0, 255, 0)) if (x // 20) % 2 == 0 else bytes((255, 0, 255))
    msg.data = bytes(row) * 120
    msg.header.frame_id = "camera_optical"
    return msg


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

        # the camera: a test pattern on /image, as a driver would publish it
        image_pub = rospy.Publisher("/image", Image, queue_size=1)
        stop = threading.Event()

        def publish_pattern():
            msg = pattern_image()
            while not stop.is_set() and not rospy.is_shutdown():
                msg.header.stamp = rospy.Time.now()
                image_pub.publish(msg)
                time.sleep(0.2)

        publisher = threading.Thread(target=publish_pattern, daemon=True)
        publisher.start()
        hollow_markers = []

        def on_markers(arr):
            for m in arr.markers:
                if m.id == 9 and m.action == m.ADD:  # the cavity's cubes (ros/interior_markers.h)
                    hollow_markers.append(len(m.points))

        rospy.Subscriber("/interior_markers", MarkerArray, on_markers)
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
            if after > 0.002 * total:
                break
        time.sleep(2)
        after, total = self.screenshot(display, after_png)
        stop.set()
        hollow = hollow_pixels(after_png)
        green, magenta = pattern_pixels(after_png)
        cavity = max(hollow_markers) if hollow_markers else 0
        print("[rviz] solid-coloured pixels: %d before the interior, %d after (of %d); cavity: %d cubes drawn, "
              "%d cyan pixels; camera panel: %d green, %d magenta pixels; screenshot %s"
              % (before, after, total, cavity, hollow, green, magenta, after_png))
        self.assertLess(before, 0.001 * total, "red in the view before any interior was published: " + before_png)
        # the half towards the viewer is cut away and the solid is translucent: 0.2 % of the screen
        self.assertGreater(after, 0.002 * total, "the interior's solid colour is not in rviz's view: " + after_png)
        self.assertGreater(after, 10 * before, "the interior's solid colour is not in rviz's view: " + after_png)
        self.assertGreater(green, 500, "the camera panel does not show /image (No Image?): " + after_png)
        self.assertGreater(magenta, 500, "the camera panel does not show /image (No Image?): " + after_png)
        if cavity > 0:
            self.assertGreater(hollow, 50, "the interior has a cavity (%d cubes in the kept half) but its highlight "
                               "is not in the view: %s" % (cavity, after_png))
        else:
            print("[rviz] the inferred interior has no cavity in the kept half: the highlight check does not apply")


if __name__ == "__main__":
    rospy.init_node("rviz_screenshot_test")
    rostest.rosrun(PKG, "rviz_screenshot", RvizScreenshot, sys.argv)
