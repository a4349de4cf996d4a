"""An experiment plan (experiment_runner's YAML, docs/nodes.md#experiment_runner), read and checked
without ROS. parse_plan(text or dict) -> Plan, or PlanError naming the step, what is wrong and the fix.

    object_id: doll              # the inference keeps this object's experiments across its goals
    task: tumbler                # the task of steps that name none
    max_iterations: 20           # each inference's objective evaluations (0: the task's)
    infer: each                  # each: after every step that adds an experiment | end | never
    on_error: stop               # stop | continue: what a step that fails does (a step may say its own)
    steps:
      - observe: ""              # the camera's next measured window (of experiment NAME; "": any)
      - perform: hang1           # the rig performs it (~perform_experiment) ...
        task: hanging
        overrides: [hanging_point=0,0.04,0.02]
        instruments: [target_pitch_deg]
      - pause: "hang the doll at B" # a person acts; waits for ~continue or timeout_s, then the
        camera: true             #   camera's window (camera: false: it only waits)
        experiment: hangB
        task: hanging
      - pressure: [0, 20000, 40000] # the finger: each set point on pressure_command, hold_s each
        experiment: ladder
      - infer: {}                # an inference now, over the experiments since the last one
"""
import copy

try:
    import yaml
except ImportError:  # parse_plan on a dict still works
    yaml = None

KINDS = ("observe", "perform", "pause", "pressure", "infer")
INFER_MODES = ("each", "end", "never")
ON_ERROR = ("stop", "continue")
# keys each kind takes besides its own
COMMON_KEYS = {"on_error", "timeout_s", "task", "experiment", "overrides", "targets", "max_iterations", "min_window_s"}
KIND_KEYS = {
    "observe": set(),
    "perform": {"instruments", "tilt_reference_deg"},
    "pause": {"camera"},
    "pressure": {"hold_s"},
    "infer": {"experiments", "ignore_motion_features"},
}
PLAN_KEYS = {"object_id", "task", "max_iterations", "infer", "on_error", "steps", "timeout_s", "infer_timeout_s"}


class PlanError(ValueError):
    """A plan the runner cannot run: the message names the step (1-based), what is wrong and the fix."""


class Step:
    """One step: kind (observe | perform | pause | pressure | infer), the value given with the kind
    (an experiment name, the pause's instruction, the pressures), and its settings."""

    def __init__(self, index, kind, value, options):
        self.index = index  # 1-based, as messages name it
        self.kind = kind
        self.value = value
        self.options = options
        self.on_error = options["on_error"]
        self.timeout_s = options["timeout_s"]
        self.task = options.get("task", "")
        self.experiment = options.get("experiment", "")
        self.overrides = options.get("overrides", [])
        self.targets = options.get("targets", [])
        self.instruments = options.get("instruments", [])
        self.pressures = options.get("pressures", [])
        self.hold_s = options.get("hold_s", 0.0)
        self.observe = options.get("observe", True)
        self.max_iterations = options.get("max_iterations")
        self.min_window_s = options.get("min_window_s", 3.0)

    @property
    def adds_experiment(self):
        """True when the step adds an experiment to the next inference."""
        if self.kind in ("observe", "perform", "pressure"):
            return True
        return self.kind == "pause" and self.observe

    def label(self):
        what = self.experiment or (self.value if self.kind in ("observe", "perform") and isinstance(self.value, str) else "")
        return "step %d (%s%s)" % (self.index, self.kind, (" " + what) if what else "")

    def __repr__(self):
        return "Step(%d, %s, %r)" % (self.index, self.kind, self.value)


class Plan:
    def __init__(self, object_id, task, max_iterations, infer, on_error, timeout_s, infer_timeout_s, steps):
        self.object_id = object_id
        self.task = task
        self.max_iterations = max_iterations
        self.infer = infer
        self.on_error = on_error
        self.timeout_s = timeout_s
        self.infer_timeout_s = infer_timeout_s
        self.steps = steps


def _texts(value, where, key):
    if value is None:
        return []
    if isinstance(value, str):
        return [v.strip() for v in value.split(";") if v.strip()]
    if isinstance(value, dict):
        return ["%s=%s" % (k, ",".join(str(x) for x in v) if isinstance(v, (list, tuple)) else v)
                for k, v in value.items()]
    if isinstance(value, (list, tuple)):
        return [str(v) for v in value]
    raise PlanError("%s: '%s' is %r, not a list: write e.g. %s: [KEY=VALUE, ...]" % (where, key, value, key))


def _assignments(value, where, key):
    """KEY=VALUE texts; a mapping {KEY: VALUE or [x, y, z]} too. An item without '=' is most often a
    vector split by YAML's flow list ([hanging_point=0,0.04,0.02] reads as three items)."""
    items = _texts(value, where, key)
    for item in items:
        if "=" not in item:
            raise PlanError("%s: %s item '%s' is not KEY=VALUE (a vector in [...] is split at its commas): write "
                            "%s: {hanging_point: [0, 0.04, 0.02]} or quote the item: [\"hanging_point=0,0.04,0.02\"]"
                            % (where, key, item, key))
    return items


