"""ParamReader for rospy nodes: typed private parameters with messages that name them, and the same
descriptions as the C++ nodes' ros/param_reader.h (with TOPO_DESCRIBE_PARAMS=FILE set, each read is
appended to FILE as one JSON line: docs/nodes.md's parameter tables are rendered from them).
A bad value raises ValueError naming ~name (/resolved/name), what was found and an example."""
import json
import math
import os

import rospy

_written = set()


def _number_text(v):
    return "%.12g" % v


class ParamReader:
    def __init__(self, node):
        self.node = node

    def display(self, name):
        return "~%s (%s)" % (name, rospy.resolve_name("~" + name))

    def _describe(self, name, kind, default, unit="", range_text="", choices=(), example=""):
        path = os.environ.get("TOPO_DESCRIBE_PARAMS", "")
        if not path:
            return
        entry = {"node": self.node, "ns": rospy.get_name(), "name": name, "type": kind, "default": default,
                 "unit": unit, "range": range_text, "choices": list(choices), "size": 0, "example": example}
        line = json.dumps(entry, ensure_ascii=True) + "\n"
        if (path, line) in _written:
            return
        _written.add((path, line))
        try:
            fd = os.open(path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
            try:
                os.write(fd, line.encode())
            finally:
                os.close(fd)
        except OSError:
            pass  # documentation never stops a node

    def _get(self, name):
        key = "~" + name
        return (True, rospy.get_param(key)) if rospy.has_param(key) else (False, None)

    def number(self, name, default, unit="", low=None, strict=False):
        range_text = ""
        if low is not None:
            range_text = "%s%s, inf)" % ("(" if strict else "[", _number_text(low))
        self._describe(name, "number", _number_text(default), unit, range_text)
        found, v = self._get(name)
        if not found:
            return float(default)
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise ValueError("%s is %r (%s), not a number: set e.g. _%s:=%s" % (
                self.display(name), v, type(v).__name__, name, _number_text(default)))
        v = float(v)
        if not math.isfinite(v) or (low is not None and (v <= low if strict else v < low)):
            raise ValueError("%s = %r %s is outside %s %s" % (self.display(name), v, unit, range_text, unit))
        return v

    def flag(self, name, default):
        self._describe(name, "flag", "true" if default else "false")
        found, v = self._get(name)
        if not found:
            return bool(default)
        if not isinstance(v, bool):
            raise ValueError("%s is %r, not true or false: set e.g. _%s:=%s" % (
                self.display(name), v, name, "true" if default else "false"))
        return v

    def text(self, name, default, choices=(), example=""):
        self._describe(name, "text", default if default else '""', choices=choices, example=example)
        found, v = self._get(name)
        if not found:
            return default
        if not isinstance(v, str):
            raise ValueError("%s is %r, not a text: set e.g. _%s:=%s" % (self.display(name), v, name,
                                                                        example or default or "NAME"))
        if choices and v not in choices:
            raise ValueError("%s is '%s': use one of %s" % (self.display(name), v, ", ".join(choices)))
        return v
