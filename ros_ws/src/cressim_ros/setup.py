"""ament_python package of the twin node. The engine (cressim), torch and the robot model come
from the Python environment (the project's .venv), not from ROS packages."""
from setuptools import setup

package_name = "cressim_ros"

setup(
    name=package_name,
    version="0.1.0",
    packages=[package_name],
    data_files=[
        ("share/ament_index/resource_index/packages", [f"resource/{package_name}"]),
        (f"share/{package_name}", ["package.xml"]),
    ],
    install_requires=["setuptools"],
    zip_safe=True,
    maintainer="CRESSim",
    maintainer_email="cressim@example.org",
    description="ROS 2 digital twin of the dVRK PSM on the CRESSim engine",
    license="MIT",
    entry_points={"console_scripts": ["cressim_twin = cressim_ros.twin_node:main"]},
)
