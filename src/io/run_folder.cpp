#include "topo_gaussian/io/run_folder.h"

#include <algorithm>
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

LatestRun findLatestRun(const std::string& parent) {
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
      out.run = loadRunFolder(dir.string());
      out.found = true;
      return out;
    } catch (const std::exception& e) {
      out.skipped.push_back(dir.string() + ": " + e.what());
    }
  }
  return out;
}

}  // namespace topo_gaussian::io
