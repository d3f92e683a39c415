"""Multi-sensor fusion of skeletons on the global clock (no ROS).

``frames``: sensor poses and the world frame; ``align``: a view's samples
interpolated to common instants; ``associate``: the same person across
views; ``fuse``: one joint from the views that see it, with a 95 % bound;
``calibration``: residuals between views, wrong poses, pose refinement;
``views``: each view's health; ``pipeline``: the fusion loop on an
injected clock.
"""
