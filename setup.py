"""Packaging glue: map the repository's top-level folders into the one ``kinegym.*`` namespace.

The metadata lives in ``pyproject.toml``; this file only says where each package's source
lies, because the repository keeps ``envs/``, ``agents/``, ``kinematics/``, ``vision/`` and
``configs/`` at its top level while an installed kinegym holds them as ``kinegym.envs``,
``kinegym.agents``, ... (a user's own ``configs/`` or ``agents/`` folder then never shadows
ours). Packages are discovered, never listed by hand: every folder with an ``__init__.py``
under one of the roots below becomes ``kinegym.<its dotted path>``. The same mapping serves
editable installs (setuptools' editable finder) and wheels.
"""

from setuptools import find_packages, setup

#: repository folder -> installed package
ROOTS = ("kinematics", "vision", "envs", "agents", "configs")

package_dir = {"kinegym": "kinegym"}
packages = find_packages(include=["kinegym", "kinegym.*"])
for root in ROOTS:
    package_dir[f"kinegym.{root}"] = root
    packages += [f"kinegym.{name}" for name in find_packages(include=[root, f"{root}.*"])]

setup(
    packages=sorted(packages),
    package_dir=package_dir,
    package_data={
        "kinegym.configs": ["**/*.yaml"],
        "kinegym.agents": ["data/*.npz"],
        "kinegym.vision": ["data/*.npz", "data/*.json"],
        "kinegym.zoo": ["*.yml"],
    },
    exclude_package_data={"kinegym": ["assets/*"]},
)
