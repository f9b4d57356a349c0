"""The contact models side by side: a disk on a surface with less friction than its motion needs, sliding then rolling
again, and the cost of each contact model per disk-step.

``python benchmarks/bench_contact.py [--quick] [--out DIR] [--skip-timing]`` writes ``contact.md`` and
``contact.png``. The motion: the paper's steady circle (scenario 2), whose contact needs a friction coefficient of
0.356, on a surface of mu = 0.3, under ``contact="coulomb"`` (``rd.simulate``, dop853): it slides from the start,
leans into the turn and spirals in, loses energy to friction, sticks, and rolls on. Beside it, the same start rolling
(the paper's model, which assumes friction enough) and on the frozen lake (``contact="sliding"``, mu = 0). The timing
(skipped with ``--skip-timing``; run it on a quiet machine) is of batches of disks that need no friction, a tenth of
them driven to slide, under the rolling and the Coulomb contacts (N = 1024 and 4096); of the native vector env under
each contact (task ``circle``, random actions, N = 1 and 1024, against ``CartPoleVectorEnv`` timed in turns with it);
and of
``rd.simulate`` for one disk, per output step of 0.01 s, with each contact and method, on scenario 1 (which never
needs more than 0.186: the hybrid rolls throughout) and on scenario 2 at mu = 0.3 (slides, then rolls).
"""

from __future__ import annotations

import time

import gymnasium as gym
import numpy as np
from _common import arguments, cpu, median_seconds, medians_in_turns, table, write_markdown
from bench_env import VectorRun

import rolling_disk_env as rd
from rolling_disk_env.dynamics import ROLLING_INDICES
from rolling_disk_env.integrators import simulate_contact
from rolling_disk_env.paper import scenarios

MU = 0.3
"""The surface's friction coefficient, below the steady circle's 0.356."""
OUTPUT_DT = 0.005
"""s, between the chart's samples."""
TIMING_DT = 0.01
"""s, the output step of the timed simulations."""
ROLLING = list(ROLLING_INDICES)


def motions(duration: float) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """``(times, 10-states)`` of scenario 2 rolling, under Coulomb's hybrid at mu = :data:`MU`, and on the frozen
    lake, with dop853; and the hybrid's switching events."""
    state0 = np.array(scenarios()[1].state0)
    times, rolling = rd.simulate(state0, duration, OUTPUT_DT, method="dop853")
    coulomb = simulate_contact(state0, duration, OUTPUT_DT, "dop853", friction_coefficient=MU, rtol=1e-12, atol=1e-12)
    _, ice = rd.simulate(state0, duration, OUTPUT_DT, method="dop853", contact="sliding", rtol=1e-12, atol=1e-12)
    runs = {"rolling": (times, rd.sliding_state(rolling)), "coulomb": (times, coulomb.states), "ice": (times, ice)}
    return runs, coulomb.events


def contact_needs(states: np.ndarray, sliding: np.ndarray) -> np.ndarray:
    """The friction the contact uses, ``|F| / N``: the needed ``|lambda| / N`` where the disk rolls, mu where it
    slides."""
    used = rd.required_friction(states[:, ROLLING])
    return np.where(sliding, MU, used)


