"""A DPM processor that wedges, for the fault matrix (fault_dpm_wedged):
the skeleton expressiveness, whose result waits while ``wedge_file``
exists, as a processor stuck in its computation would (the DPM process
alive, its processing held)."""
import os
import time

from hri_sync.dance_off.expressiveness import SkeletonExpressiveness


class WedgedExpressiveness(SkeletonExpressiveness):
    """SkeletonExpressiveness whose ``result`` waits while ``wedge_file``
    exists."""

    def __init__(self, wedge_file='', **params):
        super().__init__(**params)
        self.wedge_file = wedge_file

    def result(self):
        while self.wedge_file and os.path.exists(self.wedge_file):
            time.sleep(0.05)
        return super().result()
