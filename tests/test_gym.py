"""The gymnasium environment on both backends: the checker, determinism, rendering."""

from __future__ import annotations

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import sdc.gym  # noqa: F401  (registers the environment)
from scenarios.spec.scenario_spec import ScenarioSpec
from sdc.gym import ENV_ID, MAX_STEER_RAD, ObstacleAvoidanceEnv

pytestmark = pytest.mark.slow


@pytest.mark.parametrize("backend", ["sumo", "highway"])
def test_env_checker_passes_and_frames_render_without_a_display(backend, monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    env = gymnasium.make(ENV_ID, backend=backend, render_mode="rgb_array")
    check_env(env.unwrapped)
    obs, info = env.reset(seed=4)
    assert env.observation_space.contains(obs) and info["seed"] == 4
    frame = env.render()
    assert frame.ndim == 3 and frame.shape[2] == 3 and frame.dtype == np.uint8
    assert frame.std() > 5  # something drawn, not a blank (or black) frame
    env.close()


def rollout(env, seed: int, steps: int = 1000) -> list:
    rng = np.random.default_rng(0)
    env.reset(seed=seed)
    out = []
    for _ in range(steps):
        obs, reward, terminated, truncated, info = env.step(
            rng.uniform(-1, 1, 2).astype(np.float32))
        out.append((obs.tobytes(), reward, terminated, truncated, info["termination"]))
        if terminated or truncated:
            env.reset(seed=seed + len(out))
    return out


def test_a_random_policy_rollout_is_the_same_for_the_same_seed(lesson_plain):
    lesson_plain["lidar"]["noise_std_m"] = 0.02  # the seed draws the noise
    env = gymnasium.make(ENV_ID, spec=ScenarioSpec.from_plain(lesson_plain))
    first, again, other = rollout(env, 5), rollout(env, 5), rollout(env, 6)
    env.close()
    assert first == again
    assert first != other
    assert any(step[4] == "collision" for step in first)  # random steering finds edges


def test_observation_reward_and_termination_follow_the_documentation():
    env = ObstacleAvoidanceEnv()  # seed-lesson: the barrel 27 m ahead in the ego's lane
    obs, _ = env.reset(seed=1)
    beams, max_range = env.scenario.lidar.beams, env.scenario.lidar.max_range_m
    assert obs.shape == (beams + 3,)
    assert np.isclose(obs[beams + 2], 3.74)  # speed
    assert np.any(obs[:beams] == np.float32(max_range))  # no return: the max range
    rewards, info, terminated = [], {}, False
    while not terminated:  # straight on, no steering: into the barrel
        obs, reward, terminated, truncated, info = env.step(np.zeros(2, np.float32))
        rewards.append(reward)
        assert not truncated
    assert info["termination"] == "collision" and info["collision_with"] == "obstacle"
    assert rewards[-1] < -9.0  # the collision penalty
    assert all(0.0 < r < 0.1 for r in rewards[:-1])  # progress at 3.74 m/s x 0.064 s
    env.reset(seed=1)
    _, _, _, _, info = env.step(np.array([1.0, 0.0], np.float32))
    assert env._sim.state.steer_rad > 0  # positive action steers left, rate-limited
    assert env._sim.state.steer_rad <= MAX_STEER_RAD
    env.close()
