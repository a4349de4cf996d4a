// infer_client: sends one infer_interior goal and prints its feedback and result; with
// ~ground_truth_topic (a rig_simulator's ~ground_truth) it also prints the recovered features next to
// the twin's truth and exits 0 only when every truth feature is reproduced within ~tolerance.
// What `make demo` runs against demo.launch. Parameters (private):
//   ~task (tumbler), ~representation (""), ~overrides [], ~targets [] (lists, or "A=1;B=2"), ~max_iterations (0),
//   ~output_dir (""), ~wait_for_features_s (120: wait for motion_features with a measured motion
//   before sending; 0 = send at once), ~ground_truth_topic (""), ~tolerance (0.02), ~timeout_s (900)
// Exit codes: 0 done (and within tolerance of the truth), 1 aborted / timed out / bad parameters,
// 3 finished but the truth was not reproduced.
#include <actionlib/client/simple_action_client.h>
#include <ros/ros.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "topo_gaussian/InferInteriorAction.h"
#include "topo_gaussian/MotionFeatures.h"
#include "topo_gaussian/RigGroundTruth.h"
#include "topo_gaussian/ros/ascii_text.h"
#include "topo_gaussian/ros/param_reader.h"

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

bool measured(const topo_gaussian::MotionFeatures& f) {
  return f.oscillation_found || f.bending_confidence > 0 || f.equilibrium_confidence > 0;
}

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "infer_client");
  ros::NodeHandle pnh("~");
  topo_gaussian::InferInteriorGoal goal;
  double wait_s = 120, tolerance = 0.02, timeout_s = 900;
  std::string truth_topic;
  try {
    const topo_gaussian::topo_ros::ParamReader r(pnh, "infer_client");
    using topo_gaussian::topo_ros::Range;
    goal.task = r.text("task", "tumbler");
    goal.representation = r.text("representation", "");
    // Lists, or one string with ';' between entries (what `_overrides:="a=1;b=2"` on a command line gives).
    goal.overrides = r.texts("overrides", {}, "\"initial_tilt_deg=8;density_solid=4000\"");
    goal.targets = r.texts("targets", {}, "\"period_s=1.2\"");
    goal.max_iterations = int(r.integer("max_iterations", 0, "", Range::atLeast(0)));
    goal.output_dir = r.text("output_dir", "");
    wait_s = r.number("wait_for_features_s", wait_s, "s", Range::atLeast(0.0));
    tolerance = r.number("tolerance", tolerance, "", Range::above(0.0));
    timeout_s = r.number("timeout_s", timeout_s, "s", Range::above(0.0));
    truth_topic = r.text("ground_truth_topic", "");
  } catch (const std::exception& e) {
    ROS_FATAL("infer_client: %s", topo_gaussian::topo_ros::asciiText(e.what()).c_str());
    return 1;
  }
  ros::AsyncSpinner spinner(1);
  spinner.start();

  topo_gaussian::RigGroundTruth::ConstPtr truth;
  if (!truth_topic.empty()) {
    truth = waitFor<topo_gaussian::RigGroundTruth>(truth_topic, 60.0, nullptr);
    if (!truth) {
      ROS_FATAL("infer_client: no ground truth on %s within 60 s (is rig_simulator running?)", truth_topic.c_str());
      return 1;
    }
  }
  if (wait_s > 0) {
    std::printf("[demo] waiting up to %.0f s for measured motion features on motion_features ...\n", wait_s);
    std::fflush(stdout);
    const auto f = waitFor<topo_gaussian::MotionFeatures>("motion_features", wait_s, &measured);
    if (!f) {
      ROS_FATAL(
          "infer_client: no measured motion on motion_features within %.0f s (is motion_tracker seeing the camera?)",
          wait_s);
      return 1;
    }
    std::printf("[demo] tracker (%s, %s): period %.4f s, max tilt %.3f deg, bend %.3f deg\n", f->source.c_str(),
                f->kind.c_str(), f->period_s, f->max_tilt_deg, f->bending_angle_deg);
  }
  actionlib::SimpleActionClient<topo_gaussian::InferInteriorAction> client("infer_interior", false);
  if (!client.waitForServer(ros::Duration(60.0))) {
    ROS_FATAL("infer_client: no infer_interior action server within 60 s (is interior_inference running?)");
    return 1;
  }
  std::printf("[demo] goal: task %s\n", goal.task.c_str());
  std::fflush(stdout);
  client.sendGoal(goal, {}, {}, [](const topo_gaussian::InferInteriorFeedbackConstPtr& fb) {
    std::printf("[demo] iteration %3d  loss %.4e  best %.4e  |grad| %.3e  %.1f s", fb->iteration, fb->loss,
                fb->best_loss, fb->gradient_norm, fb->elapsed_s);
    for (std::size_t k = 0; k < fb->feature_names.size() && k < 2; ++k)
      std::printf("  %s %.5g", fb->feature_names[k].c_str(), fb->feature_values[k]);
    std::printf("\n");
    std::fflush(stdout);
  });
  if (!client.waitForResult(ros::Duration(timeout_s))) {
    client.cancelGoal();
    ROS_FATAL("infer_client: no result within %.0f s; goal cancelled", timeout_s);
    return 1;
  }
  const auto state = client.getState();
  const auto res = client.getResult();
  std::printf("[demo] %s: %s\n", state.toString().c_str(), res->message.c_str());
  if (state != actionlib::SimpleClientGoalState::SUCCEEDED) return 1;
  for (const auto& f : res->files) std::printf("[demo] wrote %s\n", f.c_str());
  int status = 0;
  std::printf("[demo] %-22s %12s %12s %12s\n", "feature", "recovered", "target", "twin truth");
  for (std::size_t k = 0; k < res->feature_names.size(); ++k) {
    const std::string& name = res->feature_names[k];
    double t = NAN;
    if (truth)
      for (std::size_t j = 0; j < truth->feature_names.size(); ++j)
        if (truth->feature_names[j] == name) t = truth->feature_values[j];
    std::printf("[demo] %-22s %12.5g %12.5g %12.5g", name.c_str(), res->achieved[k], res->target[k], t);
    if (std::isfinite(t) && std::isfinite(res->target[k])) {
      const double rel = std::abs(res->achieved[k] - t) / std::max(std::abs(t), 1e-12);
      std::printf("   %+.2f %%%s", 100 * (res->achieved[k] - t) / std::max(std::abs(t), 1e-12),
                  rel <= tolerance ? "" : "  (outside tolerance)");
      if (rel > tolerance) status = 3;
    }
    std::printf("\n");
  }
  std::printf("[demo] solid fraction %.3f (twin %.3f), %d evaluations\n", res->solid_fraction,
              truth ? truth->solid_fraction : NAN, res->iterations);
  return status;
}
