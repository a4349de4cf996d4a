"""Plain Python calls on the running nodes (docs/python.md).

- infer(task, ...) -> InteriorResult: one goal on interior_inference's `infer_interior` action
  (action/InferInterior.action), waiting for its result.
- track(video_file, ...) -> topo_gaussian.msg.MotionFeatures: motion_tracker's ~extract_motion service.
- perform(name, task, ...) -> PerformResult: a rig's ~perform_experiment service (rig_simulator's twin,
  or a lab's rig serving the same srv/PerformExperiment.srv).

They need rospy.init_node() first. Each raises TopoClientError naming what is wrong and what to do
(no server, a refused goal, a timeout); a refusal the server states in its answer (a rig that cannot
perform the experiment) is returned, not raised, so a loop can go on.
"""
import math

import numpy as np

__all__ = ["infer", "track", "perform", "action_client", "InteriorResult", "PerformResult", "TopoClientError", "cloud_arrays"]

MOMENT_NAMES = ("m", "cx", "cy", "cz", "Ixx", "Iyy", "Izz", "Ixy", "Ixz", "Iyz")


class TopoClientError(RuntimeError):
    """A call that did not reach a result: the message names the call, what happened and what to do."""


# PointCloud2 field datatypes -> numpy
_PC2_TYPES = {1: "i1", 2: "u1", 3: "i2", 4: "u2", 5: "i4", 6: "u4", 7: "f4", 8: "f8"}


def cloud_arrays(cloud):
    """{field name: numpy array (one entry per point)} of a sensor_msgs/PointCloud2 (any field layout)."""
    n = cloud.width * cloud.height
    if n == 0 or not cloud.fields:
        return {}
    endian = ">" if cloud.is_bigendian else "<"
    names, formats, offsets = [], [], []
    for f in cloud.fields:
        if f.datatype not in _PC2_TYPES:
            continue
        names.append(f.name)
        formats.append(endian + _PC2_TYPES[f.datatype])
        offsets.append(f.offset)
    dtype = np.dtype({"names": names, "formats": formats, "offsets": offsets, "itemsize": cloud.point_step})
    rows = np.frombuffer(bytes(cloud.data), dtype=dtype, count=n)
    return {name: np.array(rows[name]) for name in names}


class InteriorResult:
    """An infer_interior result with numpy arrays.

    points (N x 3, m, object frame), solid (N, 0..1: the indicator r), density (N, kg/m^3), stiffness,
    confidence (N, where published); mass (kg), com (3, m), inertia (3 x 3, kg m^2 about the centre of
    mass), moment_std (dict of the ten moments' stds, empty when not analysed; inf: unconstrained),
    determined / free (moment names), identifiability (words), next_experiment (words) and its
    next_kind / next_task / next_overrides / next_instruments / next_tilt_deg, loop_continues /
    loop_decision / loop_reason, converged, preempted, message, experiment_names, files, output_dir;
    features {name: (achieved, target, unit)}; `msg` is the action result message itself.
    """

    def __init__(self, msg, state_text="SUCCEEDED"):
        self.msg = msg
        self.state = state_text
        arrays = cloud_arrays(msg.interior)
        if arrays:
            self.points = np.stack([arrays["x"], arrays["y"], arrays["z"]], axis=1).astype(float)
        else:
            self.points = np.zeros((0, 3))
        empty = np.zeros(len(self.points))
        self.solid = arrays.get("solid", empty).astype(float)
        self.r = self.solid
        self.density = arrays.get("density", empty).astype(float)
        self.stiffness = arrays.get("stiffness", empty).astype(float)
        self.confidence = arrays.get("confidence", empty).astype(float)
        self.mass = float(msg.mass_kg)
        self.com = np.array(msg.center_of_mass, dtype=float) if len(msg.center_of_mass) == 3 else np.full(3, np.nan)
        self.inertia = np.array(msg.inertia, dtype=float).reshape(3, 3) if len(msg.inertia) == 9 else np.full((3, 3), np.nan)
        stds = list(msg.moment_std)
        self.moment_std = dict(zip(MOMENT_NAMES, stds)) if len(stds) == len(MOMENT_NAMES) else {}
        self.determined = list(msg.determined_moments)
        self.free = list(msg.free_moments)
        self.identifiability = msg.identifiability
        self.next_experiment = msg.next_experiment
        self.next_kind = msg.next_experiment_kind
        self.next_task = msg.next_experiment_task
        self.next_overrides = list(msg.next_experiment_overrides)
        self.next_instruments = list(msg.next_experiment_instruments)
        self.next_tilt_deg = float(msg.next_experiment_tilt_deg)
        self.uncertain_fraction = float(msg.uncertain_fraction)
        self.loop_continues = bool(msg.loop_continues)
        self.loop_decision = msg.loop_decision
        self.loop_reason = msg.loop_reason
        self.converged = bool(msg.converged)
        self.preempted = bool(msg.preempted)
        self.message = msg.message
        self.iterations = int(msg.iterations)
        self.solid_fraction = float(msg.solid_fraction)
        self.experiment_names = list(msg.experiment_names)
        self.files = list(msg.files)
        self.output_dir = msg.output_dir
        self.features = {
            name: (msg.achieved[k] if k < len(msg.achieved) else math.nan,
                   msg.target[k] if k < len(msg.target) else math.nan,
                   msg.units[k] if k < len(msg.units) else "")
            for k, name in enumerate(msg.feature_names)
        }

    def summary(self):
        """A dict of plain numbers and words (JSON-ready): what a log or a result file keeps."""

        def finite(v):
            return v if isinstance(v, float) and math.isfinite(v) else None

        return {
            "state": self.state,
            "converged": self.converged,
            "message": self.message,
            "mass_kg": finite(self.mass),
            "center_of_mass_m": [finite(float(v)) for v in self.com],
            "inertia_kg_m2": [[finite(float(v)) for v in row] for row in self.inertia],
            "moment_std": {k: (finite(float(v)) if math.isfinite(v) else ("inf" if math.isinf(v) else None))
                           for k, v in self.moment_std.items()},
            "determined": self.determined,
            "free": self.free,
            "identifiability": self.identifiability,
            "next_experiment": self.next_experiment,
            "next_kind": self.next_kind,
            "next_task": self.next_task,
            "next_overrides": self.next_overrides,
            "next_instruments": self.next_instruments,
            "loop_continues": self.loop_continues,
            "loop_decision": self.loop_decision,
            "loop_reason": self.loop_reason,
            "experiment_names": self.experiment_names,
            "iterations": self.iterations,
            "points": int(len(self.points)),
            "output_dir": self.output_dir,
            "files": self.files,
        }

    def __repr__(self):
        return "InteriorResult(mass=%.4g kg, %d points, experiments %s, converged %s)" % (
            self.mass, len(self.points), ",".join(self.experiment_names) or "-", self.converged)


