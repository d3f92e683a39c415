"""The names of one system: what lives where, relative to its namespace.

A system (time server aside) is a *system namespace* ``NS`` (``/`` by
default, ``/lab1/`` when its launch files are pushed into
``<group ns="lab1">``):

- ``NS/control_module``, ``NS/decision_module`` and the protocol topics
  ``NS/sync_time``, ``NS/sync_ack``, ``NS/capture_data``,
  ``NS/round_status``, ``NS/client_result``, ``NS/decision``;
- each client's nodes in ``NS/<client_id>/`` (``cpm``, ``dpm``,
  ``sensor`` or ``tracker``) and its topics there (``clock_state``,
  ``capture_command``, ``skeleton``, ``captured``);
- the nodes that are a whole client (``NS/dj_rob``, ``NS/music``) and
  the robot's topics (``NS/odom``, ``NS/mobile_base/commands/*``).

A node finds ``NS`` from its own namespace: a client's node (one whose
namespace ends in its ``~client_id``) is in ``NS/<client_id>/``, any
other node in ``NS``.  ROS names have no ``..``, so a client's node
resolves the protocol topics here (``protocol_topic``), honouring the
remappings of the name as a ROS user writes it (``sync_time:=...`` on
that node) and of the resolved name (``/lab1/sync_time:=...``).
"""
import rosgraph.names
import rospy


def system_namespace_of(namespace, client_id=None):
    """The system namespace of a node in ``namespace`` (``'/lab1/left/'``)
    that serves client ``client_id`` (None: not a client's node)."""
    ns = rosgraph.names.make_global_ns(namespace or '/')
    parts = [p for p in ns.split('/') if p]
    if client_id and parts and parts[-1] == client_id:
        parts = parts[:-1]
    return '/' + ''.join(p + '/' for p in parts)


def resolve_in(system_ns, name, own_ns, mappings):
    """``name`` (relative) resolved in ``system_ns`` for a node in
    ``own_ns`` with the resolved remappings ``mappings``: a remapping of
    the name in the node's own namespace wins, then one of the resolved
    name."""
    if name.startswith('/') or name.startswith('~'):
        raise ValueError('%r: a relative name is needed' % name)
    own = rosgraph.names.ns_join(own_ns or '/', name)
    if own in mappings:
        return mappings[own]
    full = rosgraph.names.ns_join(system_ns, name)
    return mappings.get(full, full)


def system_namespace():
    """This node's system namespace (after ``rospy.init_node``)."""
    client_id = rospy.get_param('~client_id', None)
    return system_namespace_of(rospy.get_namespace(),
                               client_id if isinstance(client_id, str)
                               else None)


def protocol_topic(name):
    """A protocol topic (``'sync_time'``) or a topic of the system
    namespace (``'left/clock_state'``), fully resolved for this node."""
    return resolve_in(system_namespace(), name, rospy.get_namespace(),
                      rospy.names.get_resolved_mappings())


def client_topic(client_id, name):
    """Client ``client_id``'s topic ``name`` (``'clock_state'``): in
    ``NS/<client_id>/``."""
    return protocol_topic('%s/%s' % (client_id, name))
