"""The peer users would pick instead: the same disk in MuJoCo (``pip install -e ".[bench]"``).

``python benchmarks/bench_mujoco.py [--quick] [--out DIR]`` writes ``mujoco.md`` and ``mujoco_work_precision.png`` to
DIR (default ``benchmarks/results``).

MuJoCo gets a thin cylinder of the same mass and inertia (5 kg; m r^2/2 about the axis, m r^2/4 about a diameter)
on a plane with friction 1 (condim 3), started in the paper's two scenarios with the velocities of rolling. At each
timestep it reports: slip (largest speed of the disk's lowest material point), energy lost (relative), centre-position
and lean errors against our exact model (``dop853``, rtol 1e-12), the radius error on scenario 2's steady circle,
and wall time per simulated second. Our fixed-step methods are timed in the same run (``rd.simulate``, one disk: a
Python call per step, as MuJoCo's ``mj_step`` loop is here) and drawn on the same chart; "matched wall time" and
"equal error" compare MuJoCo with our RK4 by interpolating its curve; "<" marks MuJoCo errors larger than our
cheapest RK4 run (dt 0.05 s) has. MuJoCo uses its default integrator. Medians of 3 runs (1 with ``--quick``, which
also shortens the scenarios to 2 s and the timesteps to the three largest).
"""

from __future__ import annotations

import statistics
import time

import numpy as np
from _common import arguments, table, write_markdown
from bench_accuracy import run as run_ours

import rolling_disk_env as rd
from rolling_disk_env.paper import scenarios

PARAMS = rd.DiskParams()
TIMESTEPS = (0.004, 0.002, 0.001, 0.0005, 0.0002)
OURS = {"rk4": (0.05, 0.02, 0.01, 0.005, 0.002), "euler": (0.01, 0.005, 0.002, 0.001)}
OUTPUT_DT = 0.1

MJCF = """
<mujoco>
  <option timestep="{timestep}" gravity="0 0 -{g}" integrator="{integrator}"/>
  <worldbody>
    <geom type="plane" size="100 100 0.1" friction="1 0.005 0.0001"/>
    <body name="disk">
      <freejoint/>
      <inertial pos="0 0 0" mass="{m}" diaginertia="{axial} {diametral} {diametral}"/>
      <geom type="cylinder" size="{r} 0.005" euler="0 90 0" friction="1 0.005 0.0001" condim="3" mass="0"/>
    </body>
  </worldbody>
</mujoco>
"""


def body_angular_velocity(x) -> np.ndarray:
    """The paper's omega_r (body frame), what a MuJoCo free joint takes as its angular velocity."""
    _, _, phi, theta, _, dphi, dtheta, dpsi = x
    return np.array(
        [
            dphi - dpsi * np.sin(theta),
            dtheta * np.cos(phi) + dpsi * np.sin(phi) * np.cos(theta),
            -dtheta * np.sin(phi) + dpsi * np.cos(theta) * np.cos(phi),
        ]
    )


def simulate_mujoco(x0, duration, timestep, integrator="Euler"):
    """(states at OUTPUT_DT in the paper's coordinates, slip speeds, energies, wall seconds)."""
    import mujoco

    model = mujoco.MjModel.from_xml_string(
        MJCF.format(
            timestep=timestep,
            g=PARAMS.gravity,
            m=PARAMS.mass,
            r=PARAMS.radius,
            axial=PARAMS.axial_inertia,
            diametral=PARAMS.diametral_inertia,
            integrator=integrator,
        )
    )
    data = mujoco.MjData(model)
    quaternion = np.empty(4)
    mujoco.mju_mat2Quat(quaternion, rd.dynamics.rotation_matrix(*x0[2:5]).ravel())
    data.qpos[:3] = [x0[0], x0[1], PARAMS.radius * np.cos(x0[3])]
    data.qpos[3:] = quaternion
    centre_velocity = rd.state_derivative(x0)[:2]
    data.qvel[:3] = [*centre_velocity, -PARAMS.radius * np.sin(x0[3]) * x0[6]]
    data.qvel[3:] = body_angular_velocity(x0)
    every = round(OUTPUT_DT / timestep)
    steps = round(duration / timestep)
    samples = []
    start = time.perf_counter()
    for i in range(steps + 1):
        if i % every == 0:
            samples.append((data.qpos.copy(), data.qvel.copy()))
        if i < steps:
            mujoco.mj_step(model, data)
    seconds = time.perf_counter() - start
    states, slips, energies = [], [], []
    for qpos, qvel in samples:
        r_matrix = np.empty(9)
        mujoco.mju_quat2Mat(r_matrix, qpos[3:])
        r_matrix = r_matrix.reshape(3, 3)
        theta = -np.arcsin(np.clip(r_matrix[2, 0], -1, 1))
        psi, phi = np.arctan2(r_matrix[1, 0], r_matrix[0, 0]), np.arctan2(r_matrix[2, 1], r_matrix[2, 2])
        states.append([qpos[0], qpos[1], phi, theta, psi])
        omega_world = r_matrix @ qvel[3:]
        axis = r_matrix[:, 0]
        down = np.array([0.0, 0.0, -1.0]) + axis[2] * axis
        contact_offset = PARAMS.radius * down / np.linalg.norm(down)
        slips.append(np.linalg.norm(qvel[:3] + np.cross(omega_world, contact_offset)))
        inertia = np.diag([PARAMS.axial_inertia, PARAMS.diametral_inertia, PARAMS.diametral_inertia])
        energies.append(
            0.5 * PARAMS.mass * qvel[:3] @ qvel[:3]
            + 0.5 * qvel[3:] @ inertia @ qvel[3:]
            + PARAMS.mass * PARAMS.gravity * qpos[2]
        )
    return np.array(states), np.array(slips), np.array(energies), seconds