def _as_list(value, what):
    if value is None:
        return []
    if isinstance(value, str):
        return [value]
    if isinstance(value, dict):
        return ["%s=%s" % (k, v) for k, v in value.items()]
    try:
        return [str(v) for v in value]
    except TypeError:
        raise TopoClientError("%s %r is not a list of 'KEY=VALUE' texts: give e.g. ['duration_s=1.5'] or "
                              "{'duration_s': 1.5}" % (what, value))


_action_clients = {}


def action_client(action="infer_interior"):
    """The process's SimpleActionClient of `action` (made on first use, then reused: a node that makes
    it at start shows the action client in its interface before its first goal)."""
    import actionlib
    import rospy
    from topo_gaussian.msg import InferInteriorAction

    name = rospy.resolve_name(action)
    if name not in _action_clients:
        _action_clients[name] = actionlib.SimpleActionClient(name, InferInteriorAction)
    return _action_clients[name]


def infer(task="", targets=None, overrides=None, object_id="", experiments=None, representation="",
          max_iterations=0, output_dir="", features=None, ignore_motion_features=False, volume=None,
          timeout=900.0, action="infer_interior", feedback_cb=None, server_wait=10.0):
    """One infer_interior goal; returns its InteriorResult.

    task: a task name or YAML path (config/tasks); experiments: "[NAME=]TASK" texts; targets and
    overrides: "NAME=VALUE" texts or a dict; object_id: keep this object's experiments across calls;
    features: a MotionFeatures message (None: the node takes the latest on motion_features);
    timeout (s): the goal is cancelled and TopoClientError raised after it (the node keeps serving).
    A goal the node aborts (bad task, no volume ...) raises TopoClientError with the node's message.
    """
    import rospy
    from actionlib_msgs.msg import GoalStatus
    from topo_gaussian.msg import InferInteriorGoal

    goal = InferInteriorGoal()
    goal.task = task or ""
    goal.experiments = _as_list(experiments, "experiments")
    goal.representation = representation or ""
    goal.overrides = _as_list(overrides, "overrides")
    goal.targets = _as_list(targets, "targets")
    goal.max_iterations = int(max_iterations)
    goal.output_dir = output_dir or ""
    goal.object_id = object_id or ""
    goal.ignore_motion_features = bool(ignore_motion_features)
    if features is not None:
        goal.features = features
    if volume is not None:
        goal.volume = volume
    if not goal.task and not goal.experiments:
        raise TopoClientError("infer: no task and no experiments: give task='tumbler' (a config/tasks name or a "
                              "YAML path) or experiments=['rock=tumbler']")
    client = action_client(action)
    name = rospy.resolve_name(action)
    if not client.wait_for_server(rospy.Duration(server_wait)):
        raise TopoClientError("infer: no action server on %s within %.0f s: start interior_inference (roslaunch "
                              "topo_gaussian inference.launch) or pass action='/NS/infer_interior'" % (name, server_wait))
    client.send_goal(goal, feedback_cb=feedback_cb)
    if not client.wait_for_result(rospy.Duration(timeout)):
        client.cancel_goal()
        client.wait_for_result(rospy.Duration(30.0))
        raise TopoClientError("infer: no result from %s within timeout=%.0f s: the goal was cancelled; give a "
                              "longer timeout or fewer max_iterations" % (name, timeout))
    state = client.get_state()
    result = client.get_result()
    texts = {GoalStatus.SUCCEEDED: "SUCCEEDED", GoalStatus.PREEMPTED: "PREEMPTED", GoalStatus.ABORTED: "ABORTED",
             GoalStatus.REJECTED: "REJECTED"}
    state_text = texts.get(state, str(state))
    if result is None or state in (GoalStatus.ABORTED, GoalStatus.REJECTED):
        why = result.message if result is not None and result.message else client.get_goal_status_text()
        raise TopoClientError("infer: %s refused the goal (%s): %s" % (name, state_text, why))
    return InteriorResult(result, state_text)


