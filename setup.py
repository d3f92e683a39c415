"""Install the hri_sync Python package (catkin calls this)."""
from setuptools import find_packages, setup
from catkin_pkg.python_setup import generate_distutils_setup

# Every package under src/ (a list by hand once left hri_sync.sensors out
# of the install space).
setup(**generate_distutils_setup(
    packages=find_packages('src'),
    package_dir={'': 'src'},
))
