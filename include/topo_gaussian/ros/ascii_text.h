// asciiText: what our nodes hand to rosout. rosout (rqt_console, roslaunch's screen, the log files)
// shows any byte above 127 as "??", so "0.2 × 0.3" arrived as "0.2 ?? 0.3". The library keeps its
// UTF-8 messages (the CLI prints them fine); every ROS_* line of a node and every message it answers on
// a service or an action goes through asciiText, which spells the symbols our messages use in ASCII
// (× → x, · → *, ≥ → >=, ≤ → <=, ° → deg, − → -, → → ->, ² → ^2, μ → u, ...) and writes any other
// non-ASCII character as U+XXXX, so nothing is lost and nothing shows as "??".
#pragma once

#include <string>

namespace topo_gaussian::topo_ros {

/// `text` (UTF-8) with every non-ASCII character spelled in ASCII. Invalid UTF-8 bytes become '?'.
std::string asciiText(const std::string& text);

}  // namespace topo_gaussian::topo_ros
