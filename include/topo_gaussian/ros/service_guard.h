// guardService: the one wrapper for our service callbacks. A node survives any request: an
// exception in the body (a TopoError for bad input, or anything else) becomes res.success = false and
// res.message = what(), logged once with ROS_ERROR (in ASCII) naming the node and the service, and the call
// still returns true (errors travel in the response, never as a failed call).
//
//   bool Node::onExtract(Srv::Request& req, Srv::Response& res) {
//     return guardService("motion_tracker", service_.getService(), res, [&] {
//       ...;                      // fill res, throw on error
//       res.success = true;
//     });
//   }
//
// On an error the response is reset first (a half-filled response is not sent), then success and
// message are set. Works for any response type with `bool success` and `string message`.
#pragma once

#include <ros/console.h>

#include <exception>
#include <new>
#include <string>

#include "topo_gaussian/ros/ascii_text.h"

namespace topo_gaussian::topo_ros {

template <typename Response, typename Body>
bool guardService(const std::string& node, const std::string& service, Response& res, Body&& body) {
  try {
    body();
  } catch (const std::bad_alloc&) {
    res = Response();
    res.success = false;
    res.message =
        service +
        ": out of memory while answering the request; ask for fewer particles (a larger spacing) or a smaller input";
    ROS_ERROR("%s: %s failed: %s", node.c_str(), service.c_str(), res.message.c_str());
  } catch (const std::exception& e) {
    res = Response();
    res.success = false;
    res.message = e.what();
    ROS_ERROR("%s: %s failed: %s", node.c_str(), service.c_str(), asciiText(e.what()).c_str());
  } catch (...) {
    res = Response();
    res.success = false;
    res.message =
        service +
        ": failed with an exception that is not a std::exception; the node keeps serving (report this as a bug)";
    ROS_ERROR("%s: %s failed: %s", node.c_str(), service.c_str(), res.message.c_str());
  }
  return true;
}

}  // namespace topo_gaussian::topo_ros
