// infer_client: sends one infer_interior goal and prints its feedback and result; with
// ~ground_truth_topic (a rig_simulator's ~ground_truth) it also prints the recovered features next to
// the twin's truth, the recovered mass, centre of mass, inertia and solid fraction next to the true ones and
// the IoU of the recovered and true cavity, and exits 0 only when every truth feature is reproduced within
// ~tolerance (the interior is reported, not judged: several interiors may reproduce the features); a
// targeted feature relative to its truth, or, near zero, to its natural scale (angles [deg] on 10 deg,
// lengths [m] on the object's size).
// What `make demo` runs against demo.launch. Parameters (private):
//   ~task (tumbler; "" when ~experiments are given), ~experiments [] ("NAME=TASK": several experiments of the
//   object, as the goal's; the client waits for a measured window of each), ~representation (""),
//   ~overrides [], ~targets [] (lists, or "A=1;B=2"), ~max_evaluations (0: the task's; objective evaluations, the
//   goal's max_iterations; ~max_iterations is its old name, still read),
//   ~output_dir (""), ~wait_for_features_s (120: wait for motion_features with a measured motion
//   before sending; 0 = send at once), ~ground_truth_topic (""), ~tolerance (0.02), ~timeout_s (900),
//   ~weigh_topic ("": a std_msgs/Float64 scale reading [kg], e.g. /scale_kg of a rig_simulator, added as the
//   target mass_kg of ~weigh_experiment (a hanging, balance or stand experiment; "" with a single experiment)
//   ~auto_experiments (0): after the result, let the rig perform the suggested next experiment (~perform_service,
//   /rig_simulator/perform_experiment; the tracker gets its predicted rest tilt on `tilt_reference`), wait for
//   its measured window and infer again with the object's experiments so far (~object_id, "demo_object"), until
//   the result's loop rule stops or the object has this many experiments; a line per step.
// Exit codes: 0 done (and within tolerance of the truth), 1 aborted / timed out / bad parameters,
// 3 finished but the truth was not reproduced.
#include <actionlib/client/simple_action_client.h>
#include <ros/ros.h>

#include <sensor_msgs/point_cloud2_iterator.h>
#include <std_msgs/Float64.h>
#include <std_msgs/String.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <mutex>
#include <set>
#include <string>
#include <vector>

#include "topo_gaussian/InferInteriorAction.h"
#include "topo_gaussian/MotionFeatures.h"
#include "topo_gaussian/PerformExperiment.h"
#include "topo_gaussian/RigGroundTruth.h"
#include "topo_gaussian/common/error.h"
#include "topo_gaussian/ros/ascii_text.h"
#include "topo_gaussian/ros/param_reader.h"
#include "topo_gaussian/ros/truth_comparison_msg.h"

