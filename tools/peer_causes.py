"""The development runs behind docs/peers.md, "The peers as navground runs them": gpcnav's
navground peers with one candidate difference changed at a time ("knobs"), and the same
behaviours inside navground's simulator (gpcnav.navground_twin), on scenario files or a suite.

Knobs of the ``peer`` side (an investigation tool: the knobs reach into the simulator's truth,
which no controller of gpcnav may do):

- ``exact``: the neighbours' true positions and their velocity over the last 0.1 s (what
  navground gives its behaviours) instead of the EKF's;
- ``point``: navground's point target ``Target.Point(goal)`` instead of its path following;
- ``noacc``: no wheel-acceleration limit on the robot (navground's ``2WDiff``);
- ``dyn``: the acceleration limit by navground's ``2WDiffDyn`` (``moi`` 2) inside the behaviour
  instead of the adapter's scaling;
- ``cmdtwist``: the behaviour told its last command as ``actuated_twist``;
- ``noise=X``: the scenario's position noise set to X m;
- ``ekfq=F``: the EKF's speed, heading and turn noise times F;
- ``clear``: also print the median smallest clearance.

The ``twin`` side takes :class:`gpcnav.navground_twin.TwinSettings` fields; behaviours
``GpcnavPeerHRVO`` and ``GpcnavPeerORCA`` run gpcnav's own adapters inside navground's
simulator (through the GPC plugin's machinery: navground's exact positions, the adapter's EKF).

Usage (one JSON argument)::

    python tools/peer_causes.py '{"side":"peer","kind":"orca","files":"out/dev-blind/*.toml","n":200,"knobs":["exact"],"kw":{"time_horizon_s":5}}'
    python tools/peer_causes.py '{"side":"twin","suite":{"name":"circle-crossing","seed":100},"n":200,"kw":{"behaviour":"HRVO"}}'
"""
import sys, json, math, glob
from dataclasses import replace
from concurrent.futures import ProcessPoolExecutor
import numpy as np
from scenarios import load_scenario
from scenarios.suites import Suite
from scenarios.simulator import Episode
from gpcnav.peers.navground_peer import NavgroundPeer, OrcaSettings, HrvoSettings
from gpcnav.navground_twin import run_twin, TwinSettings
from navground import core


def _register_plugin_peers():
    """gpcnav's own navground adapters as navground behaviours (the split test)."""
    global _PLUGIN_PEERS
    if _PLUGIN_PEERS:
        return
    from gpcnav.navground_plugin import GPCBehavior

    class _PeerBase(GPCBehavior):
        def controller_spec(self):
            from gpcnav.controllers import ControllerSpec
            return ControllerSpec(self.controller_name)

    class PeerHRVO(_PeerBase, name="GpcnavPeerHRVO"):
        controller_name = "hrvo"

    class PeerORCA(_PeerBase, name="GpcnavPeerORCA"):
        controller_name = "orca"

    _PLUGIN_PEERS = (PeerHRVO, PeerORCA)


_PLUGIN_PEERS = ()


def scenario(item):
    if isinstance(item, str):
        return load_scenario(item)
    name, i, seed, movers = item
    return Suite(name, count=i + 1, seed=seed, movers=movers).scenario(i)

class Peer(NavgroundPeer):
    """knobs: exact (true neighbour velocities and positions), point (point target), noacc (no accel limit)"""
    def __init__(self, settings, robot, knobs, episode_ref):
        self.knobs = knobs; self.ep = episode_ref
        super().__init__(settings, robot)
    def _set_target(self, reference):
        if "point" not in self.knobs:
            return super()._set_target(reference)
        b = self._behaviour
        b.optimal_speed = reference.speed_mps
        b.max_speed = self.robot.max_wheel_speed_mps
        b.target = core.Target.Point(np.asarray(reference.end_pose[:2], float), self.settings.goal_tolerance_m)
        self._reference = reference
    def neighbours(self, observation):
        if "exact" not in self.knobs:
            return super().neighbours(observation)
        ep = self.ep[0]; t = ep.t_s
        pos = ep.world.positions(t); vel = ep.world.velocities(t + 1e-9)
        return [core.Neighbor(pos[j], float(ep.world.radii[j]), vel[j], j) for j in range(len(pos))]

