#!/usr/bin/env python3
"""experiment_runner's pressure ladder on the finger twin (experiment_runner_finger.test): the twin
reports each set point on pressure_pa, and the runner's record holds a measured finger window (the
bend at full pressure) with the step done."""
import json
import sys
import time
import unittest

import rospy
import rostest
from std_msgs.msg import Float64, String


class PressureLadderOnTheFingerTwin(unittest.TestCase):
    def test_ladder_reaches_the_twin_and_the_bend_is_recorded(self):
        latest, pressures = {}, []
        rospy.Subscriber("/experiment_runner/result", String, lambda m: latest.update(record=json.loads(m.data)))
        rospy.Subscriber("/pressure_pa", Float64, lambda m: pressures.append(m.data))
        end = time.monotonic() + 240.0
        while time.monotonic() < end and not latest.get("record", {}).get("finished"):
            time.sleep(0.5)
        record = latest.get("record")
        self.assertIsNotNone(record, "nothing on /experiment_runner/result within 240 s")
        self.assertTrue(record["finished"], record)
        self.assertEqual(record["status"], "completed", record)
        self.assertEqual(record["inferences"], [])  # infer: never
        (step,) = record["steps"]
        self.assertEqual((step["kind"], step["status"]), ("pressure", "done"), step)
        self.assertIn("ladder 0, 500000, 0, 500000 Pa played", step["message"])
        finger = [w for w in step["windows"] if w["kind"] == "finger" and w["measured"]]
        self.assertTrue(finger, "no measured finger window in %s" % step["windows"])
        self.assertGreater(max(abs(w["bending_angle_deg"] or 0.0) for w in finger), 1.0)
        self.assertTrue(pressures, "nothing on /pressure_pa")
        self.assertAlmostEqual(max(pressures), 500000.0, delta=5000.0)


if __name__ == "__main__":
    rospy.init_node("experiment_runner_finger_test")
    rostest.rosrun("topo_gaussian", "experiment_runner_finger", PressureLadderOnTheFingerTwin, sys.argv)