def chart(path, runs, events) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    times, coulomb = runs["coulomb"]
    slip = np.hypot(*rd.slip_velocity(coulomb).T)
    stick = next((event.time for event in events if event.kind == "stick"), None)
    fig, axes = plt.subplots(2, 2, figsize=(11, 8.5))
    top, speed, friction, energy = axes.ravel()
    styles = {"rolling": ("black", "rolling (needs mu = 0.356)"), "coulomb": ("tab:red", f"Coulomb, mu = {MU}")}
    styles["ice"] = ("tab:cyan", "frozen lake, mu = 0")
    for name, (color, label) in styles.items():
        states = runs[name][1]
        top.plot(states[:, 0], states[:, 1], color=color, lw=1.2, label=label)
        energy.plot(times, rd.sliding_energy(states), color=color, lw=1.2, label=label)
    if stick is not None:
        at = np.argmin(np.abs(times - stick))
        top.plot(*coulomb[at, :2], "o", color="tab:red", ms=6, label=f"sticks at t = {stick:.3f} s")
    top.set_aspect("equal")
    top.set_xlim(-1.5, 9.5)
    top.set_ylim(-5, 4)
    top.set(xlabel="x (m)", ylabel="y (m)", title="the centre's track (the frozen lake's leaves the frame)")
    top.legend(fontsize=8, loc="upper left")
    speed.plot(times, slip, color="tab:red")
    speed.set(xlabel="t (s)", ylabel="slip speed |v| (m/s)", title="slip: the contact point's speed")
    friction.plot(times, rd.required_friction(runs["rolling"][1][:, ROLLING]), color="black", label="rolling: needed")
    sliding = slip > 1e-9  # a rolling state's slip is round-off
    friction.plot(times, contact_needs(coulomb, sliding), color="tab:red", label="Coulomb: used, |F| / N")
    friction.axhline(MU, color="tab:gray", ls="--", lw=0.8, label=f"mu = {MU}")
    friction.set(xlabel="t (s)", ylabel="friction coefficient", title="friction needed (rolling) and used")
    friction.legend(fontsize=8)
    energy.set(xlabel="t (s)", ylabel="energy (J)", title="energy: friction takes it while the disk slides")
    energy.legend(fontsize=8)
    for ax in (speed, friction, energy):
        for event in events:
            ax.axvline(event.time, color="tab:red", lw=0.6, ls=":")
        ax.grid(alpha=0.3)
    top.grid(alpha=0.3)
    fig.suptitle("The paper's steady circle on a surface with mu = 0.3 < 0.356: it slides, then rolls again")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


ENV_CONTACTS = {
    "rolling": {},
    "sliding, mu = 0 (frozen lake)": {"contact": "sliding"},
    "coulomb, mu = 1.1 (rolls throughout)": {"contact": "coulomb", "friction_coefficient": 1.1},
    "coulomb, mu = 0.2 (slides at times)": {"contact": "coulomb", "friction_coefficient": 0.2},
}
"""The contacts whose env steps are timed on task circle with random actions, by row name."""
BATCH_SETUP = {
    "task": "upright",
    "initial_ranges": {"theta": (0.0, 0.0), "dtheta": (0.0, 0.0), "dpsi": (0.0, 0.0), "dphi": (3.0, 4.0)},
}
"""Disks that need no friction: upright, rolling straight faster than they need to stay up (3 to 4 rad/s against
sqrt(g / 3r) = 1.81)."""
BATCH_CONTACTS = {
    "rolling": {},
    "coulomb, mu = 1.1: no disk slides": {"contact": "coulomb", "friction_coefficient": 1.1},
    "coulomb, mu = 0.05: a tenth slide": {"contact": "coulomb", "friction_coefficient": 0.05},
}
"""The batches of :func:`batch_rows`: a tenth of the disks spun by the full spin torque (5 N m, which needs a friction
coefficient of 2 tau / (3 m g r) = 0.068 to roll), the others without torque."""


class DrivenRun:
    """A vector env of :data:`BATCH_SETUP` stepped with a tenth of its disks under the full spin torque: each call
    times about ``seconds`` of stepping and returns the env steps per second; ``sliding`` gathers the fraction of
    disks that slide at each step."""

    def __init__(self, num_envs: int, kwargs: dict, seconds: float):
        self.env = gym.make_vec(
            rd.ENV_ID, num_envs=num_envs, vectorization_mode="vector_entry_point", **BATCH_SETUP, **kwargs
        )
        self.env.reset(seed=0)
        self.action = np.zeros((num_envs, 2), np.float32)
        self.action[::10, 0] = 1.0  # every tenth disk: spread over the threads' shares
        self.sliding: list[float] = []
        self.steps = 1
        start = time.perf_counter()
        self()  # compiles or loads the steps
        self.steps = max(5, round(seconds / ((time.perf_counter() - start) / self.steps)))

    def __call__(self) -> float:
        start = time.perf_counter()
        for _ in range(self.steps):
            info = self.env.step(self.action)[-1]
            self.sliding.append(float(np.mean(info["sliding"])))
        return self.env.num_envs * self.steps / (time.perf_counter() - start)


