#!/usr/bin/env python3
"""docs/nodes.md's interface blocks against the running nodes.

node_interfaces.test starts each node in a namespace of its own, with TOPO_DESCRIBE_PARAMS naming a
file: every parameter a node reads through ParamReader (ros/param_reader.h) is described there, one
JSON line each. This test waits until each node is up (its parameters described, its main thread
asleep in ros::spin() or a wait, its registrations unchanged for a while), asks the
master what it subscribes, publishes and serves (topic types from the master, service types from the
services, latching from each publisher's connection header), reads the parameter descriptions, and
renders one markdown block per node. A block must equal the text between

    <!-- BEGIN GENERATED: NODE -->  and  <!-- END GENERATED: NODE -->

in docs/nodes.md. With TOPO_UPDATE_DOCS=1 it rewrites the text between the markers (nothing else)
and then checks the rewritten file.

Names are written as the node sees them: `~x` is private (/NS/NODE/x), `x` is relative to the
node's namespace (remappable), `/x` is absolute. An action's goal/cancel/status/feedback/result
topics are one line under Actions. ROS's own interfaces (rosout, get_loggers, set_logger_level) are
left out. A node run in several modes (rig_simulator: the rigid twin and the finger twin;
infer_client: waiting for motion features, or sending at once) is started once per mode; what only
one mode has is marked "(MODE only)". Parameters: the descriptions' type, default (the package's
folder written `$(find topo_gaussian)`, ROS_HOME `$ROS_HOME`), unit, range, choices and example; the
last column, where there is one, is the `doc` of the launch argument that sets the parameter in the
node's own launch file (launch_docs below).

Private parameters: ~params_file (the TOPO_DESCRIBE_PARAMS file), ~docs (docs/nodes.md),
~nodes (a list of {doc: NODE, node: /NS/NODE, mode: LABEL, about: TEXT}; mode and about, what
sets the mode, only for a node started more than once), ~settle_s (2: the node's
main thread must sleep and its registrations stay unchanged this long), ~wait_s (480: for every node
in all).
"""
import difflib
import io
import json
import os
import re
import socket
import sys
import time
import unittest
import xmlrpc.client
import xml.etree.ElementTree as ElementTree

import rosgraph
import rosgraph.network
import rospkg
import rospy
import rosservice
import rostest

PKG = "topo_gaussian"
ROS_OWN_TOPICS = {"/rosout"}
ROS_OWN_SERVICES = {"get_loggers", "set_logger_level"}
ACTION_SERVER_SUBS = ("goal", "cancel")
ACTION_SERVER_PUBS = ("status", "feedback", "result")
TYPE_NAMES = {"number": "double", "integer": "int", "flag": "bool", "text": "string", "texts": "string[]"}
REGENERATE = "TOPO_UPDATE_DOCS=1 rostest topo_gaussian node_interfaces.test"


def update_requested():
    return os.environ.get("TOPO_UPDATE_DOCS") == "1"


# ------------------------------------------------------------------------------------------ master


def registrations(state, node):
    """(subscribed topics, published topics, services) of `node` in a getSystemState answer."""
    pubs, subs, srvs = state

    def of(entries):
        return sorted(name for name, nodes in entries if node in nodes)

    return of(subs), of(pubs), of(srvs)


def own_interface(node, subs, pubs, srvs):
    """Without ROS's own: /rosout, ~get_loggers, ~set_logger_level."""
    subs = [t for t in subs if t not in ROS_OWN_TOPICS]
    pubs = [t for t in pubs if t not in ROS_OWN_TOPICS]
    srvs = [s for s in srvs if s not in {node + "/" + n for n in ROS_OWN_SERVICES}]
    return subs, pubs, srvs


