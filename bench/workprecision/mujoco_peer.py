"""The same pendulum in MuJoCo: an MJCF model built from the scene's parameters with explicit
inertias, run with MuJoCo's RK4 and (semi-implicit) Euler through `mujoco.rollout`.

Coordinates: MuJoCo's hinges are relative joint angles; ipgen's θi are absolute angles from the
upright, clockwise positive. A link along +z turned by φ about +y has its tip at (l sin φ, 0, l cos φ),
ipgen's convention, so θi = φ1 + … + φi. The rotary arm turns about −z (θ0 > 0 is clockwise seen
from above) and points along +y at θ0 = 0; its links swing about the arm's axis.

Inertias (docs/model.md): rods, CoG at l/2, inertia m l²/12 about any axis through the CoG normal to
the rod and 0 along it — MuJoCo's rigid bodies have the full tensor, i.e. ipgen's `full` rotary
variant (classical systems have no variant). The arm's inertia about the vertical through its
pivot is m0 l0²/3. Damping: MuJoCo's joint damping acts on relative joint rates, as docs/model.md's
Rayleigh function does (δ1 on link 1 against the base). No contacts, no constraints.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import mujoco
import numpy as np
from mujoco import rollout

from ipgen.experiment.scene import Scene

# A thin rod's inertia along its own axis is zero, which MuJoCo refuses (every principal moment
# must exceed mjMINVAL); 1e-9 of the transverse one stands in. It changes the rotary models'
# kinetic energy by at most that fraction and the classical ones not at all (their links never
# spin about their own axes).
AXIAL = 1e-9
INTEGRATORS = {"rk4": mujoco.mjtIntegrator.mjINT_RK4, "euler": mujoco.mjtIntegrator.mjINT_EULER}


def mjcf(scene: Scene) -> str:
    """An MJCF model of the scene's system (gravity, inertias, damping, a motor on θ0)."""
    n = scene.links
    m, length, delta = scene.m, scene.l, scene.delta

    def rod(i: int) -> str:
        inertia = m[i] * length[i] ** 2 / 12.0
        return (
            f'<inertial pos="0 0 {length[i] / 2!r}" mass="{m[i]!r}" '
            f'diaginertia="{inertia!r} {inertia!r} {AXIAL * inertia!r}"/>'
        )

    links = ""
    for i in range(n, 0, -1):  # innermost last: each link contains the next
        pos = "0 0 0" if i == 1 else f"0 0 {length[i - 1]!r}"
        links = (
            f'<body name="link{i}" pos="{pos}">'
            f'<joint name="joint{i}" type="hinge" axis="0 1 0" damping="{delta[i]!r}"/>'
            f"{rod(i)}{links}</body>"
        )
    if scene.type == "classical":
        base = (
            '<body name="cart"><joint name="base" type="slide" axis="1 0 0" '
            f'damping="{delta[0]!r}"/><inertial pos="0 0 0" mass="{m[0]!r}" diaginertia="1e-3 1e-3 1e-3"/>'
            f"{links}</body>"
        )
    else:
        arm = m[0] * length[0] ** 2 / 12.0
        # The links hang from the arm's tip and swing about the arm's axis (+y in the arm frame).
        tip = f'<frame pos="0 {length[0]!r} 0">{links}</frame>'
        base = (
            '<body name="arm"><joint name="base" type="hinge" axis="0 0 -1" '
            f'damping="{delta[0]!r}"/><inertial pos="0 {length[0] / 2!r} 0" mass="{m[0]!r}" '
            f'diaginertia="{arm!r} {AXIAL * arm!r} {arm!r}"/>{tip}</body>'
        )
    return (
        '<mujoco model="ipgen">'
        f'<option gravity="0 0 {-scene.g!r}" timestep="0.001" integrator="RK4">'
        '<flag contact="disable" constraint="disable" energy="disable"/></option>'
        f"<worldbody>{base}</worldbody>"
        '<actuator><motor joint="base" gear="1" ctrllimited="false"/></actuator>'
        "</mujoco>"
    )