def cost_chart(batch: list[list[object]], env: list[list[object]], path) -> None:
    """The cost per disk-step of each contact model: the driven batches' rows and the circle env's at N = 1024."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    bars = [(f"{row[0]}, N = {row[1]}", float(row[2])) for row in batch]
    bars += [(f"circle env, {row[0]}, N = {row[1]}", float(row[2])) for row in env if row[1] == 1024]
    fig, ax = plt.subplots(figsize=(9.5, 0.6 + 0.38 * len(bars)), facecolor="white")
    names, values = zip(*bars)
    ax.barh(names, values, color=["tab:blue" if "rolling" in name else "tab:orange" for name in names])
    for y, value in enumerate(values):
        ax.text(value, y, f" {value:.0f} ns", va="center", fontsize=7)
    ax.set_xscale("log")
    ax.invert_yaxis()
    ax.tick_params(axis="y", labelsize=7)
    ax.set_xlabel("ns per disk-step (median; log scale)")
    ax.set_title(cpu(), fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110, facecolor="white")
    plt.close(fig)


def batch_rows(quick: bool) -> list[list[object]]:
    """Nanoseconds per disk-step of a batch of :data:`BATCH_SETUP` under each of :data:`BATCH_CONTACTS`, timed in
    turns, and the cost against the rolling batch's."""
    rows = []
    for n in (1024, 4096):
        seconds = 0.05 if quick else 0.5
        runs = {name: DrivenRun(n, kw, seconds) for name, kw in BATCH_CONTACTS.items()}
        rates = medians_in_turns(runs, 3 if quick else 9)
        for name, run in runs.items():
            cost = rates["rolling"] / rates[name]
            sliding = 100 * np.mean(run.sliding)
            rows.append([name, n, f"{1e9 / rates[name]:.0f}", f"{cost:.2f}", f"{sliding:.1f}%"])
            run.env.close()
    return rows


def env_rows(quick: bool) -> list[list[object]]:
    """Nanoseconds per disk-step of the native vector env (task circle, random actions) under each contact, and its
    rate over ``CartPoleVectorEnv``'s at the same N, timed in turns."""
    rows = []
    for n in (1, 1024):
        seconds = 0.05 if quick else 0.5
        runs = {"CartPoleVectorEnv": VectorRun("CartPole-v1", n, {}, seconds)}
        runs.update(
            {name: VectorRun(rd.ENV_ID, n, {"task": "circle", **kw}, seconds) for name, kw in ENV_CONTACTS.items()}
        )
        rates = medians_in_turns(runs, 3 if quick else 7)
        for name in ENV_CONTACTS:
            rows.append([name, n, f"{1e9 / rates[name]:.0f}", f"{rates[name] / rates['CartPoleVectorEnv']:.2f}"])
        for run in runs.values():
            run.close()
    return rows


def timing_rows(quick: bool) -> list[list[object]]:
    """Seconds per output step of ``rd.simulate`` for one disk, per contact and method."""
    duration = 1.0 if quick else 6.0
    steps = round(duration / TIMING_DT)
    first, circle = (np.array(scenario.state0) for scenario in scenarios())
    rows = []
    for method in ("rk4", "dop853"):
        for name, state0, kwargs in (
            ("scenario 1", first, {}),
            ("scenario 1", first, {"contact": "sliding"}),
            ("scenario 1", first, {"contact": "coulomb", "friction_coefficient": 0.5}),
            ("scenario 2", circle, {}),
            ("scenario 2", circle, {"contact": "coulomb", "friction_coefficient": MU}),
        ):

            def run(state0=state0, kwargs=kwargs, method=method):
                return rd.simulate(state0, duration, TIMING_DT, method=method, **kwargs)

            run()  # compiles
            seconds = median_seconds(run, 1, 3 if quick else 7) / steps
            contact = kwargs.get("contact", "rolling")
            mu = kwargs.get("friction_coefficient", "-")
            rows.append([name, contact, mu, method, f"{seconds * 1e6:.0f}"])
    return rows


