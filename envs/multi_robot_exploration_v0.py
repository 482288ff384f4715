"""Multi-robot exploration with periodic tomographic map merging (PettingZoo, parallel API).

Lidar-equipped differential-drive robots (pymunk physics, 360-beam lidar,
drifting odometry) start at random free poses with random headings, unknown
to each other, and each builds an occupancy grid in its own start frame.
Every ``team.merge_interval`` steps (50 by default) all grids are merged
(tomographic method by default); once a robot's map is linked to teammates'
by confirmed merges, its observation shows the team's map in its own frame.

=====================  =============================================================
Import                 ``from envs import multi_robot_exploration_v0``
Agents                 ``robot_0`` ... ``robot_{N-1}`` (fixed order; default N = 3)
Parallel API           yes (native); AEC through ``env()`` / ``raw_env()``
Action space           ``Box(-1, 1, (2,), float32)``: linear, angular velocity
Observation space      ``Dict(scan, map, pose)``, see below
Reward                 square metres of free space the team first saw, per robot
Episode end            termination: team coverage >= ``coverage_target``;
                       truncation: ``max_cycles`` steps
=====================  =============================================================

Observation (per robot)
-----------------------

=====  ============  =======  ==========================================================
key    shape         dtype    values
=====  ============  =======  ==========================================================
scan   (360,)        float32  lidar ranges in metres, ``[0, 8]``; no return and dropouts
                              read the maximum range (8 m)
map    (64, 64)      int8     window of the robot's best map around its estimated
                              position, 0.1 m per cell (6.4 m square), ROS coding:
                              -1 unknown, 0..100 percent occupied; aligned with the
                              robot's map frame (not rotated with its heading), row 0
                              at the lowest y; each cell the maximum of the 2 x 2 map
                              cells it covers
pose   (3,)          float32  pose estimate (x, y, theta) in the robot's own map frame
                              (metres, radians); x, y bounded by the world's diagonal
                              plus 10 m
=====  ============  =======  ==========================================================

The *best map* of a robot is its own grid, with the cells it has not observed
filled in from the grids of the teammates its map is linked to through
confirmed merges, carried into its frame by the merge transforms
(:mod:`tomosim.team.sharing`; teammates' grids are refreshed every
``team.share_interval`` steps, 10 by default).
A merge the merger does not accept is never used; one it accepts is used
once the next round confirms it (:class:`tomosim.team.TeamMerger`).

Action
------
``(linear, angular)`` as fractions of the maximum forward speed (1 m/s) and turn
rate (2 rad/s); values outside ``[-1, 1]`` are clipped. An agent given no action
is commanded ``(0, 0)``: it brakes (at most 5 m/s², so from full speed it stops
within about 0.1 m) and stays. One step is 0.1 s of physics for all robots at once.

Reward
------
Each step, the free cells of the world (its explorable space: the largest
connected free region, strands narrower than 0.2 m left out) that the team
knows for the first time, in square metres, credited to the
robots whose maps now know them (shared equally when several do at once).
The rewards of a step sum to the growth of the team's known area; they use
the simulator's truth (start poses) and are not observable by the robots.

Starting state
--------------
Robots at random free poses (0.35 m of clearance, 0.8 m apart) with headings
uniform in ``[-pi, pi)``, each having taken one scan.

Episode end
-----------
All agents terminate when the team knows ``coverage_target`` of the free space
(the truth cells whose centres fall on known cells of some robot's grid, placed
by true start poses), and are truncated after ``max_cycles`` steps.

Infos (per agent, new objects every step)
-----------------------------------------
``step``; ``team_coverage`` and ``coverage`` (this robot's own) as fractions of
the free space; ``teammates``: the agents whose maps this robot sees;
``merged_now``: a merge round ran at this step; ``merge``: the latest merge
round (empty before the first; one dictionary shared by the agents of a step)
with ``step``, ``method``, ``agreement`` (the
merged map's acceptance index against the ground truth, placed by its
reference robot's true start pose), ``accepted`` (number of accepted pair
estimates), ``merged_robots`` (agent ids), and ``pairs``: per pair of agents
``"robot_0-robot_1"``, the estimated and true pose of robot 1's map frame in
robot 0's (``estimate``,
``truth``: x, y metres, yaw radians), ``rotation_error_deg``,
``translation_error_m`` (``inf`` without an estimate), ``matching_index``
(eq. 31 of the paper; None for estimates not accepted), ``confidence``,
``accepted``, ``confirmed``, ``used``,
``dropped`` (confirmed but contradicting the other links), the merger's
``reason`` and ``shared_free_m2`` (the free space both maps know, laid by the
true transform: how much they overlap). Reports and recordings of tomosim call
the same robots ``r0``, ``r1``, ... (:func:`tomosim.team.robot_name`).

At the last step of an episode each agent's info also holds ``episode``: ``r``
(the agent's return), ``l`` (steps), its ``coverage``, ``team_coverage``,
``terminated``, ``truncated``, ``world`` (its name) and every agent's
``returns`` (``r`` and ``l`` as in Stable-Baselines3's ``Monitor``), and the
figures exploration papers report, named as in ``tomosim sweep``'s rows
(:mod:`tomosim.episode.exploration_tracker`): ``steps_to_target`` (the step at which the
team reached ``coverage_target``, None if it did not), ``path_length_m`` (metres
the robots' true positions travelled, all robots together), ``overlap_rate``
(the sum of the robots' own coverages over the team's, less one),
``merge_rounds``, and ``pairs_accepted`` and ``pairs_confirmed`` (pair estimates
the merger accepted, and of those the confirmed ones, summed over the rounds). No reset
info has this key, so a vector environment that resets on its own and merges
the reset's infos into the last step's (SuperSuit's) keeps it; the same
dictionary, without ``r`` and ``coverage``, stays in ``env.last_episode``
until the next episode ends.

Arguments
---------

======================  ==========================================================
argument                meaning (default)
======================  ==========================================================
``world``               generated floor plan seed, map_server YAML path or
                        ``World`` (floor plan 0)
``world_size``          width, height of a generated floor plan in metres (30, 20)
``robots``              number of robots (3)
``max_cycles``          steps before truncation (1500)
``team``                a ``tomosim.team.TeamConfig``: every setting of the team,
                        among them ``merge`` (True), ``method``
                        ("tomographic"; "oracle": the true start poses),
                        ``merge_interval`` (50 steps),
                        ``unlinked_merge_interval`` (10 steps; 50 in the
                        default team), ``confirmations`` (2),
                        ``share_interval`` (10 steps), ``tracking`` (True),
                        ``comms`` (unlimited range) and ``simulation`` (robots,
                        lidar, odometry, mapping); default
                        :data:`V0_TEAM` (``TeamConfig()`` with v0's merge
                        schedule, see the version history)
``coverage_target``     team coverage that terminates the episode (0.9)
``crop_size``           side of the ``map`` observation in cells (64)
``crop_resolution``     metres per cell of the ``map`` observation (0.1)
``render_mode``         None, "rgb_array" or "human" (None; below)
``floors``              None, or floor plan seeds: each reset generates a floor
                        drawn from them, of ``world_size``; use
                        ``TRAINING_FLOORS`` to learn and ``HELD_OUT_FLOORS``,
                        disjoint from them, to evaluate (None)
``observation_format``  "metric", the table above, or "normalised", for
                        learners: the map as a ``uint8`` image of channels
                        free, occupied, unknown, scan and pose scaled to
                        ``[0, 1]`` and ``[-1, 1]``; see :mod:`envs.observations`
                        ("metric")
======================  ==========================================================

For example ``parallel_env(robots=4, team=TeamConfig(merge_interval=100,
comms=CommsConfig(10.0)))``. A team setting given on its own
(``parallel_env(merge_interval=100)``) is refused with the ``team=`` to write
instead.

Rendering
---------
A frame shows the ground truth, what the team knows (tinted blue), the merged
map's walls placed by the truth (magenta) and the robots, one pixel per truth
cell. ``render_mode="rgb_array"``: ``render()`` returns it as a ``(rows, cols,
3)`` uint8 array. ``render_mode="human"``: ``reset()``, ``step()`` and
``render()`` draw it in a matplotlib window, at ``render_fps`` frames a
second, and ``render()`` returns None; without a display (matplotlib's
``Agg`` backend) the frames go to an off-screen figure instead, ``env.window.figure``,
and no window opens. ``close()`` closes the window.

Seeding
-------
``reset(seed=...)`` builds the environment's one generator; every draw (start
poses, odometry and lidar noise, merging) comes from streams derived from it.
``reset()`` without a seed continues from the same generator.

Version history
---------------
* v0: initial version. Later additions left its defaults (spaces, dynamics,
  rewards) as they were and so kept the name: ``render_mode="human"``, the
  options ``floors`` and ``observation_format``, the ``episode`` info of the
  last step and its exploration figures (``steps_to_target`` to
  ``pairs_confirmed``), and the ``team`` argument, which took in the arguments
  ``merge``, ``merge_interval``, ``method`` and ``simulation`` (with the same
  defaults) and gave the environment the team's other settings. When
  ``TeamConfig`` began to merge sooner while maps are not all linked
  (``unlinked_merge_interval``, ``tracker.search_unlinked_at_once``), the
  environment's own default team (:data:`V0_TEAM`) kept v0's schedule, so
  that a seed's episode stays the one recorded
  (``tests/envs/test_episode_digest.py``); a team passed in is used as
  given, ``team=TeamConfig()`` with the sooner links. Likewise when a confident
  estimate began to link maps in its first round (``confirm_at_once_confidence``):
  :data:`V0_TEAM` sets it to None.
"""

