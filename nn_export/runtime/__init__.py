"""What the deployed policy runs: numpy, onnxruntime and numba (the obstacle forecasts' and the
check's compiled loops, in :mod:`casadi_gpc`) only, never torch or CasADi.

Rooms: ``layouts`` (which inputs, in which order), ``situation`` (what the planner knows at
one instant), ``features`` (the input values of a situation), ``tracker`` (situations from
the stream of observations, with the planner's own EKF bank and reference clock) and
``policy`` (:class:`~nn_export.runtime.policy.OnnxPolicy`, behind the safety filter of
:mod:`casadi_gpc.safety`). Nothing is imported here: the features load without onnxruntime.
"""
