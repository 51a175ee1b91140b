"""Simulation control over ROS 2 with the `simulation_interfaces` services (ros_ws/src/
simulation_interfaces): play, pause, stop, step, reset, and the entities' states. docs/twin.md,
"Simulation control", lists the services and what each scope and state means here.

Paused (or stopped), the twin's tick neither steps the engine nor publishes: its clock and its
topics wait. StepSimulation then runs whole ticks (physics, publishing, sensors) on request.
Entities: each env's arm (its base, fixed by the scene) and, where the scene has one, its needle.
"""
from __future__ import annotations

import math
import re

import numpy as np
from simulation_interfaces.msg import Result, SimulationState, SimulatorFeatures
from simulation_interfaces.srv import (GetEntities, GetEntityState, GetSimulationState, GetSimulatorFeatures,
                                       ResetSimulation, SetEntityState, SetSimulationState, StepSimulation)

import torch

from cressim.robots.kinematics import matrix_to_pose7, pose7_to_matrix

from .topics import env_frame_prefix, fill_pose

MAX_STEPS = 100_000  # per StepSimulation call: the node serves nothing else while it steps

FEATURES = (SimulatorFeatures.SIMULATION_RESET, SimulatorFeatures.SIMULATION_RESET_TIME,
            SimulatorFeatures.SIMULATION_RESET_STATE, SimulatorFeatures.SIMULATION_STATE_GETTING,
            SimulatorFeatures.SIMULATION_STATE_SETTING, SimulatorFeatures.SIMULATION_STATE_PAUSE,
            SimulatorFeatures.STEP_SIMULATION_SINGLE, SimulatorFeatures.STEP_SIMULATION_MULTIPLE,
            SimulatorFeatures.ENTITY_STATE_GETTING, SimulatorFeatures.ENTITY_STATE_SETTING)


def _result(response, code: int, message: str = ""):
    response.result = Result(result=code, error_message=message)
    return response


