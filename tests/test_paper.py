"""`python -m rolling_disk_env.paper` prints the equations, the comparison, scenario 2's stability and friction, and
writes the figures (scenario 1 also on the frozen lake)."""

import re

import numpy as np
import pytest

from rolling_disk_env import paper
from rolling_disk_env.rendering import rim_points
from tests import reference

# The SymPy derivation (about a minute, cached in the process) runs in one pytest-xdist worker for the three files
# that need it: test_codegen, test_derivation and test_paper (conftest.py's pytest_configure).
pytestmark = pytest.mark.xdist_group("derivation")


def test_paper_cli_reports_matches_and_writes_the_figures(tmp_path, capsys):
    paper.main(["--out", str(tmp_path)])
    output = capsys.readouterr().out
    assert "DIFFERS" not in output
    assert sum(line.rstrip().endswith(" matches") for line in output.splitlines()) == 9
    for name in ("scenario1", "scenario2", "scenario1_frozen_lake"):
        image = tmp_path / f"{name}.png"
        assert image.stat().st_size > 20_000
    _check_scenario2_report(output)


def _check_scenario2_report(output: str) -> None:
    """Scenario 2 is reported stable, with N = m g and the friction of its centre's circle, m v dpsi / (m g)."""
    _, circle = paper.scenarios()
    theta, dphi, dpsi = circle.state0[3], circle.state0[5], circle.state0[7]
    assert "stable: purely imaginary eigenvalues" in output
    assert "unstable" not in output
    # The lean's small oscillation about the circle, sqrt(-k) from the characteristic polynomial worked out by hand
    # (tests/test_steady_motions.py).
    g, c, s = 9.81, np.cos(theta), np.sin(theta)
    k = (-5 * dpsi**4 * c**2 * (1 + 2 * c**2) + 12 * dpsi**2 * g * c * np.cos(2 * theta) - 16 * g**2 * s**2) / (
        15 * dpsi**2 * c**2
    )
    frequency = float(re.search(r"oscillates about it at ([\d.]+) rad/s", output).group(1))
    assert frequency == pytest.approx(np.sqrt(-k), abs=1e-4)
    normal = float(re.search(r"N = ([\d.]+) N", output).group(1))
    assert normal == pytest.approx(5.0 * 9.81, abs=1e-4)
    mu = float(re.search(r"mu = \|lambda\| / N = ([\d.]+)", output).group(1))
    speed = dphi - dpsi * np.sin(theta)  # r = 1 m
    assert mu == pytest.approx(speed * dpsi / 9.81, abs=1e-4)
    assert round(mu, 3) == 0.356


def test_scenario2_spin_rate_is_the_papers_circle_condition():
    _, circle = paper.scenarios()
    theta, dpsi = circle.state0[3], circle.state0[7]
    assert circle.state0[5] == pytest.approx(2 * 9.81 * np.tan(theta) / (3 * dpsi) + 5 / 6 * dpsi * np.sin(theta))


def test_rim_points_lie_on_the_disk_and_touch_the_ground_once():
    state = np.array([1.0, 2.0, 0.4, 0.6, -1.0, 0, 0, 0])
    rim = rim_points(state, 1.0, count=2001)
    centre = reference.centre(state, paper.DEFAULT_PARAMS)
    np.testing.assert_allclose(np.linalg.norm(rim - centre, axis=1), 1.0)
    axis = reference.rotation(*state[2:5])[:, 0]
    np.testing.assert_allclose((rim - centre) @ axis, 0.0, atol=1e-12)
    assert np.min(rim[:, 2]) == pytest.approx(0.0, abs=1e-5)
