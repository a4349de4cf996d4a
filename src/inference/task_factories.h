// Internal: one register function per task file; each appends its TaskDefinition(s) to the registry
// (called from the explicit list in task_registry.cpp).
#pragma once

#include "topo_gaussian/inference/task_registry.h"

namespace topo_gaussian::inference {

void registerStaticTasks(TaskList* tasks);  ///< hanging, balance, stand (static_task.cpp)
void registerTumblerTask(TaskList* tasks);
void registerQiqiTask(TaskList* tasks);
void registerBallTask(TaskList* tasks);
void registerFingerTask(TaskList* tasks);
void registerPearTask(TaskList* tasks);
void registerCantileverTask(TaskList* tasks);

}  // namespace topo_gaussian::inference
