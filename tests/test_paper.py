"""`python -m rolling_disk_env.paper` prints the equations, the comparison, and writes the two figures."""

import numpy as np
import pytest

from rolling_disk_env import paper
from rolling_disk_env.rendering import rim_points
from tests import reference


def test_paper_cli_reports_matches_and_writes_both_figures(tmp_path, capsys):
    paper.main(["--out", str(tmp_path)])
    output = capsys.readouterr().out
    assert "DIFFERS" not in output
    assert sum(line.rstrip().endswith(" matches") for line in output.splitlines()) == 9
    for name in ("scenario1", "scenario2"):
        image = tmp_path / f"{name}.png"
        assert image.stat().st_size > 20_000


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
