"""Install the hri_sync Python package (catkin calls this)."""
from setuptools import setup
from catkin_pkg.python_setup import generate_distutils_setup

setup(**generate_distutils_setup(
    packages=['hri_sync'],
    package_dir={'': 'src'},
))