namespace {

template <typename Msg>
typename Msg::ConstPtr waitFor(const std::string& topic, double timeout_s, bool (*accept)(const Msg&)) {
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(timeout_s);
  while (ros::ok() && ros::WallTime::now() < end) {
    const auto m = ros::topic::waitForMessage<Msg>(topic, ros::Duration(1.0));
    if (m && (!accept || accept(*m))) return m;
  }
  return nullptr;
}

/// A window the goal can use: an oscillation, a bend the tracker is sure of (confidence >= 0.5 means
/// within its stated tolerance; a live window that has not yet seen the finger at rest is below it),
/// or a measured equilibrium.
bool measured(const topo_gaussian::MotionFeatures& f) {
  if (f.kind == "finger") return f.bending_confidence >= 0.5;
  return f.oscillation_found || f.bending_confidence > 0 || f.equilibrium_confidence > 0;
}

struct Options {
  topo_gaussian::InferInteriorGoal goal;
  double wait_s = 120, tolerance = 0.02, timeout_s = 900;
  std::string truth_topic, weigh_topic, weigh_experiment;
  int auto_experiments = 0;  ///< perform suggested experiments until the object has this many (0: never)
  std::string perform_service = "/rig_simulator/perform_experiment";
};

Options readOptions(const ros::NodeHandle& pnh) {
  Options o;
  const topo_gaussian::topo_ros::ParamReader r(pnh, "infer_client");
  using topo_gaussian::topo_ros::Range;
  o.goal.experiments = r.texts("experiments", {}, "\"rock10=tumbler;rock25=tumbler\"");
  o.goal.task = r.text("task", o.goal.experiments.empty() ? "tumbler" : "");
  o.goal.representation = r.text("representation", "");
  // Lists, or one string with ';' between entries (what `_overrides:="a=1;b=2"` on a command line gives).
  o.goal.overrides = r.texts("overrides", {}, "\"initial_tilt_deg=8;density_solid=4000\"");
  o.goal.targets = r.texts("targets", {}, "\"period_s=1.2\"");
  // The goal's max_iterations field counts objective evaluations: ~max_evaluations, or its old name.
  const long evaluations = r.integer("max_evaluations", 0, "", Range::atLeast(0));
  const long old_name = r.integer("max_iterations", 0, "", Range::atLeast(0));
  if (r.has("max_evaluations") && r.has("max_iterations") && evaluations != old_name) {
    const std::string values = std::to_string(evaluations) + " and " + std::to_string(old_name);
    throw topo_gaussian::TopoError(r.displayName("max_evaluations") + " and " + r.displayName("max_iterations"),
                                   "name one limit twice with different values (" + values +
                                       "); ~max_iterations is an alias of ~max_evaluations (it always counted "
                                       "evaluations)",
                                   "give only ~max_evaluations");
  }
  o.goal.max_iterations = int(r.has("max_evaluations") ? evaluations : old_name);
  o.goal.output_dir = r.text("output_dir", "");
  o.wait_s = r.number("wait_for_features_s", o.wait_s, "s", Range::atLeast(0.0));
  o.tolerance = r.number("tolerance", o.tolerance, "", Range::above(0.0));
  o.timeout_s = r.number("timeout_s", o.timeout_s, "s", Range::above(0.0));
  o.truth_topic = r.text("ground_truth_topic", "");
  o.weigh_topic = r.text("weigh_topic", "");
  o.weigh_experiment = r.text("weigh_experiment", "");
  o.auto_experiments = int(r.integer("auto_experiments", 0, "", Range::atLeast(0)));
  o.perform_service = r.text("perform_service", o.perform_service);
  o.goal.object_id = r.text("object_id", o.auto_experiments > 0 ? "demo_object" : "");
  if (o.auto_experiments > 0 && o.goal.object_id.empty())
    throw topo_gaussian::TopoError(r.displayName("object_id"), "is empty while ~auto_experiments is set",
                                   "name the object (its experiments are kept across goals under it), or leave "
                                   "~object_id unset");
  return o;
}

/// The scale reading as the target mass_kg (of ~weigh_experiment). False (logged) when none came.
bool addWeighing(Options* o) {
  // The object on a scale (a rig_simulator's scale_kg): rigid motion alone never fixes the mass.
  const auto w = waitFor<std_msgs::Float64>(o->weigh_topic, 60.0, nullptr);
  if (!w || !(w->data > 0) || !std::isfinite(w->data)) {
    ROS_FATAL("infer_client: no positive scale reading on %s within 60 s (~weigh_topic; is the scale publishing?)",
              o->weigh_topic.c_str());
    return false;
  }
  const std::string key = (o->weigh_experiment.empty() ? "" : o->weigh_experiment + ".") + "mass_kg";
  char text[64];
  std::snprintf(text, sizeof(text), "%.9g", w->data);
  o->goal.targets.push_back(key + "=" + text);
  std::printf("[demo] scale (%s): %s kg, target %s\n", o->weigh_topic.c_str(), text, key.c_str());
  std::fflush(stdout);
  return true;
}

/// A measured window of every experiment of the goal (motion_tracker tags them with the `experiment` topic):
/// an oscillation for a tilt or pendulum window, or, with `equilibrium_suffices` (a hang the rig performs:
/// its rest tilt is the target, and a swing seen end-on may show no oscillation), a measured equilibrium.
bool waitForExperiments(const Options& o, bool equilibrium_suffices = false) {
  std::set<std::string> names;
  for (const auto& e : o.goal.experiments) names.insert(e.substr(0, e.find('=')));
  std::printf("[demo] waiting up to %.0f s for measured motion of %zu experiments on motion_features ...\n", o.wait_s,
              names.size());
  std::fflush(stdout);
  std::mutex mutex;
  std::map<std::string, topo_gaussian::MotionFeatures> seen;
  ros::NodeHandle nh;
  ros::Subscriber sub = nh.subscribe<topo_gaussian::MotionFeatures>(
      "motion_features", 10, [&](const topo_gaussian::MotionFeatures::ConstPtr& f) {
        // A motion the task analyses as an oscillation needs one; a static pose its equilibrium.
        const bool oscillates = f->kind == "tilt" || f->kind == "pendulum";
        const bool ok = oscillates ? f->oscillation_found || (equilibrium_suffices && f->equilibrium_confidence > 0)
                                   : measured(*f);
        if (!ok || !names.count(f->experiment)) return;
        std::lock_guard<std::mutex> lock(mutex);
        if (!seen.count(f->experiment))
          std::printf("[demo] tracker, experiment %s (%s): period %.4f s, max tilt %.3f deg, equilibrium %.3f deg\n",
                      f->experiment.c_str(), f->kind.c_str(), f->period_s, f->max_tilt_deg, f->equilibrium_deg);
        std::fflush(stdout);
        seen[f->experiment] = *f;
      });
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(o.wait_s);
  for (;;) {
    {
      std::lock_guard<std::mutex> lock(mutex);
      if (seen.size() == names.size()) return true;
    }
    if (!ros::ok() || ros::WallTime::now() > end) {
      ROS_FATAL("infer_client: not every experiment was measured on motion_features within %.0f s (%zu of %zu)",
                o.wait_s, seen.size(), names.size());
      return false;
    }
    ros::WallDuration(0.2).sleep();
  }
}

/// One measured window; the goal carries it, so that a later, partial window (the tracker publishes its
/// growing window every second) cannot replace it.
bool waitForFeatures(Options* o) {
  std::printf("[demo] waiting up to %.0f s for measured motion features on motion_features ...\n", o->wait_s);
  std::fflush(stdout);
  const auto f = waitFor<topo_gaussian::MotionFeatures>("motion_features", o->wait_s, &measured);
  if (!f) {
    ROS_FATAL("infer_client: no measured motion on motion_features within %.0f s (is motion_tracker seeing the camera?)",
              o->wait_s);
    return false;
  }
  std::printf("[demo] tracker (%s, %s): period %.4f s, max tilt %.3f deg, bend %.3f deg (confidence %.2f)\n",
              f->source.c_str(), f->kind.c_str(), f->period_s, f->max_tilt_deg, f->bending_angle_deg,
              f->bending_confidence);
  if (o->goal.features.kind.empty()) o->goal.features = *f;
  return true;
}

/// Sends the goal, prints its feedback; the result, or null (logged) when it did not succeed.
topo_gaussian::InferInteriorResultConstPtr runGoal(const Options& o) {
  actionlib::SimpleActionClient<topo_gaussian::InferInteriorAction> client("infer_interior", false);
  if (!client.waitForServer(ros::Duration(60.0))) {
    ROS_FATAL("infer_client: no infer_interior action server within 60 s (is interior_inference running?)");
    return nullptr;
  }
  std::string list;
  for (const auto& e : o.goal.experiments) list += (list.empty() ? "" : ", ") + e;
  std::printf("[demo] goal: task %s%s%s\n", o.goal.task.c_str(), list.empty() ? "" : ", experiments ", list.c_str());
  std::fflush(stdout);
  client.sendGoal(o.goal, {}, {}, [](const topo_gaussian::InferInteriorFeedbackConstPtr& fb) {
    std::printf("[demo] iteration %3d  loss %.4e  best %.4e  |grad| %.3e  %.1f s", fb->iteration, fb->loss,
                fb->best_loss, fb->gradient_norm, fb->elapsed_s);
    for (std::size_t k = 0; k < fb->feature_names.size() && k < 2; ++k)
      std::printf("  %s %.5g", fb->feature_names[k].c_str(), fb->feature_values[k]);
    std::printf("\n");
    std::fflush(stdout);
  });
  if (!client.waitForResult(ros::Duration(o.timeout_s))) {
    client.cancelGoal();
    ROS_FATAL("infer_client: no result within %.0f s; goal cancelled", o.timeout_s);
    return nullptr;
  }
  const auto state = client.getState();
  const auto res = client.getResult();
  std::printf("[demo] %s: %s\n", state.toString().c_str(), res->message.c_str());
  if (state != actionlib::SimpleClientGoalState::SUCCEEDED) return nullptr;
  for (const auto& f : res->files) std::printf("[demo] wrote %s\n", f.c_str());
  return res;
}

/// The recovered features next to the truth; the worst relative error (0 when nothing was compared) and
/// the features outside the tolerance.
double printFeatures(const topo_gaussian::InferInteriorResult& res, const topo_gaussian::RigGroundTruth* truth,
                     double object_size_m, double tolerance, std::vector<std::string>* outside) {
  namespace tr = topo_gaussian::topo_ros;
  double worst = 0.0;
  std::printf("[demo] %-22s %12s %12s %12s\n", "feature", "recovered", "target", "twin truth");
  for (std::size_t k = 0; k < res.feature_names.size(); ++k) {
    const std::string& name = res.feature_names[k];
    double t = NAN;
    if (truth)
      for (std::size_t j = 0; j < truth->feature_names.size(); ++j)
        if (truth->feature_names[j] == name) t = truth->feature_values[j];
    std::printf("[demo] %-22s %12.5g %12.5g %12.5g", name.c_str(), res.achieved[k], res.target[k], t);
    if (std::isfinite(t) && std::isfinite(res.target[k])) {
      const tr::FeatureComparison c = tr::compareFeature(name, res.achieved[k], t, object_size_m, tolerance);
      std::printf("   %+.2f %%%s%s", 100 * c.relative_error, c.of_the_scale ? " (of the scale)" : "",
                  c.within ? "" : "  (outside tolerance)");
      worst = std::max(worst, std::abs(c.relative_error));
      if (!c.within) outside->push_back(name);
    }
    std::printf("\n");
  }
  return worst;
}

/// The interior itself against the twin's: several interiors may give the same motion (reported, not judged).
void printInterior(const topo_gaussian::InferInteriorResult& res, const topo_gaussian::RigGroundTruth& truth,
                   double object_size_m) {
  if (truth.center_of_mass.size() != 3 || res.center_of_mass.size() != 3 || truth.inertia.size() != 9 ||
      res.inertia.size() != 9)
    return;
  std::printf("[demo] %-22s %12s %12s %9s\n", "interior", "recovered", "twin truth", "error");
  auto row = [](const char* name, double got, double want, double scale) {
    std::printf("[demo] %-22s %12.5g %12.5g %+8.2f %%\n", name, got, want, 100 * (got - want) / scale);
  };
  row("solid fraction", res.solid_fraction, truth.solid_fraction, truth.solid_fraction);
  row("mass [kg]", res.mass_kg, truth.mass_kg, truth.mass_kg);
  const char* c[3] = {"centre of mass x [m]", "centre of mass y [m]", "centre of mass z [m]"};
  // The centre of mass relative to the object's size (its extent in the true interior cloud).
  const double size = std::isfinite(object_size_m) ? object_size_m : 1.0;
  for (int a = 0; a < 3; ++a) row(c[a], res.center_of_mass[a], truth.center_of_mass[a], size);
  const char* I[3] = {"inertia xx [kg m^2]", "inertia yy [kg m^2]", "inertia zz [kg m^2]"};
  for (int a = 0; a < 3; ++a) row(I[a], res.inertia[4 * a], truth.inertia[4 * a], truth.inertia[4 * a]);
  if (res.interior.width * res.interior.height > 0 && truth.interior.width * truth.interior.height > 0) {
    const auto iou = topo_gaussian::topo_ros::interiorIou(res.interior, truth.interior);
    std::printf("[demo] IoU of the cavity %.3f, of the solid %.3f (recovered particles against the twin's interior)\n",
                iou.cavity, iou.solid);
  }
  std::printf("[demo] (centre of mass errors relative to the object's size %.4g m)\n", size);
}

/// How sure, and what the experiments determine.
void printCertainty(const topo_gaussian::InferInteriorResult& res) {
  // the share of the volume whose label the designs that fit (spread, region analysis) disagree on
  if (std::isfinite(res.uncertain_fraction))
    std::printf("[demo] %.1f %% of the volume is uncertain (designs that fit the observations disagree on it)\n",
                100.0 * res.uncertain_fraction);
  if (!res.identifiability.empty()) {
    std::string det, fr;
    for (const auto& m : res.determined_moments) det += (det.empty() ? "" : " ") + m;
    for (const auto& m : res.free_moments) fr += (fr.empty() ? "" : " ") + m;
    std::printf("[demo] determined by the experiments: %s; free: %s\n", det.empty() ? "none" : det.c_str(),
                fr.empty() ? "none" : fr.c_str());
    std::printf("[demo] %s\n", res.identifiability.c_str());
    if (!res.next_experiment.empty()) std::printf("[demo] next: %s\n", res.next_experiment.c_str());
  }
}

/// The rig performs the result's next experiment as `name` (the tracker told the tilt it will rest at);
/// `next` becomes the goal of that experiment alone (the object's earlier ones join it in the node), with
/// its set-up overrides and the rig's readings (timed periods, the hung pitch) as its targets, once the
/// tracker has measured it. False (printed why): the
/// rig refused or is not there, or no measured window came.
bool performNext(const topo_gaussian::InferInteriorResult& res, const std::string& name, const Options& first,
                 ros::Publisher* tilt_reference, Options* next) {
  if (std::isfinite(res.next_experiment_tilt_deg)) {
    for (int k = 0; k < 20 && tilt_reference->getNumSubscribers() == 0; ++k) ros::WallDuration(0.1).sleep();
    std_msgs::String m;
    char deg[32];
    std::snprintf(deg, sizeof(deg), "%.3f", res.next_experiment_tilt_deg);
    m.data = name + "=" + deg;
    tilt_reference->publish(m);
  }
  ros::NodeHandle nh;
  ros::ServiceClient perform = nh.serviceClient<topo_gaussian::PerformExperiment>(first.perform_service);
  if (!perform.waitForExistence(ros::Duration(10.0))) {
    std::printf("[demo] loop: no rig performs experiments on %s (~perform_service): stopping here\n",
                first.perform_service.c_str());
    return false;
  }
  topo_gaussian::PerformExperiment srv;
  srv.request.name = name;
  srv.request.task = res.next_experiment_task;
  srv.request.overrides = res.next_experiment_overrides;
  srv.request.instruments = res.next_experiment_instruments;
  std::printf("[demo] loop: the rig performs %s: %s\n", name.c_str(), res.next_experiment.c_str());
  std::fflush(stdout);
  if (!perform.call(srv)) {
    std::printf("[demo] loop: the call to %s failed: stopping here\n", first.perform_service.c_str());
    return false;
  }
  std::printf("[demo] loop: rig: %s\n", srv.response.message.c_str());
  if (!srv.response.accepted) return false;
  *next = first;
  next->goal.task.clear();
  next->goal.experiments = {name + "=" + res.next_experiment_task};
  next->goal.overrides.clear();
  for (const auto& a : res.next_experiment_overrides) next->goal.overrides.push_back(name + "." + a);
  next->goal.targets.clear();
  // the timed periods are known to the timer's step: the goal states it (the task's default is 1 %)
  double period_tolerance = 0.0;
  for (std::size_t k = 0; k < srv.response.readings.size(); ++k) {
    const std::string& r = srv.response.readings[k];
    next->goal.targets.push_back(name + "." + r);
    const std::string key = r.substr(0, r.find('='));
    const double value = std::atof(r.substr(r.find('=') + 1).c_str());
    if (key.size() > 9 && key.compare(key.size() - 9, 9, "_period_s") == 0 && value > 0 &&
        k < srv.response.resolutions.size() && srv.response.resolutions[k] > 0)
      period_tolerance = std::max(period_tolerance, srv.response.resolutions[k] / value);
  }
  if (period_tolerance > 0) {
    char text[64];
    std::snprintf(text, sizeof(text), "%s.axle_period_tolerance=%.3g", name.c_str(), period_tolerance);
    next->goal.overrides.push_back(text);
  }
  next->goal.features = topo_gaussian::MotionFeatures();
  // A hang whose pose the rig read (roll and pitch): the camera adds nothing, and hung end-on (a large pitch)
  // it may see no orientation at all; otherwise the tracker's window of it gives its targets.
  bool pose_read = false;
  for (const auto& r : srv.response.readings) pose_read = pose_read || r.rfind("target_pitch_deg=", 0) == 0;
  if (pose_read) {
    next->goal.ignore_motion_features = true;
    std::printf("[demo] loop: %s's rest pose is read on the rig: its targets are the readings\n", name.c_str());
    return true;
  }
  return waitForExperiments(*next, res.next_experiment_kind == "hang" || res.next_experiment_kind == "swing");
}

/// One line per loop step: what the experiments determine, how much is uncertain, the IoU against the twin.
void printLoopStep(int step, const topo_gaussian::InferInteriorResult& res, const topo_gaussian::RigGroundTruth* truth) {
  std::string names, det;
  for (const auto& n : res.experiment_names) names += (names.empty() ? "" : ",") + n;
  for (const auto& m : res.determined_moments) det += (det.empty() ? "" : " ") + m;
  std::printf("[demo] loop step %d: %zu experiments (%s): determined %zu/10 (%s), %.1f %% of the volume uncertain",
              step, res.experiment_names.size(), names.c_str(), res.determined_moments.size(),
              det.empty() ? "none" : det.c_str(), 100.0 * res.uncertain_fraction);
  if (truth && res.interior.width * res.interior.height > 0 && truth->interior.width * truth->interior.height > 0)
    std::printf(", cavity IoU %.3f", topo_gaussian::topo_ros::interiorIou(res.interior, truth->interior).cavity);
  std::printf("; %s\n", res.loop_reason.c_str());
  std::fflush(stdout);
}

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "infer_client");
  ros::NodeHandle pnh("~");
  Options o;
  try {
    o = readOptions(pnh);
  } catch (const std::exception& e) {
    ROS_FATAL("infer_client: %s", topo_gaussian::topo_ros::asciiText(e.what()).c_str());
    return 1;
  }
  ros::AsyncSpinner spinner(1);
  spinner.start();

  topo_gaussian::RigGroundTruth::ConstPtr truth;
  if (!o.truth_topic.empty()) {
    truth = waitFor<topo_gaussian::RigGroundTruth>(o.truth_topic, 60.0, nullptr);
    if (!truth) {
      ROS_FATAL("infer_client: no ground truth on %s within 60 s (is rig_simulator running?)", o.truth_topic.c_str());
      return 1;
    }
  }
  if (!o.weigh_topic.empty() && !addWeighing(&o)) return 1;
  if (o.wait_s > 0 && !(o.goal.experiments.empty() ? waitForFeatures(&o) : waitForExperiments(o))) return 1;
  auto res = runGoal(o);
  if (!res) {
    std::printf("[demo] verdict: FAIL (no result)\n");
    return 1;
  }
  // The loop: the rig performs the suggested experiment, the object's experiments so far infer again.
  if (o.auto_experiments > 0) {
    ros::NodeHandle nh;
    ros::Publisher tilt_reference = nh.advertise<std_msgs::String>("tilt_reference", 10, true);
    printLoopStep(1, *res, truth.get());
    std::string ended = res->loop_reason;
    for (int step = 2; res->loop_continues; ++step) {
      if (int(res->experiment_names.size()) >= o.auto_experiments) {
        ended = "the object has ~auto_experiments = " + std::to_string(o.auto_experiments) + " experiments";
        break;
      }
      Options next;
      const std::string name = "auto" + std::to_string(res->experiment_names.size() + 1);
      if (!performNext(*res, name, o, &tilt_reference, &next)) {
        ended = "the rig did not perform " + name + " (above)";
        break;
      }
      const auto more = runGoal(next);
      if (!more) {
        ended = "the inference with " + name + " failed (above): the last result is kept";
        break;
      }
      if (res->converged && !more->converged) {  // it reached every target before, not with this one
        printLoopStep(step, *more, truth.get());
        ended = "with " + name + " no interior reaches every target (it contradicts the earlier experiments, or its "
                "readings are off): the last result that did, from " + std::to_string(res->experiment_names.size()) +
                " experiments, is kept";
        break;
      }
      ended = more->loop_reason;
      res = more;
      if (truth) {  // the rig's truth now has the new experiment's features too
        const auto t = waitFor<topo_gaussian::RigGroundTruth>(o.truth_topic, 10.0, nullptr);
        if (t) truth = t;
      }
      printLoopStep(step, *res, truth.get());
    }
    std::printf("[demo] loop: ended with %zu experiments: %s\n", res->experiment_names.size(), ended.c_str());
  }
  // A feature near zero (a rest tilt, a centre-of-mass offset) is judged on its natural scale, not its
  // own size: angles on 10 deg, lengths on the object's size (the twin's true interior's extent).
  const double object_size_m = truth ? topo_gaussian::topo_ros::objectSizeM(truth->interior) : NAN;
  std::vector<std::string> outside;
  const double worst = printFeatures(*res, truth.get(), object_size_m, o.tolerance, &outside);
  std::printf("[demo] solid fraction %.3f (twin %.3f), %d evaluations\n", res->solid_fraction,
              truth ? truth->solid_fraction : NAN, res->iterations);
  for (std::size_t k = 0; k < res->experiment_names.size(); ++k)
    std::printf("[demo] experiment %-12s loss %.3e (weight %g)\n", res->experiment_names[k].c_str(),
                res->experiment_losses[k], k < res->experiment_weights.size() ? res->experiment_weights[k] : 1.0);
  if (truth) printInterior(*res, *truth, object_size_m);
  printCertainty(*res);
  if (!truth) {
    std::printf("[demo] verdict: DONE (no ground truth to judge against)\n");
    return 0;
  }
  std::string names;
  for (const auto& n : outside) names += (names.empty() ? "" : ", ") + n;
  if (outside.empty())
    std::printf("[demo] verdict: PASS: every feature within %.3g %% of the twin's truth (worst %.2f %%)\n",
                100 * o.tolerance, 100 * worst);
  else
    std::printf("[demo] verdict: FAIL: %s outside %.3g %% of the twin's truth (worst %.2f %%)\n", names.c_str(),
                100 * o.tolerance, 100 * worst);
  return outside.empty() ? 0 : 3;
}
