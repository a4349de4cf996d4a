#!/usr/bin/env python3
"""experiment_runner's plan format (topo_gaussian.experiment_plan): what a lab writes is read as
written, and each mistake is refused naming the step, what is wrong and the fix. No ROS graph needed:
run directly or through experiment_plan.test."""
import os
import sys
import unittest

from topo_gaussian.experiment_plan import Experiment, PlanError, goal_arguments, parse_plan

PKG_DIR = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))

TUMBLER = """
object_id: doll
task: tumbler
max_iterations: 8
steps:
  - observe: ""
    timeout_s: 90
  - perform: hang1
    task: hanging
    overrides: {hanging_point: [0, 0.04, 0.02]}
    instruments: [target_pitch_deg]
    on_error: continue
  - pause: "hang the doll by its hook at B, then call ~continue"
    experiment: hangB
    task: hanging
    timeout_s: 300
"""


class PlanParsing(unittest.TestCase):
    def refused(self, text, *words):
        with self.assertRaises(PlanError) as cm:
            parse_plan(text)
        for w in words:
            self.assertIn(w, str(cm.exception))
        return str(cm.exception)

    def test_tumbler_plan_is_read_as_written(self):
        plan = parse_plan(TUMBLER)
        self.assertEqual(plan.object_id, "doll")
        self.assertEqual(plan.max_iterations, 8)
        self.assertEqual(plan.infer, "each")
        self.assertEqual([s.kind for s in plan.steps], ["observe", "perform", "pause"])
        observe, hang, pause = plan.steps
        self.assertEqual((observe.task, observe.experiment, observe.timeout_s), ("tumbler", "", 90.0))
        self.assertEqual((hang.experiment, hang.task), ("hang1", "hanging"))
        self.assertEqual(hang.overrides, ["hanging_point=0,0.04,0.02"])
        self.assertEqual(hang.instruments, ["target_pitch_deg"])
        self.assertEqual((hang.on_error, observe.on_error), ("continue", "stop"))
        self.assertEqual((pause.experiment, pause.timeout_s, pause.observe), ("hangB", 300.0, True))
        self.assertTrue(all(s.adds_experiment for s in plan.steps))

    def test_finger_ladder_and_an_explicit_inference(self):
        plan = parse_plan({"task": "finger", "infer": "never",
                           "steps": [{"pressure": [0, 20000, 40000], "hold_s": 4, "experiment": "ladder"},
                                     {"infer": {}, "max_iterations": 3}]})
        ladder, inf = plan.steps
        self.assertEqual(ladder.pressures, [0.0, 20000.0, 40000.0])
        self.assertEqual((ladder.hold_s, ladder.task), (4.0, "finger"))
        self.assertEqual((inf.kind, inf.max_iterations, inf.adds_experiment), ("infer", 3, False))

    def test_a_pause_without_the_camera_needs_no_task(self):
        pause = parse_plan("steps: [{pause: 'open the valve', camera: false}]").steps[0]
        self.assertEqual((pause.kind, pause.value, pause.adds_experiment), ("pause", "open the valve", False))
        self.refused("steps: [{pause: x, camera: 'no'}]", "step 1 (pause)", "'camera' is 'no'")

    def test_a_bare_list_is_the_steps_and_the_object_id_defaults(self):
        plan = parse_plan("- {observe: rock, task: tumbler}", default_object_id="my_plan")
        self.assertEqual((plan.object_id, plan.steps[0].experiment), ("my_plan", "rock"))

    def test_unknown_step_kind_names_the_step_and_the_kinds(self):
        self.refused("steps: [{observe: '', task: tumbler}, {swing: s1, task: hanging}]",
                     "step 2", "unknown step kind 'swing'", "observe, perform, pause, pressure, infer")

    def test_a_step_with_two_kinds_or_an_unknown_key(self):
        self.refused("steps: [{observe: a, perform: b, task: t}]", "step 1", "exactly one of")
        self.refused("steps: [{perform: h, task: hanging, instrument: [x]}]", "step 1 (perform)", "unknown key(s) instrument",
                     "instruments")

    def test_perform_needs_a_name_and_a_task(self):
        self.refused("steps: [{perform: null, task: hanging}]", "step 1 (perform)", "no experiment name")
        self.refused("steps: [{perform: hang1}]", "step 1 (perform hang1)", "no task", "task: hanging")

    def test_bad_values_are_named(self):
        self.refused("steps: [{pressure: 40000, task: finger}]", "step 1 (pressure)", "not a list of pressures")
        self.refused("steps: [{pressure: [0, -5], task: finger}]", "step 1", "'pressure'", "out of range")
        self.refused("steps: [{observe: a, task: t, timeout_s: 0}]", "step 1", "'timeout_s'", "> 0")
        self.refused("on_error: retry\nsteps: [{observe: a, task: t}]", "'on_error' is 'retry'", "stop, continue")
        self.refused("infer: always\nsteps: [{observe: a, task: t}]", "'infer'", "each, end, never")
        self.refused("steps: [{observe: a.b, task: t}]", "step 1", "'a.b'", "letters")
        self.refused("steps: [{observe: a}]", "step 1 (observe)", "no task")
        self.refused("steps: [{pause: ''}]", "step 1 (pause)", "no instruction")
        self.refused("steps: [{perform: h, task: hanging, overrides: [hanging_point=0,0.04,0.02]}]", "step 1",
                     "overrides item '0.04' is not KEY=VALUE", "{hanging_point: [0, 0.04, 0.02]}")

    def test_plan_level_mistakes(self):
        self.refused("steps: []", "no steps")
        self.refused("steps: [{observe: a, task: t}]\nstep: x", "unknown key(s) step")
        self.refused("steps: [{observe: a, task: t}, {perform: a, task: hanging}]", "step 2",
                     "'a' is already step 1's")
        self.refused("steps: [observe: a\n  - x", "not valid YAML")

    def test_goals_of_one_and_of_several_experiments(self):
        plan = parse_plan(TUMBLER)
        observe, hang, pause = plan.steps
        window = object()
        single = goal_arguments([Experiment(observe, "", "tumbler", ["measured_cycles=1"], [], window)])
        self.assertEqual(single, dict(task="tumbler", overrides=["measured_cycles=1"], targets=[], features=window))
        performed = Experiment(hang, "hang1", "hanging", hang.overrides, ["target_pitch_deg=12.5"], None, True, 0.002)
        kw = goal_arguments([performed])
        self.assertEqual(kw["experiments"], ["hang1=hanging"])
        self.assertEqual(kw["overrides"], ["hang1.hanging_point=0,0.04,0.02", "hang1.axle_period_tolerance=0.002"])
        self.assertEqual(kw["targets"], ["hang1.target_pitch_deg=12.5"])
        self.assertTrue(kw["ignore_motion_features"])
        # infer: end: all of them in one goal, the unnamed one as step1, the camera's windows from the node
        joint = goal_arguments([Experiment(observe, "", "tumbler", [], [], window), performed,
                                Experiment(pause, "hangB", "hanging", [], [], window)])
        self.assertEqual(joint["experiments"], ["step1=tumbler", "hang1=hanging", "hangB=hanging"])
        self.assertFalse(joint["ignore_motion_features"])
        self.assertNotIn("features", joint)

    def test_the_shipped_plans_parse(self):
        folder = os.path.join(PKG_DIR, "config", "plans")
        names = sorted(f for f in os.listdir(folder) if f.endswith(".yaml"))
        self.assertTrue(names, "no plan in %s" % folder)
        for name in names:
            with open(os.path.join(folder, name)) as f:
                self.assertTrue(parse_plan(f.read()).steps, name)


if __name__ == "__main__":
    if "--gtest_output" in " ".join(sys.argv) or any(a.startswith("__name:=") for a in sys.argv):
        import rostest

        rostest.rosrun("topo_gaussian", "experiment_plan", PlanParsing, sys.argv)
    else:
        unittest.main()
