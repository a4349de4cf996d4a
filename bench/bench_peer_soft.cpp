// bench_peer_soft: the soft half of the peer world (bench/peer_world/README.md, "Soft objects").
// A pneumatic finger whose chamber is known, observed without this package's simulators or renderer,
// then inferred on the user path at the user's defaults:
//   CalculiX (C3D10, NLGEOM, a true void under follower pressure; peer_world/calculix_finger.h) at a
//   ladder of pressures → the peer rasteriser films each pressure window from the rig's side camera
//   (rest frames, then the held bend) → the motion tracker (kind finger, silhouette, as the rig's
//   motion_tracker) per window, the window tagged with its pressure → the finger task's rule takes the
//   top window's bend (`topo track --kind finger` → `topo infer --task finger --set pressure_pa=P
//   --set youngs_modulus_solid=2e6`, workflow::runInference) on the finger's box filled at the task's
//   default spacing (`topo fill`) → the result against the truth:
//   - chamber IoU = Σ V_i [found_i ∧ true_i] / Σ V_i [found_i ∨ true_i] over the inference's particles
//     (found: r_i < 0.5; true: the particle's centre in the void box), chamber volume Σ V_i [found_i]
//     against the box's exact volume, mass Σ ρ_i V_i against ρ (box − void) (the void weighs nothing);
//   - the bend: tracked against CalculiX's own (its material's centroid chord, the task's definition);
//   - held out: the bends at the pressures not fitted, the result simulated there (simulateInterior)
//     against CalculiX's (--fit ends: the lowest and the top window are two experiments of one object,
//     each tagged with its pressure, as `topo infer --experiment p50kpa=... --features p50kpa=...`; the
//     middle is held out);
//   - baseline in the same run: the TRUE chamber rasterised on the same particles, simulated by the
//     task at each pressure (the model's own bias against CalculiX: what a perfect search would fit);
//   - the verdict the result gives: its region uncertainty (IoU band of the designs that fit) and
//     "determined" when that expects IoU ≥ 0.9, as bench_interiors calls it; without a region analysis
//     (soft tasks: no mass moments observed) the identifiability's word (`topo infer` prints it):
//     "cannot determine" → not determined.
// Prints a table and one JSON line per case. Needs ccx (Debian calculix-ccx): without it, says so and exits 2.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "peer_world/calculix_finger.h"
#include "topo_gaussian/common/error.h"
#include "topo_gaussian/common/json.h"
#include "topo_gaussian/geometry/interior_fill.h"
#include "topo_gaussian/geometry/shape_generator.h"
#include "topo_gaussian/inference/pipeline.h"
#include "topo_gaussian/inference/region_uncertainty.h"
#include "topo_gaussian/vision/motion_features.h"
#include "topo_gaussian/vision/motion_tracker.h"
#include "topo_gaussian/workflow/inference_run.h"

using namespace topo_gaussian;