def is_latched(master, node, topic, caller_id, timeout_s=5.0):
    """True when `node` publishes `topic` latched: its TCPROS connection header says latching=1."""
    uri = master.lookupNode(node)  # rosgraph.MasterError when it does not know the node
    server = xmlrpc.client.ServerProxy(uri)
    code, msg, proto = server.requestTopic(caller_id, topic, [["TCPROS"]])
    if code != 1 or not proto or proto[0] != "TCPROS":
        raise RuntimeError("%s refused a TCPROS connection to %s: %s" % (node, topic, msg))
    _, host, port = proto
    with socket.create_connection((host, port), timeout=timeout_s) as sock:
        sock.settimeout(timeout_s)
        sock.sendall(
            rosgraph.network.encode_ros_handshake_header(
                {"callerid": caller_id, "topic": topic, "md5sum": "*", "type": "*", "tcp_nodelay": "1"}
            )
        )
        header = rosgraph.network.read_ros_handshake_header(sock, io.BytesIO(), 65536)
    if "error" in header:
        raise RuntimeError("%s on %s: %s" % (node, topic, header["error"]))
    return header.get("latching") == "1"


def node_pid(master, node):
    """The node's process id (its XML-RPC getPid), or None while it is not registered."""
    try:
        code, _, pid = xmlrpc.client.ServerProxy(master.lookupNode(node)).getPid(rospy.get_name())
        return pid if code == 1 else None
    except (OSError, xmlrpc.client.Error, rosgraph.MasterError):
        return None


def main_thread_sleeps(pid):
    """True when the process's main thread waits (state S or I in /proc): a node in ros::spin() or
    waitForShutdown(), not one still computing in its constructor (R). The nodes run on this machine."""
    try:
        with open("/proc/%d/stat" % pid) as f:
            return f.read().rsplit(")", 1)[1].split()[0] in ("S", "I")
    except (OSError, IndexError):
        return False


# --------------------------------------------------------------------------------------- rendering


class Names:
    """A node's names as the node writes them: ~private, relative, /absolute."""

    def __init__(self, node):
        self.private = node + "/"
        self.ns = node[: node.rfind("/") + 1]  # "/doc_x/" for /doc_x/node

    def __call__(self, name):
        if name.startswith(self.private):
            return "~" + name[len(self.private) :]
        if name.startswith(self.ns) and self.ns != "/":
            return name[len(self.ns) :]
        return name


def split_actions(subs, pubs, types):
    """Finds actionlib servers and clients among the topics: returns (subs, pubs, actions) with the
    five topics of each action taken out; actions as [(base, role, action type)]."""
    actions = []
    bases = {t.rsplit("/", 1)[0] for t in subs + pubs if "/" in t.lstrip("/")}
    for base in sorted(bases):
        server = all(base + "/" + s in subs for s in ACTION_SERVER_SUBS) and all(
            base + "/" + p in pubs for p in ACTION_SERVER_PUBS
        )
        client = all(base + "/" + s in pubs for s in ACTION_SERVER_SUBS) and all(
            base + "/" + p in subs for p in ACTION_SERVER_PUBS
        )
        if not (server or client):
            continue
        goal_type = types.get(base + "/goal", "?")
        action_type = goal_type[: -len("ActionGoal")] if goal_type.endswith("ActionGoal") else goal_type
        actions.append((base, "server" if server else "client", action_type))
        taken = {base + "/" + x for x in ACTION_SERVER_SUBS + ACTION_SERVER_PUBS}
        subs = [t for t in subs if t not in taken]
        pubs = [t for t in pubs if t not in taken]
    return subs, pubs, actions


class Paths:
    """Machine-dependent defaults written as a reader would: the package folder and ROS_HOME."""

    def __init__(self):
        self.package = rospkg.RosPack().get_path(PKG)
        self.ros_home = rospkg.get_ros_home()
        self.used = set()

    def __call__(self, text):
        for path, name in ((self.package, "$(find topo_gaussian)"), (self.ros_home, "$ROS_HOME")):
            if path and (text == path or text.startswith(path + "/")):
                self.used.add(name)
                return name + text[len(path) :]
        return text

    def note(self):
        notes = []
        if "$(find topo_gaussian)" in self.used:
            notes.append("`$(find topo_gaussian)` is the package's folder")
        if "$ROS_HOME" in self.used:
            notes.append("`$ROS_HOME` is `~/.ros` unless the variable is set")
        return ("Defaults: " + "; ".join(notes) + ".") if notes else ""