def _number(value, where, key, low=None, strict=False):
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise PlanError("%s: '%s' is %r, not a number: write e.g. %s: 60" % (where, key, value, key))
    v = float(value)
    if v != v or (low is not None and (v <= low if strict else v < low)):
        raise PlanError("%s: '%s' = %r is out of range: it must be %s %g" % (where, key, value,
                                                                          ">" if strict else ">=", low))
    return v


def _choice(value, where, key, choices):
    if value not in choices:
        raise PlanError("%s: '%s' is %r: use one of %s" % (where, key, value, ", ".join(choices)))
    return value


def parse_plan(source, default_object_id="experiment_runner"):
    """A Plan from YAML text or an already loaded dict. PlanError on anything the runner could not do."""
    if isinstance(source, str):
        if yaml is None:
            raise PlanError("the plan is YAML text but PyYAML is missing: install python3-yaml")
        try:
            data = yaml.safe_load(source)
        except yaml.YAMLError as e:
            raise PlanError("the plan is not valid YAML (%s): check its indentation and quoting" % e)
    else:
        data = copy.deepcopy(source)
    if isinstance(data, list):
        data = {"steps": data}
    if not isinstance(data, dict):
        raise PlanError("the plan is %r, not a mapping with a 'steps:' list: see docs/nodes.md#experiment_runner"
                        % (data,))
    unknown = sorted(set(data) - PLAN_KEYS)
    if unknown:
        raise PlanError("the plan has unknown key(s) %s: the keys are %s" % (", ".join(unknown),
                                                                            ", ".join(sorted(PLAN_KEYS))))
    where = "the plan"
    object_id = str(data.get("object_id", default_object_id) or default_object_id)
    task = str(data.get("task", "") or "")
    max_iterations = int(_number(data.get("max_iterations", 0), where, "max_iterations", 0))
    infer = _choice(data.get("infer", "each"), where, "infer", INFER_MODES)
    on_error = _choice(data.get("on_error", "stop"), where, "on_error", ON_ERROR)
    timeout_s = _number(data.get("timeout_s", 120.0), where, "timeout_s", 0, strict=True)
    infer_timeout_s = _number(data.get("infer_timeout_s", 900.0), where, "infer_timeout_s", 0, strict=True)
    raw_steps = data.get("steps")
    if not isinstance(raw_steps, list) or not raw_steps:
        raise PlanError("the plan has no steps: give 'steps:' as a list, e.g. steps: [{observe: ''}]")
    steps = []
    for i, raw in enumerate(raw_steps, 1):
        steps.append(_parse_step(i, raw, task, on_error, timeout_s, max_iterations))
    names = {}
    for s in steps:
        if s.experiment:
            if s.experiment in names:
                raise PlanError("step %d: experiment '%s' is already step %d's: give each experiment its own name"
                                % (s.index, s.experiment, names[s.experiment]))
            names[s.experiment] = s.index
    return Plan(object_id, task, max_iterations, infer, on_error, timeout_s, infer_timeout_s, steps)


