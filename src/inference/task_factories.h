// Internal: one factory per task family (each in its own .cpp).
#pragma once

#include <memory>

#include "topo_gaussian/inference/task.h"

namespace topo_gaussian::inference {

std::unique_ptr<Task> makeStaticTask(const TaskConfig& config, const VolumeCloud& cloud);
std::unique_ptr<Task> makeTumblerTask(const TaskConfig& config, const VolumeCloud& cloud);
std::unique_ptr<Task> makeQiqiTask(const TaskConfig& config, const VolumeCloud& cloud);
std::unique_ptr<Task> makeBallTask(const TaskConfig& config, const VolumeCloud& cloud);
std::unique_ptr<Task> makeFingerTask(const TaskConfig& config, const VolumeCloud& cloud);
std::unique_ptr<Task> makePearTask(const TaskConfig& config, const VolumeCloud& cloud);
std::unique_ptr<Task> makeCantileverTask(const TaskConfig& config, const VolumeCloud& cloud);

}  // namespace topo_gaussian::inference
