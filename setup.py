"""The one thing pyproject.toml cannot say: the MuJoCo models live at the top level,
``sim/models/`` (as the design names them), and ship inside the wheel as the package
``rasc.sim.models`` (its files are package data: pyproject's
``[tool.setuptools.package-data]``). Everything else is in pyproject.toml."""

from setuptools import find_packages, setup

setup(packages=[*find_packages(include=["rasc", "rasc.*"]), "rasc.sim.models"],
      package_dir={"rasc.sim.models": "sim/models"})
