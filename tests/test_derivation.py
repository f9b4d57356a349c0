"""The symbolic derivation against the paper's printed forms and against first principles."""

import numpy as np
import pytest
import sympy as sp

from rolling_disk_env import derivation as d
from rolling_disk_env import paper

# The SymPy derivation (about a minute, cached in the process) runs in one pytest-xdist worker for the three files
# that need it: test_codegen, test_derivation and test_paper (conftest.py's pytest_configure).
pytestmark = pytest.mark.xdist_group("derivation")


@pytest.fixture(scope="module")
def derivation():
    return d.derive()


def test_every_printed_form_of_the_paper_is_reproduced():
    # M, b, lambda1, lambda2, ddc1, ddc2, ddphi, ddtheta, ddpsi, each simplified to zero difference.
    result = paper.compare()
    assert set(result) == {"M", "b", "lambda1", "lambda2", "ddc1", "ddc2", "ddphi", "ddtheta", "ddpsi"}
    assert all(result.values()), result


def test_comparison_detects_a_wrong_coefficient():
    wrong = paper.printed_solution()["ddtheta"] * sp.Rational(101, 100)
    assert not paper._equal(paper.derived_solution()["ddtheta"], wrong)


def test_rotation_vector_matches_the_paper(derivation):
    expected = sp.Matrix(
        [
            d.dphi - d.dpsi * sp.sin(d.theta),
            d.dtheta * sp.cos(d.phi) + d.dpsi * sp.sin(d.phi) * sp.cos(d.theta),
            -d.dtheta * sp.sin(d.phi) + d.dpsi * sp.cos(d.theta) * sp.cos(d.phi),
        ]
    )
    assert sp.simplify(derivation.omega_body - expected) == sp.zeros(3, 1)


def test_torques_enter_by_virtual_power(derivation):
    # The generalized force of a torque T is J^T T: its power Q . dq equals T . omega for every velocity.
    power = (derivation.torque_forces.T * d.dq)[0]
    axis = derivation.rotation[:, 0]
    expected = d.tau_spin * axis.dot(derivation.omega_world) + d.tau_steer * derivation.omega_world[2]
    assert sp.simplify(power - expected) == 0
    # A tilted spin torque is not only a phi torque: it also acts on psi (by -sin(theta)).
    assert sp.simplify(derivation.torque_forces[4].diff(d.tau_spin) + sp.sin(d.theta)) == 0


def test_lean_is_not_directly_actuated(derivation):
    assert derivation.accelerations_input[3, :] == sp.zeros(1, 2)


def test_numeric_rotation_matrix_equals_the_symbolic_one(derivation):
    from rolling_disk_env.dynamics import rotation_matrix

    symbolic = sp.lambdify((d.phi, d.theta, d.psi), derivation.rotation, "numpy")
    for angles in [(0.3, -0.7, 2.1), (-2.5, 1.2, -0.4)]:
        assert abs(np.asarray(symbolic(*angles), dtype=float) - rotation_matrix(*angles)).max() < 1e-15


def test_normal_force_is_newtons_law_for_the_centres_height(derivation):
    # N = m (g + c3'') with c3 = r cos(theta(t)), differentiated here and given the paper's printed ddtheta: an
    # independent route to the same expression, whatever the torques.
    theta_t = sp.Function("theta")(d.t)
    height = (d.r * sp.cos(theta_t)).diff(d.t, 2)
    height = height.subs(theta_t.diff(d.t, 2), paper.printed_solution()["ddtheta"])
    height = height.subs(theta_t.diff(d.t), d.dtheta).subs(theta_t, d.theta)
    expected = d.m * (d.g + height)
    assert sp.simplify(sp.expand_trig(derivation.normal_force - expected)) == 0
    assert derivation.normal_force_input == sp.zeros(1, 2)
    # A wrong coefficient in ddtheta would show: the comparison is not vacuous.
    assert sp.simplify(sp.expand_trig(derivation.normal_force - expected * sp.Rational(101, 100))) != 0


def test_normal_force_of_a_vertical_disk_without_lean_rate_is_its_weight(derivation):
    upright = derivation.normal_force.subs({d.theta: 0, d.dtheta: 0})
    assert sp.simplify(upright - d.m * d.g) == 0
    # Any spin and heading rate: at theta = 0 they do not reach the centre's height.
    assert not upright.has(d.dphi, d.dpsi, d.tau_spin, d.tau_steer)
    # A lean rate lifts the centre's acceleration: N = m (g - r dtheta^2) when vertical.
    vertical = derivation.normal_force.subs(d.theta, 0)
    assert sp.simplify(vertical - d.m * (d.g - d.r * d.dtheta**2)) == 0
