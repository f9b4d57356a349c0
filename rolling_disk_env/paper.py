"""The paper reproduced: ``python -m rolling_disk_env.paper [--out DIR]``.

Prints the derived mass matrix M, right-hand side b, contact forces lambda and accelerations ddq; says whether each
equals the form printed in L. Jaulin, *Modelisation of a rolling disk with Sympy* (transcribed below); and draws the
paper's two simulations as seen from above, with the disk's rim drawn at a few instants:

* scenario 1, ``x0 = (2, 0, 0, 0.1, 0, 2.5, 0, 0)``, t in [0, 10] s: a slowly falling lean and precession;
* scenario 2, ``x0 = (2, 0, 0, 0.5, 0, dphi, 0, 1)`` with ``dphi`` from the paper's circle condition, t in [0, 6] s:
  a steady circle.

It also says whether scenario 2's steady circle is stable (the eigenvalues of the lean model linearized about it)
and what friction coefficient its contact needs (``|lambda| / N``); and draws scenario 1 again on the paper's "flat
frozen lake" (the sliding model without friction, started with the rolling disk's velocities) beside the rolling one.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import sympy as sp

from rolling_disk_env import derivation as d
from rolling_disk_env.dynamics import (
    DEFAULT_PARAMS,
    contact_force,
    normal_force,
    required_friction,
    steady_motion,
    steady_motion_eigenvalues,
)
from rolling_disk_env.integrators import simulate
from rolling_disk_env.rendering import rim_points

_s, _c = sp.sin, sp.cos
_th, _ps = d.theta, d.psi


def printed_mass_matrix() -> sp.Matrix:
    """M as printed in the paper (columns: lambda1, lambda2, ddc1, ddc2, ddphi, ddtheta, ddpsi)."""
    m, r = d.m, d.r
    return sp.Matrix(
        [
            [0, 0, 1, 0, -r * _s(_ps), -r * _c(_th) * _c(_ps), r * _s(_th) * _s(_ps)],
            [0, 0, 0, 1, r * _c(_ps), -r * _s(_ps) * _c(_th), -r * _s(_th) * _c(_ps)],
            [-1, 0, m, 0, 0, 0, 0],
            [0, -1, 0, m, 0, 0, 0],
            [r * _s(_ps), -r * _c(_ps), 0, 0, m * r**2 / 2, 0, -m * r**2 * _s(_th) / 2],
            [r * _c(_th) * _c(_ps), r * _s(_ps) * _c(_th), 0, 0, 0, m * r**2 * (_s(_th) ** 2 + sp.Rational(1, 4)), 0],
            [
                -r * _s(_th) * _s(_ps),
                r * _s(_th) * _c(_ps),
                0,
                0,
                -m * r**2 * _s(_th) / 2,
                0,
                m * r**2 * (_s(_th) ** 2 + 1) / 4,
            ],
        ]
    )


def printed_rhs() -> sp.Matrix:
    """b as printed in the paper (torque-free)."""
    m, g, r = d.m, d.g, d.r
    dph, dth, dps = d.dphi, d.dtheta, d.dpsi
    return sp.Matrix(
        [
            r
            * (
                -(dth**2) * _s(_th) * _c(_ps)
                - 2 * dth * dps * _s(_ps) * _c(_th)
                + dph * dps * _c(_ps)
                - dps**2 * _s(_th) * _c(_ps)
            ),
            r
            * (
                -(dth**2) * _s(_th) * _s(_ps)
                + 2 * dth * dps * _c(_th) * _c(_ps)
                + dph * dps * _s(_ps)
                - dps**2 * _s(_th) * _s(_ps)
            ),
            0,
            0,
            m * r**2 * dth * dps * _c(_th) / 2,
            m
            * r
            / 8
            * (8 * g * _s(_th) - 4 * r * dth**2 * _s(2 * _th) - 4 * r * dph * dps * _c(_th) + r * dps**2 * _s(2 * _th)),
            m * r**2 / 2 * (dph - dps * _s(_th)) * dth * _c(_th),
        ]
    )


def printed_solution() -> dict[str, sp.Expr]:
    """The paper's closed forms for lambda1, lambda2, ddc1, ddc2, ddphi, ddtheta, ddpsi (torque-free)."""
    m, g, r = d.m, d.g, d.r
    dph, dth, dps = d.dphi, d.dtheta, d.dpsi

    def horizontal(trig, other, sign):
        return (
            2 * g * _s(2 * _th) * trig / 5
            - r * dth**2 * _s(_th) * trig
            + sign * r / 3 * dth * dps * _c(_th) * other
            + sp.Rational(6, 5) * r * dph * dps * _s(_th) ** 2 * trig
            - r / 5 * dph * dps * trig
            - r * dps**2 * _s(_th) ** 3 * trig
        )

    lambda1 = (
        m
        * (
            6 * g * _s(2 * _th) * _c(_ps)
            - 15 * r * dth**2 * _s(_th) * _c(_ps)
            - 5 * r * dth * dps * _s(_ps) * _c(_th)
            + 18 * r * dph * dps * _s(_th) ** 2 * _c(_ps)
            - 3 * r * dph * dps * _c(_ps)
            - 15 * r * dps**2 * _s(_th) ** 3 * _c(_ps)
        )
        / 15
    )
    lambda2 = (
        m
        * (
            6 * g * _s(2 * _th) * _s(_ps)
            - 15 * r * dth**2 * _s(_th) * _s(_ps)
            + 5 * r * dth * dps * _c(_th) * _c(_ps)
            + 18 * r * dph * dps * _s(_th) ** 2 * _s(_ps)
            - 3 * r * dph * dps * _s(_ps)
            - 15 * r * dps**2 * _s(_th) ** 3 * _s(_ps)
        )
        / 15
    )
    return {
        "lambda1": lambda1,
        "lambda2": lambda2,
        "ddc1": horizontal(_c(_ps), _s(_ps), -1),
        "ddc2": horizontal(_s(_ps), _c(_ps), +1),
        "ddphi": 2 * dph * dth * sp.tan(_th) + sp.Rational(5, 3) * dth * dps * _c(_th),
        "ddtheta": 4 * g * _s(_th) / (5 * r) - sp.Rational(6, 5) * dph * dps * _c(_th) + dps**2 * _s(2 * _th) / 2,
        "ddpsi": 2 * dph * dth / _c(_th),
    }


