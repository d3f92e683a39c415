"""People in view: other trackers' skeletons as hri_sync/Skeleton
(``adapters``), the joint maps of the formats (``joint_maps``), the
participant zone (``participant``) and REP 155 bodies out (``rep155``).
No ROS."""