def _parse_step(i, raw, plan_task, plan_on_error, plan_timeout_s, plan_max_iterations):
    where = "step %d" % i
    if isinstance(raw, str):
        raw = {raw: None}
    if not isinstance(raw, dict):
        raise PlanError("%s is %r, not a mapping: write e.g. '- observe: rock' or '- perform: hang1'" % (where, raw))
    kinds = [k for k in raw if k in KINDS]
    if len(kinds) != 1:
        others = [k for k in raw if k not in COMMON_KEYS and k not in set().union(*KIND_KEYS.values())]
        if not kinds and others:
            raise PlanError("%s: unknown step kind '%s': the kinds are %s" % (where, others[0], ", ".join(KINDS)))
        raise PlanError("%s names %s: give exactly one of %s" % (
            where, ("the kinds " + ", ".join(kinds)) if kinds else "no kind", ", ".join(KINDS)))
    kind = kinds[0]
    value = raw[kind]
    allowed = COMMON_KEYS | KIND_KEYS[kind] | {kind}
    unknown = sorted(k for k in raw if k not in allowed)
    if unknown:
        raise PlanError("%s (%s): unknown key(s) %s: a %s step takes %s" % (
            where, kind, ", ".join(map(str, unknown)), kind, ", ".join(sorted(allowed - {kind}))))
    opts = {
        "on_error": _choice(raw.get("on_error", plan_on_error), where, "on_error", ON_ERROR),
        "timeout_s": _number(raw.get("timeout_s", plan_timeout_s), where, "timeout_s", 0, strict=True),
        "task": str(raw.get("task", plan_task) or ""),
        "overrides": _assignments(raw.get("overrides"), where, "overrides"),
        "targets": _assignments(raw.get("targets"), where, "targets"),
        "max_iterations": int(_number(raw.get("max_iterations", plan_max_iterations), where, "max_iterations", 0)),
        "min_window_s": _number(raw.get("min_window_s", 3.0), where, "min_window_s", 0),
    }
    experiment = raw.get("experiment")
    if kind == "observe":
        experiment = value if experiment is None else experiment
    elif kind == "perform":
        if experiment is not None and value is not None and experiment != value:
            raise PlanError("%s (perform): the experiment is named twice ('%s', '%s'): write '- perform: NAME'"
                            % (where, value, experiment))
        experiment = value if value is not None else experiment
        if not experiment or not isinstance(experiment, str):
            raise PlanError("%s (perform): no experiment name: write '- perform: hang1' (the rig and the tracker "
                            "tag the experiment with it)" % where)
        if not opts["task"]:
            raise PlanError("%s (perform %s): no task: give 'task: hanging' (the rig sets the experiment up as "
                            "that task)" % (where, experiment))
        opts["instruments"] = _texts(raw.get("instruments"), where, "instruments")
    elif kind == "pause":
        if not isinstance(value, str) or not value.strip():
            raise PlanError("%s (pause): no instruction: write '- pause: \"hang the doll at B\"' (what the person "
                            "does before calling ~continue)" % where)
        obs = raw.get("camera", True)
        if not isinstance(obs, bool):
            raise PlanError("%s (pause): 'camera' is %r: write true (the camera's window after it) or false (it only "
                            "waits)" % (where, obs))
        opts["observe"] = obs
    elif kind == "pressure":
        if not isinstance(value, list) or not value:
            raise PlanError("%s (pressure): %r is not a list of pressures: write e.g. '- pressure: [0, 20000, "
                            "40000]' (Pa)" % (where, value))
        opts["pressures"] = [_number(p, where, "pressure", 0) for p in value]
        opts["hold_s"] = _number(raw.get("hold_s", 5.0), where, "hold_s", 0, strict=True)
    elif kind == "infer":
        if value not in (None, {}) and not isinstance(value, dict):
            raise PlanError("%s (infer): %r: write '- infer: {}' or give its settings as keys of the step" % (where, value))
    if experiment is not None and not isinstance(experiment, str):
        raise PlanError("%s (%s): experiment %r is not a name: write e.g. experiment: rock10" % (where, kind, experiment))
    experiment = experiment or ""
    if "." in experiment or "=" in experiment or ";" in experiment:
        raise PlanError("%s (%s): experiment name '%s' has '.', '=' or ';': use letters, digits and _ (e.g. hang1)"
                        % (where, kind, experiment))
    opts["experiment"] = experiment
    if kind in ("observe", "pressure", "pause") and not opts["task"] and (kind != "pause" or opts["observe"]):
        raise PlanError("%s (%s): no task for its experiment: give 'task: tumbler' in the step or the plan" % (where, kind))
    return Step(i, kind, value, opts)


class Experiment:
    """What a step added to the next inference: its name ("" = unnamed), task, set-up overrides and
    targets ("KEY=VALUE", without the name), the camera's window (a MotionFeatures message or None),
    whether the rig read its pose (its targets are the readings) and the timer's relative resolution."""

    def __init__(self, step, name, task, overrides, targets, window=None, pose_read=False, period_tolerance=0.0):
        self.step, self.name, self.task = step, name, task
        self.overrides, self.targets = list(overrides), list(targets)
        self.window, self.pose_read, self.period_tolerance = window, pose_read, period_tolerance


def goal_arguments(experiments):
    """topo_gaussian.infer() keyword arguments for the experiments since the last inference: one
    unnamed experiment is a plain task goal with its window; otherwise each goes by its name (an
    unnamed one as stepN) with its overrides and targets prefixed "NAME.", and a single one brings its
    window along (the node takes the latest tagged window of each of several)."""
    if len(experiments) == 1 and not experiments[0].name:
        e = experiments[0]
        return dict(task=e.task, overrides=e.overrides, targets=e.targets, features=e.window)
    names, overrides, targets = [], [], []
    for e in experiments:
        name = e.name or "step%d" % e.step.index
        names.append("%s=%s" % (name, e.task))
        overrides += ["%s.%s" % (name, o) for o in e.overrides]
        targets += ["%s.%s" % (name, t) for t in e.targets]
        if e.period_tolerance > 0:
            overrides.append("%s.axle_period_tolerance=%.3g" % (name, e.period_tolerance))
    kw = dict(experiments=names, overrides=overrides, targets=targets,
              ignore_motion_features=all(e.pose_read for e in experiments))
    if len(experiments) == 1 and experiments[0].window is not None:
        kw["features"] = experiments[0].window
    return kw