namespace {

struct SoftCase {
  std::string name, what;
  Eigen::Vector3d lo, hi;  ///< the void [m] in the 0.1 × 0.02 × 0.015 m finger (z ∈ ±7.5 mm)
};

/// The chambers: the rig's default (workflow/finger_twin.h's box), a larger one, one nearer the tip and
/// one with a thinner lower wall (off-centre towards −z).
std::vector<SoftCase> cases() {
  return {
      {"default_chamber", "x 15-65, |y| < 6, z -4.5..0.5 mm (walls 3 below, 7 above)", {0.015, -0.006, -0.0045},
       {0.065, 0.006, 0.0005}},
      {"large_chamber", "x 15-70, |y| < 7, z -4.5..2.5 mm (walls 3 below, 5 above, 3 beside)",
       {0.015, -0.007, -0.0045}, {0.070, 0.007, 0.0025}},
      {"tip_chamber", "x 40-90, |y| < 6, z -4.5..0.5 mm (under the bend's segments)", {0.040, -0.006, -0.0045},
       {0.090, 0.006, 0.0005}},
      {"thin_wall", "x 15-65, |y| < 6, z -5.5..-0.5 mm (lower wall 2 mm)", {0.015, -0.006, -0.0055},
       {0.065, 0.006, -0.0005}},
  };
}

double bendOf(const inference::ProblemEvaluation& ev) {
  for (const auto& f : ev.task.features)
    if (f.name == "bend_angle_deg") return f.value;
  return NAN;
}

std::string pct(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%+.1f %%", 100 * v);
  return b;
}

int usage() {
  std::fprintf(stderr,
               "usage: bench_peer_soft [--pressures P1,P2,...] [--fit top|ends|all] [--max-evaluations N] [--cell M]\n"
               "                       [--frames DIR] [--set KEY=VALUE ...] [CASE...]\n"
               "  cases: default_chamber large_chamber tip_chamber thin_wall (all when none given)\n"
               "  --pressures: the ladder [Pa], increasing (default 5e4,1e5,1.5e5)\n"
               "  --fit: the windows fitted: top (the rig's full pressure, one experiment: the default), ends (the\n"
               "         lowest and the top, two experiments of one object), all; the others are held out\n"
               "  --max-evaluations: the inference's budget (default: the task's)\n"
               "  --cell: CalculiX's largest grid cell [m] (default 0.0025)\n"
               "  --frames DIR: write each window's rest and held frame as PNG\n"
               "  --set KEY=VALUE: a finger task parameter for the inference, as topo infer --set (repeatable),\n"
               "         e.g. youngs_modulus_hollow=2000 for a chamber modelled as a void\n");
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<double> pressures{5e4, 1e5, 1.5e5};
  std::string frames_dir, max_evaluations, fit = "top";
  double cell_m = peer::CalculixFingerOptions{}.cell_m;
  std::vector<std::string> wanted, sets;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--pressures" && i + 1 < argc) {
      pressures.clear();
      std::string s = argv[++i];
      for (std::size_t at = 0; at < s.size();) {
        const std::size_t comma = s.find(',', at);
        pressures.push_back(std::atof(s.substr(at, comma - at).c_str()));
        at = comma == std::string::npos ? s.size() : comma + 1;
      }
    } else if (a == "--max-evaluations" && i + 1 < argc) {
      max_evaluations = argv[++i];
    } else if (a == "--cell" && i + 1 < argc) {
      cell_m = std::atof(argv[++i]);
    } else if (a == "--fit" && i + 1 < argc) {
      fit = argv[++i];
      if (fit != "top" && fit != "ends" && fit != "all") return usage();
    } else if (a == "--frames" && i + 1 < argc) {
      frames_dir = argv[++i];
    } else if (a == "--set" && i + 1 < argc) {
      sets.push_back(argv[++i]);
    } else if (a == "-h" || a == "--help" || a.rfind("--", 0) == 0) {
      return usage();
    } else {
      wanted.push_back(a);
    }
  }
  std::string why;
  if (!peer::calculixAvailable(&why)) {
    std::fprintf(stderr, "bench_peer_soft: %s\n", why.c_str());
    return 2;
  }
  if (!frames_dir.empty()) std::filesystem::create_directories(frames_dir);

  struct Row {
    std::string name, verdict;
    double iou = NAN, volume = NAN, mass = NAN, tracked = NAN, ccx = NAN, fitted = NAN, truth_model = NAN;
    double held_pred = NAN, held_ccx = NAN, held_p = NAN, seconds = NAN;
  };
  std::vector<Row> rows;
  for (const SoftCase& sc : cases()) {
    if (!wanted.empty() && std::find(wanted.begin(), wanted.end(), sc.name) == wanted.end()) continue;
    Row row;
    row.name = sc.name;
    const auto t0 = std::chrono::steady_clock::now();
    try {
      // 1. CalculiX at the ladder of pressures.
      peer::CalculixFingerOptions po;
      po.chamber_lo_m = sc.lo;
      po.chamber_hi_m = sc.hi;
      po.cell_m = cell_m;
      const peer::CalculixFinger finger(po);
      double ccx_s = 0;
      const auto states = finger.solve(pressures, &ccx_s);
      // 2. Each pressure window filmed and tracked, tagged with its pressure.
      const auto tr0 = std::chrono::steady_clock::now();
      std::vector<std::shared_ptr<motion::MotionFeatures>> windows;
      std::vector<double> tracked;
      std::string tracker_message;
      for (const auto& s : states) {
        const auto frames = peer::renderPressureWindow(finger, s, peer::fingerRigCamera(), peer::fingerRigStyle());
        vision::TrackOptions o;
        o.kind = "finger";
        o.tracker.method = "silhouette";
        vision::MotionTracker mt(o);
        for (std::size_t k = 0; k < frames.size(); ++k) mt.addFrame(frames[k], k / 30.0);
        const vision::TrackResult r = mt.finish();
        auto f = std::make_shared<motion::MotionFeatures>(vision::toMotionFeatures(r));
        f->experiment = "p" + std::to_string(static_cast<long>(std::lround(s.pressure_pa / 1e3))) + "kpa";
        f->source = "peer world " + sc.name + " at " + std::to_string(static_cast<long>(s.pressure_pa)) + " Pa";
        windows.push_back(f);
        tracked.push_back(f->bending_confidence > 0 ? std::abs(f->bending_angle_deg) : NAN);
        tracker_message = r.message;
        if (!frames_dir.empty()) {
          const std::string stem = frames_dir + "/" + sc.name + "_" + f->experiment;
          cv::imwrite(stem + "_rest.png", frames.front());
          cv::imwrite(stem + "_held.png", frames.back());
        }
      }
      const double track_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - tr0).count();
      // 3. The user path: the box filled at the task's default spacing, the top window's targets.
      inference::TaskConfig config = inference::TaskConfig::defaults("finger");
      config.setAssignment("youngs_modulus_solid=" + std::to_string(po.youngs_modulus_pa), "--set");
      config.setNumber("pressure_pa", pressures.back());
      if (!max_evaluations.empty()) config.setAssignment("max_evaluations=" + max_evaluations, "--set");
      for (const auto& a : sets) config.setAssignment(a, "--set");  // e.g. the chamber as a void
      geometry::SurfaceData box = geometry::makeBox(po.size_m);
      for (auto& p : box.points) p.x() += 0.5 * po.size_m.x();
      geometry::FillOptions fo;
      fo.spacing_m = config.number("default_spacing_m");
      auto cloud = std::make_shared<VolumeCloud>(geometry::fillInterior(box, fo));
      std::vector<std::size_t> fitted;
      for (std::size_t k = 0; k < states.size(); ++k)
        if (fit == "all" || k + 1 == states.size() || (fit == "ends" && k == 0)) fitted.push_back(k);
      workflow::InferenceRunRequest rq;
      rq.volume = cloud;
      if (fitted.size() == 1) {  // `topo infer --task finger --features top.json`: the window untagged
        rq.config = config;
        auto top = std::make_shared<motion::MotionFeatures>(*windows.back());
        top->experiment.clear();
        rq.observed = top;
      } else {  // one experiment per fitted window, each tagged with its pressure
        rq.config = inference::TaskConfig::common();
        if (!max_evaluations.empty()) rq.config.setAssignment("max_evaluations=" + max_evaluations, "--set");
        for (std::size_t k : fitted) {
          inference::TaskConfig e = config;
          e.setNumber("pressure_pa", pressures[k]);
          rq.config.addExperiment(windows[k]->experiment, 1.0, e);
          rq.observed_experiments.push_back(windows[k]);
        }
      }
      rq.output_parent = (std::filesystem::temp_directory_path() / "bench_peer_soft").string();  // a new folder
      rq.export_files = false;
      const auto ti0 = std::chrono::steady_clock::now();
      const workflow::InferenceRunOutcome out = workflow::runInference(rq);
      std::filesystem::remove_all(out.output_dir);  // the run's files are not kept
      const double infer_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - ti0).count();
      const inference::InferenceResult& res = out.result;
      // 4. Against the truth.
      std::vector<double> found(cloud->size()), truth(cloud->size());
      double v_found = 0, mass = 0;
      for (std::size_t i = 0; i < cloud->size(); ++i) {
        found[i] = res.r[i] < 0.5 ? 1.0 : 0.0;
        truth[i] = finger.inChamber(cloud->X[i]) ? 1.0 : 0.0;
        v_found += found[i] * cloud->V[i];
        mass += res.density[i] * cloud->V[i];
      }
      const double rho = config.number("density_solid");
      row.iou = inference::volumeIou(cloud->V, found, truth);
      row.volume = v_found / finger.chamberVolumeM3() - 1.0;
      row.mass = mass / (rho * finger.solidVolumeM3()) - 1.0;
      row.tracked = tracked.back();
      row.ccx = states.back().bend_deg;
      // the true chamber on the same particles, simulated by the task (baseline), and the held-out bends
      std::vector<double> r_true(cloud->size());
      for (std::size_t i = 0; i < cloud->size(); ++i) r_true[i] = 1.0 - truth[i];
      std::vector<double> truth_model, held_pred;
      for (double p : pressures) {
        inference::TaskConfig c = config;
        c.setNumber("pressure_pa", p);
        truth_model.push_back(bendOf(inference::simulateInterior(c, *cloud, r_true)));
        held_pred.push_back(bendOf(inference::simulateInterior(c, *cloud, res.r)));
      }
      row.truth_model = truth_model.back();
      row.fitted = held_pred.back();
      for (std::size_t k = 0; k < states.size(); ++k)
        if (std::find(fitted.begin(), fitted.end(), k) == fitted.end()) {  // the first one held out
          row.held_p = pressures[k];
          row.held_pred = held_pred[k];
          row.held_ccx = states[k].bend_deg;
          break;
        }
      const bool available = res.region.available;
      const bool determined = available && res.region.iou_mean >= 0.9;
      char verdict[160];
      if (available)
        std::snprintf(verdict, sizeof verdict, "%s (expected IoU %.2f, 10-90 %% %.2f-%.2f)",
                      determined ? "determined" : "not determined", res.region.iou_mean, res.region.iou_p10,
                      res.region.iou_p90);
      else if (res.identifiability.summary.find("cannot determine") != std::string::npos)
        std::snprintf(verdict, sizeof verdict, "not determined (identifiability: %d observed for %d parameters)",
                      static_cast<int>(fitted.size()), static_cast<int>(res.theta.size()));
      else
        std::snprintf(verdict, sizeof verdict, "no statement");
      row.verdict = verdict;
      row.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      // One JSON line per case.
      auto list = [](const std::vector<double>& v) {
        std::string s;
        for (double x : v) s += (s.empty() ? "[" : ", ") + json::num(x);
        return s + "]";
      };
      std::vector<double> ccx_bends;
      for (const auto& s : states) ccx_bends.push_back(s.bend_deg);
      std::printf(
          "{\"bench\": \"peer_soft\", \"case\": %s, \"chamber\": %s, \"pressures_pa\": %s, \"fit\": %s, "
          "\"ccx_bend_deg\": %s, \"tracked_bend_deg\": %s, \"result_bend_deg\": %s, \"true_chamber_model_bend_deg\": %s, "
          "\"chamber_iou\": %s, \"chamber_volume_error\": %s, \"mass_error\": %s, \"particles\": %zu, "
          "\"ccx_cell_m\": %s, \"ccx_nodes\": %zu, \"ccx_tets\": %zu, \"region_available\": %s, \"iou_expected\": %s, \"iou_p10\": %s, "
          "\"iou_p90\": %s, \"called_determined\": %s, \"evaluations\": %d, \"ccx_s\": %s, \"render_track_s\": %s, "
          "\"infer_s\": %s, \"total_s\": %s, \"region\": %s, \"identifiability\": %s, \"tracker\": %s, "
          "\"message\": %s}\n",
          json::quote(sc.name).c_str(), json::quote(sc.what).c_str(), list(pressures).c_str(),
          json::quote(fit).c_str(), list(ccx_bends).c_str(), list(tracked).c_str(), list(held_pred).c_str(),
          list(truth_model).c_str(), json::num(row.iou).c_str(), json::num(row.volume).c_str(),
          json::num(row.mass).c_str(), cloud->size(), json::num(cell_m).c_str(), finger.mesh().nodes.size(), finger.mesh().tets.size(),
          available ? "true" : "false", json::num(res.region.iou_mean).c_str(), json::num(res.region.iou_p10).c_str(),
          json::num(res.region.iou_p90).c_str(), determined ? "true" : "false", res.optimizer.evaluations,
          json::num(ccx_s).c_str(), json::num(track_s).c_str(), json::num(infer_s).c_str(),
          json::num(row.seconds).c_str(),
          json::quote(available ? res.region.sentence : res.region.note).c_str(),
          json::quote(res.identifiability.summary).c_str(), json::quote(tracker_message).c_str(),
          json::quote(out.message).c_str());
      std::fflush(stdout);
    } catch (const std::exception& e) {
      row.verdict = std::string("FAILED: ") + e.what();
      row.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      std::printf("{\"bench\": \"peer_soft\", \"case\": %s, \"error\": %s}\n", json::quote(sc.name).c_str(),
                  json::quote(e.what()).c_str());
      std::fflush(stdout);
    }
    rows.push_back(row);
  }
  if (rows.empty()) return usage();

  std::printf("\n| case | chamber IoU | volume | mass | bend at %.3g Pa: tracked / CalculiX / result / true chamber "
              "in our model | held out: result / CalculiX | verdict | time |\n",
              pressures.back());
  std::printf("| --- | --- | --- | --- | --- | --- | --- | --- |\n");
  for (const Row& r : rows)
    std::printf("| %s | %.3f | %s | %s | %.3f / %.3f / %.3f / %.3f deg | %.3g Pa: %.3f / %.3f deg (%+.2f) | %s | %.0f s |\n",
                r.name.c_str(), r.iou, pct(r.volume).c_str(), pct(r.mass).c_str(), r.tracked, r.ccx, r.fitted,
                r.truth_model, r.held_p, r.held_pred, r.held_ccx, r.held_pred - r.held_ccx,
                r.verdict.c_str(), r.seconds);
  int goal = 0, honest = 0;
  for (const Row& r : rows) {
    const bool met = r.iou >= 0.8 && std::abs(r.volume) <= 0.05;
    const bool called = r.verdict.rfind("determined", 0) == 0;
    goal += met;
    honest += met == called;
  }
  std::printf("\ngoal (chamber IoU >= 0.8, volume within 5 %%): %d of %zu; the verdict says determined exactly when "
              "the goal holds: %d of %zu\n",
              goal, rows.size(), honest, rows.size());
  return 0;
}
