"""What the fuse_bag system tests share: the three views' poses (as in
test/system/fuse_bag_live.launch) and ``fuse_bag`` run as a user runs
it."""
import subprocess

POSES = {'left': '3.3 0.4 1.0 -3.02', 'right': '0.5 -3.3 1.0 1.72',
         'back': '-2.3 2.3 1.0 -0.785'}


def fuse_bag(*args):
    """``rosrun hri_sync fuse_bag ARGS`` (its CompletedProcess)."""
    return subprocess.run(['rosrun', 'hri_sync', 'fuse_bag'] + list(args),
                          capture_output=True, text=True, timeout=300)