def derived_solution() -> dict[str, sp.Expr]:
    """The derivation's torque-free lambda and ddq, keyed like :func:`printed_solution`."""
    derivation = d.derive()
    values = [*derivation.multipliers_free, *derivation.accelerations_free]
    return dict(zip(printed_solution(), values))


def _equal(a: sp.Expr, b: sp.Expr) -> bool:
    return sp.simplify(sp.expand_trig(a - b)) == 0


def compare() -> dict[str, bool]:
    """Whether each derived quantity equals the paper's printed form, symbolically."""
    derivation = d.derive()
    zero_torque = {d.tau_spin: 0, d.tau_steer: 0}
    result = {
        "M": _equal_matrices(derivation.mass_matrix, printed_mass_matrix()),
        "b": _equal_matrices(derivation.rhs.subs(zero_torque), printed_rhs()),
    }
    derived = derived_solution()
    result.update({name: _equal(derived[name], printed) for name, printed in printed_solution().items()})
    return result


def _equal_matrices(a: sp.Matrix, b: sp.Matrix) -> bool:
    return a.shape == b.shape and all(_equal(x, y) for x, y in zip(a, b))


@dataclass(frozen=True)
class Scenario:
    """One of the paper's simulations."""

    name: str
    title: str
    state0: tuple[float, ...]
    duration: float


def scenarios() -> tuple[Scenario, Scenario]:
    """The paper's two simulations (section 3), with the default disk."""
    theta, dpsi = 0.5, 1.0
    dphi = steady_motion(theta, dpsi, DEFAULT_PARAMS)
    return (
        Scenario("scenario1", "Scenario 1: rolling with precession", (2, 0, 0, 0.1, 0, 2.5, 0, 0), 10.0),
        Scenario("scenario2", "Scenario 2: a steady circle", (2, 0, 0, theta, 0, dphi, 0, dpsi), 6.0),
    )


def steady_circle_report(scenario: Scenario) -> str:
    """Whether a steady-circle scenario is stable, and the contact force and friction coefficient it needs.

    Stable means no eigenvalue with a positive real part beyond round-off: the disk conserves energy, so a stable
    steady motion has purely imaginary eigenvalues (and two zeros, the family of steady motions).
    """
    state = np.array(scenario.state0, dtype=float)
    theta, dphi, dpsi = state[3], state[5], state[7]
    eigenvalues = steady_motion_eigenvalues(theta, dpsi, DEFAULT_PARAMS)
    scale = max(1.0, float(np.max(np.abs(eigenvalues))))
    # Real parts below round-off shown as zero (adding 0.0 turns -0.0 into 0.0), the largest imaginary part first.
    shown = [complex(round(z.real / scale, 9) * scale + 0.0, z.imag + 0.0) for z in eigenvalues]
    shown.sort(key=lambda z: (-z.real, -z.imag))
    listed = ", ".join(f"{z.real:.4f}{z.imag:+.4f}j" for z in shown)
    if max(z.real for z in shown) > 0:
        verdict = f"unstable: the lean departs from it at the rate {max(z.real for z in shown):.4g} 1/s"
    else:
        frequency = float(np.max(np.abs(eigenvalues.imag)))
        verdict = f"stable: purely imaginary eigenvalues, the lean oscillates about it at {frequency:.4f} rad/s"
    horizontal = float(np.hypot(*contact_force(state, params=DEFAULT_PARAMS)))
    weight = DEFAULT_PARAMS.mass * DEFAULT_PARAMS.gravity
    return "\n".join(
        [
            f"{scenario.title} (theta = {theta:g} rad, dphi = {dphi:.4f} rad/s, dpsi = {dpsi:g} rad/s):",
            f"  eigenvalues of the lean model linearized about it (1/s): {listed}",
            f"  {verdict}",
            f"  contact: N = {normal_force(state, params=DEFAULT_PARAMS):.4f} N (m g = {weight:.4f} N), "
            f"|lambda| = {horizontal:.4f} N, friction coefficient needed mu = |lambda| / N = "
            f"{required_friction(state, params=DEFAULT_PARAMS):.4f}",
        ]
    )


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _draw_from_above(ax, times: np.ndarray, states: np.ndarray, title: str, color: str = "tab:blue") -> None:
    """The centre's track and the disk at 9 instants (an ellipse in projection, the first one filled), seen from
    above, axes in metres; states of the rolling (8) or the sliding (10) model."""
    radius = DEFAULT_PARAMS.radius
    ax.plot(states[:, 0], states[:, 1], color="black", lw=1.2, label="centre (c1, c2)")
    instants = np.linspace(0, len(times) - 1, 9).astype(int)
    for number, i in enumerate(instants):
        rim = rim_points(states[i], radius)
        if number == 0:
            ax.fill(rim[:, 0], rim[:, 1], color=color, alpha=0.6, label="disk at t = 0")
        ax.plot(rim[:, 0], rim[:, 1], color=color, lw=0.8)
        ax.annotate(f"{times[i]:.1f} s", (states[i, 0], states[i, 1]), fontsize=7, color="tab:gray")
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.grid(alpha=0.3)
    ax.set_title(title, fontsize=10)
    ax.legend(loc="best", fontsize=8)