@dataclass
class Run:
    integrator: str
    timestep: float
    states: np.ndarray  # samples x 2·dof, ipgen's coordinates
    wall_per_second: float  # median wall time per simulated second [s]
    repeats: int
    steps: int
    unstable: bool  # MuJoCo met NaN or huge accelerations and reset the state


def _quiet(_message: str) -> None:
    """Instability is detected from MuJoCo's warning counters; its printed warnings only clutter
    the benchmark's output."""


class MujocoPendulum:
    """A compiled MuJoCo model of one scene, run open-loop with the scene's input."""

    def __init__(self, scene: Scene) -> None:
        mujoco.set_mju_user_warning(_quiet)
        self.scene = scene
        self.model = mujoco.MjModel.from_xml_string(mjcf(scene))
        self.data = mujoco.MjData(self.model)
        self.dof = scene.links + 1
        self.spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
        self.size = mujoco.mj_stateSize(self.model, self.spec)

    def initial_state(self) -> np.ndarray:
        mujoco.mj_resetData(self.model, self.data)
        theta = np.array(self.scene.theta)
        dtheta = np.array(self.scene.dtheta)
        # Relative joint coordinates: φ0 = θ0, φ1 = θ1, φi = θi − θ(i−1).
        self.data.qpos[:] = np.concatenate(([theta[0]], np.diff(theta[1:], prepend=0.0)))
        self.data.qvel[:] = np.concatenate(([dtheta[0]], np.diff(dtheta[1:], prepend=0.0)))
        state = np.empty(self.size)
        mujoco.mj_getState(self.model, self.data, state, self.spec)
        return state

    def to_ipgen(self, states: np.ndarray) -> np.ndarray:
        """FULLPHYSICS states (time, qpos, qvel, ...) -> rows [θ; θ̇] in ipgen's coordinates."""
        n = self.dof
        qpos = states[:, 1 : 1 + n]
        qvel = states[:, 1 + n : 1 + 2 * n]
        theta = np.concatenate((qpos[:, :1], np.cumsum(qpos[:, 1:], axis=1)), axis=1)
        dtheta = np.concatenate((qvel[:, :1], np.cumsum(qvel[:, 1:], axis=1)), axis=1)
        return np.concatenate((theta, dtheta), axis=1)

    def run(self, integrator: str, timestep: float, sample: float, repeat_seconds: float = 0.2) -> Run:
        """Integrate to t_end with a fixed step; states every `sample` (a multiple of the step)."""
        scene = self.scene
        per_sample = round(sample / timestep)
        steps = round(scene.t_end / timestep)
        if abs(per_sample * timestep - sample) > 1e-9 * sample or abs(steps * timestep - scene.t_end) > 1e-9:
            raise ValueError(f"timestep {timestep} does not divide the sample interval and t_end")
        self.model.opt.timestep = timestep
        self.model.opt.integrator = INTEGRATORS[integrator]
        # u for each step, taken at the step's start (the pulse edges lie on the step grid).
        times = np.arange(steps) * timestep
        control = np.array([scene.input.value(t) for t in times]).reshape(1, steps, 1)
        initial = self.initial_state().reshape(1, -1)
        output = np.empty((1, steps, self.size))
        walls: list[float] = []
        spent = 0.0
        # At least 3 runs (1 when a run takes more than a second), then until repeat_seconds.
        while (len(walls) < 3 or (spent < repeat_seconds and len(walls) < 25)) and not (
            walls and spent > 1.0
        ):
            start = time.perf_counter()
            rollout.rollout(
                [self.model], [self.data], initial, control, state=output, nstep=steps, skip_checks=True
            )
            walls.append(time.perf_counter() - start)
            spent += walls[-1]
        unstable = self.data.warning[mujoco.mjtWarning.mjWARN_BADQACC].number > 0
        sampled = output[0, per_sample - 1 :: per_sample]
        rows = np.concatenate((self.to_ipgen(initial), self.to_ipgen(sampled)), axis=0)
        wall = float(np.median(walls)) / scene.t_end
        return Run(integrator, timestep, rows, wall, len(walls), steps, bool(unstable))
