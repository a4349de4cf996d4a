// Where the task YAML files (config/tasks/NAME.yaml) are found at run time, without baking a source
// path into the binaries: $TOPO_TASK_DIR when set; else config/tasks of the topo_gaussian package on
// $ROS_PACKAGE_PATH (set by `source build/devel/setup.bash` or an install space); else the install
// share directory beside the executable; else "" (the tasks' built-in defaults, which the YAML files
// only restate).
#pragma once

#include <string>

namespace topo_gaussian::io {

std::string defaultTaskDir();

}  // namespace topo_gaussian::io
