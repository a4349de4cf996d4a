#include "topo_gaussian/io/run_folder.h"

#include <algorithm>
#include <cctype>
#include <ctime>
#include <filesystem>
#include <iomanip>
#include <nlohmann/json.hpp>
#include <sstream>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/io/text_file.h"
#include "topo_gaussian/io/volume_ply.h"

namespace topo_gaussian::io {

namespace fs = std::filesystem;

void ensureDirectory(const std::string& dir, const std::string& what) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (!fs::is_directory(dir))
    throw TopoError(what + " " + dir, "cannot be created" + (ec ? " (" + ec.message() + ")" : std::string()),
                    "give a writable directory");
}

const std::vector<std::string>& runFileNames() {
  static const std::vector<std::string> names = {"volume.ply", "interior.ply", "report.json",
                                                 "signal.csv", "interior.stl", "slices.png",
                                                 "signal.png", "loss.png",     "export.json",
                                                 "inertial.urdf", "inertial.sdf"};
  return names;
}

namespace {

/// A name a run writes: one of runFileNames(), or such a name + ".tmp" + digits (an interrupted
/// atomic write, io/text_file.h).
bool isRunFileName(const std::string& name) {
  for (const auto& f : runFileNames()) {
    if (name == f) return true;
    if (name.size() > f.size() + 4 && name.compare(0, f.size() + 4, f + ".tmp") == 0 &&
        std::all_of(name.begin() + f.size() + 4, name.end(), [](char c) { return std::isdigit(c) != 0; }))
      return true;
  }
  return false;
}

std::string firstNames(const std::vector<std::string>& names, std::size_t most) {
  std::string s;
  for (std::size_t i = 0; i < names.size() && i < most; ++i) s += (i ? ", " : "") + names[i];
  if (names.size() > most) s += " and " + std::to_string(names.size() - most) + " more";
  return s;
}

}  // namespace

PreparedRunFolder prepareRunFolder(const std::string& dir, bool replace) {
  ensureDirectory(dir, "output directory");
  std::vector<std::string> run_files, others;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    const std::string name = e.path().filename().string();
    std::error_code tec;
    (isRunFileName(name) && !e.is_directory(tec) ? run_files : others).push_back(name);
  }
  if (ec)
    throw TopoError("output directory " + dir, "cannot be listed (" + ec.message() + ")", "give a readable directory");
  std::sort(run_files.begin(), run_files.end());
  std::sort(others.begin(), others.end());
  PreparedRunFolder out;
  if (run_files.empty() && others.empty()) return out;
  if (!replace) {
    std::string what;
    if (!run_files.empty()) {
      std::string task;
      try {
        task = nlohmann::json::parse(readTextFile((fs::path(dir) / "report.json").string())).value("task", "");
      } catch (const std::exception&) {  // no report, or a torn one: still a run's files
      }
      what = "holds an earlier run" + (task.empty() ? std::string() : " of task " + task) + " (" +
             firstNames(run_files, 9) + (others.empty() ? "" : "; and " + firstNames(others, 3)) + ")";
    } else {
      what = "is not empty (" + firstNames(others, 5) + ")";
    }
    throw TopoError("output directory " + dir,
                    what + ": a run there would overwrite some of it and leave the rest beside the new files",
                    "give another folder (a new or empty one), or clear this one: `topo infer --force` removes an "
                    "earlier run's files first and keeps any other file");
  }
  for (const auto& name : run_files) {
    std::error_code rec;
    fs::remove(fs::path(dir) / name, rec);
    if (rec)
      throw TopoError(dir + "/" + name, "of an earlier run cannot be removed (" + rec.message() + ")",
                      "check the folder's permissions, or give another folder");
    out.removed.push_back(name);
  }
  out.kept = others;
  return out;
}

std::string createRunFolder(const std::string& parent, const std::string& stem) {
  ensureDirectory(parent, "output directory");
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  localtime_r(&now, &tm);
  std::ostringstream base;
  base << parent << "/" << stem << "_" << std::put_time(&tm, "%Y%m%d_%H%M%S");
  for (int k = 1; k < 10000; ++k) {
    const std::string dir = base.str() + (k == 1 ? std::string() : "_" + std::to_string(k));
    std::error_code ec;
    if (fs::create_directory(dir, ec)) return dir;  // false when it exists: try the next suffix
    if (ec)
      throw TopoError("output directory " + dir, "cannot be created (" + ec.message() + ")",
                      "give a writable directory");
  }
  throw TopoError("output directory " + parent, "has 10000 runs named " + base.str() + "_N", "clean it up");
}

RunFiles loadRunFolder(const std::string& dir) {
  RunFiles run;
  run.dir = dir;
  for (const char* name : {"volume.ply", "interior.ply", "report.json"})
    if (!fs::is_regular_file(fs::path(dir) / name))
      throw TopoError(dir, std::string("has no ") + name,
                      "give a run folder written by topo infer or interior_inference");
  run.report_json = readTextFile((fs::path(dir) / "report.json").string());
  const nlohmann::json report = nlohmann::json::parse(run.report_json, nullptr, /*allow_exceptions=*/false);
  if (report.is_discarded() || !report.is_object())
    throw TopoError(dir + "/report.json", run.report_json.empty() ? "is empty" : "is not valid JSON (truncated?)",
                    "the run was interrupted while writing: run it again");
  const auto task = report.find("task");
  if (task == report.end() || !task->is_string() || task->get<std::string>().empty())
    throw TopoError(dir + "/report.json", "names no task", "give a report written by topo infer or interior_inference");
  run.task = task->get<std::string>();
  run.volume = readVolumePly((fs::path(dir) / "volume.ply").string());
  run.interior = readInteriorPlyData((fs::path(dir) / "interior.ply").string(), run.volume.size());
  return run;
}

bool reportSaysCancelled(const std::string& report_json) {
  const nlohmann::json report = nlohmann::json::parse(report_json, nullptr, /*allow_exceptions=*/false);
  if (!report.is_object()) return false;
  const auto c = report.find("cancelled");
  return c != report.end() && c->is_boolean() && c->get<bool>();
}

LatestRun findLatestRun(const std::string& parent, const RunCheck& check) {
  std::vector<std::pair<fs::file_time_type, fs::path>> runs;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(parent, ec)) {
    const fs::path report = e.path() / "report.json";
    std::error_code tec;
    if (!e.is_directory(tec) || !fs::exists(report, tec)) continue;
    const auto t = fs::last_write_time(report, tec);
    if (!tec) runs.emplace_back(t, e.path());
  }
  std::sort(runs.begin(), runs.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  LatestRun out;
  for (const auto& [time, dir] : runs) {
    try {
      RunFiles run = loadRunFolder(dir.string());
      if (reportSaysCancelled(run.report_json))
        throw TopoError(dir.string() + "/report.json",
                        "says \"cancelled\": true: the run was interrupted (its goal cancelled, or the node or "
                        "topo infer stopped while it ran), so it holds the best design found until then, not a "
                        "finished run",
                        "run the inference again to finish it (topo simulate and topo export still read this "
                        "folder when named)");
      if (check) check(run);
      out.run = std::move(run);
      out.found = true;
      return out;
    } catch (const std::exception& e) {
      out.skipped.push_back(dir.string() + ": " + e.what());
    }
  }
  return out;
}

}  // namespace topo_gaussian::io