def launch_docs(launch_dir):
    """{node type: {parameter: (doc, launch file)}} from the launch files that start one node of
    ours (launch/cloud_ingest.launch, inference.launch, motion_tracker.launch: their args are the
    node's parameters): <param name="P" value="$(arg A)"/> takes the doc of <arg name="A" doc="..."/>.
    The rigs' launch files are left out: their args feed several nodes, their docs speak of the rig."""
    out = {}
    for fname in sorted(os.listdir(launch_dir)):
        if not fname.endswith(".launch"):
            continue
        root = ElementTree.parse(os.path.join(launch_dir, fname)).getroot()
        args = {a.get("name"): a.get("doc") for a in root.iter("arg") if a.get("doc")}
        ours = [n for n in root.iter("node") if n.get("pkg") == PKG]
        if len(ours) != 1 or any(True for _ in root.iter("include")):
            continue
        for node in ours:
            for param in node.iter("param"):
                m = re.fullmatch(r"\$\(arg (\w+)\)", param.get("value") or "")
                if m and m.group(1) in args:
                    out.setdefault(node.get("type"), {}).setdefault(param.get("name"), (args[m.group(1)], fname))
    return out


def cell(text):
    return text.replace("|", "\\|").replace("\n", " ")


def param_row(p, paths, meaning):
    kind = p["type"]
    if kind == "numbers":
        type_text = "double[%d]" % p["size"] if p.get("size") else "double[]"
    else:
        type_text = TYPE_NAMES.get(kind, kind)
    default = paths(p["default"])
    notes = []
    if p.get("range"):
        notes.append(p["range"])
    if p.get("choices"):
        notes.append("one of " + ", ".join("`%s`" % c for c in p["choices"]))
    if p.get("example") and p["example"] != p["default"]:
        notes.append("e.g. " + p["example"])
    return [type_text, "`%s`" % default, p.get("unit", ""), "; ".join(notes), meaning]


def read_params(path):
    """{ns: {name: description}}: the last description of each parameter per private namespace (a
    node that reads a parameter twice, e.g. rig_simulator's ~task, uses the later read's default)."""
    out = {}
    if not os.path.exists(path):
        return out
    with open(path, encoding="utf-8") as f:
        for n, line in enumerate(f, 1):
            line = line.strip()
            if not line:
                continue
            try:
                p = json.loads(line)
            except ValueError as e:
                raise AssertionError("%s line %d is not JSON (%s): %r" % (path, n, e, line))
            out.setdefault(p["ns"], {})[p["name"]] = p
    return out


def render(doc, instances, params, paths, meanings):
    """The markdown block of `doc` from its instances [(mode or None, snapshot)]."""
    modes = [m for m, _ in instances]
    abouts = [snap.get("about", "") for _, snap in instances]
    several = len(instances) > 1

    def mark(present):
        if not several or len(present) == len(instances):
            return ""
        return " (" + ", ".join(m for m in modes if m in present) + " only)"

    def merged(kind):
        """[(line, modes having it)] over the instances, sorted by name."""
        lines = {}
        for mode, snap in instances:
            for key in snap[kind]:
                lines.setdefault(key, set()).add(mode)
        return [(line, present) for (_, line), present in sorted(lines.items())]

    out = ["<!-- generated by test/ros/node_interfaces.test: edit the nodes, not this block; %s -->" % REGENERATE]
    if several:
        out.append("")
        out.append(
            "Started once per mode: "
            + "; ".join("**%s**%s" % (m, (" (%s)" % about) if about else "") for m, about in zip(modes, abouts))
            + ". A line marked with a mode is there only in that mode."
        )
    for title, kind in (
        ("Subscribed topics", "subs"),
        ("Published topics", "pubs"),
        ("Services", "srvs"),
        ("Actions", "actions"),
    ):
        out += ["", "**%s**" % title, ""]
        lines = merged(kind)
        out += ["- %s%s" % (line, mark(present)) for line, present in lines] or ["- none"]

    rows = {}
    for mode, snap in instances:
        for name, p in params.get(snap["ns"], {}).items():
            meaning = meanings.get(name, ("", None))[0]
            rows.setdefault(name, {}).setdefault(tuple(param_row(p, paths, meaning)), set()).add(mode)
    out += ["", "**Parameters** (private: `_name:=value` on a command line, `<param>` in a launch file)", ""]
    with_docs = False
    if not rows:
        out.append("- none")
    else:
        with_docs = any(row[-1] for variants in rows.values() for row in variants)
        out.append("| Parameter | Type | Default | Unit | Range, choices, example |" + (" Launch file's doc |" if with_docs else ""))
        out.append("|---|---|---|---|---|" + ("---|" if with_docs else ""))
        for name in sorted(rows):
            variants = rows[name]
            for row, present in sorted(variants.items(), key=lambda v: [m for m in modes if m in v[1]]):
                label = "`~%s`" % name
                if several and (len(variants) > 1 or len(present) < len(instances)):
                    label += " (" + ", ".join(m for m in modes if m in present) + ")"
                cells = [label] + list(row if with_docs else row[:-1])
                out.append("| " + " | ".join(cell(c) for c in cells) + " |")
    notes = []
    if rows and with_docs:
        files = sorted({f for _, f in meanings.values()})
        notes.append("Launch file's doc: the `doc` of the argument that sets the parameter in %s." % ", ".join(
            "`launch/%s`" % f for f in files))
    if paths.note():
        notes.append(paths.note())
    if notes:
        for n in notes:
            out += ["", n]
    return "\n".join(out) + "\n"