def draw(scenario: Scenario, path: Path, dt: float = 0.01) -> Path:
    """Simulates a scenario with ``"dop853"`` and draws it from above (:func:`_draw_from_above`)."""
    plt = _pyplot()
    times, states = simulate(np.array(scenario.state0, dtype=float), scenario.duration, dt, method="dop853")
    fig, ax = plt.subplots(figsize=(6.5, 6.5))
    x0 = ", ".join(f"{v:.3g}" for v in scenario.state0)
    _draw_from_above(ax, times, states, f"{scenario.title}\nx0 = ({x0}), t in [0, {scenario.duration:g}] s")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def draw_frozen_lake(scenario: Scenario, path: Path, dt: float = 0.01) -> Path:
    """Simulates a scenario rolling and on the paper's frozen lake (``contact="sliding"``, no friction, the
    centre's velocity at the start that of rolling), both with ``"dop853"``, and draws them side by side from
    above: on the ice the centre keeps its velocity, a straight line, while the disk spins, leans and turns about
    it."""
    plt = _pyplot()
    state0 = np.array(scenario.state0, dtype=float)
    rolling = simulate(state0, scenario.duration, dt, method="dop853")
    sliding = simulate(state0, scenario.duration, dt, method="dop853", contact="sliding", rtol=1e-12, atol=1e-12)
    lean = np.degrees(np.abs(sliding[1][:, 3]).max())
    fig, axes = plt.subplots(1, 2, figsize=(11, 7.5), width_ratios=(2.2, 1))
    _draw_from_above(axes[0], *rolling, "rolling without slipping (the paper's model)")
    _draw_from_above(axes[1], *sliding, f"on the frozen lake: no friction\n(lean up to {lean:.0f} deg)", "tab:cyan")
    x0 = ", ".join(f"{v:.3g}" for v in scenario.state0)
    fig.suptitle(f"{scenario.title}, rolling and on ice\nx0 = ({x0}), t in [0, {scenario.duration:g}] s", fontsize=11)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description="Reproduce Jaulin's rolling-disk paper: equations and figures.")
    parser.add_argument("--out", type=Path, default=Path("paper_figures"), help="folder for the PNGs")
    args = parser.parse_args(argv)

    derivation = d.derive()
    zero_torque = {d.tau_spin: 0, d.tau_steer: 0}
    print("Mass matrix M (unknowns lambda1, lambda2, ddc1, ddc2, ddphi, ddtheta, ddpsi):")
    sp.pprint(derivation.mass_matrix, wrap_line=False)
    print("\nRight-hand side b (torque-free):")
    sp.pprint(derivation.rhs.subs(zero_torque), wrap_line=False)
    print("\n(lambda, ddq) = M^-1 b, torque-free:")
    for name, expr in derived_solution().items():
        print(f"  {name} = {expr}")
    print("\nInput matrices with u = (tau_spin, tau_steer): d lambda / du and B = d ddq / du:")
    print(f"  {derivation.multipliers_input.tolist()}")
    print(f"  {derivation.accelerations_input.tolist()}")
    print("\nAgainst the paper's printed forms:")
    for name, same in compare().items():
        print(f"  {name:8s} {'matches' if same else 'DIFFERS'}")

    print()
    print(steady_circle_report(scenarios()[1]))

    args.out.mkdir(parents=True, exist_ok=True)
    for scenario in scenarios():
        print(f"wrote {draw(scenario, args.out / f'{scenario.name}.png')}")
    first = scenarios()[0]
    print(f"wrote {draw_frozen_lake(first, args.out / f'{first.name}_frozen_lake.png')}")


if __name__ == "__main__":
    main()
