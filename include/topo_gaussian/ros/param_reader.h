// ParamReader: the one way our nodes read their private ROS parameters — typed, checked, and with
// messages that name the parameter. Over a private NodeHandle:
//
//   ParamReader p(pnh, "motion_tracker");
//   double w = p.number("window_s", 20.0, "s", Range::above(0.0));          // (0, inf) s
//   int n    = p.integer("stride", 1, "", Range::atLeast(1));
//   bool b   = p.flag("undamped", false);
//   std::string m = p.text("method", "marker", {"marker", "silhouette", "klt"});
//   std::vector<double> v = p.numbers("pivot", {}, 2, "px");                // 2 entries, or unset
//
// - absent → the default (never checked: defaults are the node's own);
// - present with the wrong XmlRpc type (a string where a number is expected, a double where an
//   integer is, a number where a flag is) → TopoError naming "~name (/resolved/name)", the type
//   found, the type expected and an example (`_name:=<default>`);
// - out of range, or not finite → TopoError with the value, the range and the unit;
// - integers are accepted where numbers are expected, and whole doubles where integers are (YAML
//   writes 5e4 as a double); a list of numbers may also arrive as one string ("[1, 2, 3]", as
//   `_name:="[1,2,3]"` on a command line gives it); a list of strings as one string of items
//   separated by ';' (or the separators the caller names).
// The checks themselves take an XmlRpcValue (the param_check functions below), so they are tested
// without a ROS master (test/unit/ros_param_reader.cpp).
//
// Every read also describes the parameter (param_doc below): with the environment variable
// TOPO_DESCRIBE_PARAMS=FILE set, each distinct description is appended to FILE as one JSON line
// {node, ns, name, type, default, unit, range, choices, size, example}. docs/nodes.md's parameter
// tables are rendered from these lines (test/ros/node_interfaces.test), so they list what the nodes
// actually read. Unset (the normal case), nothing is written.
#pragma once

#include <ros/node_handle.h>
#include <xmlrpcpp/XmlRpcValue.h>

#include <limits>
#include <string>
#include <vector>

namespace topo_gaussian::topo_ros {

/// An interval for a number; each end inclusive or exclusive. Default: everything finite.
struct Range {
  double low = -std::numeric_limits<double>::infinity();
  double high = std::numeric_limits<double>::infinity();
  bool low_exclusive = false, high_exclusive = false;

