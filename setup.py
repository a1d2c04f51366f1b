# The build of `pip install --no-build-isolation .` (pyproject.toml): the
# project's CMake, configured for the Python module alone, its package
# installed (component python) where scikit-build collects it.
import re
from pathlib import Path

from skbuild import setup

version = re.search(r"project\(rocklab VERSION ([0-9.]+)", Path("CMakeLists.txt").read_text()).group(1)

setup(
    name="rocklab",
    version=version,
    description="The rocking-block laboratory's data and models in Python (C++ core)",
    license="BSD-3-Clause",
    packages=["rocklab"],
    package_dir={"rocklab": "python/rocklab"},
    python_requires=">=3.9",
    install_requires=["numpy"],
    cmake_args=[
        "-DROCKLAB_PYTHON_ONLY=ON",
        "-DROCKLAB_PYTHON_INSTALL_DIR=python",
    ],
    cmake_install_target="rocklab_install_python",
)
