// The JSON texts that describe an inference for people and for the other front ends: report.json of
// a run (task, source, parameters, targets, initial and achieved features, losses, flags, message,
// mass properties, geometry, timings, loss history) and the features of a simulated design. The
// text only: io writes it (io/text_file.h), io/run_folder.h reads it back.
#pragma once

#include <string>

#include "topo_gaussian/inference/pipeline.h"

namespace topo_gaussian::inference {

/// report.json of a run.
std::string reportJson(const InferenceResult& result, const TaskConfig& config);
/// JSON of a simulated design (features, loss, mass properties, geometry).
std::string simulationJson(const ProblemEvaluation& ev, const TaskConfig& config, const TaskGeometry& geometry);

}  // namespace topo_gaussian::inference
