"""Install the hri_sync Python package (catkin calls this)."""
from setuptools import setup
from catkin_pkg.python_setup import generate_distutils_setup

setup(**generate_distutils_setup(
    packages=['hri_sync', 'hri_sync.timing', 'hri_sync.dance_off',
              'hri_sync.robot', 'hri_sync.tools', 'hri_sync.ros',
              'hri_sync.people'],
    package_dir={'': 'src'},
))
