#!/usr/bin/env python3
"""experiment_runner on the tumbler twin (experiment_runner.test): the record it publishes on
/experiment_runner/result once the plan is done, and the same record in its ~result_file.

- step 1 (observe) recorded a measured window of the twin's rocking, and its inference ran;
- step 2 (a pause) waited for a person until this test called /experiment_runner/continue;
- step 3 (a hang 0.82 m off the object) was refused by the rig, the refusal named in the record with
  the step, and the run went on (on_error: continue);
- step 4 (a hang on the flat top) was performed, its pitch read, and the inference after it fitted the
  object's two experiments (object_id) and states what they determine and the next experiment.
Then the Python module on the same graph: topo_gaussian.infer's arrays (points, solid, density, a
symmetric positive definite inertia), and bad input (an unknown task, an override without '=', a
missing video, no action server) raised or refused naming it, the inference serving on after it.
Test methods run in name order: the client's goals come after the plan's.
"""
import json
import sys
import time
import unittest

import rospy
import rostest
from std_msgs.msg import String
from std_srvs.srv import Trigger


class ExperimentRunnerOnTheTwin(unittest.TestCase):
    def test_a_plan_runs_and_is_recorded(self):
        wait_s = float(rospy.get_param("~wait_s", 560.0))
        result_file = rospy.get_param("~result_file")
        latest = {}

        def on_result(msg):
            latest["record"] = json.loads(msg.data)

        rospy.Subscriber("/experiment_runner/result", String, on_result)
        rospy.wait_for_service("/experiment_runner/continue", 60.0)
        proceed = rospy.ServiceProxy("/experiment_runner/continue", Trigger)
        continued = []
        end = time.monotonic() + wait_s
        while time.monotonic() < end and not latest.get("record", {}).get("finished"):
            if not continued:  # refused (success false) until the pause waits
                try:
                    answer = proceed()
                    if answer.success:
                        continued.append(answer.message)
                except rospy.ServiceException:
                    pass
            time.sleep(0.5)
        record = latest.get("record")
        self.assertIsNotNone(record, "nothing on /experiment_runner/result within %.0f s" % wait_s)
        self.assertTrue(record["finished"], "the plan did not finish within %.0f s: %s" % (wait_s, record))
        with open(result_file) as f:
            self.assertEqual(json.load(f), record, "~result_file differs from ~result")

        self.assertEqual(record["object_id"], "rostest_doll")
        self.assertTrue(record["status"].startswith("completed"), record["status"])
        steps = {s["step"]: s for s in record["steps"]}
        self.assertEqual(sorted(steps), [1, 2, 3, 4], record["steps"])

        observe, pause, far, hang = steps[1], steps[2], steps[3], steps[4]
        self.assertEqual(len(continued), 1, "~continue never answered success")
        self.assertIn("the test calls /experiment_runner/continue", continued[0])
        self.assertEqual((pause["status"], pause["message"]), ("done", "~continue called"), pause)
        self.assertEqual(observe["status"], "done", observe)
        self.assertTrue(any(w["measured"] for w in observe["windows"]), observe["windows"])
        self.assertEqual(far["status"], "failed", far)
        self.assertIn("step 3 (perform far)", far["message"])
        self.assertIn("the rig cannot perform it", far["message"])
        self.assertIn("hanging_point", far["message"])
        self.assertEqual(hang["status"], "done", hang)
        self.assertIn("target_pitch_deg=", hang["message"])
        self.assertEqual(record["status"], "completed (failed steps: 3)")

        inferences = record["inferences"]
        self.assertEqual([i["after"] for i in inferences], [[1], [4]], inferences)
        for i in inferences:
            self.assertEqual(i["status"], "done", i)
            r = i["result"]
            self.assertGreater(r["mass_kg"], 0.0)
            self.assertEqual(len(r["center_of_mass_m"]), 3)
            self.assertEqual(len(r["inertia_kg_m2"]), 3)
            self.assertGreater(r["points"], 100)
        last = inferences[-1]["result"]
        self.assertEqual(len(last["experiment_names"]), 2, last["experiment_names"])
        self.assertIn("hang1", last["experiment_names"])
        self.assertTrue(last["identifiability"], "the two-experiment result states no identifiability")
        self.assertTrue(last["loop_decision"] or last["loop_continues"], last)
        self.assertIn("hang1.target_pitch_deg=", " ".join(inferences[-1]["goal"]["targets"]))

    # then the Python client on the same graph (after the plan: a new goal would preempt the runner's):
    # numpy arrays, and bad input named with the nodes serving on

    def test_c_infer_returns_arrays_after_the_refusals(self):
        import numpy as np
        import topo_gaussian

        # the node serves on after test_b's refused goal
        r = topo_gaussian.infer("tumbler", targets={"period_s": 0.93, "max_tilt_deg": 10.0}, max_iterations=1,
                                ignore_motion_features=True, timeout=300)
        self.assertEqual(r.points.ndim, 2)
        self.assertEqual(r.points.shape[1], 3)
        self.assertGreater(len(r.points), 100)
        self.assertEqual(r.solid.shape, (len(r.points),))
        self.assertTrue(np.all((r.solid >= 0) & (r.solid <= 1)))
        self.assertTrue(np.all(r.density > 0))
        self.assertGreater(r.mass, 0)
        self.assertEqual(r.inertia.shape, (3, 3))
        np.testing.assert_allclose(r.inertia, r.inertia.T, atol=1e-12)
        self.assertTrue(np.all(np.linalg.eigvalsh(r.inertia) > 0))
        self.assertEqual(r.com.shape, (3,))
        self.assertIn("period_s", r.features)

    def test_b_bad_input_is_named(self):
        import topo_gaussian

        with self.assertRaises(topo_gaussian.TopoClientError) as cm:
            topo_gaussian.infer("no_such_task", timeout=120)
        self.assertIn("no_such_task", str(cm.exception))
        self.assertIn("refused the goal", str(cm.exception))
        rig = topo_gaussian.perform("bad", "hanging", overrides=["hanging_point"])
        self.assertFalse(rig.accepted)
        self.assertIn("is not KEY=VALUE", rig.message)
        with self.assertRaises(topo_gaussian.TopoClientError) as cm:
            topo_gaussian.track("/nonexistent/clip.mp4")
        self.assertIn("/nonexistent/clip.mp4", str(cm.exception))
        with self.assertRaises(topo_gaussian.TopoClientError) as cm:
            topo_gaussian.infer("tumbler", action="/no_such_server/infer_interior", server_wait=1.0)
        self.assertIn("no action server on /no_such_server/infer_interior", str(cm.exception))


if __name__ == "__main__":
    rospy.init_node("experiment_runner_test")
    rostest.rosrun("topo_gaussian", "experiment_runner", ExperimentRunnerOnTheTwin, sys.argv)
