"""Online walking: a generator that streams whole-body references at the control rate."""

from cocomopl.online.commands import VelocityCommand, command_range, step_period
from cocomopl.online.generator import Reference, WalkingGenerator, grid_of

__all__ = ["Reference", "VelocityCommand", "WalkingGenerator", "command_range", "grid_of", "step_period"]