from __future__ import annotations

import copy
import dataclasses
import logging
import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from gymnasium import spaces
from numpy.typing import NDArray
from pettingzoo import AECEnv, ParallelEnv
from pettingzoo.utils import wrappers
from pettingzoo.utils.conversions import parallel_to_aec_wrapper

from envs.observations import (
    OBSERVATION_FORMATS,
    action_space,
    command,
    normalise_team,
    normalised_observation_space,
    observation_space,
    observe_team,
    pose_bound,
)
from envs.rendering import HumanWindow, render_frame
from merging.validators import SettingTypeError, one_of, real_number, whole_number
from tomosim.episode import DEFAULT_COVERAGE_TARGET, DEFAULT_ROBOTS, DEFAULT_WORLD_SEED, load_world
from tomosim.episode.exploration_tracker import ExplorationTracker
from tomosim.kernels.jit import interrupts_unwrapped
from tomosim.mapping import MAX_GRID_SIDE_CELLS
from tomosim.team import RoundQuality, TeamConfig, TeamSession, TrackingParams, robot_name
from tomosim.worlds import World

TRAINING_FLOORS = range(1000, 1_000_000)
"""Floor plan seeds to draw training worlds from (``floors=TRAINING_FLOORS``)."""
HELD_OUT_FLOORS = range(0, 1000)
"""Floor plan seeds never in :data:`TRAINING_FLOORS`, for evaluation; the default
world (floor 0) is one of them."""
RESOLUTION_TOLERANCE = 1e-9
"""Relative slack when checking that the crop resolution is a whole number of map cells."""
V0_TEAM = TeamConfig(
    unlinked_merge_interval=TeamConfig().merge_interval,
    confirm_at_once_confidence=None,
    tracker=TrackingParams(search_unlinked_at_once=False),
)
"""The team of an environment made without ``team``: :class:`TeamConfig`'s defaults with
v0's merge schedule, a round every ``merge_interval`` steps, each global search used
at the pair's next round and every estimate confirmed by a second round (version
history)."""
TEAM_SETTINGS = frozenset(f.name for f in dataclasses.fields(TeamConfig))
"""Names of the team's settings, which the environment takes in one ``team`` argument."""

