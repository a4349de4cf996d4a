#!/usr/bin/env python3
"""Every command in README.md's and docs/cli.md's ```bash blocks runs.

Extracts the fenced ```bash blocks of README.md, then of docs/cli.md (DOCS; continuation lines
joined, comment-only lines dropped) and runs each command, in that order, in one scratch directory
laid out like the repository root (build -> the build directory, ../shared -> the shared data beside
the repository), after `source BUILD/devel/setup.bash` and the earlier `source`/`export` lines (as in
the reader's shell session: README's first, then the manual's). A command must exit 0 within its time
limit; the failure names the file, the line and the command and shows its output.

- Long-running commands that serve until stopped (`roslaunch ...`) run until they have done their
  first job (LONG_RUNNING: a message on a topic), must not log an error, and are then stopped with
  SIGINT.
- Commands that cannot run here are in SKIP, each with the reason and where the same thing is
  tested instead. A command that is neither run nor in SKIP fails the test, so a new command in
  either file needs a decision.

Run by rostest (test/ros/readme_commands.test.in), so `roslaunch` and `rosrun` find the rostest's
master: args `--build BUILD_DIR`.
"""
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
import unittest

import rospy
import rostest

PKG = "topo_gaussian"
HERE = os.path.dirname(os.path.abspath(__file__))
SOURCE = os.path.normpath(os.path.join(HERE, "..", ".."))
README = os.path.join(SOURCE, "README.md")
# The files whose ```bash blocks run, in this order (all in one scratch directory and one session).
DOCS = [README, os.path.join(SOURCE, "docs", "cli.md")]

# Commands not run here, by prefix, with the reason (and where the same thing is tested).
SKIP = {
    "make demo": "builds and runs the whole lab loop for minutes; the same launches and client run in "
                 "test/ros/demo_tumbler.test.in and test/ros/finger_rig.test.in",
    "make test": "runs every test, this one included (recursion)",
    "roslaunch topo_gaussian demo.launch gui:=true": "opens rviz (needs a display); demo.launch runs headless in "
                                                     "test/ros/demo_tumbler.test.in and rviz in rviz_screenshot.test.in",
    "roslaunch topo_gaussian tumbler_rig.launch twin:=false": "needs the lab's camera and /data/doll.ply",
    "roslaunch topo_gaussian soft_finger_rig.launch gui:=true": "opens rviz (needs a display); the launch runs "
                                                                "headless in test/ros/finger_rig.test.in",
    "rosservice call /interior_inference/infer": "needs interior_inference running with a volume; the same "
                                                 "~infer call succeeds in test/ros/rviz_screenshot.test.in",
    "rosrun topo_gaussian infer_client": "needs the lab loop running (demo.launch); it runs in "
                                         "test/ros/demo_tumbler.test.in",
}

# Commands that serve until stopped: (prefix, topic whose first message means "started cleanly",
# seconds to wait for it).
LONG_RUNNING = [
    ("roslaunch topo_gaussian cloud_ingest.launch", "/volume", 120.0),
]

COMMAND_TIMEOUT_S = 900.0


def readme_commands(path):
    """The commands of the ```bash blocks of one Markdown file, in order, as (line number, command)."""
    commands = []
    with open(path, encoding="utf-8") as f:
        lines = f.read().split("\n")
    in_block = False
    pending, pending_line = "", 0
    for number, line in enumerate(lines, start=1):
        if not in_block:
            in_block = line.strip() == "```bash"
            continue
        if line.strip() == "```":
            in_block = False
            continue
        text = line.strip()
        if not pending and (not text or text.startswith("#")):
            continue
        if not pending:
            pending_line = number
        if text.endswith("\\"):
            pending += text[:-1] + " "
            continue
        commands.append((pending_line, re.sub(r"\s+", " ", pending + text).strip()))
        pending = ""
    return commands


def matches(command, prefix):
    return command == prefix or command.startswith(prefix + " ")


def build_dir():
    if "--build" in sys.argv:
        return os.path.abspath(sys.argv[sys.argv.index("--build") + 1])
    return os.path.join(SOURCE, "build")


def where(path, line):
    """`README.md:12` or `docs/cli.md:40`: the file relative to the repository, and the line."""
    return "%s:%d" % (os.path.relpath(path, SOURCE), line)