class DynPeer(Peer):
    def reset(self):
        super().reset()
        if "dyn" in self.knobs:
            kin = core.Kinematics.make_type("2WDiffDyn")
            kin.set("wheel_axis", self.robot.wheel_base_m); kin.max_speed = self.robot.max_wheel_speed_mps
            kin.set("max_acceleration", self.robot.max_wheel_accel_mps2); kin.set("moi", 2.0)
            self._behaviour.kinematics = kin; self._kinematics = kin
        self._last_cmd = None
        for k in self.knobs:
            if k.startswith("ekfq="):
                from dataclasses import replace as rp
                from casadi_gpc.estimation.ekf import EKFSettings
                from casadi_gpc.estimation.tracking import TrackBank
                f = float(k[5:]); T = self.settings.sample_time_s
                base = EKFSettings().for_sample_time(T)
                st = rp(base, speed_noise_mps2=base.speed_noise_mps2 * f, heading_noise_rad=base.heading_noise_rad * f,
                        turn_noise_rad=base.turn_noise_rad * f)
                self.bank = TrackBank(T, st, self.counters)
    def decide(self, observation):
        import math
        from casadi_gpc.types import ControlDecision
        b, r, st = self._behaviour, self.robot, observation.robot
        if observation.reference is not self._reference:
            self._set_target(observation.reference)
        speed = 0.5 * (st.v_right_mps + st.v_left_mps)
        twist = core.Twist2((speed * math.cos(st.heading_rad), speed * math.sin(st.heading_rad)),
                            (st.v_right_mps - st.v_left_mps) / r.wheel_base_m, frame=core.Frame.absolute)
        b.position = np.array((st.x_m, st.y_m)); b.orientation = st.heading_rad; b.twist = twist
        if "cmdtwist" in self.knobs and self._last_cmd is not None:
            b.actuated_twist = self._last_cmd
        else:
            b.actuated_twist = twist
        b.environment_state.neighbors = self.neighbours(observation)
        b.environment_state.static_obstacles = [core.Disc(np.asarray(s.position_m, dtype=float), s.radius_m) for s in observation.static]
        cmd = b.compute_cmd(self.sample_time_s, core.Frame.relative, True)
        self._last_cmd = b.to_frame(cmd, core.Frame.absolute) if "cmdtwist" in self.knobs else None
        left, right = self._kinematics.wheel_speeds(cmd)
        if "dyn" in self.knobs:
            vr, vl = right, left
        else:
            from gpcnav.peers.navground_peer import limit_wheel_change
            vr, vl = limit_wheel_change((st.v_right_mps, st.v_left_mps), (right, left), r.max_step_change_mps(self.sample_time_s))
        return ControlDecision(float(vr), float(vl), reason="x")

def peer_run(args):
    item, kind, kw, knobs = args
    sc = scenario(item)
    S = OrcaSettings if kind == "orca" else HrvoSettings
    ep_ref = [None]
    peer = DynPeer(S(**kw), sc.robot, knobs, ep_ref)
    if knobs and knobs[0].startswith("noise="):
        sc = replace(sc, sensing=replace(sc.sensing, position_noise_std_m=float(knobs[0][6:])))
    if "noacc" in knobs:
        sc = replace(sc, robot=replace(sc.robot, max_wheel_accel_mps2=1e6))
        peer.robot = sc.robot
    peer.reset()
    ep = Episode(sc, peer.sample_time_s, kind); ep_ref[0] = ep
    while not ep.done:
        ep.step(peer.decide(ep.observation()))
    return ep.log.outcome if not knobs or 'clear' not in knobs else (ep.log.outcome, ep.log.min_clearance_m)

def twin_run(args):
    item, kw = args
    _register_plugin_peers()
    return run_twin(scenario(item), TwinSettings(**kw)).outcome

def summary(outs):
    return {o: outs.count(o) for o in ("reached_goal", "collided", "timed_out")}

if __name__ == "__main__":
    spec = json.loads(sys.argv[1])
    n = spec.get("n", 40)
    if "suite" in spec:
        s = spec["suite"]
        items = [(s["name"], i, s.get("seed", 100), s.get("movers", 5)) for i in range(n)]
    else:
        items = sorted(glob.glob(spec["files"]))[:n]
    with ProcessPoolExecutor(2) as pool:
        if spec["side"] == "peer":
            outs = list(pool.map(peer_run, [(f, spec["kind"], spec.get("kw", {}), spec.get("knobs", [])) for f in items]))
        else:
            outs = list(pool.map(twin_run, [(f, spec.get("kw", {})) for f in items]))
    if outs and isinstance(outs[0], tuple):
        print("median min clearance", float(np.median([c for _, c in outs])))
        outs = [o for o, _ in outs]
    coll = [i for i, o in enumerate(outs) if o == "collided"]
    print(json.dumps(spec), summary(outs), "collided idx:", coll, flush=True)