LOG = logging.getLogger(__name__)
"""Says when an episode ends as it starts (the team already knows enough)."""


def agent_name(index: int) -> str:
    """The agent id of robot ``index``: ``robot_0``, ``robot_1``, ..."""
    return f"robot_{index}"


class MultiRobotExplorationEnv(ParallelEnv):
    """The parallel environment of the module docstring (its spec card)."""

    metadata: dict[str, Any] = {  # noqa: RUF012  # PettingZoo reads the class attribute
        "name": "multi_robot_exploration_v0",
        "render_modes": ["human", "rgb_array"],
        "is_parallelizable": True,
        "render_fps": 10,
    }

    def __init__(
        self,
        world: int | str | Path | World = DEFAULT_WORLD_SEED,
        *,
        world_size: tuple[float, float] | None = None,
        robots: int = DEFAULT_ROBOTS,
        max_cycles: int = 1500,
        team: TeamConfig | None = None,
        coverage_target: float = DEFAULT_COVERAGE_TARGET,
        crop_size: int = 64,
        crop_resolution: float = 0.1,
        render_mode: str | None = None,
        floors: Sequence[int] | None = None,
        observation_format: str = OBSERVATION_FORMATS[0],
    ) -> None:
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(
                f"render_mode must be None or one of {self.metadata['render_modes']}, "
                f"got {render_mode!r}"
            )
        whole_number(robots, "robots", minimum=1)
        whole_number(max_cycles, "max_cycles", minimum=1, unit="steps")
        real_number(coverage_target, "coverage_target", low=0.0, high=1.0, low_open=True)
        real_number(crop_resolution, "crop_resolution", low=0.0, low_open=True, unit="metres")
        if team is not None and not isinstance(team, TeamConfig):
            raise SettingTypeError(
                f"team must be a tomosim.team.TeamConfig, got {type(team).__name__}"
            )
        whole_number(crop_size, "crop_size", minimum=2, unit="cells")
        if crop_size % 2:
            raise ValueError(f"crop_size must be an even number of cells >= 2, got {crop_size!r}")
        one_of(observation_format, OBSERVATION_FORMATS, what="observation_format")
        generated = isinstance(world, int | np.integer) or (
            isinstance(world, str) and world.strip().isdigit()
        )
        if world_size is not None and floors is None and not generated:
            raise ValueError(
                f"world_size sizes a generated floor plan (a seed); the world {world!r} has its "
                "own size: drop world_size"
            )
        if floors is not None:
            if isinstance(world, World) or world != DEFAULT_WORLD_SEED:
                raise ValueError("give either world or floors, not both")
            _check_floors(floors)
        self.team_config = team if team is not None else V0_TEAM
        resolution = self.team_config.simulation.mapping.resolution
        pool = round(crop_resolution / resolution)
        if pool < 1 or abs(pool * resolution - crop_resolution) > RESOLUTION_TOLERANCE * pool:
            raise ValueError(
                f"crop_resolution must be a whole multiple of the map's {resolution} m cells, "
                f"got {crop_resolution}"
            )
        if crop_size * pool > MAX_GRID_SIDE_CELLS:
            raise ValueError(
                f"crop_size {crop_size} at crop_resolution {crop_resolution} m reads "
                f"{crop_size * pool} of the maps' {resolution} m cells a side, more than "
                f"{MAX_GRID_SIDE_CELLS} ({MAX_GRID_SIDE_CELLS * resolution:g} m); ask for a "
                "smaller crop_size or a finer crop_resolution"
            )
        self.floors = floors
        self.world_size = world_size
        if floors is not None:
            world = int(floors[0])  # every floor of one size has the same bounds
        self.world = world if isinstance(world, World) else load_world(world, size=world_size)
        self.observation_format = observation_format
        self.render_mode = render_mode
        self.max_cycles = int(max_cycles)
        self.coverage_target = float(coverage_target)
        self._warned_done_at_start = False  # said once per environment
        self._warned_step_after_end = False
        self.crop_size = int(crop_size)
        self.pool = int(pool)
        self._bound = pose_bound(self.world)
        self.possible_agents = [agent_name(k) for k in range(int(robots))]
        self.agents: list[str] = []
        lidar = self.team_config.simulation.lidar
        self._max_range = lidar.max_range
        if observation_format == "normalised":
            self._observation_space = normalised_observation_space(lidar.beams, self.crop_size)
        else:
            self._observation_space = observation_space(
                lidar.beams, lidar.max_range, self.crop_size, self._bound
            )
        # One object per agent, so that seeding one agent's space leaves the others' alone.
        self._observation_spaces = {
            agent: copy.deepcopy(self._observation_space) for agent in self.possible_agents
        }
        self._action_spaces = {agent: action_space() for agent in self.possible_agents}
        self.np_random: np.random.Generator | None = None
        self.session: TeamSession | None = None
        self.last_episode: dict[str, Any] | None = None
        self._merge_source: Any = None
        self._merge_info: dict[str, Any] = {}
        self._returns = np.zeros(len(self.possible_agents))
        self._tracker: ExplorationTracker | None = None
        self._pair_counts = np.zeros(3, dtype=int)  # merge rounds, accepted, confirmed
        self.window: HumanWindow | None = None
        if render_mode == "human":
            self.window = HumanWindow(self.metadata["render_fps"], title=self.metadata["name"])

    def observation_space(self, agent: str) -> spaces.Space[Any]:
        """The observation space of ``agent`` (its own object, the same every call)."""
        return self._observation_spaces[self._known(agent)]

    def action_space(self, agent: str) -> spaces.Space[Any]:
        """The action space of ``agent`` (its own object, the same every call)."""
        return self._action_spaces[self._known(agent)]

    def _known(self, agent: str) -> str:
        if agent not in self._action_spaces:
            raise KeyError(f"unknown agent {agent!r}; agents are {self.possible_agents}")
        return agent

    def reset(
        self, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, dict[str, NDArray[Any]]], dict[str, dict[str, Any]]]:
        """Start a new episode; ``seed`` rebuilds the generator (module docstring).

        ``options`` are accepted for the API's sake and not used.
        """
        if seed is not None:
            whole_number(seed, "seed", minimum=0)
            self.np_random = np.random.default_rng(seed)
        elif self.np_random is None:
            self.np_random = np.random.default_rng()
        return self.start(self.np_random)

    def start(
        self, generator: np.random.Generator
    ) -> tuple[dict[str, dict[str, NDArray[Any]]], dict[str, dict[str, Any]]]:
        """Start a new episode drawing from ``generator``; returns observations and infos."""
        if self.floors is not None:
            floor = int(self.floors[int(generator.integers(len(self.floors)))])
            self.world = load_world(floor, size=self.world_size)
        self._returns = np.zeros(len(self.possible_agents))
        with interrupts_unwrapped():  # as in step()
            self.session = TeamSession(
                self.world, robots=len(self.possible_agents), config=self.team_config, rng=generator
            )
            self.agents = list(self.possible_agents)
            self._warned_step_after_end = False
            self._tracker = ExplorationTracker(self.session)
            self._pair_counts[:] = 0
            start = self.session.coverage.fraction
            if start >= self.coverage_target and not self._warned_done_at_start:
                self._warned_done_at_start = True
                LOG.warning(
                    "the robots' first scans already cover %.2f of the free space, at least "
                    "coverage_target %.2f: this episode ends at its first step; use fewer "
                    "robots, a larger world or a higher coverage_target",
                    start,
                    self.coverage_target,
                )
            if self.window is not None:
                self.render()
            return self._observations(), self._infos(merged_now=False)

    def step(
        self, actions: dict[str, Any]
    ) -> tuple[
        dict[str, dict[str, NDArray[Any]]],
        dict[str, float],
        dict[str, bool],
        dict[str, bool],
        dict[str, dict[str, Any]],
    ]:
        """Advance all robots by one step of 0.1 s under ``actions``."""
        session = self.session
        if session is None:
            raise RuntimeError("call reset() before step()")
        if not self.agents:
            if not self._warned_step_after_end:  # said once per episode
                self._warned_step_after_end = True
                LOG.warning(
                    "step() after the episode ended: every robot is done, so nothing moves and "
                    "the dicts are empty; call reset() to start the next episode"
                )
            return {}, {}, {}, {}, {}
        if not isinstance(actions, Mapping):
            raise TypeError(
                f"actions must be a dict of agent name -> action, got {type(actions).__name__}"
            )
        unknown = set(actions) - set(self.possible_agents)
        if unknown:
            raise ValueError(
                f"actions for unknown agents {sorted(unknown)}; agents are {self.agents}"
            )
        commands = [
            (0.0, 0.0) if actions.get(agent) is None else command(actions[agent], name=agent)
            for agent in self.possible_agents
        ]
        with interrupts_unwrapped():  # a Ctrl-C inside a kernel reaches the caller as one
            merge = session.step(commands)
            observations = self._observations()
        self._follow(merge)
        rewards = dict(zip(self.agents, session.rewards.tolist(), strict=True))
        done = session.coverage.fraction >= self.coverage_target
        cut = session.steps >= self.max_cycles
        terminations = dict.fromkeys(self.agents, bool(done))
        truncations = dict.fromkeys(self.agents, bool(cut and not done))
        infos = self._infos(merged_now=merge is not None)
        self._returns += session.rewards
        if done or cut:
            self._end_episode(infos, terminated=bool(done))
            self.agents = []
        if self.window is not None:
            self.render()
        return observations, rewards, terminations, truncations, infos

    def _follow(self, merge: RoundQuality | None) -> None:
        """Take in a step's path lengths and coverages, and its merge round if one ran."""
        assert self._tracker is not None and self.session is not None  # start() made them
        self._tracker.advance(self.session)
        if merge is not None:
            accepted = merge.accepted
            self._pair_counts += (1, len(accepted), sum(p.confirmed for p in accepted))

    def _end_episode(self, infos: dict[str, dict[str, Any]], *, terminated: bool) -> None:
        """Keep the episode's final figures (``last_episode``, ``infos[a]["episode"]``)."""
        session, tracker = self.session, self._tracker
        assert session is not None and tracker is not None  # step() checked them
        returns = {a: float(r) for a, r in zip(self.possible_agents, self._returns, strict=True)}
        rounds, accepted, confirmed = (int(n) for n in self._pair_counts)
        summary = {
            "l": session.steps,
            "team_coverage": session.coverage.fraction,
            "terminated": terminated,
            "truncated": not terminated,
            "world": self.world.name,
            "returns": returns,
            "steps_to_target": next(
                (s for s, c in enumerate(tracker.team_curve) if c >= self.coverage_target), None
            ),
            "path_length_m": tracker.last.path_length,
            "overlap_rate": tracker.last.overlap_rate,
            "merge_rounds": rounds,
            "pairs_accepted": accepted,
            "pairs_confirmed": confirmed,
        }
        self.last_episode = summary
        for k, agent in enumerate(self.possible_agents):
            infos[agent]["episode"] = {
                **summary,
                "returns": dict(returns),  # each agent's own, as every info is
                "r": float(self._returns[k]),
                "coverage": session.coverage.robot_fraction(k),
            }

    def _observations(self) -> dict[str, dict[str, NDArray[Any]]]:
        """Every live agent's observation: views of one new array per key (a row each)."""
        assert self.session is not None  # reset() made it
        scans, maps, poses = observe_team(
            self.session, size=self.crop_size, pool=self.pool, bound=self._bound
        )
        if self.observation_format == "normalised":
            scans, images, poses = normalise_team(
                scans, maps, poses, bound=self._bound, max_range=self._max_range
            )
            return {
                agent: {"scan": scans[k], "map": images[k], "pose": poses[k]}
                for k, agent in enumerate(self.possible_agents)
                if agent in self.agents
            }
        return {
            agent: {"scan": scans[k], "map": maps[k], "pose": poses[k]}
            for k, agent in enumerate(self.possible_agents)
            if agent in self.agents
        }

    def _infos(self, *, merged_now: bool) -> dict[str, dict[str, Any]]:
        session = self.session
        assert session is not None  # reset() made it
        scored = session.last_quality
        if scored is not self._merge_source:  # the round's dictionary, built once per round
            self._merge_source = scored
            self._merge_info = {} if scored is None else scored.as_dict(name=agent_name)
            for pair in self._merge_info.get("pairs", {}).values():  # nan is not equal to itself
                if not math.isfinite(pair["matching_index"]):
                    pair["matching_index"] = None
        merge_info = _copy_merge_info(self._merge_info)
        steps, coverage, names = session.steps, session.coverage, self.possible_agents
        team_coverage = coverage.fraction
        infos = {}
        for k, agent in enumerate(names):
            if agent not in self.agents:
                continue
            infos[agent] = {
                "step": steps,
                "team_coverage": team_coverage,
                "coverage": coverage.robot_fraction(k),
                "teammates": [names[t] for t in session.shared.teammates(k)],
                "merged_now": merged_now,
                "merge": merge_info,
            }
        return infos

    def render(self) -> NDArray[np.uint8] | None:
        """The current frame (module docstring): an RGB array for "rgb_array", else None.

        With ``render_mode="human"`` the frame is drawn in the window instead.
        """
        if self.render_mode is None or self.session is None:
            return None
        frame = render_frame(self.session)
        if self.window is not None:
            self.window.show(frame)
            return None
        return frame

    def close(self) -> None:
        """Release the episode (no agent is left) and close the window, if any."""
        self.session = None
        self.agents = []
        if self.window is not None:
            self.window.close()


