"""The launch file of a bench's rounds (not installed; no rospy).

Time server, server (CM + DM) and participant ``a`` fed by a
``synthetic_sensor`` on the true clock; the bench adds its action
clients (``body``).  The launch takes ``ntp_port:=``.
"""

TEMPLATE = """<launch>
  <arg name="ntp_port"/>
  <include file="$(find hri_sync)/launch/timeserver.launch">
    <arg name="ntp_port" value="$(arg ntp_port)"/>
  </include>
  <include file="$(find hri_sync)/launch/server.launch">
    <arg name="clients" value="a,{clients}"/>
    <arg name="participants" value="a"/>
    <arg name="rounds" value="{rounds}"/>
    <arg name="dur" value="{dur}"/>
    <arg name="ntp_port" value="$(arg ntp_port)"/>
    <arg name="required" value="false"/>{server}
  </include>
  <node pkg="hri_sync" type="synthetic_sensor" name="reference">
    <param name="rate" value="50.0"/>
    <param name="signal" value="sine"/>
  </node>
  <include file="$(find hri_sync)/launch/client.launch">
    <arg name="client_id" value="a"/>
    <arg name="ntp_port" value="$(arg ntp_port)"/>
    <arg name="input" value="/reference/samples"/>
    <arg name="stamp_source" value="arrival"/>
  </include>
{body}
</launch>
"""


def round_launch(clients, rounds, dur, body, **server_args):
    """The launch XML: ``clients`` (their ids, comma-separated) besides
    ``a``, ``rounds`` of ``dur`` s, more server.launch args
    (``round_pause=1.0``) and the action clients' XML ``body``."""
    server = ''.join('\n    <arg name="%s" value="%s"/>' % kv
                     for kv in sorted(server_args.items()))
    return TEMPLATE.format(clients=clients, rounds=rounds, dur=dur,
                           server=server, body=body)
