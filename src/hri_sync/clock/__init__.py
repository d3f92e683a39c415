"""The clock: the time server's global timeline on every host (no ROS
outside the ``ros_*`` shells).

``model``: NTP offset estimation and the drift-corrected clock model;
``ntp``: an SNTP client; ``sync``: keeping a host's global clock against
the time server, with holdover; ``host_clock``: the system clock against
the time server (chrony); ``truth`` and ``skew``: the true clock and start
skew measured against it; ``health``: the clock on /diagnostics.
``ros_synced_clock`` and ``ros_clock_state`` are its ROS shell.
"""