class ReadmeCommands(unittest.TestCase):
    scratch = None
    session = []  # the `source` and `export` lines run so far: every later command runs after them

    @classmethod
    def setUpClass(cls):
        cls.build = build_dir()
        cls.root = tempfile.mkdtemp(prefix="topo_readme_")
        cls.scratch = os.path.join(cls.root, "topo_gaussian")
        os.mkdir(cls.scratch)
        os.symlink(cls.build, os.path.join(cls.scratch, "build"))
        shared = os.path.normpath(os.path.join(SOURCE, "..", "shared"))
        cls.has_shared = os.path.isdir(os.path.join(shared, "data"))
        if cls.has_shared:
            os.symlink(shared, os.path.join(cls.root, "shared"))

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.root, ignore_errors=True)

    def shell(self, command):
        """bash running `command` after the environment and the session so far, one line each (a
        README line may end in a # comment)."""
        setup = os.path.join(self.build, "devel", "setup.bash")
        lines = ['source "%s"' % setup, 'cd "%s"' % self.scratch] + self.session
        script = "".join("%s\n[ $? -eq 0 ] || exit 97\n" % line for line in lines)
        return ["bash", "-c", "set -o pipefail\n" + script + command + "\n"]

    def run_command(self, path, line, command):
        at = where(path, line)
        for prefix, reason in SKIP.items():
            if matches(command, prefix):
                self.skipTest("%s `%s`: %s" % (at, command, reason))
        if "../shared/" in command and not self.has_shared:
            self.skipTest("%s `%s`: ../shared/data is not there (CI always has it)" % (at, command))
        for prefix, topic, wait_s in LONG_RUNNING:
            if matches(command, prefix):
                return self.run_until_started(at, command, topic, wait_s)
        start = time.time()
        try:
            p = subprocess.run(self.shell(command), stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                               timeout=COMMAND_TIMEOUT_S, start_new_session=True)
        except subprocess.TimeoutExpired as e:
            out = (e.output or b"").decode(errors="replace")
            self.fail("%s `%s` ran longer than %.0f s; output:\n%s" % (at, command, COMMAND_TIMEOUT_S, out[-4000:]))
        out = p.stdout.decode(errors="replace")
        if p.returncode == 0 and re.match(r"(source|export) ", command):
            ReadmeCommands.session.append(command)
        self.assertEqual(p.returncode, 0, "%s `%s` exited %d after %.1f s; output:\n%s" %
                         (at, command, p.returncode, time.time() - start, out[-4000:]))
        print("%s `%s`: %.1f s" % (at, command, time.time() - start))

    def run_until_started(self, what, command, topic, wait_s):
        """Starts a serving command, waits for its first message on `topic`, stops it with SIGINT."""
        from rospy import AnyMsg
        got = threading.Event()
        sub = rospy.Subscriber(topic, AnyMsg, lambda _msg: got.set())
        log = tempfile.TemporaryFile()
        p = subprocess.Popen(self.shell(command), stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
        try:
            deadline = time.time() + wait_s
            while time.time() < deadline and not got.is_set() and p.poll() is None:
                time.sleep(0.2)
            alive = p.poll() is None
        finally:
            if p.poll() is None:
                os.killpg(p.pid, signal.SIGINT)
                try:
                    p.wait(30)
                except subprocess.TimeoutExpired:
                    os.killpg(p.pid, signal.SIGKILL)
                    p.wait()
            sub.unregister()
        log.seek(0)
        out = log.read().decode(errors="replace")
        what = "%s `%s`" % (what, command)
        self.assertTrue(alive, "%s exited %s before its first message on %s; output:\n%s" %
                        (what, p.returncode, topic, out[-4000:]))
        self.assertTrue(got.is_set(), "%s published nothing on %s within %.0f s; output:\n%s" %
                        (what, topic, wait_s, out[-4000:]))
        errors = [l for l in out.splitlines() if "[ERROR]" in l or "[FATAL]" in l or "has died" in l]
        self.assertEqual(errors, [], "%s logged errors:\n%s" % (what, "\n".join(errors)))


def add_tests():
    # unittest runs a class's tests in the order of their names: the index keeps the files' order
    index = 0
    found = {}
    for path in DOCS:
        commands = readme_commands(path) if os.path.isfile(path) else []
        found[path] = commands
        tag = re.sub(r"[^A-Za-z0-9]+", "_", os.path.splitext(os.path.relpath(path, SOURCE))[0])
        for line, command in commands:
            slug = re.sub(r"[^A-Za-z0-9]+", "_", command)[:50].strip("_")
            name = "test_%03d_%s_line%d_%s" % (index, tag, line, slug)
            setattr(ReadmeCommands, name, lambda self, p=path, l=line, c=command: self.run_command(p, l, c))
            index += 1

    def test_found_commands(self):
        for path, least in ((README, 5), (DOCS[1], 5)):
            self.assertGreaterEqual(len(found[path]), least,
                                    "%s's ```bash blocks: %r" % (os.path.relpath(path, SOURCE), found[path]))

    ReadmeCommands.test_found_commands = test_found_commands


add_tests()

if __name__ == "__main__":
    rospy.init_node("readme_commands_test", anonymous=True)
    rostest.rosrun(PKG, "readme_commands", ReadmeCommands)
