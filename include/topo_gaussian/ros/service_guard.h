// guardService: the one wrapper for our service callbacks. A node survives any request: an
// exception in the body (a TopoError for bad input, or anything else) becomes res.success = false and
// res.message = what(), logged once with ROS_ERROR naming the node and the service, and the call
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
#include <string>

namespace topo_gaussian::topo_ros {

template <typename Response, typename Body>
bool guardService(const std::string& node, const std::string& service, Response& res, Body&& body) {
  try {
    body();
  } catch (const std::exception& e) {
    res = Response();
    res.success = false;
    res.message = e.what();
    ROS_ERROR("%s: %s failed: %s", node.c_str(), service.c_str(), e.what());
  }
  return true;
}

}  // namespace topo_gaussian::topo_ros