def unwrap_errors(states, reference):
    position = float(np.max(np.hypot(*(states[:, :2] - reference[:, :2]).T)))
    lean = float(np.max(np.abs(states[:, 3] - reference[:, 3])))
    return position, lean


def main() -> None:
    args = arguments(__doc__)
    repeats, duration_cap, timesteps = (1, 2.0, TIMESTEPS[:3]) if args.quick else (3, np.inf, TIMESTEPS)
    rows, chart_data, comparisons = [], {}, []
    for scenario in scenarios():
        x0 = np.array(scenario.state0, dtype=float)
        duration = min(scenario.duration, duration_cap)
        _, reference = rd.simulate(x0, duration, OUTPUT_DT, method="dop853", rtol=1e-12, atol=1e-12)
        energy0 = rd.energy(x0)
        ours = {}
        for method, steps in OURS.items():
            for dt in steps:
                outcome = run_ours(x0, duration, method, dt, repeats)
                if outcome.states is not None:
                    position, lean = unwrap_errors(outcome.states, reference)
                    ours.setdefault(method, []).append((outcome.seconds, position, lean))
        mujoco_points = []
        for timestep in timesteps:
            runs = [simulate_mujoco(x0, duration, timestep) for _ in range(repeats)]
            states, slips, energies, _ = runs[0]
            seconds = statistics.median(r[3] for r in runs)
            position, lean = unwrap_errors(states, reference)
            lost = (energy0 - energies[-1]) / energy0
            circle = ""
            if scenario.name == "scenario2":
                theta, dpsi = x0[3], x0[7]
                radius = PARAMS.radius * (x0[5] - dpsi * np.sin(theta)) / dpsi
                circle = f"{np.max(np.abs(np.hypot(states[:, 0] - 2 - radius, states[:, 1]) - radius)):.3f}"
            per_second = seconds / duration
            mujoco_points.append((per_second, position, lean))
            rows.append(
                [
                    scenario.name,
                    f"{timestep:g}",
                    f"{np.max(slips):.2e}",
                    f"{100 * lost:.2f}%",
                    f"{position:.3f}",
                    f"{lean:.4f}",
                    circle,
                    f"{per_second * 1e3:.2f}",
                ]
            )
        chart_data[scenario.name] = (ours, mujoco_points)
        comparisons += compare(scenario.name, ours["rk4"], timesteps, mujoco_points)
    chart(chart_data, timesteps, args.out / "mujoco_work_precision.png")
    write_markdown(
        "mujoco",
        "MuJoCo against the exact model",
        "python benchmarks/bench_mujoco.py",
        [
            __doc__.split("\n\n", 2)[2].strip(),
            "",
            table(
                [
                    "scenario",
                    "MuJoCo timestep (s)",
                    "max slip (m/s)",
                    "energy lost",
                    "centre error (m)",
                    "lean error (rad)",
                    "circle radius error (m)",
                    "ms per simulated s",
                ],
                rows,
            ),
            "",
            "## Against our RK4 (`rd.simulate`, one disk)",
            "",
            table(
                [
                    "scenario",
                    "MuJoCo timestep (s)",
                    "MuJoCo centre error (m)",
                    "our RK4 error at MuJoCo's wall time (m)",
                    "our RK4 wall time at MuJoCo's error (ms/s)",
                    "MuJoCo wall time (ms/s)",
                ],
                comparisons,
            ),
            "",
            "![work-precision with MuJoCo](mujoco_work_precision.png)",
        ],
        out=args.out,
    )


def compare(name, rk4_points, timesteps, mujoco_points) -> list[list[str]]:
    """Interpolates our RK4 curve (log-log) at MuJoCo's wall time and at MuJoCo's error."""
    costs = np.log([p[0] for p in rk4_points])
    errors = np.log([max(p[1], 1e-16) for p in rk4_points])
    order = np.argsort(costs)
    by_error = np.argsort(errors)
    rows = []
    for timestep, (cost, error, _) in zip(timesteps, mujoco_points):
        # Outside our measured range np.interp clamps: say so instead of inventing a number.
        at_cost = np.exp(np.interp(np.log(cost), costs[order], errors[order]))
        beyond = np.log(cost) > costs.max()
        at_error = np.exp(np.interp(np.log(max(error, 1e-16)), errors[by_error], costs[by_error]))
        cheaper = np.log(max(error, 1e-16)) > errors.max()
        rows.append(
            [
                name,
                f"{timestep:g}",
                f"{error:.3f}",
                f"{'<= ' if beyond else ''}{at_cost:.1e}",
                f"{'< ' if cheaper else ''}{at_error * 1e3:.3f}",
                f"{cost * 1e3:.2f}",
            ]
        )
    return rows


def chart(chart_data, timesteps, path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(chart_data), figsize=(6 * len(chart_data), 4.5))
    for ax, (name, (ours, mujoco_points)) in zip(axes, chart_data.items()):
        for method, points in ours.items():
            ax.loglog([p[0] * 1e3 for p in points], [max(p[1], 1e-16) for p in points], "o-", label=f"ours, {method}")
        ax.loglog(
            [p[0] * 1e3 for p in mujoco_points],
            [p[1] for p in mujoco_points],
            "s--",
            color="black",
            label="MuJoCo (friction contact)",
        )
        for timestep, point in zip(timesteps, mujoco_points):
            ax.annotate(f"{timestep:g} s", (point[0] * 1e3, point[1]), fontsize=7)
        ax.set_xlabel("wall time per simulated second (ms)")
        ax.set_ylabel("centre position error (m), max over the run")
        ax.set_title(name)
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


if __name__ == "__main__":
    main()