  static Range any() { return {}; }
  static Range between(double lo, double hi) { return {lo, hi, false, false}; }  ///< [lo, hi]
  static Range atLeast(double lo) {
    return {lo, std::numeric_limits<double>::infinity(), false, false};
  }                                                                                                     ///< [lo, inf)
  static Range above(double lo) { return {lo, std::numeric_limits<double>::infinity(), true, false}; }  ///< (lo, inf)
  bool contains(double v) const;
  std::string text(const std::string& unit) const;  ///< e.g. "(0, 3600] s"
};

/// The checks of one value, independent of a NodeHandle. `name` is how the message names it
/// ("~window_s (/motion_tracker/window_s)"), `example` the value the message suggests (e.g. "20").
namespace param_check {
double number(const XmlRpc::XmlRpcValue& v, const std::string& name, const std::string& unit, const Range& range,
              const std::string& example);
long integer(const XmlRpc::XmlRpcValue& v, const std::string& name, const std::string& unit, const Range& range,
             const std::string& example);
bool flag(const XmlRpc::XmlRpcValue& v, const std::string& name);
std::string text(const XmlRpc::XmlRpcValue& v, const std::string& name, const std::vector<std::string>& choices,
                 const std::string& example);
/// size 0: any length.
std::vector<double> numbers(const XmlRpc::XmlRpcValue& v, const std::string& name, std::size_t size,
                            const std::string& unit, const std::string& example);
std::vector<std::string> texts(const XmlRpc::XmlRpcValue& v, const std::string& name, const std::string& example,
                               const std::string& separators);
/// "a string", "an integer", ... for messages.
std::string typeName(const XmlRpc::XmlRpcValue& v);
}  // namespace param_check

/// What a read declares about a parameter, for docs/nodes.md (written only with TOPO_DESCRIBE_PARAMS).
namespace param_doc {
struct Entry {
  std::string node;           ///< the reader's node name, e.g. "motion_tracker"
  std::string ns;             ///< the private namespace it reads, e.g. "/motion_tracker"
  std::string name;           ///< e.g. "window_s"
  std::string type;           ///< number | integer | flag | text | numbers | texts
  std::string default_value;  ///< as a user writes it: 20, true, marker, [0, 1], ['a=1'], "" (empty text)
  std::string unit;
  std::string range;  ///< Range::text without the unit, e.g. "(0, inf)"; "" when any finite value goes
  std::vector<std::string> choices;
  std::size_t size = 0;  ///< numbers: the entries required (0: any)
  std::string example;
};
/// The entry as one line of JSON (no newline); keys as in Entry, "default" for default_value.
std::string jsonLine(const Entry& e);
/// Appends jsonLine(e) + '\n' to `path`, once per process for the same line; thread-safe, one write(2)
/// per line with O_APPEND (several processes may share the file). Errors are ignored: documentation
/// never stops a node.
void append(const std::string& path, const Entry& e);
/// The value of TOPO_DESCRIBE_PARAMS when the process first asked, or "" (unset: nothing recorded).
const std::string& targetFile();
/// Defaults as a user writes them.
std::string numberDefault(double v);                          ///< 20, 0.02, 50000
std::string numbersDefault(const std::vector<double>& v);     ///< [0, 1]; [] when empty
std::string textDefault(const std::string& v);                ///< the text; "" when empty
std::string textsDefault(const std::vector<std::string>& v);  ///< ['a=1', 'b=2']; [] when empty
std::string rangeText(const Range& range);                    ///< "" for Range::any()
}  // namespace param_doc

class ParamReader {
 public:
  /// `node` names the node in log lines (e.g. "motion_tracker").
  ParamReader(const ::ros::NodeHandle& pnh, std::string node);

  double number(const std::string& name, double fallback, const std::string& unit = "",
                const Range& range = Range()) const;
  long integer(const std::string& name, long fallback, const std::string& unit = "",
               const Range& range = Range()) const;
  bool flag(const std::string& name, bool fallback) const;
  /// choices empty: any string.
  std::string text(const std::string& name, const std::string& fallback,
                   const std::vector<std::string>& choices = {}) const;
  /// size > 0: exactly that many entries when set. `example` shows a good value in messages.
  std::vector<double> numbers(const std::string& name, const std::vector<double>& fallback, std::size_t size = 0,
                              const std::string& unit = "", const std::string& example = "") const;
  /// A list of strings, or one string of items split at any of `separators` (default ';').
  std::vector<std::string> texts(const std::string& name, const std::vector<std::string>& fallback,
                                 const std::string& example = "", const std::string& separators = ";") const;

  bool has(const std::string& name) const;
  /// "~name (/resolved/name)", for the node's own messages about a parameter.
  std::string displayName(const std::string& name) const;
  const std::string& node() const { return node_; }
  const ::ros::NodeHandle& handle() const { return pnh_; }

 private:
  bool get(const std::string& name, XmlRpc::XmlRpcValue& v) const;
  /// Describes the read (param_doc::append) when TOPO_DESCRIBE_PARAMS is set.
  void describe(const std::string& name, const char* type, const std::string& default_value,
                const std::string& unit = "", const Range* range = nullptr,
                const std::vector<std::string>& choices = {}, std::size_t size = 0,
                const std::string& example = "") const;
  ::ros::NodeHandle pnh_;
  std::string node_;
};

}  // namespace topo_gaussian::topo_ros
