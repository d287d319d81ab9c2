"""Benchmarks that need both the robot's side and the world: ``solvers`` (every NLP solver
on the same recorded control problems, and the policies' rows) and ``decisions`` (a
controller's whole decision, closed loop, in the simulator). Used by ``gpcnav bench``."""