class SimulationControl:
    def __init__(self, node):
        self.node = node
        self.state = SimulationState.STATE_PLAYING  # the twin starts playing, as the dVRK's console does
        arms = node.arms
        self.entities = {}  # name -> (env, "arm" | "needle")
        for env in range(arms.num_envs):  # a cart's rows are its PSMs, by name
            prefix = env_frame_prefix(env, arms.num_envs)
            self.entities[f"{node.prefixes[env]}{node.arm_names[env]}"] = (env, "arm")
            if arms.instrument("needle") is not None:
                self.entities[f"{prefix}needle"] = (env, "needle")
        self.handles = [node.create_service(t, name, handler) for t, name, handler in (
            (GetSimulatorFeatures, "get_simulator_features", self._features),
            (GetSimulationState, "get_simulation_state", self._get_state),
            (SetSimulationState, "set_simulation_state", self._set_state),
            (StepSimulation, "step_simulation", self._step),
            (ResetSimulation, "reset_simulation", self._reset),
            (GetEntities, "get_entities", self._get_entities),
            (GetEntityState, "get_entity_state", self._get_entity_state),
            (SetEntityState, "set_entity_state", self._set_entity_state))]

    @property
    def running(self) -> bool:
        return self.state == SimulationState.STATE_PLAYING

    # ------------------------------------------------------------------ simulation
    def _features(self, request, response):
        response.features.features = list(FEATURES)
        response.features.custom_info = "cressim dVRK twin: docs/twin.md, 'Simulation control'"
        return response

    def _get_state(self, request, response):
        response.state.state = self.state
        return _result(response, Result.RESULT_OK)

    def _set_state(self, request, response):
        target, S = request.state.state, SimulationState
        if target not in (S.STATE_PLAYING, S.STATE_PAUSED, S.STATE_STOPPED):
            return _result(response, Result.RESULT_FEATURE_UNSUPPORTED,
                           f"state {target}: the twin plays, pauses and stops (quit by stopping the node)")
        if target == self.state:
            return _result(response, SetSimulationState.Response.ALREADY_IN_TARGET_STATE, "")
        if target == S.STATE_STOPPED:  # paused and reset to the start, clock included
            self._restart(clock=True)
        if target == S.STATE_PLAYING:
            self.node.resume()
        self.state = target
        return _result(response, Result.RESULT_OK)

    def _step(self, request, response):
        if self.state == SimulationState.STATE_PLAYING:
            return _result(response, Result.RESULT_OPERATION_FAILED,
                           "step_simulation: the simulation is playing; pause it first (set_simulation_state)")
        if not 1 <= request.steps <= MAX_STEPS:
            return _result(response, Result.RESULT_OPERATION_FAILED,
                           f"step_simulation: steps must be in [1, {MAX_STEPS}], got {request.steps}")
        for _ in range(request.steps):
            self.node.advance()
        if self.state == SimulationState.STATE_STOPPED:  # stepping starts a stopped simulation, paused
            self.state = SimulationState.STATE_PAUSED
        return _result(response, Result.RESULT_OK)

    def _reset(self, request, response):
        R = ResetSimulation.Request
        known = R.SCOPE_TIME | R.SCOPE_STATE | R.SCOPE_SPAWNED
        scope = known if request.scope in (R.SCOPE_DEFAULT, R.SCOPE_ALL) else request.scope
        if scope & ~known:
            return _result(response, Result.RESULT_FEATURE_UNSUPPORTED, f"scope {request.scope}: unknown bits")
        # nothing is spawned at run time: SCOPE_SPAWNED has nothing to remove
        self._restart(clock=bool(scope & R.SCOPE_TIME), state=bool(scope & R.SCOPE_STATE))
        return _result(response, Result.RESULT_OK)

    def _restart(self, *, clock: bool, state: bool = True):
        arms = self.node.arms
        if state:
            arms.restart(clock=clock)
            self.node.drop_held_answers()
        elif clock:
            arms.sim_ns, arms.ticks = 0, 0
        if clock:
            self.node.rewind()

    # ------------------------------------------------------------------ entities
    def _get_entities(self, request, response):
        f = request.filters
        if f.categories or f.tags.tags or f.bounds.points:
            return _result(response, Result.RESULT_FEATURE_UNSUPPORTED,
                           "get_entities: filters by name only (no categories, tags or bounds)")
        try:
            pattern = re.compile(f.filter)
        except re.error as exc:
            return _result(response, Result.RESULT_OPERATION_FAILED, f"get_entities: filter {f.filter!r}: {exc}")
        response.entities = [name for name in self.entities if pattern.search(name)]
        return _result(response, Result.RESULT_OK)

    def _entity(self, name: str, response):
        found = self.entities.get(name)
        if found is None:
            _result(response, Result.RESULT_NOT_FOUND, f"no entity {name!r}; entities: {', '.join(self.entities)}")
        return found

    def _get_entity_state(self, request, response):
        found = self._entity(request.entity, response)
        if found is None:
            return response
        env, kind = found
        arms, scene = self.node.arms, self.node.scene
        T = arms.instrument("needle").pose(arms, env) if kind == "needle" else pose7_to_matrix(
            np.array([*scene.base_position, *scene.base_rotation]))
        response.state.header.stamp = self.node.stamp()
        response.state.header.frame_id = "world"
        fill_pose(response.state.pose, matrix_to_pose7(torch.as_tensor(T, dtype=torch.float64)[None])[0].numpy())
        return _result(response, Result.RESULT_OK)

    def _set_entity_state(self, request, response):
        found = self._entity(request.entity, response)
        if found is None:
            return response
        env, kind = found
        s = request.state
        if kind == "arm":
            return _result(response, Result.RESULT_OPERATION_FAILED,
                           f"{request.entity}: an arm's base is placed by the scene file (arm.base_position); "
                           "set_base_frame sets the frame its poses are reported in")
        moving = [s.twist.linear, s.twist.angular, s.acceleration.linear, s.acceleration.angular]
        if (request.set_twist or request.set_acceleration) and any(abs(v.x) + abs(v.y) + abs(v.z) > 0 for v in moving):
            return _result(response, Result.RESULT_OPERATION_FAILED,
                           f"{request.entity}: the needle takes a pose (set at rest, out of the jaws: it falls from "
                           "there), not a twist or an acceleration")
        if s.header.frame_id not in ("", "world"):
            return _result(response, SetEntityState.Response.INVALID_POSE,
                           f"{request.entity}: frame_id {s.header.frame_id!r}: poses are set in 'world'")
        if request.set_pose:
            p, q = s.pose.position, s.pose.orientation
            values = [p.x, p.y, p.z, q.x, q.y, q.z, q.w]
            norm = math.sqrt(q.x ** 2 + q.y ** 2 + q.z ** 2 + q.w ** 2)
            if not all(math.isfinite(v) for v in values) or abs(norm - 1.0) > 1e-3:
                return _result(response, SetEntityState.Response.INVALID_POSE,
                               f"{request.entity}: the pose must be finite with a unit quaternion (|q| = {norm:.6g})")
            arms = self.node.arms
            arms.instrument("needle").set_pose(arms, env, pose7_to_matrix(np.array(values) / [1, 1, 1, norm, norm, norm, norm]))
        return _result(response, Result.RESULT_OK)

