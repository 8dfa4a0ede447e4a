"""The paper's controller on any humanoid (docs/your-robot.md): lump a URDF or MJCF into a robot
file, scale the gains to it, run the paper's experiment on it.

    robot = lump_file("talos.urdf", keyframe=..., srdf=...)   # -> Robot
    robot.write("talos.toml")
    robot = load_robot("talos.toml")
"""
from .lump import lump_file
from .robotfile import Robot, RobotFileError, load_robot

__all__ = ["Robot", "RobotFileError", "load_robot", "lump_file"]