def markers(doc):
    return "<!-- BEGIN GENERATED: %s -->" % doc, "<!-- END GENERATED: %s -->" % doc


def block_span(text, doc):
    """(start, end) of the text between doc's markers, or None."""
    begin, end = markers(doc)
    b = text.find(begin)
    if b < 0:
        return None
    b = text.index("\n", b) + 1 if "\n" in text[b:] else b + len(begin)
    e = text.find(end, b)
    if e < 0:
        return None
    return b, e


# ------------------------------------------------------------------------------------------- test


class NodeInterfaces(unittest.TestCase):
    def setUp(self):
        self.params_file = rospy.get_param("~params_file")
        self.docs = rospy.get_param("~docs")
        self.nodes = rospy.get_param("~nodes")
        self.settle_s = float(rospy.get_param("~settle_s", 2.0))
        self.wait_s = float(rospy.get_param("~wait_s", 480.0))
        self.master = rosgraph.Master(rospy.get_name())

    def tearDown(self):
        try:
            os.remove(self.params_file)
        except OSError:
            pass

    def snapshot(self, node, state, types):
        subs, pubs, srvs = own_interface(node, *registrations(state, node))
        subs, pubs, actions = split_actions(subs, pubs, types)
        name = Names(node)
        snap = {"ns": node, "subs": [], "pubs": [], "srvs": [], "actions": []}
        for t in subs:
            snap["subs"].append((name(t), "`%s` (`%s`)" % (name(t), types.get(t, "?"))))
        last = None
        for t in pubs:
            latched = None
            for attempt in range(5):
                try:
                    latched = is_latched(self.master, node, t, rospy.get_name())
                    break
                except (OSError, RuntimeError, xmlrpc.client.Error, rosgraph.MasterError) as e:
                    last = e
                    time.sleep(1.0)
            self.assertIsNotNone(latched, "could not ask %s whether %s is latched: %s" % (node, t, last))
            snap["pubs"].append((name(t), "`%s` (`%s`%s)" % (name(t), types.get(t, "?"), ", latched" if latched else "")))
        for s in srvs:
            srv_type = None
            for attempt in range(5):
                try:
                    srv_type = rosservice.get_service_type(s)
                    if srv_type:
                        break
                except rosservice.ROSServiceException as e:
                    last = e
                time.sleep(1.0)
            self.assertTrue(srv_type, "no type for %s's service %s" % (node, s))
            snap["srvs"].append((name(s), "`%s` (`%s`)" % (name(s), srv_type)))
        for base, role, action_type in actions:
            snap["actions"].append((name(base), "`%s` (action %s, `%s`)" % (name(base), role, action_type)))
        return snap

    def wait_for_nodes(self):
        """{node: snapshot} once every node is up: it has described its parameters, its main thread
        has been asleep (in ros::spin, waitForShutdown or a wait: its constructor is done) and its
        registrations unchanged for settle_s. Fails naming the nodes not up after wait_s.

        Not a call to the node's ~get_loggers / ~set_logger_level: roscpp answers those from an
        internal thread, also while the constructor still runs (and with Debian's log4cxx a node
        asked for its loggers segfaults when a subscriber later disconnects)."""
        snaps, seen, asleep_since, pids = {}, {}, {}, {}
        deadline = time.monotonic() + self.wait_s
        while len(snaps) < len(self.nodes):
            now = time.monotonic()
            pending = [e["node"] for e in self.nodes if e["node"] not in snaps]
            if now > deadline:
                self.fail(
                    "not up within %.0f s (no parameters described, still computing, or its topics kept changing): "
                    "%s; see the nodes' output above (a bad parameter stops a node with a FATAL line)"
                    % (self.wait_s, ", ".join(pending))
                )
            described = read_params(self.params_file)
            state = self.master.getSystemState()
            for node in pending:
                regs = registrations(state, node)
                if seen.get(node, (None,))[0] != regs:
                    seen[node] = (regs, now)
                if pids.get(node) is None:  # not registered yet at the last look: ask again
                    pids[node] = node_pid(self.master, node)
                sleeping = pids[node] is not None and main_thread_sleeps(pids[node])
                if not sleeping or node not in described:
                    asleep_since.pop(node, None)
                    continue
                asleep_since.setdefault(node, now)
                if now - max(seen[node][1], asleep_since[node]) >= self.settle_s:
                    types = dict(self.master.getTopicTypes())
                    snaps[node] = self.snapshot(node, state, types)
                    rospy.loginfo("node_interfaces: %s is up", node)
            time.sleep(0.25)
        return snaps

    def test_docs_match_the_nodes(self):
        snaps = self.wait_for_nodes()
        params = read_params(self.params_file)
        for entry in self.nodes:
            self.assertIn(
                entry["node"],
                params,
                "%s read no parameter through ParamReader (or TOPO_DESCRIBE_PARAMS=%s was not written)"
                % (entry["node"], self.params_file),
            )
        blocks = {}
        for entry in self.nodes:
            snaps[entry["node"]]["about"] = entry.get("about", "")
            blocks.setdefault(entry["doc"], []).append((entry.get("mode"), snaps[entry["node"]]))
        paths = Paths()
        meanings = launch_docs(os.path.join(paths.package, "launch"))
        rendered = {}
        for doc, instances in blocks.items():
            paths.used = set()
            rendered[doc] = render(doc, instances, params, paths, meanings.get(doc, {}))

        if not os.path.exists(self.docs) or any(block_span(open(self.docs).read(), d) is None for d in rendered):
            for doc in sorted(rendered):
                sys.stderr.write("---- generated block of %s ----\n%s" % (doc, rendered[doc]))
        self.assertTrue(
            os.path.exists(self.docs), "%s does not exist: create it with the markers %s" % (self.docs, markers("NODE"))
        )
        with open(self.docs, encoding="utf-8") as f:
            text = f.read()
        missing = [doc for doc in rendered if block_span(text, doc) is None]
        self.assertFalse(
            missing,
            "%s lacks the markers of %s: add\n%s"
            % (self.docs, ", ".join(missing), "\n".join("%s\n%s" % markers(d) for d in missing)),
        )
        if update_requested():
            for doc in sorted(rendered, key=lambda d: -block_span(text, d)[0]):  # from the end: spans stay valid
                b, e = block_span(text, doc)
                text = text[:b] + rendered[doc] + text[e:]
            with open(self.docs, "w", encoding="utf-8") as f:
                f.write(text)
            rospy.loginfo("node_interfaces: rewrote %s between the markers of %s", self.docs, ", ".join(rendered))
        stale = []
        for doc in sorted(rendered):
            b, e = block_span(text, doc)
            if text[b:e] != rendered[doc]:
                stale.append(doc)
                diff = difflib.unified_diff(
                    text[b:e].splitlines(True), rendered[doc].splitlines(True), "docs/nodes.md " + doc, "the nodes"
                )
                sys.stderr.write("".join(diff))
        if stale:
            self.fail(
                "%s is stale for %s (the nodes read or advertise something else than it says; the differences are "
                "above): regenerate it with\n  %s\nand commit docs/nodes.md." % (self.docs, ", ".join(stale), REGENERATE)
            )


if __name__ == "__main__":
    rospy.init_node("node_interfaces_test")
    rostest.rosrun(PKG, "node_interfaces", NodeInterfaces, sys.argv)
