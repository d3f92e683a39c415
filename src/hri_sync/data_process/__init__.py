"""The data capture/process module (DPM): a sensor's samples in a
capture window on the global timeline, processed into a result (no ROS
outside the ``ros_*`` shells).

``dpm``: the DPM as a state machine; ``orders``: which capture commands
it takes (those the CM's order confirms); ``capture``: the capture window;
``mapping``: a sample's source time to the global timeline;
``processors``: a window's samples into a result; ``noise_floor``: the
processor's value when nothing moves; ``republish``: the captured samples'
way out; ``health``: its results on /diagnostics; ``ros_republisher``:
the republishing thread on ROS.
"""
