"""The planner's optimisation problem, built once in CasADi and kept apart from the solvers
that solve it (rockit's and acados's split): ``cost`` (the NLP: the paper's cost over the
wheel-speed increments, its parameters and constraints) and ``selection`` (which obstacles
enter the NLP's slots and parameter vector, shared by the planner and the labeller).

Nothing is imported here: ``cost`` needs CasADi, ``selection`` does not.
"""
