// A run folder: what one inference leaves on disk, the same whichever front end ran it (`topo infer`,
// the interior_inference node, a benchmark), so any of them can load any run:
//   volume.ply     the particles the run used (io/volume_ply.h)
//   interior.ply   r, solid and density per particle (io/interior_ply.h)
//   report.json    task, parameters, targets, features, loss history (inference/report.h); written
//                  last, after the files a restore loads, so a folder with a report holds the whole run
//   signal.csv     the simulated signal, when the task has one (io/run_files.h)
//   and the export: interior.stl, slices.png, signal.png, loss.png, export.json (workflow/interior_export.h).
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "topo_gaussian/io/interior_ply.h"
#include "topo_gaussian/physics/volume_cloud.h"

namespace topo_gaussian::io {

/// Creates `dir` and its parents when missing. Throws TopoError naming `what` and the directory when
/// it cannot be created or is not a directory.
void ensureDirectory(const std::string& dir, const std::string& what);

/// The names of the files a run writes into its folder: volume.ply, interior.ply, report.json,
/// signal.csv and the export's interior.stl, slices.png, signal.png, loss.png, export.json.
const std::vector<std::string>& runFileNames();

struct PreparedRunFolder {
  std::vector<std::string> removed;  ///< an earlier run's files removed (replace), names inside the folder
  std::vector<std::string> kept;     ///< other entries left in place (replace), names inside the folder
};

/// Makes `dir` ready for one run: creates it when missing. A folder that holds anything is refused
/// with a TopoError naming what it holds (an earlier run: its task and files) and the fix, since the
/// new run would overwrite the earlier one in part and leave its other files (signal.csv, signal.png)
/// beside the new report. With `replace`, the files a run writes (runFileNames(), and the ".tmpN"
/// leftovers of an interrupted write) are removed first; any other entry is kept, never removed.
PreparedRunFolder prepareRunFolder(const std::string& dir, bool replace);

/// Creates and returns a new folder <parent>/<stem>_<YYYYmmdd_HHMMSS> (local time); when that name
/// exists (two runs in one second) the suffix _2, _3, ... is added, so no run overwrites another.
std::string createRunFolder(const std::string& parent, const std::string& stem);

struct RunFiles {
  std::string dir;
  VolumeCloud volume;
  InteriorPly interior;
  std::string report_json;
  std::string task;  ///< the "task" of report.json
};

/// Loads and checks a run folder. Throws TopoError naming the file that is missing, truncated or not
/// what it should be (an empty or unparsable report.json, a report without a task, an interior whose
/// count differs from the volume's).
RunFiles loadRunFolder(const std::string& dir);

struct LatestRun {
  bool found = false;
  RunFiles run;
  std::vector<std::string> skipped;  ///< newer folders passed over, each "DIR: why"
};

/// Whether a run's report.json says the run was interrupted: "cancelled": true (a cancelled goal, Ctrl-C,
/// a node stopped while it ran). Such a folder holds the best design found until then, not a finished run.
bool reportSaysCancelled(const std::string& report_json);

/// Throws (a TopoError saying why) for a loaded run the caller cannot use, e.g. one whose task is unknown.
using RunCheck = std::function<void(const RunFiles&)>;

/// The newest *complete* run folder under `parent` (by the time of its report.json, which a run writes
/// last): one that loads, was not interrupted (reportSaysCancelled) and passes `check` (when given).
/// Folders without report.json are not runs and are ignored; newer runs passed over are listed in
/// `skipped`, each with the reason, and the search goes on to older ones.
LatestRun findLatestRun(const std::string& parent, const RunCheck& check = {});

}  // namespace topo_gaussian::io