def _call_service(what, service, srv_type, req, timeout, start_hint):
    """(resolved name, response) of one call; TopoClientError when no server comes or the call fails."""
    import rospy

    name = rospy.resolve_name(service)
    try:
        rospy.wait_for_service(name, timeout)
    except rospy.ROSException:
        raise TopoClientError("%s: no service %s within %.0f s: %s" % (what, name, timeout, start_hint))
    try:
        return name, rospy.ServiceProxy(name, srv_type)(req)
    except rospy.ServiceException as e:
        raise TopoClientError("%s: the call to %s failed (%s)" % (what, name, e))


def track(video_file, kind="", method="", roi=None, start_s=0.0, end_s=0.0, stride=1,
          service="motion_tracker/extract_motion", timeout=10.0):
    """motion_tracker's ~extract_motion on a video file: returns its MotionFeatures message. A video
    the tracker cannot measure raises TopoClientError with the tracker's message."""
    from topo_gaussian.srv import ExtractMotion, ExtractMotionRequest

    req = ExtractMotionRequest(video_file=video_file, method=method, kind=kind, roi=list(roi or []),
                               start_s=start_s, end_s=end_s, stride=int(stride))
    name, res = _call_service("track", service, ExtractMotion, req, timeout,
                              "start motion_tracker (roslaunch topo_gaussian motion_tracker.launch) or pass "
                              "service='/NS/motion_tracker/extract_motion'")
    if not res.success:
        raise TopoClientError("track: %s could not measure %s: %s" % (name, video_file, res.message))
    return res.features


class PerformResult:
    """A rig's answer: accepted, message, readings {name: value}, resolutions {name: step}, setup_s,
    raw_readings ("name=value" as the rig wrote them: an infer goal's targets of this experiment)."""

    def __init__(self, name, res):
        self.name = name
        self.accepted = bool(res.accepted)
        self.message = res.message
        self.readings, self.resolutions = {}, {}
        for k, text in enumerate(res.readings):
            key, _, value = text.partition("=")
            try:
                self.readings[key] = float(value)
            except ValueError:
                self.readings[key] = math.nan
            self.resolutions[key] = res.resolutions[k] if k < len(res.resolutions) else 0.0
        self.setup_s = float(res.setup_s)
        self.raw_readings = list(res.readings)

    def __repr__(self):
        return "PerformResult(%s, accepted=%s, readings=%s)" % (self.name, self.accepted, self.readings)


def perform(name, task, overrides=None, instruments=None, service="rig_simulator/perform_experiment",
            timeout=10.0):
    """A rig's ~perform_experiment: returns a PerformResult (accepted False with the rig's reason when it
    cannot perform it; the rig keeps the experiments so far). No rig, or a failed call: TopoClientError."""
    from topo_gaussian.srv import PerformExperiment, PerformExperimentRequest

    req = PerformExperimentRequest(name=name, task=task, overrides=_as_list(overrides, "overrides"),
                                   instruments=_as_list(instruments, "instruments"))
    _, res = _call_service("perform", service, PerformExperiment, req, timeout,
                           "start the rig (roslaunch topo_gaussian tumbler_rig.launch for the twin) or pass "
                           "service='/NS/perform_experiment'")
    return PerformResult(name, res)
