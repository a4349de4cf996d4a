"""topo_gaussian from Python: the inference, the tracker and a rig as plain calls (docs/python.md).

    import rospy, topo_gaussian
    rospy.init_node("my_lab")
    r = topo_gaussian.infer("tumbler", object_id="doll", max_iterations=20)
    print(r.mass, r.com, r.inertia, r.identifiability, r.next_experiment)

The generated messages live beside this module (topo_gaussian.msg, topo_gaussian.srv); the client is
imported on first use, so `import topo_gaussian.msg` does not load actionlib.
"""

_CLIENT_NAMES = ("infer", "track", "perform", "action_client", "InteriorResult", "PerformResult", "TopoClientError", "cloud_arrays")


def __getattr__(name):
    if name in _CLIENT_NAMES:
        from topo_gaussian import client

        return getattr(client, name)
    raise AttributeError("module 'topo_gaussian' has no attribute '%s'" % name)
