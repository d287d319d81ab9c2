"""The peers: the planners a user would pick instead of gpcnav, wired to the Policy protocol
(``reset()``, ``decide(observation) -> ControlDecision``, ``sample_time_s``) so that the
simulator, ``evaluate``, ``compare``, ``bench`` and the Gymnasium environment run them as
they run the GPC. Each comes from a well-kept library; nothing here re-implements one.

- ``navground_peer``: ORCA, HRVO and the social force model, navground's behaviours with its
  two-wheel differential-drive kinematics (navground is a core dependency);
- ``mppi_peer``: MPPI from pytorch-mppi on the GPC's own cost (torch: the ``train`` extra;
  import it only when asked for).

There is no DWA: no maintained DWA implementation is published on PyPI (docs/peers.md).
``gpcnav.controllers`` makes them by name.
"""
