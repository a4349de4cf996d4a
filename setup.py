# The Python client module topo_gaussian (src/topo_gaussian), installed by catkin_python_setup():
# catkin merges it with the generated messages (topo_gaussian.msg, topo_gaussian.srv) into one package.
from catkin_pkg.python_setup import generate_distutils_setup
from setuptools import setup

setup(**generate_distutils_setup(packages=["topo_gaussian"], package_dir={"": "src"}))
