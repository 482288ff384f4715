"""What every part of the simulator takes a robot to be: a disc of one radius.

The physics simulates the body (:class:`~tomosim.physics.PhysicsConfig`), the
planner inflates obstacles by it (:class:`~tomosim.exploration.planning.PlannerConfig`)
and the path follower's lidar guard keeps it clear
(:class:`~tomosim.exploration.controller.ControllerConfig`); each takes its default from
here, so that changing the robot changes all three.
"""

ROBOT_RADIUS_M = 0.2
"""Radius of a robot's round body, metres (a small indoor robot such as a TurtleBot)."""