def main() -> None:
    args = arguments(__doc__, **{"skip-timing": {"action": "store_true", "help": "chart only, no timing"}})
    duration = 3.0 if args.quick else 6.0
    runs, events = motions(duration)
    chart(args.out / "contact.png", runs, events)
    energies = {name: rd.sliding_energy(states) for name, (_, states) in runs.items()}
    event_rows = [[f"{event.time:.6f}", event.kind, f"{np.degrees(event.state[3]):.1f}"] for event in events]
    summary = [
        [name, f"{energy[0]:.3f}", f"{energy[-1]:.3f}", f"{np.degrees(runs[name][1][-1, 3]):.1f}"]
        for name, energy in energies.items()
    ]
    skipped = "Not measured in this run (`--skip-timing`): to be measured on a quiet machine."
    env_timing = batch_timing = skipped
    if not args.skip_timing:
        batch, env = batch_rows(args.quick), env_rows(args.quick)
        cost_chart(batch, env, args.out / "contact_cost.png")
        env_timing = table(["contact", "N", "ns per disk-step", "x CartPoleVectorEnv"], env)
        batch_timing = "\n\n".join(
            [
                table(["contact", "N", "ns per disk-step", "x the rolling batch's time", "disks sliding"], batch),
                "![the cost per disk-step of each contact](contact_cost.png)",
            ]
        )
    timing = (
        skipped
        if args.skip_timing
        else table(["start", "contact", "mu", "method", "us per output step"], timing_rows(args.quick))
    )
    write_markdown(
        "contact",
        "Contact models: sliding then rolling again",
        "python benchmarks/bench_contact.py",
        [
            "![the steady circle on mu = 0.3](contact.png)",
            "",
            f"The paper's steady circle (scenario 2, whose contact needs mu = 0.356) on a surface of mu = {MU}, "
            f'{duration:g} s with dop853 (rtol = atol = 1e-12) under `contact="coulomb"`: it cannot hold the circle, '
            "slides from the start (friction mu N along the force the circle needs), leans into the turn and "
            "spirals inwards while friction takes its energy, the slip speed rising to about 3 m/s and falling "
            "back to zero; there it sticks (the friction it then needs is within mu) and rolls on without slipping, "
            "energy constant again. Rolling (the paper's model, friction assumed sufficient) keeps the circle; on the "
            "frozen lake (mu = 0) the centre keeps its initial velocity.",
            "",
            "Switching events of the Coulomb run:",
            "",
            table(["t (s)", "event", "lean (deg)"], event_rows),
            "",
            table(["contact", "energy at 0 (J)", f"energy at {duration:g} s (J)", "final lean (deg)"], summary),
            "",
            "## Cost per disk-step",
            "",
            f"CPU: {cpu()}.",
            "",
            "Under the Coulomb contact a batch rolls every disk in the vectorized loops of the rolling step, each "
            "disk checked against mu at the start of each substep and at the end; those that slide or slip go "
            "through the period again on their own, one mode at a time (`engine.advance_contact`, which the model "
            "API's `simulate_contact` runs too). Batches of disks that need no friction (upright, rolling straight "
            "at 3 to 4 rad/s), a tenth of them spun by the full spin torque (5 N m: rolling needs mu >= 0.068), "
            "median of 9 samples of 0.5 s, the contacts timed in turns:",
            "",
            batch_timing,
            "",
            "The native vector env, task circle, random actions in [-1, 1], median of 7 samples of 0.5 s, each "
            "contact timed in turns with `CartPoleVectorEnv` at the same N. Random torques on the circle make disks "
            "slip and stick again: each start and end of a slide takes the hybrid's short steps near zero slip "
            "(`engine.slide_step_limit`), which these rows pay for.",
            "",
            env_timing,
            "",
            "`rd.simulate` for one disk, microseconds per output step of 0.01 s (median of 7 runs). Under the "
            "sliding and Coulomb contacts rk4 runs the engine's switching (`engine.contact_run`), dop853 scipy's "
            "DOP853 between the events and the engine near zero slip; the rolling contact the compiled engine "
            "(scipy for dop853).",
            "",
            timing,
        ],
        out=args.out,
    )


if __name__ == "__main__":
    main()