def _check_floors(floors: object) -> None:
    """Raise naming ``floors`` unless it is a non-empty sequence of floor plan seeds."""
    advice = "e.g. TRAINING_FLOORS or HELD_OUT_FLOORS"
    if isinstance(floors, str) or not isinstance(floors, Sequence) or len(floors) == 0:
        raise ValueError(f"floors must be non-negative floor plan seeds, got {floors!r}; {advice}")
    # A range holds whole numbers between its ends: its ends say it all, where checking
    # each of TRAINING_FLOORS' million seeds would take a while.
    seeds = (floors[0], floors[-1]) if isinstance(floors, range) else floors
    for k, seed in enumerate(seeds):
        try:
            whole_number(seed, f"floors[{k}]", minimum=0)
        except ValueError as error:
            raise type(error)(f"{error}; floors are floor plan seeds, {advice}") from None


def _copy_merge_info(info: dict[str, Any]) -> dict[str, Any]:
    """A copy of a round's info dictionary down to its mutable parts (tuples are shared)."""
    if not info:
        return {}
    return {
        **info,
        "merged_robots": list(info["merged_robots"]),
        "pairs": {name: dict(pair) for name, pair in info["pairs"].items()},
    }


def parallel_env(**kwargs: Any) -> MultiRobotExplorationEnv:
    """The native parallel environment (arguments as in the module docstring)."""
    loose = sorted(TEAM_SETTINGS & set(kwargs))
    if loose:
        given = ", ".join(f"{name}={kwargs[name]!r}" for name in loose)
        raise TypeError(
            f"{', '.join(loose)} {'is a team setting' if len(loose) == 1 else 'are team settings'}"
            f": pass team=tomosim.team.TeamConfig({given})"
        )
    return MultiRobotExplorationEnv(**kwargs)


def raw_env(**kwargs: Any) -> AECEnv:
    """The AEC view of :func:`parallel_env`, without wrappers."""
    return parallel_to_aec_wrapper(parallel_env(**kwargs))


def env(**kwargs: Any) -> AECEnv:
    """The AEC view with PettingZoo's order-enforcing wrapper (the usual entry point)."""
    return wrappers.OrderEnforcingWrapper(raw_env(**kwargs))


__all__ = [
    "HELD_OUT_FLOORS",
    "TRAINING_FLOORS",
    "V0_TEAM",
    "MultiRobotExplorationEnv",
    "agent_name",
    "env",
    "parallel_env",
    "raw_env",
    "robot_name",
]
